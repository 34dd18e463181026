//! The world the skin lives in, on a virtual clock.
//!
//! A robot under velocity control with position feedback, its static base
//! standing or lying relative to gravity (optionally swaying as a balancing
//! humanoid does, and rocking when its joints accelerate), and one BMA250
//! per skin cell. [`World::step`] advances one control tick (4 ms, 250 Hz)
//! and returns one [`Sample`] per cell, exactly what the skin network would
//! deliver to the host. Force and proximity come from a [`Tactile`] model
//! plugged in by a scene; without one they read zero.

use std::time::{Duration, Instant};

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use skin_protocol::{Address, Sample};

use crate::accel::{Bma250, Bma250Config, G0};
use skin_model::robot::kinematics::{self, BodyState, DofMotion};
use skin_model::robot::{hrp2, DofKind, Robot};
use skin_model::skin::{Cell, Skin};

/// Physics sub-steps per control tick.
const SUBSTEPS: u32 = 4;
/// LM71 counts of the constant 25 degC skin temperature (0.03125 degC per count).
const TEMPERATURE_COUNTS: i16 = 800;

/// How the robot's static reference body (the root) sits in the world.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BaseConfig {
    /// Orientation of the root relative to the world (z up), roll-pitch-yaw, rad.
    pub tilt_rpy: [f64; 3],
    /// Amplitude of a slow balancing sway about both horizontal axes, rad.
    pub sway_rad: f64,
    /// Frequency of the sway, Hz (the second axis sways 1.618 times faster).
    pub sway_hz: f64,
    /// Rocking of the whole robot about a pivot below the root, excited by
    /// the reaction to joint accelerations.
    pub rocking: Rocking,
}

/// A damped rocking mode of the robot on its feet or mount.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rocking {
    /// Natural frequency, Hz.
    pub natural_hz: f64,
    /// Damping ratio.
    pub damping_ratio: f64,
    /// Rocking acceleration per joint acceleration about a horizontal axis (inertia ratio).
    pub coupling: f64,
    /// Depth of the pivot (ankles, mount) below the root origin, m.
    pub pivot_depth_m: f64,
}

impl BaseConfig {
    /// Upright, balancing: a humanoid standing as HRP-2 did in the paper.
    pub fn standing() -> BaseConfig {
        BaseConfig {
            tilt_rpy: [0.0; 3],
            sway_rad: 1e-3,
            sway_hz: 0.4,
            rocking: Rocking { natural_hz: 4.0, damping_ratio: 0.1, coupling: 3e-3, pivot_depth_m: 0.8 },
        }
    }

    /// Lying on its back: the standing posture turned 90 degrees about y.
    pub fn lying() -> BaseConfig {
        BaseConfig { tilt_rpy: [0.0, -std::f64::consts::FRAC_PI_2, 0.0], ..BaseConfig::standing() }
    }

    /// Bolted down and perfectly still.
    pub fn rigid() -> BaseConfig {
        BaseConfig {
            tilt_rpy: [0.0; 3],
            sway_rad: 0.0,
            sway_hz: 0.0,
            rocking: Rocking { coupling: 0.0, ..BaseConfig::standing().rocking },
        }
    }
}

/// Everything about a world except the robot and its skin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WorldConfig {
    /// Control tick, s (4 ms: the skin's 250 Hz).
    pub tick_s: f64,
    /// Time constant of the joint velocity servos, s.
    pub servo_time_constant_s: f64,
    /// The base.
    pub base: BaseConfig,
    /// The accelerometers.
    pub accel: Bma250Config,
    /// Seed of every random thing in the world.
    pub seed: u64,
}

impl Default for WorldConfig {
    fn default() -> Self {
        WorldConfig {
            tick_s: 0.004,
            servo_time_constant_s: 0.01,
            base: BaseConfig::standing(),
            accel: Bma250Config::default(),
            seed: 0,
        }
    }
}

/// Why a command was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum WorldError {
    /// A velocity command with the wrong number of values.
    #[error("a velocity command of {got} values for a robot with {expected} DoFs")]
    WrongLength {
        /// DoFs of the robot.
        expected: usize,
        /// Values given.
        got: usize,
    },
    /// A NaN or infinite velocity.
    #[error("the velocity command for DoF {0} is not finite")]
    NotFinite(usize),
}

/// Force and proximity of one cell, raw counts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Touch {
    /// Proximity (VCNL4010 counts, larger is closer).
    pub proximity: u16,
    /// The three normal forces (12-bit counts).
    pub force: [u16; 3],
}

/// A scene that touches the skin: given the world pose of every cell (in
/// skin order), it fills in their force and proximity readings.
pub trait Tactile {
    /// Fills `out[i]` for the cell at `poses[i]` at time `time_s`.
    fn sense(&mut self, time_s: f64, poses: &[Isometry3<f64>], out: &mut [Touch]);
}

/// A robot, its skin and its base on a virtual clock.
pub struct World {
    robot: Robot,
    skin: Skin,
    cfg: WorldConfig,
    q: Vec<f64>,
    command: Vec<f64>,
    engine: Engine,
    ticks: u64,
    sensors: Vec<Bma250>,
    seq: u8,
    rng: ChaCha8Rng,
    poses: Vec<Isometry3<f64>>,
    /// Per cell, the specific force its accelerometer feels (cell frame), m/s^2.
    specific: Vec<Vector3<f64>>,
    touches: Vec<Touch>,
    tactile: Option<Box<dyn Tactile>>,
    /// Wall time spent in [`World::step`] so far, and of it in the engine.
    step_time: Duration,
    engine_time: Duration,
}

/// What moves the robot: the built-in kinematics, or MuJoCo's physics.
enum Engine {
    BuiltIn(BuiltIn),
    #[cfg(feature = "mujoco")]
    Mujoco(Box<crate::mujoco::Engine>),
}

/// The built-in world's motion: first-order velocity servos, the base's
/// sway and rocking, and forward kinematics.
struct BuiltIn {
    qd: Vec<f64>,
    qdd: Vec<f64>,
    rock: Vector3<f64>,
    rock_rate: Vector3<f64>,
    rock_accel: Vector3<f64>,
    sway_phase: [f64; 2],
    states: Vec<BodyState>,
}

impl World {
    /// A world with the robot at rest in its home pose.
    pub fn new(robot: Robot, skin: Skin, cfg: WorldConfig) -> World {
        World::with_engine(robot, skin, cfg, |rng, n| {
            let sway_phase = [
                rand::Rng::random_range(rng, 0.0..std::f64::consts::TAU),
                rand::Rng::random_range(rng, 0.0..std::f64::consts::TAU),
            ];
            Engine::BuiltIn(BuiltIn {
                qd: vec![0.0; n],
                qdd: vec![0.0; n],
                rock: Vector3::zeros(),
                rock_rate: Vector3::zeros(),
                rock_accel: Vector3::zeros(),
                sway_phase,
                states: Vec::new(),
            })
        })
    }

    /// A world moved by `engine`, made after the cells' accelerometers are
    /// drawn from the seed's generator (which it may draw from too).
    fn with_engine(
        robot: Robot,
        skin: Skin,
        cfg: WorldConfig,
        engine: impl FnOnce(&mut ChaCha8Rng, usize) -> Engine,
    ) -> World {
        let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
        let sensors = skin.cells().iter().map(|_| Bma250::new(&cfg.accel, cfg.tick_s, &mut rng)).collect();
        let n = robot.dofs().len();
        let engine = engine(&mut rng, n);
        let cells = skin.cells().len();
        let mut world = World {
            q: robot.home().to_vec(),
            command: vec![0.0; n],
            engine,
            ticks: 0,
            sensors,
            seq: 0,
            rng,
            poses: vec![Isometry3::identity(); cells],
            specific: vec![Vector3::zeros(); cells],
            touches: vec![Touch::default(); cells],
            tactile: None,
            step_time: Duration::ZERO,
            engine_time: Duration::ZERO,
            robot,
            skin,
            cfg,
        };
        match &mut world.engine {
            Engine::BuiltIn(b) => {
                b.update_kinematics(&world.robot, &world.skin, &world.cfg, &world.q, 0.0, &mut world.poses);
            }
            #[cfg(feature = "mujoco")]
            Engine::Mujoco(m) => {
                world.q = m.positions();
                m.cell_poses(&mut world.poses);
            }
        }
        world
    }

    /// A world moved by MuJoCo: `engine` runs the model `robot` was read
    /// from, carrying `skin`'s cells as sites with their sensors.
    #[cfg(feature = "mujoco")]
    pub(crate) fn mujoco(robot: Robot, skin: Skin, cfg: WorldConfig, engine: crate::mujoco::Engine) -> World {
        World::with_engine(robot, skin, cfg, |_, _| Engine::Mujoco(Box::new(engine)))
    }

    /// The paper's experiment: the built-in robot with its 74-cell skin,
    /// standing, BMA250 sensors; skin placement, sensor errors, noise and sway
    /// all drawn from `seed`.
    pub fn hrp2(seed: u64) -> World {
        let robot = hrp2::robot();
        let skin = Skin::with_counts(&robot, &hrp2::SKIN, seed).expect("the built-in skin fits the built-in robot");
        World::new(robot, skin, WorldConfig { seed, ..WorldConfig::default() })
    }

    /// The robot.
    pub fn robot(&self) -> &Robot {
        &self.robot
    }

    /// The skin (ground truth: where every cell is).
    pub fn skin(&self) -> &Skin {
        &self.skin
    }

    /// The configuration.
    pub fn config(&self) -> &WorldConfig {
        &self.cfg
    }

    /// Ground truth: each cell's accelerometer (skin order), for its
    /// offset, gain and mounting errors.
    pub fn sensors(&self) -> &[Bma250] {
        &self.sensors
    }

    /// Virtual time since the start, s.
    pub fn time_s(&self) -> f64 {
        self.ticks as f64 * self.cfg.tick_s
    }

    /// Joint position feedback, rad (m for prismatic DoFs), in DoF order.
    pub fn positions(&self) -> &[f64] {
        &self.q
    }

    /// Commands joint velocities (rad/s, m/s for prismatic DoFs; DoF order) until the next command;
    /// each is clipped to its joint's velocity limit.
    pub fn command(&mut self, omega: &[f64]) -> Result<(), WorldError> {
        if omega.len() != self.command.len() {
            return Err(WorldError::WrongLength { expected: self.command.len(), got: omega.len() });
        }
        if let Some(d) = omega.iter().position(|w| !w.is_finite()) {
            return Err(WorldError::NotFinite(d));
        }
        for ((c, w), dof) in self.command.iter_mut().zip(omega).zip(self.robot.dofs()) {
            *c = w.clamp(-dof.max_velocity, dof.max_velocity);
        }
        Ok(())
    }

    /// Plugs in the scene that supplies force and proximity (in MuJoCo, in
    /// place of its touch and rangefinder sensors).
    pub fn set_tactile(&mut self, tactile: Box<dyn Tactile>) {
        self.tactile = Some(tactile);
    }

    /// World pose of every cell at the current tick, in skin order.
    pub fn cell_poses(&self) -> &[Isometry3<f64>] {
        &self.poses
    }

    /// Advances one tick and appends one sample per cell to `out`.
    pub fn step(&mut self, out: &mut Vec<(Address, Sample)>) {
        self.ticks += 1;
        let time_s = self.time_s();
        let started = Instant::now();
        match &mut self.engine {
            Engine::BuiltIn(b) => {
                b.advance(&self.robot, &self.cfg, &self.command, &mut self.q);
                b.update_kinematics(&self.robot, &self.skin, &self.cfg, &self.q, time_s, &mut self.poses);
                b.specific_forces(&self.skin, &self.poses, &mut self.specific);
            }
            #[cfg(feature = "mujoco")]
            Engine::Mujoco(m) => {
                m.advance(&self.command, &mut self.q, &mut self.poses, &mut self.specific);
                m.touches(&mut self.touches, &mut self.rng);
            }
        }
        let moved = Instant::now();
        self.engine_time += moved - started;
        if let Some(t) = self.tactile.as_mut() {
            t.sense(time_s, &self.poses, &mut self.touches);
        }
        self.seq = self.seq.wrapping_add(1);
        for (i, cell) in self.skin.cells().iter().enumerate() {
            let accel = self.sensors[i].sample(&self.specific[i], &mut self.rng);
            let t = self.touches[i];
            out.push((cell.id, Sample::saturating(t.proximity, t.force, accel, TEMPERATURE_COUNTS, self.seq)));
        }
        self.step_time += moved.elapsed() + (moved - started);
    }

    /// Wall time spent moving the robot so far: the built-in kinematics, or
    /// MuJoCo's steps and its sensors' readings (the force and proximity
    /// models' counts among them, a small part); the rest of
    /// [`World::step`] is the accelerometer models and the scene's touch.
    pub fn engine_time(&self) -> Duration {
        self.engine_time
    }

    /// Wall time spent in [`World::step`] so far: the engine's, and the sensor models'.
    pub fn step_time(&self) -> Duration {
        self.step_time
    }

    /// The root body's pose in the world now.
    fn root_pose(&self) -> Isometry3<f64> {
        match &self.engine {
            Engine::BuiltIn(b) => b.states[0].pose,
            #[cfg(feature = "mujoco")]
            Engine::Mujoco(_) => Isometry3::identity(),
        }
    }

    /// What the MuJoCo engine reports of itself (assumptions made about the
    /// model, where a step's time goes); `None` in the built-in world.
    #[cfg(feature = "mujoco")]
    pub fn mujoco_engine(&self) -> Option<&crate::mujoco::Engine> {
        match &self.engine {
            Engine::Mujoco(m) => Some(m),
            Engine::BuiltIn(_) => None,
        }
    }
}

impl BuiltIn {
    /// One tick of the velocity servos under `command`, moving `q`.
    fn advance(&mut self, robot: &Robot, cfg: &WorldConfig, command: &[f64], q: &mut [f64]) {
        let h = cfg.tick_s / f64::from(SUBSTEPS);
        let follow = 1.0 - (-h / cfg.servo_time_constant_s).exp();
        let start = self.qd.clone();
        for _ in 0..SUBSTEPS {
            for (d, dof) in robot.dofs().iter().enumerate() {
                let (pos, w) = (q[d], self.qd[d]);
                // The servo will not drive further into a limit.
                let target = match command[d] {
                    c if (pos >= dof.upper && c > 0.0) || (pos <= dof.lower && c < 0.0) => 0.0,
                    c => c,
                };
                let mut next = w + (target - w) * follow;
                let mut moved = pos + 0.5 * (w + next) * h;
                if moved > dof.upper || moved < dof.lower {
                    moved = moved.clamp(dof.lower, dof.upper);
                    next = 0.0;
                }
                self.qdd[d] = (next - w) / h;
                self.qd[d] = next;
                q[d] = moved;
            }
            self.rock_base(robot, cfg, h);
        }
        // The sensors' bandwidth spans the tick: they see its mean acceleration.
        for ((a, w), w0) in self.qdd.iter_mut().zip(&self.qd).zip(&start) {
            *a = (w - w0) / cfg.tick_s;
        }
    }

    /// Each cell's specific force in its own frame.
    fn specific_forces(&self, skin: &Skin, poses: &[Isometry3<f64>], out: &mut [Vector3<f64>]) {
        let gravity = Vector3::new(0.0, 0.0, -G0);
        for ((cell, pose), f) in skin.cells().iter().zip(poses).zip(out) {
            let state = &self.states[cell.body];
            let specific = state.point_accel(&Point3::from(cell.pose.translation.vector)) - gravity;
            *f = pose.rotation.inverse() * specific;
        }
    }
    /// The rocking mode, driven by the horizontal part of the revolute
    /// joints' angular accelerations (their torque's reaction on the base).
    /// A prismatic joint's reaction is a force along its axis, not a torque:
    /// the rocking model has no masses to turn it into one, so it is left out.
    fn rock_base(&mut self, robot: &Robot, cfg: &WorldConfig, h: f64) {
        let r = cfg.base.rocking;
        let mut drive = Vector3::zeros();
        for (d, dof) in robot.dofs().iter().enumerate().filter(|(_, dof)| dof.kind == DofKind::Revolute) {
            let j = &robot.joints()[dof.joint];
            drive += self.states[j.child_body].pose.rotation * j.axis.into_inner() * self.qdd[d];
        }
        drive.z = 0.0;
        let w = std::f64::consts::TAU * r.natural_hz;
        self.rock_accel = -r.coupling * drive - 2.0 * r.damping_ratio * w * self.rock_rate - w * w * self.rock;
        self.rock_rate += self.rock_accel * h;
        self.rock += self.rock_rate * h;
    }

    /// Base rotation about the pivot (rocking plus sway) and its first two
    /// derivatives, world frame, at time `t`.
    fn base_rotation(&self, cfg: &WorldConfig, t: f64) -> [Vector3<f64>; 3] {
        let b = &cfg.base;
        let mut angle = self.rock;
        let mut rate = self.rock_rate;
        let mut accel = self.rock_accel;
        for (axis, (speed, phase)) in [(1.0, self.sway_phase[0]), (1.618, self.sway_phase[1])].into_iter().enumerate() {
            let w = std::f64::consts::TAU * b.sway_hz * speed;
            let x = w * t + phase;
            angle[axis] += b.sway_rad * x.sin();
            rate[axis] += b.sway_rad * w * x.cos();
            accel[axis] -= b.sway_rad * w * w * x.sin();
        }
        [angle, rate, accel]
    }

    /// Body states and cell poses for positions `q` at time `t` (the base's sway).
    fn update_kinematics(
        &mut self,
        robot: &Robot,
        skin: &Skin,
        cfg: &WorldConfig,
        q: &[f64],
        t: f64,
        poses: &mut [Isometry3<f64>],
    ) {
        let [angle, omega, alpha] = self.base_rotation(cfg, t);
        let [roll, pitch, yaw] = cfg.base.tilt_rpy;
        let pivot = Vector3::new(0.0, 0.0, -cfg.base.rocking.pivot_depth_m);
        let rock = UnitQuaternion::from_scaled_axis(angle);
        let arm = rock * -pivot;
        let base = BodyState {
            pose: Isometry3::from_parts(
                Translation3::from(pivot + arm),
                rock * UnitQuaternion::from_euler_angles(roll, pitch, yaw),
            ),
            omega,
            alpha,
            accel: alpha.cross(&arm) + omega.cross(&omega.cross(&arm)),
        };
        let motion = DofMotion { q, qd: &self.qd, qdd: &self.qdd };
        kinematics::forward(robot, &base, motion, &mut self.states);
        for (p, c) in poses.iter_mut().zip(skin.cells()) {
            *p = self.states[c.body].pose * c.pose;
        }
    }
}

impl World {
    /// Ground truth: `moved[u][d]` is true when DoF `d` moves cell `u`
    /// (skin order) relative to the root.
    pub fn true_activity(&self) -> Vec<Vec<bool>> {
        let by_dof: Vec<Vec<bool>> = (0..self.robot.dofs().len()).map(|d| self.robot.moved_by(d)).collect();
        self.skin.cells().iter().map(|c| by_dof.iter().map(|m| m[c.body]).collect()).collect()
    }

    /// Ground truth for the sensory-motor map: for the robot at rest in
    /// `pose`, the acceleration of each cell per unit acceleration of each
    /// DoF, in the cell frame (the noise-free tangential direction of
    /// equation (1) times the lever arm, m per rad/s^2; for a prismatic DoF the
    /// axis, m/s^2 per m/s^2). Indexed `[u][d]`.
    pub fn true_tangential(&self, pose: &[f64]) -> Vec<Vec<Vector3<f64>>> {
        let n = self.robot.dofs().len();
        let zero = vec![0.0; n];
        let mut states = Vec::new();
        let base = BodyState::at_rest(self.root_pose());
        kinematics::forward(&self.robot, &base, DofMotion { q: pose, qd: &zero, qdd: &zero }, &mut states);
        self.skin
            .cells()
            .iter()
            .map(|c: &Cell| {
                let pose = states[c.body].pose * c.pose;
                let p = Point3::from(pose.translation.vector);
                (0..n)
                    .map(|d| pose.rotation.inverse() * kinematics::tangential(&self.robot, &states, c.body, &p, d))
                    .collect()
            })
            .collect()
    }
}
