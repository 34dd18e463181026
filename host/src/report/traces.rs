//! The grasps' traces (Figure 18): joint positions, forces and proximity
//! against time, as CSV data and an SVG plot per grasp.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::ReportError;
use skin_sim::scene::held::ObjectTruth;

use crate::grasping::GraspRun;

/// Writes each run's trace as `<object>.csv` and `<object>.svg` into `dir`
/// (created if missing) and returns the files written.
pub fn write_traces(dir: &Path, runs: &[GraspRun]) -> Result<Vec<PathBuf>, ReportError> {
    std::fs::create_dir_all(dir).map_err(ReportError::write(dir))?;
    let mut files = Vec::new();
    for run in runs {
        let csv = dir.join(format!("grasp_{}.csv", run.object));
        std::fs::write(&csv, trace_csv(run)).map_err(ReportError::write(&csv))?;
        files.push(csv);
        let file = format!("grasp_{}.svg", run.object);
        let svg = dir.join(&file);
        plot(run, &svg).map_err(|e| ReportError::Draw { file, message: e.to_string() })?;
        files.push(svg);
    }
    Ok(files)
}

fn trace_csv(run: &GraspRun) -> String {
    let dofs = run.trace.first().map_or(0, |r| r.joints_rad.len());
    let mut s = String::from("time_s,state");
    for d in 0..dofs {
        let _ = write!(s, ",q{d}_rad");
    }
    s.push_str(",force_right,force_left,force_chest,proximity_right,proximity_left,proximity_chest");
    s.push_str(
        ",object_x_m,object_y_m,object_z_m,object_force_right_n,object_force_left_n,object_force_body_n,object_gap_m,object_support_n\n",
    );
    for r in &run.trace {
        let _ = write!(s, "{:.3},{}", r.time_s, r.state.name());
        for q in &r.joints_rad {
            let _ = write!(s, ",{q:.4}");
        }
        for v in r.force.iter().chain(&r.proximity) {
            let _ = write!(s, ",{v:.4}");
        }
        match &r.object {
            Some(o) => {
                let [x, y, z] = o.centre_m;
                let [right, left] = o.arm_force_n;
                let support = o.support_n.map_or(String::new(), |f| format!("{f:.3}"));
                let (body, gap) = (o.body_force_n, o.gap_m);
                let _ = writeln!(s, ",{x:.4},{y:.4},{z:.4},{right:.3},{left:.3},{body:.3},{gap:.4},{support}");
            }
            None => s.push_str(",,,,,,,,\n"),
        }
    }
    s
}

/// The `n` DoFs whose positions spanned the widest range over the trace,
/// in DoF order: the ones worth drawing, whatever the robot.
fn most_moved(run: &GraspRun, n: usize) -> Vec<usize> {
    let dofs = run.trace.first().map_or(0, |r| r.joints_rad.len());
    let span = |d: usize| {
        let qs = run.trace.iter().filter_map(|r| r.joints_rad.get(d).copied());
        let (lo, hi) = qs.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), q| (lo.min(q), hi.max(q)));
        hi - lo
    };
    let mut by_span: Vec<usize> = (0..dofs).collect();
    by_span.sort_by(|a, b| span(*b).total_cmp(&span(*a)));
    by_span.truncate(n);
    by_span.sort_unstable();
    by_span
}

/// Figure 18: joints, forces and proximity against time, with the states;
/// below, by the simulator's truth, the object's path (its centre) and the
/// contact forces it exerts on each arm and the rest of the robot.
fn plot(run: &GraspRun, path: &Path) -> Result<(), Box<dyn std::error::Error>> {
    use plotters::prelude::*;
    let root = SVGBackend::new(path, (900, 1200)).into_drawing_area();
    root.fill(&WHITE)?;
    let panels = root.split_evenly((5, 1));
    let end = run.trace.last().map_or(1.0, |r| r.time_s).max(1.0);
    let names = ["right arm", "left arm", "chest"];
    let colours = [RED, BLUE, BLACK];
    type Series<'a> = Vec<(String, RGBColor, Vec<(f64, f64)>)>;
    let mut series: [Series<'_>; 5] = Default::default();
    for (k, d) in most_moved(run, 4).into_iter().enumerate() {
        let c = [RED, MAGENTA, BLUE, CYAN][k];
        series[0].push((
            run.dof_names.get(d).cloned().unwrap_or_else(|| format!("DoF {d}")),
            c,
            run.trace.iter().filter_map(|r| r.joints_rad.get(d).map(|q| (r.time_s, *q))).collect(),
        ));
    }
    for (k, name) in names.into_iter().enumerate() {
        series[1].push((name.to_owned(), colours[k], run.trace.iter().map(|r| (r.time_s, r.force[k])).collect()));
        series[2].push((name.to_owned(), colours[k], run.trace.iter().map(|r| (r.time_s, r.proximity[k])).collect()));
    }
    let truth = |f: fn(&ObjectTruth) -> f64| -> Vec<(f64, f64)> {
        run.trace.iter().filter_map(|r| r.object.as_ref().map(|o| (r.time_s, f(o)))).collect()
    };
    type Of = fn(&ObjectTruth) -> f64;
    let centre: [(&str, Of); 3] =
        [("x (forward)", |o| o.centre_m[0]), ("y (left)", |o| o.centre_m[1]), ("z (up)", |o| o.centre_m[2])];
    let forces: [(&str, Of); 3] =
        [("right arm", |o| o.arm_force_n[0]), ("left arm", |o| o.arm_force_n[1]), ("chest", |o| o.body_force_n)];
    for (k, ((axis, x), (name, f))) in centre.into_iter().zip(forces).enumerate() {
        series[3].push((axis.to_owned(), colours[k], truth(x)));
        series[4].push((name.to_owned(), colours[k], truth(f)));
    }
    // What the person's hands bear, where the world tells it: the handover.
    let support: Vec<(f64, f64)> =
        run.trace.iter().filter_map(|r| Some((r.time_s, r.object.as_ref()?.support_n?))).collect();
    if !support.is_empty() {
        series[4].push(("support".to_owned(), RGBColor(0, 140, 0), support));
    }
    // Each panel's title, and whether its axis starts at zero (the
    // object's path is drawn around its values alone).
    let titles = [
        (format!("{}: joint positions (rad)", run.object), true),
        ("force: summed normalized readings".to_owned(), true),
        ("pre-contact: highest proximity intensity".to_owned(), true),
        ("truth: the object's centre (m)".to_owned(), false),
        ("truth: the object's contact force, skin and bare surface, and its support's (N)".to_owned(), true),
    ];
    for ((panel, lines), (title, from_zero)) in panels.iter().zip(&series).zip(titles) {
        let first = lines.iter().flat_map(|l| l.2.first()).map(|p| p.1).next();
        let start = if from_zero { 0.0 } else { first.unwrap_or(0.0) };
        let (lo, hi) =
            lines.iter().flat_map(|l| l.2.iter().map(|p| p.1)).fold((start, start), |(a, b), v| (a.min(v), b.max(v)));
        let hi = if hi - lo < 1e-6 { lo + 1.0 } else { hi + 0.05 * (hi - lo) };
        let mut chart = ChartBuilder::on(panel)
            .caption(title, ("sans-serif", 16))
            .margin(8)
            .x_label_area_size(28)
            .y_label_area_size(48)
            .build_cartesian_2d(0.0..end, lo..hi)?;
        chart.configure_mesh().x_desc("time after the launching pat (s)").light_line_style(WHITE).draw()?;
        for l in &run.state_log {
            chart.draw_series(LineSeries::new([(l.time_s, lo), (l.time_s, hi)], &RGBColor(180, 180, 180)))?;
            chart.draw_series([Text::new(l.state.name(), (l.time_s, hi), ("sans-serif", 11).into_font())])?;
        }
        for (name, colour, points) in lines {
            let colour = *colour;
            chart
                .draw_series(LineSeries::new(points.iter().copied(), &colour))?
                .label(name.as_str())
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 16, y)], colour));
        }
        chart.configure_series_labels().background_style(WHITE.mix(0.8)).border_style(BLACK).draw()?;
    }
    root.present()?;
    Ok(())
}
