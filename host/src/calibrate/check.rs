//! A calibration judged against the simulator's ground truth (read only
//! after the run): where each cell really is, how its accelerometer is
//! really turned (the cell frame and the chip's mounting error together).
//!
//! Positions are compared along what the calibration calls observable
//! (the whole error, or the part perpendicular to an unobservable axis;
//! a part the neighbours gave is judged with the rest);
//! frames where the calibration says they are known. A cell put on the
//! wrong link counts as wrong, whatever its numbers.

use std::collections::HashMap;

use nalgebra::Vector3;
use skin_sim::world::World;

use super::Calibration;

/// A position error beyond this many claimed standard deviations (plus the
/// floor, m) is a confident wrong answer.
const OVERCONFIDENT_SIGMAS: f64 = 5.0;
const OVERCONFIDENT_FLOOR_M: f64 = 0.001;

/// Error statistics over the cells that were checked.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Spread {
    /// Cells in the statistics.
    pub cells: usize,
    /// Mean error.
    pub mean: f64,
    /// 95th percentile.
    pub p95: f64,
    /// Largest error.
    pub max: f64,
}

impl Spread {
    fn of(mut errors: Vec<f64>) -> Spread {
        if errors.is_empty() {
            return Spread::default();
        }
        errors.sort_by(f64::total_cmp);
        let n = errors.len();
        let p95 = errors[((0.95 * n as f64).ceil() as usize).clamp(1, n) - 1];
        Spread { cells: n, mean: errors.iter().sum::<f64>() / n as f64, p95, max: errors[n - 1] }
    }
}

/// How the calibration compares with the truth.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct CalibrationTruth {
    /// Position error over cells with an observable part, m.
    pub position_m: Spread,
    /// Position error (3D) over the cells whose along-axis part came from
    /// their neighbours, m (also counted in `position_m`).
    pub from_neighbours_m: Spread,
    /// Frame error over cells with an observable frame, degrees.
    pub orientation_deg: Spread,
    /// Cells whose position the calibration called wholly unobservable.
    pub position_unobservable: usize,
    /// Cells whose frame the calibration called unobservable.
    pub orientation_unobservable: usize,
    /// Cells put on a link they are not on.
    pub wrong_link: usize,
    /// Cells whose position error exceeds five times the spread the
    /// calibration claimed for it (plus 1 mm): confidently wrong.
    pub overconfident: usize,
    /// Cells the simulator does not know (none, unless IDs went wrong).
    pub unknown_cells: usize,
    /// Largest offset error over the cells with an observable frame, m/s^2
    /// (elsewhere offset and tilt are one unknown).
    pub offset_error_max_mps2: f64,
}

/// Compares `calibration` with the truth of `world`.
pub fn check(calibration: &Calibration, world: &World) -> CalibrationTruth {
    let cells = world.skin().cells();
    let index: HashMap<_, _> = cells.iter().enumerate().map(|(i, c)| (c.id, i)).collect();
    let mut truth = CalibrationTruth::default();
    let (mut positions, mut frames, mut from_neighbours) = (Vec::new(), Vec::new(), Vec::new());
    for c in &calibration.cells {
        let Some(&i) = index.get(&c.id) else {
            truth.unknown_cells += 1;
            continue;
        };
        let real = &cells[i];
        if real.body != c.body {
            truth.wrong_link += 1;
            continue;
        }
        let (offset, _, mount) = world.sensors()[i].errors();
        let mut e: Vector3<f64> = c.position - real.pose.translation.vector;
        for n in &c.unobservable {
            e -= n * n.dot(&e);
        }
        if c.unobservable.len() < 3 {
            let claimed: f64 = c.position_sigma_m.iter().filter(|s| s.is_finite()).map(|s| s * s).sum::<f64>().sqrt();
            truth.overconfident += usize::from(e.norm() > OVERCONFIDENT_SIGMAS * claimed + OVERCONFIDENT_FLOOR_M);
            positions.push(e.norm());
            if !c.from_neighbours.is_empty() {
                from_neighbours.push(e.norm());
            }
        } else {
            truth.position_unobservable += 1;
        }
        if c.orientation_observable {
            truth.offset_error_max_mps2 = truth.offset_error_max_mps2.max((c.offset_mps2 - offset).amax());
            let accelerometer = real.pose.rotation.to_rotation_matrix() * mount.inverse();
            frames.push((c.frame.inverse() * accelerometer).angle().to_degrees());
        } else {
            truth.orientation_unobservable += 1;
        }
    }
    truth.position_m = Spread::of(positions);
    truth.from_neighbours_m = Spread::of(from_neighbours);
    truth.orientation_deg = Spread::of(frames);
    truth
}
