//! A robot as its description gives it: rigid bodies joined by revolute
//! and prismatic joints.
//!
//! A URDF robot is reduced to what the skin can feel: links joined by fixed
//! joints are merged into one rigid [`Body`]; revolute, continuous and
//! prismatic joints are the degrees of freedom ([`Dof`]) the host drives,
//! each of a [`DofKind`]; a mimic joint is a [`Joint`] that follows its
//! master DoF. A world moves this model; the host learns the tree back
//! from the skin and reads the model only to calibrate and to draw it.

pub mod hrp2;
pub mod kinematics;
mod mesh;
pub mod mjcf;
mod urdf;

use nalgebra::{Isometry3, Point3, Unit, Vector3};

pub use mesh::Mesh;
pub use urdf::{limits, UrdfError};

/// One rigid body: a group of URDF links welded by fixed or locked joints.
#[derive(Clone, Debug)]
pub struct Body {
    /// Name of the body's first (most proximal) link.
    pub name: String,
    /// The joint that carries this body, `None` for the root.
    pub parent_joint: Option<usize>,
}

/// How a movable joint is driven.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Drive {
    /// The joint is DoF `n` of the robot interface.
    Dof(usize),
    /// The joint follows DoF `dof`: `q = multiplier * q_dof + offset`.
    Mimic {
        /// The master DoF.
        dof: usize,
        /// Gear ratio to the master.
        multiplier: f64,
        /// Angle at a zero master position, rad.
        offset: f64,
    },
}

/// How a joint moves its child: turning about its axis or sliding along
/// it; the robot link's type, so the simulator tells the host exactly.
pub use skin_protocol::robot_link::DofKind;

/// A movable joint between two bodies.
#[derive(Clone, Debug)]
pub struct Joint {
    /// URDF joint name.
    pub name: String,
    /// Body the joint is mounted on.
    pub parent_body: usize,
    /// Body the joint moves.
    pub child_body: usize,
    /// Child body frame in the parent body frame at zero angle.
    pub origin: Isometry3<f64>,
    /// Rotation or translation axis in the child body frame (and so in the joint frame).
    pub axis: Unit<Vector3<f64>>,
    /// Turning or sliding (a mimic's own URDF type, which may differ from its master's).
    pub kind: DofKind,
    /// Interface DoF or mimic.
    pub drive: Drive,
}

/// One degree of freedom of the robot interface (section 3.2).
#[derive(Clone, Debug)]
pub struct Dof {
    /// URDF joint name.
    pub name: String,
    /// The joint this DoF drives directly.
    pub joint: usize,
    /// Turning (rad) or sliding (m): the unit of every value below.
    pub kind: DofKind,
    /// Lower position limit, rad or m (`-inf` for continuous joints).
    pub lower: f64,
    /// Upper position limit, rad or m (`+inf` for continuous joints).
    pub upper: f64,
    /// Largest velocity the servo accepts, rad/s or m/s (`inf` when not given).
    pub max_velocity: f64,
    /// Largest torque or force the actuator gives, N m or N (`inf` when not given).
    pub max_effort: f64,
}

/// A collision shape a link declares, for skin placement.
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    /// A box with the given full edge lengths, m.
    Box(Vector3<f64>),
    /// A cylinder along its local z axis, m.
    Cylinder {
        /// Radius, m.
        radius: f64,
        /// Length, m.
        length: f64,
    },
    /// A cylinder along its local z axis closed by hemispheres, m.
    Capsule {
        /// Radius, m.
        radius: f64,
        /// Length of the straight part, m.
        length: f64,
    },
    /// A sphere, m.
    Sphere(f64),
    /// A triangle mesh (a MuJoCo model's; a URDF's mesh files are not read).
    Mesh(std::sync::Arc<Mesh>),
}

impl Shape {
    /// Whether the shape has a surface to put skin on (no edge or radius is
    /// zero, a mesh has a face).
    pub fn has_area(&self) -> bool {
        match self {
            Shape::Box(size) => size.min() > 0.0,
            Shape::Cylinder { radius, length } => *radius > 0.0 && *length > 0.0,
            Shape::Capsule { radius, length } => *radius > 0.0 && *length >= 0.0,
            Shape::Sphere(r) => *r > 0.0,
            Shape::Mesh(mesh) => mesh.area() > 0.0,
        }
    }
}

/// Where skin can go on a link.
#[derive(Clone, Debug, PartialEq)]
pub enum Surface {
    /// No geometry and no mass: a massless intermediate frame, no skin.
    None,
    /// Primitive shapes, each with its pose in the link frame.
    Shapes(Vec<(Isometry3<f64>, Shape)>),
    /// Only a mesh or only a mass: the link is approximated by capsules of
    /// `radius` around the "bones" from the link origin to each point (child
    /// joints, centre of mass, mesh origins), all in the link frame.
    Bones {
        /// Bone end points, link frame.
        points: Vec<Point3<f64>>,
        /// Capsule radius, m.
        radius: f64,
    },
}

impl Surface {
    /// Bones from the link origin to `points` (link frame) of a link of
    /// `mass_kg` that has no primitive shape to lay skin on (only meshes, or
    /// only a mass): capsules whose radius grows with the mass.
    pub fn bones(mut points: Vec<Point3<f64>>, mass_kg: f64) -> Surface {
        points.retain(|p| p.coords.norm() > 1e-3);
        // A uniform body of water density, roughly: 3 kg gives about 7 cm.
        let radius = if mass_kg > 0.0 { (0.045 * mass_kg.cbrt()).clamp(0.03, 0.1) } else { 0.04 };
        Surface::Bones { points, radius }
    }
}

/// One URDF link, kept for skin placement and ground truth.
#[derive(Clone, Debug)]
pub struct Link {
    /// URDF link name.
    pub name: String,
    /// The body the link belongs to.
    pub body: usize,
    /// Link frame in the body frame.
    pub in_body: Isometry3<f64>,
    /// Where skin can be placed.
    pub surface: Surface,
    /// The link's mass (URDF `<inertial>`), kg; 0 when not given.
    pub mass_kg: f64,
    /// The centre of mass, link frame.
    pub com: Point3<f64>,
}

/// A kinematic tree of rigid bodies driven by revolute and prismatic DoFs.
#[derive(Clone, Debug)]
pub struct Robot {
    name: String,
    bodies: Vec<Body>,
    joints: Vec<Joint>,
    dofs: Vec<Dof>,
    links: Vec<Link>,
    home: Vec<f64>,
}

impl Robot {
    /// A robot from a URDF document.
    pub fn from_urdf_str(xml: &str) -> Result<Robot, UrdfError> {
        urdf::parse(xml)
    }

    /// The robot as an MJCF model MuJoCo loads (see [`mjcf`] for what is added).
    pub fn to_mjcf(&self) -> String {
        mjcf::write(self)
    }

    /// A robot from a URDF file (at most [`limits::MAX_BYTES`] long, which is
    /// checked before the file is read whole).
    pub fn from_urdf_file(path: &std::path::Path) -> Result<Robot, UrdfError> {
        urdf::parse(&urdf::read_file(path)?)
    }

    /// A robot from a tree another description's reader built (a MuJoCo
    /// model's): bodies parents before children with body 0 the root, joints
    /// and links naming bodies by index, DoFs naming joints; the start pose
    /// is zero clamped into the limits. Refused as a URDF would be when it
    /// has no DoF or more than the robot link carries.
    pub fn from_tree(
        name: String,
        bodies: Vec<Body>,
        joints: Vec<Joint>,
        dofs: Vec<Dof>,
        links: Vec<Link>,
    ) -> Result<Robot, UrdfError> {
        if dofs.is_empty() {
            return Err(UrdfError::NoDofs);
        }
        if dofs.len() > limits::MAX_DOFS {
            return Err(UrdfError::TooLarge { what: "DoFs", limit: limits::MAX_DOFS });
        }
        let home = dofs.iter().map(|d| 0.0f64.clamp(d.lower, d.upper)).collect();
        Ok(Robot { name, bodies, joints, dofs, links, home })
    }

    /// The robot's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Bodies, parents before children; body 0 is the root.
    pub fn bodies(&self) -> &[Body] {
        &self.bodies
    }

    /// Movable joints (DoFs and mimics), parents before children.
    pub fn joints(&self) -> &[Joint] {
        &self.joints
    }

    /// The interface DoFs, in interface order (URDF order).
    pub fn dofs(&self) -> &[Dof] {
        &self.dofs
    }

    /// Every URDF link.
    pub fn links(&self) -> &[Link] {
        &self.links
    }

    /// The link named `name`.
    pub fn link(&self, name: &str) -> Option<&Link> {
        self.links.iter().find(|l| l.name == name)
    }

    /// Start pose: zero, clamped into the limits.
    pub fn home(&self) -> &[f64] {
        &self.home
    }

    /// Replaces the start pose (clamped into the limits); a pose of the
    /// wrong length is refused.
    pub fn set_home(&mut self, pose: &[f64]) -> Result<(), UrdfError> {
        if pose.len() != self.dofs.len() {
            return Err(UrdfError::PoseLength { expected: self.dofs.len(), got: pose.len() });
        }
        self.home = self.dofs.iter().zip(pose).map(|(d, q)| q.clamp(d.lower, d.upper)).collect();
        Ok(())
    }

    /// Position (rad or m) of every joint for the DoF positions `q` (mimics follow).
    pub fn joint_angles(&self, q: &[f64]) -> Vec<f64> {
        self.joints.iter().map(|j| drive_value(j.drive, q)).collect()
    }

    /// Ground truth: for each body, whether DoF `dof` moves it relative to
    /// the root (its own joint or a mimic of it lies between them).
    pub fn moved_by(&self, dof: usize) -> Vec<bool> {
        let mut moved = vec![false; self.bodies.len()];
        // Parents come before children, so one pass propagates down.
        for b in 1..self.bodies.len() {
            let j = &self.joints[self.bodies[b].parent_joint.expect("non-root bodies have a parent joint")];
            let driven = match j.drive {
                Drive::Dof(d) => d == dof,
                Drive::Mimic { dof: d, multiplier, .. } => d == dof && multiplier != 0.0,
            };
            moved[b] = driven || moved[j.parent_body];
        }
        moved
    }
}

/// The value of a joint for DoF positions `q`: its own DoF, or `multiplier *
/// master + offset` for a mimic. Derivatives use the same map without offset.
pub(crate) fn drive_value(drive: Drive, q: &[f64]) -> f64 {
    match drive {
        Drive::Dof(d) => q[d],
        Drive::Mimic { dof, multiplier, offset } => multiplier * q[dof] + offset,
    }
}

/// The rate of a joint for DoF rates `qd` (velocities or accelerations).
pub(crate) fn drive_rate(drive: Drive, qd: &[f64]) -> f64 {
    match drive {
        Drive::Dof(d) => qd[d],
        Drive::Mimic { dof, multiplier, .. } => multiplier * qd[dof],
    }
}
