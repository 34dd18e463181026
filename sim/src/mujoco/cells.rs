//! A skin cell as MuJoCo carries it: a site at the cell's accelerometer
//! with MuJoCo's `accelerometer`, a `framelinvel` (the simulated world
//! differentiates it over a tick: under implicit damping the accelerometer
//! reads more than the motion MuJoCo integrates) and a `rangefinder` along
//! its normal, and a site per force cell with a `touch` sensor. One place, so that the world
//! the skin is simulated in and the model a calibration writes out
//! (`robot_with_skin.xml`) carry the same cells; the world leaves out the
//! sensors it does not read from MuJoCo's sensor data ([`Carried`]).

use mujoco_rs::prelude::*;
use mujoco_rs::wrappers::mj_editing::MjsBody;
use nalgebra::{Isometry3, Translation3};

use super::MujocoError;

/// Radius of a force cell's touch zone around it, m: the three zones of a
/// cell (7 mm from its centre, 120 degrees apart) do not overlap.
pub(super) const TOUCH_ZONE_M: f64 = 0.006;
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

/// Radius of the pad a force cell stands on under the cell's cover, m:
/// inside its touch zone, so that whatever presses the pad is felt.
const PAD_M: f64 = 0.005;

/// The cell's cover standing off the link, as the skin is worn where
/// objects are held: each force cell a massless pad of this height on the
/// link, touching what the robot touches (contact bits `contype`,
/// `conaffinity`), its touch zone on the pad's face. Without one, the
/// zones sit on the link's own surface, which a convex object meets at a
/// single point, mostly between the zones: a hug no cell feels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Cover {
    pub height_m: f64,
    pub contype: i32,
    pub conaffinity: i32,
}

/// Adds cell `name` on body `body` at `pose` (body frame, z the outward
/// normal), its force cells at `forces` (cell frame, x y), on pads under a
/// `cover` if it has one: sites `name` and `name:f<k>`, sensors
/// `name:vel` and `name:touch<k>`, and with [`Carried::All`] `name:acc`
/// and `name:range`.
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
    let face_m = cover.map_or(0.0, |c| c.height_m);
    for (k, [x, y]) in forces.iter().enumerate() {
        add_site(on, &format!("{name}:f{k}"), &(pose * Translation3::new(*x, *y, face_m)), TOUCH_ZONE_M);
        if let Some(cover) = cover {
            let centre = pose * Translation3::new(*x, *y, face_m / 2.0);
            let q = centre.rotation.quaternion();
            let pad = on.add_geom();
            let _ = pad.set_name(&format!("{name}:pad{k}"));
            pad.set_type(MjtGeomBase::mjGEOM_CYLINDER);
            *pad.size_mut() = [PAD_M, face_m / 2.0, 0.0];
            *pad.pos_mut() = centre.translation.vector.into();
            *pad.quat_mut() = [q.w, q.i, q.j, q.k];
            pad.set_density(0.0);
            pad.set_contype(cover.contype);
            pad.set_conaffinity(cover.conaffinity);
        }
    }
    for (kind, suffix, site) in [
        (MjtSensor::mjSENS_ACCELEROMETER, "acc", name.to_owned()),
        (MjtSensor::mjSENS_FRAMELINVEL, "vel", name.to_owned()),
        (MjtSensor::mjSENS_RANGEFINDER, "range", name.to_owned()),
        (MjtSensor::mjSENS_TOUCH, "touch0", format!("{name}:f0")),
        (MjtSensor::mjSENS_TOUCH, "touch1", format!("{name}:f1")),
        (MjtSensor::mjSENS_TOUCH, "touch2", format!("{name}:f2")),
    ] {
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
