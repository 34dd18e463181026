//! The simulation's sections in the short human summary that `skin demo`
//! and `skin run` print.

use crate::report::Report;

impl Report {
    /// The summary's lines on what only the simulation knows: network
    /// latency, grasps and the checks against the truth.
    pub fn simulation_summary(&self) -> String {
        let mut s = String::new();
        if let Some(l) = &self.latency {
            s += &format!(
                "network latency: median {} us, 99% {} us, max {} us over {} sensor frames\n",
                l.p50_us, l.p99_us, l.max_us, l.frames
            );
        }
        if let Some(g) = &self.grasps {
            let held = g.runs.iter().filter(|r| r.succeeded).count();
            let names: Vec<String> = g
                .runs
                .iter()
                .map(|r| format!("{} {}", r.object, r.reason.map_or(held_name(r), |why| why.name())))
                .collect();
            s += &format!("grasps: {held} of {} held ({})\n", g.runs.len(), names.join(", "));
        }
        if let Some(truth) = &self.truth {
            s += &format!(
                "checked against the simulator: {} of {} cells with unique IDs, neighbour tables {}, tree {}\n",
                if truth.ids_unique { truth.cells_with_id } else { 0 },
                truth.cells_in_skin,
                if truth.neighbours_correct { "true" } else { "WRONG" },
                if truth.tree_correct { "true" } else { "WRONG" }
            );
        }
        s
    }
}

/// A held grasp's word in the summary: whether the object had come to rest.
fn held_name(run: &crate::grasping::GraspRun) -> &'static str {
    if run.settled == Some(false) {
        "held (still sliding)"
    } else {
        "held"
    }
}
