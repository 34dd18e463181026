//! A skin cell as MuJoCo carries it: a site at the cell's accelerometer
//! with MuJoCo's `accelerometer`, a `framelinvel` (the simulated world
//! differentiates it over a tick: under implicit damping the accelerometer
//! reads more than the motion MuJoCo integrates) and a `rangefinder` along
//! its normal, and a site per force cell with a `touch` sensor (in the
//! grasping lab, a cover plate over them instead). One place, so that the world
//! the skin is simulated in and the model a calibration writes out
//! (`robot_with_skin.xml`) carry the same cells; the world leaves out the
//! sensors it does not read from MuJoCo's sensor data ([`Carried`]).

use mujoco_rs::prelude::*;
use mujoco_rs::wrappers::mj_editing::MjsBody;
use nalgebra::{Isometry3, Translation3};

use super::MujocoError;

/// Radius of a force cell's touch zone around it, m: the three zones of a
/// cell (7 mm from its centre, 120 degrees apart) do not overlap.
const TOUCH_ZONE_M: f64 = 0.006;
/// Radius of the site a cell's accelerometer and rangefinder sit at, m.
const CELL_SITE_M: f64 = 0.002;

/// Which of a cell's sensors a model carries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Carried {
    /// All of them, for any MuJoCo program to read (`robot_with_skin.xml`).
    All,
    /// What the simulated world reads from MuJoCo's sensor data: the
    /// velocity and the touch zones. MuJoCo computes every sensor in every
    /// step; the world does not read the accelerometer (see
    /// [`super::Engine`]), and casts the rangefinder's ray itself only where
    /// something is within the proximity sensor's range
    /// ([`super::rangefinder`]), with the same result.
    World,
}

/// Radius of a cell's cover plate, m: inside the hexagon of a cell laid
/// at the 25 mm pitch of the skin's patches, so neighbours' plates do not
/// overlap.
const PLATE_M: f64 = 0.012;

/// The cell's cover standing off the link, as the skin is worn where
/// objects are held: one rigid plate of this height on the link over the
/// cell's three force cells, touching what the robot touches (contact bits
/// `contype`, `conaffinity`). The paper's cover "collects and concentrates
/// distributed forces onto the discrete force sensors" (its Figure 5): a
/// load anywhere on the plate is felt, shared among the three force cells
/// as a rigid plate on three supports shares it ([`shares`]). Without a
/// cover the touch zones sit on the link's own surface, which a convex
/// object meets at a single point, mostly between the zones: a hug no cell
/// feels; with a pad per force cell, one 5 mm pad carried a whole contact
/// and felt pain at 4.24 N, a third of what the cell bears. The plate
/// grips with the cover's `friction`, at the contact `priority` of what
/// has its own softness (MuJoCo mixes equal priorities' parameters; a
/// higher one imposes all of its own, its softness too).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Cover {
    pub height_m: f64,
    pub contype: i32,
    pub conaffinity: i32,
    pub friction: f64,
    pub priority: i32,
}

/// Adds cell `name` on body `body` at `pose` (body frame, z the outward
/// normal), its force cells at `forces` (cell frame, x y): site `name`,
/// sensor `name:vel` and with [`Carried::All`] `name:acc` and
/// `name:range`; under a `cover`, the plate geom `name:plate`, else sites
/// `name:f<k>` with sensors `name:touch<k>`.
pub(super) fn add(
    spec: &mut MjSpec,
    body: &str,
    name: &str,
    pose: &Isometry3<f64>,
    forces: &[[f64; 2]; 3],
    carried: Carried,
    cover: Option<Cover>,
) -> Result<(), MujocoError> {
    let on = spec.body_mut(body).ok_or_else(|| MujocoError::UnknownBody(body.to_owned()))?;
    add_site(on, name, pose, CELL_SITE_M);
    match cover {
        Some(cover) => {
            let centre = pose * Translation3::new(0.0, 0.0, cover.height_m / 2.0);
            let q = centre.rotation.quaternion();
            let plate = on.add_geom();
            let _ = plate.set_name(&format!("{name}:plate"));
            plate.set_type(MjtGeomBase::mjGEOM_CYLINDER);
            *plate.size_mut() = [PLATE_M, cover.height_m / 2.0, 0.0];
            *plate.pos_mut() = centre.translation.vector.into();
            *plate.quat_mut() = [q.w, q.i, q.j, q.k];
            plate.set_density(0.0);
            plate.set_contype(cover.contype);
            plate.set_conaffinity(cover.conaffinity);
            plate.friction_mut()[0] = cover.friction;
            plate.set_priority(cover.priority);
        }
        None => {
            for (k, [x, y]) in forces.iter().enumerate() {
                add_site(on, &format!("{name}:f{k}"), &(pose * Translation3::new(*x, *y, 0.0)), TOUCH_ZONE_M);
            }
        }
    }
    let touch = cover.is_none().then_some([
        (MjtSensor::mjSENS_TOUCH, "touch0", format!("{name}:f0")),
        (MjtSensor::mjSENS_TOUCH, "touch1", format!("{name}:f1")),
        (MjtSensor::mjSENS_TOUCH, "touch2", format!("{name}:f2")),
    ]);
    for (kind, suffix, site) in [
        (MjtSensor::mjSENS_ACCELEROMETER, "acc", name.to_owned()),
        (MjtSensor::mjSENS_FRAMELINVEL, "vel", name.to_owned()),
        (MjtSensor::mjSENS_RANGEFINDER, "range", name.to_owned()),
    ]
    .into_iter()
    .chain(touch.into_iter().flatten())
    {
        let read_by_world = !matches!(kind, MjtSensor::mjSENS_ACCELEROMETER | MjtSensor::mjSENS_RANGEFINDER);
        if carried == Carried::World && !read_by_world {
            continue;
        }
        let sensor = spec.add_sensor();
        sensor.set_type(kind);
        sensor.set_objtype(MjtObjBase::mjOBJ_SITE);
        sensor.set_objname(&site);
        let _ = sensor.set_name(&format!("{name}:{suffix}"));
        if kind == MjtSensor::mjSENS_RANGEFINDER {
            // What the ray reports: its distance (the XML's `data="dist"`).
            sensor.intprm_mut()[0] = 1;
        }
    }
    Ok(())
}

/// The share of a load at `(x, y)` on a rigid plate (cell frame) each of
/// the three supports at `forces` bears: the load's barycentric
/// coordinates in their triangle (statics of a plate on three supports).
/// Beyond an edge of the triangle the plate lifts off the support across
/// it, which then bears nothing, and the others share the whole load.
pub(crate) fn shares(forces: &[[f64; 2]; 3], x: f64, y: f64) -> [f64; 3] {
    let [a, b, c] = *forces;
    let det = (b[1] - c[1]) * (a[0] - c[0]) + (c[0] - b[0]) * (a[1] - c[1]);
    if det.abs() < 1e-12 {
        return [1.0 / 3.0; 3];
    }
    let l0 = ((b[1] - c[1]) * (x - c[0]) + (c[0] - b[0]) * (y - c[1])) / det;
    let l1 = ((c[1] - a[1]) * (x - c[0]) + (a[0] - c[0]) * (y - c[1])) / det;
    let bearing = [l0, l1, 1.0 - l0 - l1].map(|l| l.max(0.0));
    let sum: f64 = bearing.iter().sum();
    bearing.map(|l| l / sum)
}

/// Adds to a plate's force cells (`zone`, supports at `forces`) what one
/// contact point at `at` (cell frame, x y) pressing with `force_n` gives
/// them. MuJoCo's collider gives one patch of a face on a plate as up to
/// four points, each at the patch's depth and each bearing, as a spring,
/// what the patch bears alone, and the count jumps from tick to tick:
/// summed, a box turning flush on a plate took a force cell from 3.1 N to
/// 5.1 N (pain) in 4 ms with nothing moving. So a force cell takes the
/// largest share any one point gives it: points of one patch count once,
/// and points over different force cells each load their own.
pub(super) fn bear(zone: &mut [f64; 3], forces: &[[f64; 2]; 3], at: [f64; 2], force_n: f64) {
    for (z, share) in zone.iter_mut().zip(shares(forces, at[0], at[1])) {
        *z = z.max(force_n * share);
    }
}

/// A sphere site of `radius` named `name` at `pose` on `body`.
fn add_site(body: &mut MjsBody, name: &str, pose: &Isometry3<f64>, radius: f64) {
    let q = pose.rotation.quaternion();
    let site = body.add_site();
    let _ = site.set_name(name);
    site.set_type(MjtGeomBase::mjGEOM_SPHERE);
    *site.size_mut() = [radius, 0.0, 0.0];
    *site.pos_mut() = pose.translation.vector.into();
    *site.quat_mut() = [q.w, q.i, q.j, q.k];
}

/// How much stiffer a cover plate is than the foam under one of its
/// force cells, on average over its face: pressed at a point where the
/// supports bear shares `l`, a plate on three equal springs gives as one
/// spring over `sum(l^2)` (1 over a force cell, 3 at the centre).
pub(super) fn plate_stiffness_factor(forces: &[[f64; 2]; 3]) -> f64 {
    // The face's mean, on rings of equal area, 24 points each.
    let (rings, points) = (24, 24);
    let mut sum = 0.0;
    for i in 0..rings {
        let r = PLATE_M * ((i as f64 + 0.5) / rings as f64).sqrt();
        for j in 0..points {
            let a = std::f64::consts::TAU * j as f64 / points as f64;
            let l = shares(forces, r * a.cos(), r * a.sin());
            sum += 1.0 / l.iter().map(|x| x * x).sum::<f64>();
        }
    }
    sum / f64::from(rings * points)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_plate_shares_a_load_as_it_rests_on_its_three_force_cells() {
        let forces = crate::scene::SkinModel::default().force.positions();
        let close = |a: [f64; 3], b: [f64; 3]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-12);
        // Over a force cell, it bears all; at the centre, each a third.
        for (k, [x, y]) in forces.iter().enumerate() {
            let mut alone = [0.0; 3];
            alone[k] = 1.0;
            assert!(close(shares(&forces, *x, *y), alone), "over force cell {k}");
        }
        assert!(close(shares(&forces, 0.0, 0.0), [1.0 / 3.0; 3]));
        // Midway between two, they share it and the third bears nothing.
        let [a, b, _] = forces;
        assert!(close(shares(&forces, (a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0), [0.5, 0.5, 0.0]));
        // Beyond that edge the plate lifts off the third, which pulls nothing.
        let out = shares(&forces, a[0] + b[0], a[1] + b[1]);
        assert!(out[2] == 0.0 && (out.iter().sum::<f64>() - 1.0).abs() < 1e-12, "{out:?}");
        // The load's moment about the centre is the supports' (statics), inside the triangle.
        let (x, y) = (0.002, -0.001);
        let s = shares(&forces, x, y);
        let moment = |axis: usize| s.iter().zip(&forces).map(|(l, p)| l * p[axis]).sum::<f64>();
        assert!((moment(0) - x).abs() < 1e-12 && (moment(1) - y).abs() < 1e-12, "{s:?}");
        // Between a force cell's stiffness and three times it (at the centre).
        let factor = plate_stiffness_factor(&forces);
        assert!((1.5..1.8).contains(&factor), "{factor}");
    }

    #[test]
    fn the_points_of_one_patch_press_once_and_points_apart_each_press() {
        let forces = crate::scene::SkinModel::default().force.positions();
        let [a, b, _] = forces;
        let mut patch = [0.0; 3];
        for dx in [-1e-4, 0.0, 1e-4, 2e-4] {
            bear(&mut patch, &forces, [a[0] + dx, a[1]], 3.0);
        }
        assert!((patch[0] - 3.0).abs() < 1e-2 && patch[0] <= 3.0, "four points over force cell 0: {patch:?}");
        let mut apart = [0.0; 3];
        bear(&mut apart, &forces, a, 2.0);
        bear(&mut apart, &forces, b, 1.0);
        assert_eq!(apart, [2.0, 1.0, 0.0], "one point over each of two force cells");
    }
}
