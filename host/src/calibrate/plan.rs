//! What the robot does for a calibration: the still postures and the
//! excitation of each DoF, chosen from the description within its limits.

use nalgebra::Point3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use skin_sim::robot::{DofKind, Robot as Model};

use super::matching::Matching;
use super::CalibrateConfig;

/// A link reaches this far past its own frame origin, m: the skin on it
/// is assumed within this of the origins the description gives.
const LINK_EXTENT_M: f64 = 0.2;
/// Excitations smaller than this show too little, rad.
const SMALLEST_AMPLITUDE_RAD: f64 = 0.05;

/// One DoF's excitation: `q = start + amplitude (1 - cos wt) / 2`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Excitation {
    /// Interface DoF.
    pub dof: usize,
    /// Signed amplitude, rad (towards the side with more room).
    pub amplitude: f64,
}

/// The excitations, and the DoFs left out with the reason.
#[derive(Clone, Debug, Default)]
pub struct Excitations {
    pub planned: Vec<Excitation>,
    pub skipped: Vec<(usize, String)>,
}

/// The start, then seeded postures spread around it, inside the limits.
pub fn still_postures(model: &Model, urdf_dof: &[usize], start: &[f64], cfg: &CalibrateConfig) -> Vec<Vec<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed ^ 0xca1b);
    let mut postures = vec![start.to_vec()];
    for _ in 1..cfg.postures {
        let pose = urdf_dof
            .iter()
            .zip(start)
            .map(|(&m, &q)| {
                let dof = &model.dofs()[m];
                let scale = if dof.kind == DofKind::Prismatic { 0.1 } else { 1.0 };
                let lo = (dof.lower + cfg.limit_margin_rad * scale).max(q - cfg.posture_spread_rad * scale);
                let hi = (dof.upper - cfg.limit_margin_rad * scale).min(q + cfg.posture_spread_rad * scale);
                if lo < hi {
                    rng.random_range(lo..=hi)
                } else {
                    q
                }
            })
            .collect();
        postures.push(pose);
    }
    postures
}

/// One excitation per revolute DoF that carries a cell, as large as the
/// limits, the velocity limit and the accelerometer range allow.
pub fn excitations(
    model: &Model,
    matching: &Matching,
    start: &[f64],
    cfg: &CalibrateConfig,
) -> Excitations {
    let states = super::at_rest(model, &matching.urdf_dof, start);
    let carried: Vec<usize> = matching.candidates.iter().filter_map(|c| c.first().copied()).collect();
    let w = std::f64::consts::TAU * cfg.excitation_hz;
    let mut out = Excitations::default();
    for (d, &m) in matching.urdf_dof.iter().enumerate() {
        let dof = &model.dofs()[m];
        let moved = model.moved_by(m);
        if !carried.iter().any(|&b| moved[b]) {
            out.skipped.push((d, "it carries no cell".into()));
            continue;
        }
        if dof.kind == DofKind::Prismatic {
            out.skipped.push((d, "a sliding DoF turns nothing, so it shows no lever".into()));
            continue;
        }
        let joint = &model.joints()[dof.joint];
        let axis_pose = states[joint.child_body].pose;
        let axis = axis_pose.rotation * joint.axis.into_inner();
        let origin = Point3::from(axis_pose.translation.vector);
        let reach = (0..model.bodies().len())
            .filter(|&b| moved[b])
            .map(|b| (Point3::from(states[b].pose.translation.vector) - origin).cross(&axis).norm())
            .fold(0.0, f64::max)
            + LINK_EXTENT_M;
        let room_up = dof.upper - cfg.limit_margin_rad - start[d];
        let room_down = start[d] - (dof.lower + cfg.limit_margin_rad);
        let (room, sign) = if room_up >= room_down { (room_up, 1.0) } else { (room_down, -1.0) };
        // Peak acceleration A w^2 / 2, peak velocity A w / 2.
        let amplitude = cfg
            .excitation_amplitude_rad
            .min(2.0 * cfg.excitation_accel_mps2 / (w * w * reach))
            .min(2.0 * 0.8 * dof.max_velocity / w)
            .min(room);
        if !(amplitude >= SMALLEST_AMPLITUDE_RAD) {
            out.skipped.push((d, format!("no room to turn it by {SMALLEST_AMPLITUDE_RAD} rad inside its limits and velocity limit")));
            continue;
        }
        out.planned.push(Excitation { dof: d, amplitude: sign * amplitude });
    }
    out
}
