//! The simulation's sections in `index.html`.

use std::fmt::Write;

use crate::report::markup::{escape, row};
use crate::report::Report;

/// The summary table's rows for the network latency and the checks
/// against the truth.
pub fn summary_rows(s: &mut String, r: &Report) {
    if let Some(l) = &r.latency {
        row(s, "network latency", &format!("median {} us, 99% {} us, max {} us", l.p50_us, l.p99_us, l.max_us));
    }
    if let Some(truth) = &r.truth {
        let mark = |ok: bool| if ok { "<span class=\"ok\">yes</span>" } else { "<span class=\"bad\">NO</span>" };
        let _ = writeln!(
            s,
            "<tr><th>checked against the simulator</th><td>IDs unique: {}; neighbour tables true: {}; kinematic tree true: {} ({} wrong activity entries); sensory-motor map mean |w - w<sub>true</sub>| {:.3}</td></tr>",
            mark(truth.ids_unique && truth.cells_with_id == truth.cells_in_skin),
            mark(truth.neighbours_correct),
            mark(truth.tree_correct),
            truth.wrong_activity_entries,
            truth.smm_mean_abs_error
        );
    }
}

/// The teaching and grasping tables.
pub fn grasps(s: &mut String, r: &Report) {
    if let Some(g) = &r.grasps {
        s.push_str("<h2>Teaching and grasping</h2>\n");
        let _ = writeln!(s, "<p>{}</p>", escape(&g.how));
        s.push_str("<table>\n<tr><th>key pose</th><th>taught in (robot time)</th></tr>\n");
        for l in &g.lessons {
            let _ = writeln!(s, "<tr><td>{}</td><td>{:.1} s</td></tr>", escape(&l.pose), l.time_s);
        }
        s.push_str("</table>\n<table>\n<tr><th>object</th><th>verdict (the truth's)</th><th>controller ended in</th><th>time</th><th>grip force (object only)</th><th>pats (the person)</th></tr>\n");
        for run in &g.runs {
            let _ = writeln!(
                s,
                "<tr><td>{}</td><td class=\"{}\">{}</td><td>{}</td><td>{:.1} s</td><td>{:.2} N</td><td>{:.2} N</td></tr>",
                escape(&run.object),
                if run.succeeded { "ok" } else { "bad" },
                match (run.reason, run.failed) {
                    (Some(reason), Some(failed)) => escape(&format!("not held: {}, {failed}", reason.name())),
                    _ if run.settled == Some(false) => format!(
                        "held, still sliding down ({:.1} mm in the hold's last second)",
                        1e3 * run.sank_at_release_m.unwrap_or(0.0)
                    ),
                    _ => "held".to_owned(),
                },
                run.controller_state.name(),
                run.time_s,
                run.grip_force_max_n,
                run.hand_force_max_n
            );
        }
        s.push_str("</table>\n");
    }
}
