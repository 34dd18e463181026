//! The report's sections only a simulation can fill: the network's
//! latency, the grasping experiment and the checks against the truth; and
//! how the report shows them.

pub(super) mod html;
mod render;
mod summary;

use serde::Serialize;
use skin_sim::network::ledger::quantile;

use crate::grasping::{GraspRun, Lesson};

/// Latency of the skin network's sensor frames (from the simulator).
#[derive(Clone, Debug, Serialize)]
pub struct LatencySection {
    /// (microseconds, frames), smallest first.
    pub bins_us: Vec<(u64, u64)>,
    /// Frames counted.
    pub frames: u64,
    /// Median, us.
    pub p50_us: u64,
    /// 99th percentile, us.
    pub p99_us: u64,
    /// Largest, us.
    pub max_us: u64,
    /// Sensor frames lost in the network.
    pub sensor_frames_lost: u64,
}

impl LatencySection {
    /// From a histogram as (microseconds, frames).
    pub fn new(bins_us: Vec<(u64, u64)>, sensor_frames_lost: u64) -> LatencySection {
        let frames: u64 = bins_us.iter().map(|b| b.1).sum();
        let at = |q: f64| quantile(bins_us.iter().copied(), frames, q).unwrap_or(0);
        LatencySection {
            frames,
            p50_us: at(0.5),
            p99_us: at(0.99),
            max_us: bins_us.last().map_or(0, |b| b.0),
            sensor_frames_lost,
            bins_us,
        }
    }
}

/// Teaching and grasping.
#[derive(Clone, Debug, Serialize)]
pub struct GraspSection {
    /// How they were run.
    pub how: String,
    /// Each key pose taught.
    pub lessons: Vec<Lesson>,
    /// Each grasp (traces in the CSV and SVG files).
    pub runs: Vec<GraspRun>,
}

/// The host's results checked against what only the simulator knows.
#[derive(Clone, Debug, Serialize)]
pub struct TruthSection {
    /// Cells of the simulated skin.
    pub cells_in_skin: usize,
    /// Cells with an ID.
    pub cells_with_id: usize,
    /// No two cells share an ID.
    pub ids_unique: bool,
    /// Every cell's neighbour table in the registry is the true one.
    pub neighbours_correct: bool,
    /// The learned kinematic tree is the true one.
    pub tree_correct: bool,
    /// Activity matrix entries that differ from the truth.
    pub wrong_activity_entries: usize,
    /// Mean |w - w_true| of the sensory-motor map.
    pub smm_mean_abs_error: f64,
    /// The same where the DoF truly moves the cell.
    pub smm_mean_abs_error_moved: f64,
}

#[cfg(test)]
mod tests {
    use super::LatencySection;

    #[test]
    fn latency_quantiles_come_from_the_counts() {
        let l = LatencySection::new(vec![(100, 50), (200, 49), (900, 1)], 3);
        assert_eq!((l.frames, l.p50_us, l.p99_us, l.max_us, l.sensor_frames_lost), (100, 100, 200, 900, 3));
        let empty = LatencySection::new(Vec::new(), 0);
        assert_eq!((empty.frames, empty.p50_us, empty.max_us), (0, 0, 0));
    }
}
