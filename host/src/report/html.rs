//! `index.html`: the summary and every figure on one self-contained page.

use std::fmt::Write;

use super::markup::{escape, row};
use super::Report;

/// The page.
pub fn page(r: &Report) -> String {
    let mut s = String::from(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>Robot skin report</title>\n<style>\n\
         body { font-family: sans-serif; max-width: 1100px; margin: 2em auto; color: #222; }\n\
         table { border-collapse: collapse; margin: 1em 0; }\n\
         th, td { text-align: left; padding: 0.2em 0.8em; border-bottom: 1px solid #ddd; }\n\
         figure { margin: 2em 0; } img { max-width: 100%; border: 1px solid #eee; }\n\
         .ok { color: #1a7f37; } .bad { color: #c62828; font-weight: bold; }\n</style>\n</head>\n<body>\n",
    );
    s += "<h1>Robot skin: self-organization, self-exploration and grasping</h1>\n";
    let _ = writeln!(s, "<p>{}</p>", escape(&r.robot.source));
    s += "<h2>Summary</h2>\n<table>\n";
    let t = &r.timing;
    row(&mut s, "wall time", &format!("{:.1} s in all", t.total_wall_s));
    row(
        &mut s,
        "robot",
        &format!(
            "{} DoFs, control period {:.1} ms, {}",
            r.robot.dof_names.len(),
            r.robot.period_s * 1e3,
            if r.robot.lockstep { "lockstep (simulated time)" } else { "real time" }
        ),
    );
    let o = &r.organization;
    row(
        &mut s,
        "self-organization",
        &format!(
            "{} cells organized in {:.2} s robot time ({:.2} s wall); {} of {} settings acknowledged",
            o.cells.len(),
            o.time_s,
            t.organize_wall_s,
            o.settings_acknowledged,
            o.settings_written
        ),
    );
    let e = &r.exploration;
    row(
        &mut s,
        "exploration",
        &format!(
            "{} body parts, {} joints; structure {:.1} s + sensory-motor map {:.1} s robot time ({:.1} s wall)",
            e.body_parts.len(),
            e.joints.len(),
            t.structure_robot_s,
            t.smm_robot_s,
            t.explore_wall_s
        ),
    );
    if let Some(smallest) = e.smallest_lever_decided_m {
        let assumed = if e.assumed.is_empty() {
            String::new()
        } else {
            format!("; {} entries below it rest on the mounting clearance", e.assumed.len())
        };
        row(
            &mut s,
            "levers",
            &format!(
                "near an axis where gravity did not tell, evidence decides any lever of {:.2} mm or more{assumed}",
                smallest * 1e3
            ),
        );
    }
    let i = &r.interface;
    row(
        &mut s,
        "interface",
        &format!(
            "{} datagrams, {} frames accepted; {} datagrams and {} frames rejected",
            i.datagrams.accepted,
            i.frames.accepted,
            i.datagrams.rejected_total(),
            i.frames.rejected_total()
        ),
    );
    #[cfg(feature = "sim")]
    super::sim::html::summary_rows(&mut s, r);
    s += "</table>\n";
    #[cfg(feature = "sim")]
    super::sim::html::grasps(&mut s, r);
    for f in &r.sensor_faults {
        let left_out = if f.left_out { " (left out of the exploration and the map)" } else { "" };
        let _ = writeln!(s, "<p class=\"bad\">sensor fault: {}{left_out}</p>", escape(&f.description));
    }
    for w in &e.warnings {
        let _ = writeln!(s, "<p class=\"bad\">warning: {}</p>", escape(w));
    }
    s += "<h2>Figures</h2>\n";
    for f in &r.figures {
        let _ = writeln!(
            s,
            "<figure>\n<h3>{}</h3>\n<img src=\"{}\" alt=\"{}\">\n<figcaption>{}</figcaption>\n</figure>",
            escape(&f.title),
            escape(&f.file),
            escape(&f.title),
            escape(&f.caption)
        );
    }
    s += "<p>All data of these figures: <a href=\"report.json\">report.json</a>.</p>\n</body>\n</html>\n";
    s
}
