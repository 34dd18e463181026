//! The simulation's figures: the network latency histogram and the grasps'
//! traces.

use crate::report::figures;
use crate::report::render::Renderer;
use crate::report::{traces, Figure, ReportError};

impl Renderer<'_> {
    /// The latency histogram, if the report has a latency section.
    pub(in crate::report) fn draw_latency(&mut self) -> Result<(), ReportError> {
        let Some(l) = &self.report.latency else { return Ok(()) };
        // The bulk up to half again the 99th percentile, in about 60 bins.
        let x_max = (l.p99_us.max(1) as f64 * 1.5).ceil();
        let width_us = (x_max / 60.0).ceil().max(1.0);
        let mut bins: Vec<(f64, u64)> = Vec::new();
        for &(us, n) in &l.bins_us {
            let lo = (us as f64 / width_us).floor() * width_us;
            match bins.last_mut() {
                Some(b) if b.0 == lo => b.1 += n,
                _ => bins.push((lo, n)),
            }
        }
        let caption = format!(
            "{} sensor frames from sampling to the host's socket: median {} us, 99% within {} us, longest {} us ({} frames beyond {x_max} us not drawn); {} lost.",
            l.frames,
            l.p50_us,
            l.p99_us,
            l.max_us,
            l.bins_us.iter().filter(|b| b.0 as f64 >= x_max).map(|b| b.1).sum::<u64>(),
            l.sensor_frames_lost
        );
        self.figure("latency.svg", "Network latency", caption, |path| {
            figures::histogram(path, "skin network: latency of sensor frames", "latency (us)", &bins, width_us, x_max)
        })
    }

    /// Each grasp's trace, CSV and SVG, if the report has grasps.
    pub(in crate::report) fn draw_grasps(&mut self) -> Result<(), ReportError> {
        let Some(g) = &self.report.grasps else { return Ok(()) };
        let written = traces::write_traces(self.dir, &g.runs)?;
        for (run, svg) in g.runs.iter().zip(written.iter().filter(|p| p.extension().is_some_and(|e| e == "svg"))) {
            let file = svg.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default();
            self.figures.push(Figure {
                title: format!("Grasp: {}", run.object),
                caption: format!(
                    "{} in {:.1} s, the controller ending in {}; largest grip force on one cell {:.2} N (the person's pats {:.2} N). Joint positions, summed force and highest proximity per touch area against time after the launching pat; grey lines mark state changes (Figure 18). Data: {}.",
                    match (run.reason, run.failed) {
                        (Some(reason), Some(failed)) => format!("NOT held ({}, {failed})", reason.name()),
                        _ => "Held".to_owned(),
                    },
                    run.time_s,
                    run.controller_state.name(),
                    run.grip_force_max_n,
                    run.hand_force_max_n,
                    file.replace(".svg", ".csv")
                ),
                file,
            });
        }
        Ok(())
    }
}
