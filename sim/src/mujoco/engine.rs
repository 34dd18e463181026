//! MuJoCo moving the robot and feeling for the skin: the compiled model
//! with the cells' sites and sensors, the DoFs' position servos, and one
//! control tick as a few MuJoCo steps.

use mujoco_rs::prelude::*;
use mujoco_rs::wrappers::mj_editing::{MjtLimited, PositionConfig};
use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};
use rand::Rng;
use skin_model::skin::Skin;

use super::stage::{self, Scenery, SharedStage};
use super::{cells, rangefinder, tree, Model, MujocoError};
use crate::scene::{CellSense, SkinModel};
use crate::world::{Touch, WorldConfig};

/// Natural frequency of the position servos added to joints without one,
/// Hz, and their damping ratio: a soft, overdamped servo, as robot models
/// ship theirs (Menagerie's arms: a few Hz, damping ratio above 1); with
/// gravity compensated it does not sag. Measured: with a stiff, critically
/// damped one (25 Hz) the UR5 and the tests' arm calibrated 3-6 mm off,
/// with this one about 1 mm, as models with their own servos do (why the
/// stiff one misleads the calibration is not pinned down).
const SERVO_HZ: f64 = 10.0;
const SERVO_DAMPING_RATIO: f64 = 2.0;
/// Rotor inertia a geared servo adds to a joint without one, relative to
/// the joint's own inertia at the start pose: it is what keeps a light link
/// from being thrown by its neighbour's acceleration.
const ARMATURE_RATIO: f64 = 1.0;
/// Share of a joint's force limit its motion planner may spend on
/// acceleration (at the start pose's inertia); the rest holds the load
/// against gravity and the neighbours' reactions.
const ACCEL_SHARE: f64 = 0.5;
/// Time constant of the welds holding floating bases, s.
const WELD_TIME_CONSTANT_S: f64 = 0.004;
/// A servo that leaves its joint further than this from its set point
/// against the joint's dry friction is named in the notes, rad (m for a
/// slide): a tenth of the paper's 0.1 rad structural step, the share of
/// a step's gravity change its static test takes for noise.
const FRICTION_BAND_NOTED: f64 = 0.01;

/// How a DoF is driven, as a velocity-controlled robot's joint controller
/// does it: the velocity command integrates into a goal; a set point runs
/// after the goal no faster than the joint's force limit can accelerate
/// it, so a saturated joint arrives late instead of winding up and
/// overshooting; the position servo tracks the set point with velocity
/// and inertia feed-forward, gravity compensated. Without the inertia
/// term a stiff servo runs ahead of a decelerating set point by the
/// inertia times the deceleration over its stiffness (13 mrad at the
/// built-in robot's shoulder after a 0.2 rad step in 0.2 s) and rings for
/// 0.2 s, which the exploration's still windows read as noise.
struct Servo {
    qpos: usize,
    /// `qpos` at the robot's zero (the model's reference pose).
    zero: f64,
    /// The joint's range in `qpos`.
    range: (f64, f64),
    actuator: usize,
    /// The actuator's control range (`-inf..inf` when not limited).
    ctrl: (f64, f64),
    /// The commanded position: the velocity command's integral.
    goal: f64,
    /// The set point and its velocity.
    setpoint: f64,
    velocity: f64,
    /// Largest acceleration of the set point (infinite where the joint's
    /// force is not limited).
    accel: f64,
    /// The servo's damping over its stiffness, s: the set point's lead that
    /// cancels the damping at the set point's velocity.
    feedforward_s: f64,
    /// The DoF's row in MuJoCo's mass matrix, and the servo's compliance
    /// (1 / stiffness), rad per N m: the inertia feed-forward's factors.
    dof: usize,
    compliance: f64,
    /// How far the goal may lead the joint beyond the set point's trail:
    /// the servo's deflection at its force limit (infinite where the
    /// force is not limited). Further
    /// buys no force; it only winds up while the joint is blocked (a limb
    /// against another), and throws the joint that far on the moment it
    /// slips free, as a joint controller with anti-windup does not.
    lead_limit: f64,
}

impl Servo {
    /// Moves the goal by the command `w` over `dt` and the set point after
    /// it: the goal's own velocity, plus the fastest approach that can still
    /// stop at the goal at the acceleration limit.
    fn follow(&mut self, w: f64, dt: f64, inertia: f64, q: f64) -> f64 {
        // Plus how far the set point trails the goal at the commanded
        // speed (its braking distance, or two ticks): within that the
        // goal is not ahead of what the servo can follow.
        let trail = (w * w / (2.0 * self.accel)).max(2.0 * w.abs() * dt);
        let lead = self.lead_limit + trail;
        let (low, high) = ((q - lead).max(self.range.0), (q + lead).min(self.range.1));
        let goal = self.goal + w * dt;
        // A joint pushed further out of its range than the lead (by a
        // contact, or a limit's give) has its goal at the range's end.
        self.goal = if low <= high { goal.clamp(low, high) } else { goal.clamp(self.range.0, self.range.1) };
        let error = self.goal - self.setpoint;
        // Braking distance v^2 / 2a; near the goal, half the gap per tick.
        let approach =
            if error == 0.0 { 0.0 } else { (2.0 * self.accel * error.abs()).sqrt().min(error.abs() / (2.0 * dt)) };
        let wanted = error.signum() * approach;
        let dv = self.accel * dt;
        let accel = (wanted - self.velocity).clamp(-dv, dv) / dt;
        self.velocity += accel * dt;
        self.setpoint = (self.setpoint + self.velocity * dt).clamp(self.range.0, self.range.1);
        let lead = self.feedforward_s * self.velocity + self.compliance * inertia * accel;
        (self.setpoint + lead).clamp(self.ctrl.0, self.ctrl.1)
    }
}

/// Where a cell's readings are in MuJoCo's sensor data.
struct CellSensors {
    site: usize,
    /// The body the site is on, which its rangefinder does not see.
    body: usize,
    /// The site's linear velocity in the world (`framelinvel`).
    velocity: usize,
    /// Its force cells' `touch` sensors; none under a cover, whose plate
    /// the lab reads ([`Scenery::felt`]).
    touch: Option<[usize; 3]>,
}

/// MuJoCo running the robot and its skin.
pub struct Engine {
    data: MjData<Box<MjModel>>,
    substeps: u32,
    tick_s: f64,
    servos: Vec<Servo>,
    cells: Vec<CellSensors>,
    /// Each cell's world velocity at the end of the last tick.
    velocities: Vec<Vector3<f64>>,
    /// Whether anything touches anything at the end of the last tick:
    /// without a contact every touch zone reads zero, and MuJoCo's
    /// acceleration stage (contact forces) is not computed.
    touching: bool,
    gravity: Vector3<f64>,
    skin_model: SkinModel,
    notes: Vec<String>,
    welded: Vec<String>,
    /// The grasping experiment's lab, when the world has one.
    stage: Option<Scenery>,
}

impl Engine {
    pub(super) fn new(
        model: Model,
        skin: &Skin,
        cfg: &WorldConfig,
        lab: Option<SharedStage>,
    ) -> Result<Engine, MujocoError> {
        let Model { mut spec, compiled, tree, mut notes, start_ctrl } = model;
        let robot = &tree.robot;
        let welded = weld_floating_bases(&mut spec, &compiled);
        if !welded.is_empty() {
            notes.push(format!(
                "floating base {} held by a weld at its start pose, as on a test stand",
                welded.iter().map(|b| format!("\"{b}\"")).collect::<Vec<_>>().join(", ")
            ));
        }
        let servo_of = servos(&mut spec, &compiled, &tree, &mut notes)?;
        compensate_gravity(&mut spec, &compiled, &tree);
        notes.push(format!(
            "the joint controllers compensate the links' weight within their force limits, their set points accelerate no faster than {:.0} % of a force limit allows at the start pose's inertia, and a blocked joint's goal runs no further ahead of it than its servo's deflection at the force limit plus the set point's trail at the commanded speed",
            ACCEL_SHARE * 100.0
        ));

        let skin_model = SkinModel::default();
        let force_positions = skin_model.force.positions();
        // In the lab objects are held: the cells' covers stand off the links.
        let cover = lab.is_some().then(|| stage::cover(&skin_model));
        for (i, cell) in skin.cells().iter().enumerate() {
            let link = robot.link(&cell.link).ok_or_else(|| MujocoError::UnknownBody(cell.link.clone()))?;
            let in_body = link.in_body.inverse() * cell.pose;
            cells::add(
                &mut spec,
                &link.name,
                &format!("skin{i}"),
                &in_body,
                &force_positions,
                cells::Carried::World,
                cover,
            )?;
        }

        // A control tick is a whole number of MuJoCo steps.
        let timestep = spec.option().timestep;
        let substeps = (cfg.tick_s / timestep - 1e-9).ceil().max(1.0);
        if ((cfg.tick_s / substeps) - timestep).abs() > 1e-12 {
            notes.push(format!(
                "the model's timestep {:.4} s became {:.4} s: {substeps} steps per {:.0} ms control tick",
                timestep,
                cfg.tick_s / substeps,
                cfg.tick_s * 1e3
            ));
        }
        let [roll, pitch, yaw] = cfg.base.tilt_rpy;
        let g = Vector3::from(spec.option().gravity);
        let gravity = UnitQuaternion::from_euler_angles(roll, pitch, yaw).inverse() * g;
        {
            let option = spec.option_mut();
            option.timestep = cfg.tick_s / substeps;
            option.gravity = gravity.into();
        }

        if lab.is_some() {
            stage::furnish(&mut spec);
        }
        let model = spec.compile().map_err(|e| MujocoError::Compile(e.to_string()))?;
        let sensor = |name: String| {
            model
                .name_to_id(MjtObjBase::mjOBJ_SENSOR, &name)
                .map(|id| model.sensor_adr()[id] as usize)
                .ok_or_else(|| MujocoError::Compile(format!("the compiled model lacks sensor {name}")))
        };
        let mut cells = Vec::with_capacity(skin.cells().len());
        for i in 0..skin.cells().len() {
            let site = model
                .name_to_id(MjtObjBase::mjOBJ_SITE, &format!("skin{i}"))
                .ok_or_else(|| MujocoError::Compile(format!("the compiled model lacks site skin{i}")))?;
            cells.push(CellSensors {
                site,
                body: model.site_bodyid()[site] as usize,
                velocity: sensor(format!("skin{i}:vel"))?,
                touch: match cover {
                    Some(_) => None,
                    None => Some([
                        sensor(format!("skin{i}:touch0"))?,
                        sensor(format!("skin{i}:touch1"))?,
                        sensor(format!("skin{i}:touch2"))?,
                    ]),
                },
            });
        }
        let mut servos = Vec::with_capacity(servo_of.len());
        let mut sticking = Vec::new();
        for (d, (&joint, actuator)) in tree.dof_joint.iter().zip(servo_of).enumerate() {
            let qpos = model.jnt_qposadr()[joint] as usize;
            let zero = model.qpos0()[qpos];
            let dof = &robot.dofs()[d];
            let ctrl = if model.actuator_ctrllimited()[actuator] {
                let r = model.actuator_ctrlrange()[actuator];
                (r[0], r[1])
            } else {
                (f64::NEG_INFINITY, f64::INFINITY)
            };
            let target = zero + robot.home()[d];
            let kp = model.actuator_gainprm()[actuator][0];
            let kv = -model.actuator_biasprm()[actuator][2];
            let force = force_limit(&model, actuator, joint);
            let inertia = model.dof_m0()[model.jnt_dofadr()[joint] as usize].max(1e-9);
            if let Some(band) = friction_band(&model, joint, kp).filter(|&b| b > FRICTION_BAND_NOTED) {
                sticking.push(format!("{} {band:.3}", dof.name));
            }
            servos.push(Servo {
                qpos,
                zero,
                range: (zero + dof.lower, zero + dof.upper),
                actuator,
                ctrl,
                goal: target,
                setpoint: target,
                velocity: 0.0,
                accel: ACCEL_SHARE * force / inertia,
                feedforward_s: if kp > 0.0 { kv.max(0.0) / kp } else { 0.0 },
                dof: model.jnt_dofadr()[joint] as usize,
                compliance: if kp > 0.0 { 1.0 / kp } else { 0.0 },
                lead_limit: if kp > 0.0 { force / kp } else { f64::INFINITY },
            });
        }
        if !sticking.is_empty() {
            notes.push(format!(
                "servos that hold their joint only within this of their set point against its dry friction (friction loss over stiffness, rad or m: a smaller commanded move may leave the joint where it is): {}",
                sticking.join(", ")
            ));
        }
        let stage = match lab {
            Some(lab) => {
                let plates = cells_plates(&model, &cells)?;
                Some(Scenery::bind(lab, spec, &model, plates, force_positions).map_err(MujocoError::Compile)?)
            }
            None => None,
        };
        let mut data = MjData::new(Box::new(model));
        // The model's own actuators on what the world does not drive (a
        // gripper's tendon) hold the start keyframe's controls.
        for (a, &c) in start_ctrl.iter().enumerate() {
            if !servos.iter().any(|s| s.actuator == a) {
                data.ctrl_mut()[a] = c;
            }
        }
        for s in &servos {
            data.qpos_mut()[s.qpos] = s.goal;
            data.ctrl_mut()[s.actuator] = s.goal.clamp(s.ctrl.0, s.ctrl.1);
        }
        data.forward();
        let velocities = vec![Vector3::zeros(); cells.len()];
        Ok(Engine {
            data,
            velocities,
            touching: true,
            substeps: substeps as u32,
            tick_s: cfg.tick_s,
            servos,
            cells,
            gravity,
            skin_model,
            notes,
            welded,
            stage,
        })
    }

    /// What was assumed of the model, one sentence each (printed, and in the JSON).
    pub fn notes(&self) -> &[String] {
        &self.notes
    }

    /// The bodies with a floating base, held by a weld at their start pose.
    pub fn welded(&self) -> &[String] {
        &self.welded
    }

    /// DoF positions relative to the model's reference pose.
    pub(crate) fn positions(&self) -> Vec<f64> {
        self.servos.iter().map(|s| self.data.qpos()[s.qpos] - s.zero).collect()
    }

    /// Every cell's pose in the world, skin order.
    pub(crate) fn cell_poses(&self, poses: &mut [Isometry3<f64>]) {
        for (pose, cell) in poses.iter_mut().zip(&self.cells) {
            *pose = site_pose(&self.data, cell.site);
        }
    }

    /// One control tick under the velocity `command` (DoF order): each
    /// servo's goal moves by it (held inside the joint's range) and its set
    /// point follows as the joint can ([`Servo::follow`]), MuJoCo steps, and the
    /// positions, cell poses and each cell's specific force (cell frame) are
    /// read at the tick's end.
    ///
    /// The specific force is the tick's mean acceleration of the cell's
    /// site (its world velocity's change over the tick, as the BMA250's
    /// bandwidth and the built-in world see it) against gravity, not
    /// MuJoCo's `accelerometer`: that reports the acceleration before the
    /// implicit integrators' damping correction, 1.2 to 1.6 times the
    /// motion MuJoCo then makes under stiff damped servos (measured on the
    /// tests' arm), so it disagrees with the robot's own joint feedback as
    /// no real accelerometer does. At rest both read gravity.
    pub(crate) fn advance(
        &mut self,
        command: &[f64],
        q: &mut [f64],
        poses: &mut [Isometry3<f64>],
        specific: &mut [Vector3<f64>],
    ) {
        if let Some(lab) = &mut self.stage {
            lab.before(&mut self.data);
        }
        for (s, &w) in self.servos.iter_mut().zip(command) {
            let inertia = inertia_of(&self.data, s.dof);
            let q = self.data.qpos()[s.qpos];
            self.data.ctrl_mut()[s.actuator] = s.follow(w, self.tick_s, inertia, q);
        }
        // No step's sensors are read: only those of the state the steps reach.
        let sensors_off = MjtDisableBit::mjDSBL_SENSOR as i32;
        self.data.model_opt_mut().disableflags |= sensors_off;
        for _ in 0..self.substeps {
            self.data.step();
        }
        self.data.model_opt_mut().disableflags &= !sensors_off;
        self.sense_state();
        if let Some(lab) = &mut self.stage {
            lab.after(&self.data);
        }
        self.cell_poses(poses);
        let readings = self.data.sensordata();
        for (((f, cell), pose), last) in
            specific.iter_mut().zip(&self.cells).zip(poses.iter()).zip(&mut self.velocities)
        {
            let v = Vector3::new(readings[cell.velocity], readings[cell.velocity + 1], readings[cell.velocity + 2]);
            let accel = (v - *last) / self.tick_s;
            *last = v;
            *f = pose.rotation.inverse() * (accel - self.gravity);
        }
        for (q, s) in q.iter_mut().zip(&self.servos) {
            *q = self.data.qpos()[s.qpos] - s.zero;
        }
    }

    /// Poses, velocities and touch of the state the steps reached, as
    /// `mj_forward` computes them with their sensors: its position and
    /// velocity stages, and the acceleration stage (contact forces, the
    /// touch zones) only when something touches. Nothing of this feeds
    /// back: the next step computes its own.
    fn sense_state(&mut self) {
        self.data.fwd_position();
        self.data.sensor_pos();
        self.data.fwd_velocity();
        self.data.sensor_vel();
        self.touching = !self.data.contact().is_empty();
        if self.touching {
            self.data.fwd_actuation();
            self.data.fwd_acceleration();
            self.data.fwd_constraint();
            self.data.sensor_acc();
        }
    }

    /// Every cell's force and proximity counts: its touch zones' normal
    /// forces and its rangefinder's distance (from the skin's surface),
    /// through the skin's force-cell and VCNL4010 models.
    pub(crate) fn touches(&mut self, out: &mut [Touch], rng: &mut impl Rng) {
        let m = &self.skin_model;
        // Beyond this the proximity sensor reads nothing.
        let reach = m.proximity.range_m + m.surface_offset_m;
        for (i, (t, cell)) in out.iter_mut().zip(&self.cells).enumerate() {
            let proximity = match rangefinder::distance(&mut self.data, cell.site, cell.body, reach) {
                Some((geom, distance)) => {
                    let reflectance = self.stage.as_ref().map_or(1.0, |lab| lab.reflectance(&self.data, geom));
                    m.proximity.intensity((distance - m.surface_offset_m).max(0.0), 1.0, reflectance)
                }
                None => 0.0,
            };
            let force_n = match (cell.touch, &self.stage) {
                _ if !self.touching => [0.0; 3],
                (Some(touch), _) => touch.map(|a| self.data.sensordata()[a]),
                (None, lab) => lab.as_ref().map_or([0.0; 3], |lab| lab.felt(i)),
            };
            let sense = CellSense { force_n, proximity };
            let (proximity, force) = m.counts(&sense, rng);
            *t = Touch { proximity, force };
        }
    }
}

/// The diagonal of MuJoCo's mass matrix at `dof` (its armature included)
/// in the last computed state: the last entry of the dof's row of the
/// lower-triangular sparse matrix `M`.
fn inertia_of(data: &MjData<Box<MjModel>>, dof: usize) -> f64 {
    let model = data.model();
    let last = (model.m_rowadr()[dof] + model.m_rownnz()[dof] - 1) as usize;
    if model.m_colind()[last] as usize == dof {
        data.m()[last]
    } else {
        model.dof_m0()[dof]
    }
}

/// The pose of site `site` in the world.
pub(super) fn site_pose(data: &MjData<Box<MjModel>>, site: usize) -> Isometry3<f64> {
    let (p, m) = (data.site_xpos()[site], data.site_xmat()[site]);
    let rotation = Rotation3::from_matrix_unchecked(Matrix3::new(m[0], m[1], m[2], m[3], m[4], m[5], m[6], m[7], m[8]));
    Isometry3::from_parts(Translation3::new(p[0], p[1], p[2]), UnitQuaternion::from_rotation_matrix(&rotation))
}

/// Each cell's site and its cover plate's geom in `model`.
fn cells_plates(model: &MjModel, cells: &[CellSensors]) -> Result<Vec<(usize, usize)>, MujocoError> {
    cells
        .iter()
        .enumerate()
        .map(|(i, cell)| {
            let plate = model
                .name_to_id(MjtObjBase::mjOBJ_GEOM, &format!("skin{i}:plate"))
                .ok_or_else(|| MujocoError::Compile(format!("the compiled model lacks geom skin{i}:plate")))?;
            Ok((cell.site, plate))
        })
        .collect()
}

/// Holds every body with a free joint where it starts, by a weld to the
/// world; returns their names.
fn weld_floating_bases(spec: &mut MjSpec, compiled: &MjModel) -> Vec<String> {
    let free: Vec<String> = (0..compiled.jnt_type().len())
        .filter(|&j| compiled.jnt_type()[j] == MjtJoint::mjJNT_FREE)
        .map(|j| tree::name(compiled, MjtObjBase::mjOBJ_BODY, compiled.jnt_bodyid()[j] as usize))
        .collect();
    for body in &free {
        let weld = spec.add_equality();
        weld.set_type(MjtEq::mjEQ_WELD);
        weld.set_objtype(MjtObjBase::mjOBJ_BODY);
        weld.set_name1(body);
        // Anchor at the body's origin, the relative pose taken at the
        // start (a zero quaternion), full torque (mjSpec's default data is a
        // joint coupling's).
        *weld.data_mut() = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0];
        // As stiff as MuJoCo keeps stable (a time constant of two 2 ms
        // steps, hard impedance): a test stand, not a spring the legs rock.
        *weld.solref_mut() = [WELD_TIME_CONSTANT_S, 1.0];
        *weld.solimp_mut() = [0.99, 0.999, 0.001, 0.5, 2.0];
    }
    free
}

/// The robot's joint controllers hold its weight, as real ones do: every
/// link's gravity is compensated through the DoFs' actuators (within
/// their force limits), so a servo neither sags under load nor needs an
/// integral term that winds up.
fn compensate_gravity(spec: &mut MjSpec, compiled: &MjModel, tree: &tree::Tree) {
    for link in tree.robot.links() {
        if let Some(body) = spec.body_mut(&link.name) {
            body.set_gravcomp(1.0);
        }
    }
    for &j in &tree.dof_joint {
        if let Some(joint) = spec.joint_mut(&tree::name(compiled, MjtObjBase::mjOBJ_JOINT, j)) {
            joint.set_actgravcomp(true);
        }
    }
}

/// How far from its set point a servo of stiffness `kp` leaves `joint`
/// at rest against the joint's dry friction (MuJoCo's friction loss):
/// within it, the servo's force does not exceed the friction.
fn friction_band(model: &MjModel, joint: usize, kp: f64) -> Option<f64> {
    let friction = model.dof_frictionloss()[model.jnt_dofadr()[joint] as usize];
    (kp > 0.0 && friction > 0.0).then(|| friction / kp)
}

/// The largest force `actuator` can put on `joint`: its own force range
/// and the joint's actuator force range, infinite where neither is limited.
fn force_limit(model: &MjModel, actuator: usize, joint: usize) -> f64 {
    let mut force = f64::INFINITY;
    if model.actuator_forcelimited()[actuator] {
        let r = model.actuator_forcerange()[actuator];
        force = force.min(r[0].abs().max(r[1].abs()) * model.actuator_gear()[actuator][0].abs());
    }
    if model.jnt_actfrclimited()[joint] {
        let r = model.jnt_actfrcrange()[joint];
        force = force.min(r[0].abs().max(r[1].abs()));
    }
    force
}

/// The actuator each DoF's servo target goes to: the model's position
/// servo on the joint, or one added (at [`SERVO_HZ`], critically damped,
/// its force limited as the joint's motor is, if it has one).
fn servos(
    spec: &mut MjSpec,
    compiled: &MjModel,
    tree: &tree::Tree,
    notes: &mut Vec<String>,
) -> Result<Vec<usize>, MujocoError> {
    let on_joint = |j: usize| {
        (0..compiled.actuator_trntype().len()).filter(move |&a| {
            compiled.actuator_trntype()[a] == MjtTrn::mjTRN_JOINT && compiled.actuator_trnid()[a][0] as usize == j
        })
    };
    let mut next = compiled.actuator_trntype().len();
    let mut added = Vec::new();
    let mut actuators = Vec::with_capacity(tree.dof_joint.len());
    for &j in &tree.dof_joint {
        if let Some(a) = tree::position_servo(compiled, j) {
            actuators.push(a);
            continue;
        }
        let joint = tree::name(compiled, MjtObjBase::mjOBJ_JOINT, j);
        let inertia = compiled.dof_m0()[compiled.jnt_dofadr()[j] as usize].max(1e-6);
        let mut armature = 0.0;
        if let Some(j) = spec.joint_mut(&joint) {
            if j.armature() == 0.0 {
                j.set_armature(ARMATURE_RATIO * inertia);
            }
            armature = j.armature();
        }
        let kp = (inertia + armature) * (std::f64::consts::TAU * SERVO_HZ).powi(2);
        // A motor's torque limit is the joint's: ctrlrange times gear.
        let limit = on_joint(j).find(|&a| compiled.actuator_ctrllimited()[a]).map(|a| {
            let (r, gear) = (compiled.actuator_ctrlrange()[a], compiled.actuator_gear()[a][0].abs());
            r[0].abs().max(r[1].abs()) * gear
        });
        let actuator = spec.add_actuator();
        let _ = actuator.set_name(&format!("skin:servo:{joint}"));
        actuator.set_trntype(MjtTrn::mjTRN_JOINT);
        actuator.set_target(&joint);
        actuator
            .set_to_position(PositionConfig::default().with_kp(kp).with_dampratio(SERVO_DAMPING_RATIO))
            .map_err(|e| MujocoError::Compile(format!("a servo for joint \"{joint}\": {e}")))?;
        if let Some(limit) = limit {
            actuator.set_forcelimited(MjtLimited::mjLIMITED_TRUE);
            *actuator.forcerange_mut() = [-limit, limit];
        }
        added.push(joint);
        actuators.push(next);
        next += 1;
    }
    if !added.is_empty() {
        notes.push(format!(
            "{} joints without a position servo got one ({SERVO_HZ} Hz, damping ratio {SERVO_DAMPING_RATIO}, force limited as the joint's motor where it has one): {}",
            added.len(),
            added.join(", ")
        ));
    }
    Ok(actuators)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_joint_pressed_far_past_its_range_gets_a_goal_at_the_range_s_end() {
        // Range -0.2..0, its servo's deflection at full force 0.2 mrad.
        let mut servo = Servo {
            qpos: 0,
            zero: 0.0,
            range: (-0.2, 0.0),
            actuator: 0,
            ctrl: (f64::NEG_INFINITY, f64::INFINITY),
            goal: 0.0,
            setpoint: 0.0,
            velocity: 0.0,
            accel: 10.0,
            feedforward_s: 0.0,
            dof: 0,
            compliance: 1.0 / 5000.0,
            lead_limit: 0.0002,
        };
        // Pressed 0.3 rad past the limit by a contact: pressed on, the goal
        // stays at the limit; sent back, it moves back from there.
        servo.follow(0.5, 0.004, 1.0, 0.3);
        assert_eq!(servo.goal, 0.0);
        servo.follow(-0.5, 0.004, 1.0, 0.3);
        assert!((servo.goal + 0.002).abs() < 1e-12, "{}", servo.goal);
        // Back inside, the goal follows the joint again.
        servo.follow(-0.5, 0.004, 1.0, -0.1);
        assert!(servo.goal < 0.0 && servo.goal >= -0.1 - 0.0002 - 0.004, "{}", servo.goal);
    }
}
