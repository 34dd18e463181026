//! What the robot does for a calibration: the still postures and the
//! excitation of each DoF, chosen from the description within its limits.

use nalgebra::Point3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use skin_model::robot::{DofKind, Robot as Model};

use super::matching::Matching;
use super::CalibrateConfig;

/// A link reaches this far past its own frame origin, m: the skin on it
/// is assumed within this of the origins the description gives.
const LINK_EXTENT_M: f64 = 0.2;
/// Excitations smaller than this show too little, rad.
const SMALLEST_AMPLITUDE_RAD: f64 = 0.05;

/// One DoF's excitation: `q = start + amplitude (1 - cos wt)^2 / 4`, which
/// starts and ends every period at rest and without a jump in acceleration
/// (a jump the servo smooths in its own way, which no model of the record
/// would follow).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Excitation {
    /// Interface DoF.
    pub dof: usize,
    /// Signed amplitude, rad (towards the side with more room).
    pub amplitude: f64,
    /// The signed amplitude towards the other side, where there is room
    /// for one: the way to go when the first is blocked (a finger that
    /// spreads into its neighbour spreads away from it).
    pub reverse: Option<f64>,
    /// It turns cells, so their levers show (and the skin's delay with them).
    pub levers: bool,
}

/// The excitations, and the DoFs left out with the reason.
#[derive(Clone, Debug, Default)]
pub struct Excitations {
    pub planned: Vec<Excitation>,
    pub skipped: Vec<(usize, String)>,
}

/// `count` seeded postures spread around the start, inside the limits.
pub fn still_postures(
    model: &Model,
    urdf_dof: &[usize],
    start: &[f64],
    count: usize,
    cfg: &CalibrateConfig,
) -> Vec<Vec<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed ^ 0xca1b);
    let mut postures = Vec::with_capacity(count);
    for _ in 0..count {
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

/// One excitation per DoF that carries a cell (a tenth of the amplitude,
/// in m, for a slide), as large as the
/// limits, the velocity limit and the accelerometer range allow.
pub fn excitations(model: &Model, matching: &Matching, start: &[f64], cfg: &CalibrateConfig) -> Excitations {
    let states = super::at_rest(model, &matching.urdf_dof, start);
    let carried: Vec<usize> = matching.candidates.iter().flatten().copied().collect();
    let w = std::f64::consts::TAU * cfg.excitation_hz;
    let mut out = Excitations::default();
    for (d, &m) in matching.urdf_dof.iter().enumerate() {
        let dof = &model.dofs()[m];
        let moved = model.moved_by(m);
        // A DoF that carries no cell is moved too: a cell that moves with
        // it anyway sits on another body than the exploration found.
        let carries = carried.iter().any(|&b| moved[b]);
        // A slide moves every point of its body alike: it shows no lever,
        // but it tells bodies that slide apart (a gripper's fingers) apart.
        let scale = if dof.kind == DofKind::Prismatic { 0.1 } else { 1.0 };
        let joint = &model.joints()[dof.joint];
        let axis_pose = states[joint.child_body].pose;
        let axis = axis_pose.rotation * joint.axis.into_inner();
        let origin = Point3::from(axis_pose.translation.vector);
        let reach = (0..model.bodies().len())
            .filter(|&b| moved[b])
            .map(|b| (Point3::from(states[b].pose.translation.vector) - origin).cross(&axis).norm())
            .fold(0.0, f64::max)
            + LINK_EXTENT_M;
        let reach = if dof.kind == DofKind::Prismatic { 1.0 } else { reach };
        let room_up = dof.upper - cfg.limit_margin_rad * scale - start[d];
        let room_down = start[d] - (dof.lower + cfg.limit_margin_rad * scale);
        let (room, other, sign) =
            if room_up >= room_down { (room_up, room_down, 1.0) } else { (room_down, room_up, -1.0) };
        // Peak acceleration A w^2, peak velocity 0.65 A w.
        let largest = (cfg.excitation_amplitude_rad * scale)
            .min(cfg.excitation_accel_mps2 / (w * w * reach))
            .min(0.8 * dof.max_velocity / (0.65 * w));
        let smallest = SMALLEST_AMPLITUDE_RAD * scale;
        let amplitude = largest.min(room);
        if amplitude.is_nan() || amplitude < smallest {
            let unit = if dof.kind == DofKind::Prismatic { "m" } else { "rad" };
            out.skipped
                .push((d, format!("no room to move it by {smallest} {unit} inside its limits and velocity limit")));
            continue;
        }
        let reverse = largest.min(other);
        out.planned.push(Excitation {
            dof: d,
            amplitude: sign * amplitude,
            reverse: (reverse >= smallest).then_some(-sign * reverse),
            levers: carries && dof.kind == DofKind::Revolute,
        });
    }
    // Turning DoFs that carry cells first: they find the skin's delay for the others.
    out.planned.sort_by_key(|e| !e.levers);
    out
}
