//! The robot a compiled MuJoCo model describes, as the skin's model of a
//! robot: read from MuJoCo's own compiled arrays (mjModel), never from the
//! XML, so whatever MuJoCo loads (MJCF with its defaults and includes, or a
//! URDF) is read once, by MuJoCo.
//!
//! Bodies joined without a joint form one rigid [`Body`], as URDF links
//! joined by fixed joints do; a MuJoCo body with several hinge or slide
//! joints becomes a chain of bodies, one per joint, each frame at its
//! joint's anchor. A joint coupled to another by an active equality
//! (`q1 = c0 + c1 q2`) is a mimic of it; every other hinge or slide joint is
//! a DoF. Positions are relative to the model's reference pose (`qpos0`).
//! Every MuJoCo body is a [`Link`] named as in the model, its collision
//! geometry the surface the skin is laid on.

use mujoco_rs::prelude::*;
use std::sync::Arc;

use nalgebra::{Isometry3, Point3, Quaternion, Translation3, Unit, UnitQuaternion, Vector3};
use skin_model::robot::{Body, Dof, DofKind, Drive, Joint, Link, Mesh, Robot, Shape, Surface};

use super::MujocoError;

/// Velocity limit of a DoF: MuJoCo joints have none.
const NO_VELOCITY_LIMIT: f64 = f64::INFINITY;
/// A servo's control range narrows its joint's when it ends further
/// inside than this, rad or m (the UR5e's are its joint range rounded).
const NARROWER: f64 = 1e-3;

/// The robot of a compiled model and where its parts are in MuJoCo.
pub(super) struct Tree {
    pub(super) robot: Robot,
    /// Per DoF, its MuJoCo joint. Link `i` is MuJoCo body `i`.
    pub(super) dof_joint: Vec<usize>,
    /// The DoFs whose range is their position servo's control range,
    /// narrower than the joint's, in words.
    pub(super) narrowed: Vec<String>,
}

/// The model's own position servo on `joint` (its control is the joint's
/// position: a fixed gain and an affine bias cancelling it), if any.
pub(super) fn position_servo(model: &MjModel, joint: usize) -> Option<usize> {
    (0..model.actuator_trntype().len()).find(|&a| {
        let (gain, bias) = (model.actuator_gainprm()[a][0], model.actuator_biasprm()[a][1]);
        model.actuator_trntype()[a] == MjtTrn::mjTRN_JOINT
            && model.actuator_trnid()[a][0] as usize == joint
            && model.actuator_gaintype()[a] == MjtGain::mjGAIN_FIXED
            && model.actuator_biastype()[a] == MjtBias::mjBIAS_AFFINE
            && gain > 0.0
            && (bias + gain).abs() <= 1e-9 * gain
    })
}

/// A MuJoCo pose as an isometry.
pub(super) fn isometry(pos: &[f64; 3], quat: &[f64; 4]) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(pos[0], pos[1], pos[2]),
        UnitQuaternion::from_quaternion(Quaternion::new(quat[0], quat[1], quat[2], quat[3])),
    )
}

/// The name MuJoCo gives object `id` of type `kind` (the loader names every
/// body and joint before compiling, so there is one).
pub(super) fn name(model: &MjModel, kind: MjtObjBase, id: usize) -> String {
    model.id_to_name(kind, id).map_or_else(|| format!("#{id}"), str::to_owned)
}

/// A joint moved by another through an equality: `q = offset + multiplier * q_master`.
#[derive(Clone, Copy)]
struct Coupling {
    master: usize,
    multiplier: f64,
    offset: f64,
}

/// What the equalities make of each joint.
fn couplings(model: &MjModel) -> Result<Vec<Option<Coupling>>, MujocoError> {
    let mut coupled = vec![None; model.jnt_type().len()];
    for e in 0..model.eq_type().len() {
        if model.eq_type()[e] != MjtEq::mjEQ_JOINT || !model.eq_active0()[e] {
            continue;
        }
        let (slave, master) = (model.eq_obj1id()[e], model.eq_obj2id()[e]);
        let data = &model.eq_data()[e];
        let slave_name = name(model, MjtObjBase::mjOBJ_JOINT, slave as usize);
        if master < 0 || data[2..5].iter().any(|c| *c != 0.0) {
            return Err(MujocoError::Unsupported(format!(
                "the equality on joint \"{slave_name}\" locks it or couples it by a polynomial: only q1 = c0 + c1 q2 moves as a mimic"
            )));
        }
        coupled[slave as usize] = Some(Coupling { master: master as usize, multiplier: data[1], offset: data[0] });
    }
    Ok(coupled)
}

/// The tree of `model`, whose data `data` holds the kinematics at `qpos0`.
pub(super) fn read(model: &MjModel, data: &MjData<&MjModel>, name_of_robot: &str) -> Result<Tree, MujocoError> {
    let nbody = model.body_parentid().len();
    let coupled = couplings(model)?;
    let xpos = data.xpos();
    let xquat = data.xquat();
    let world_pose = |b: usize| isometry(&xpos[b], &xquat[b]);

    let mut bodies = vec![Body { name: name(model, MjtObjBase::mjOBJ_BODY, 0), parent_joint: None }];
    // Frame of each robot body in the world at qpos0.
    let mut frames = vec![Isometry3::identity()];
    // Robot body carrying each MuJoCo body.
    let mut carrier = vec![0usize; nbody];
    let mut joints = Vec::new();
    // Robot joint of each MuJoCo joint that moves.
    let mut robot_joint: Vec<Option<usize>> = vec![None; model.jnt_type().len()];
    let mut dof_joint = Vec::new();
    for b in 1..nbody {
        let parent = model.body_parentid()[b] as usize;
        carrier[b] = carrier[parent];
        let (first, count) = (model.body_jntadr()[b], model.body_jntnum()[b]);
        let body_name = name(model, MjtObjBase::mjOBJ_BODY, b);
        for j in (0..count.max(0) as usize).map(|k| first as usize + k) {
            let kind = match model.jnt_type()[j] {
                MjtJoint::mjJNT_HINGE => DofKind::Revolute,
                MjtJoint::mjJNT_SLIDE => DofKind::Prismatic,
                // Held by a weld at its start pose (the engine adds it): part of its parent.
                MjtJoint::mjJNT_FREE => continue,
                _ => {
                    return Err(MujocoError::Unsupported(format!(
                        "joint \"{}\" of body \"{body_name}\" is a ball joint: only hinge and slide joints are DoFs",
                        name(model, MjtObjBase::mjOBJ_JOINT, j)
                    )))
                }
            };
            let anchor = Vector3::from(model.jnt_pos()[j]);
            let frame = world_pose(b) * Translation3::from(anchor);
            let joint_name = name(model, MjtObjBase::mjOBJ_JOINT, j);
            let last = (first as usize + count as usize) - 1 == j;
            bodies.push(Body {
                name: if last { body_name.clone() } else { format!("{body_name}:{joint_name}") },
                parent_joint: Some(joints.len()),
            });
            let axis = Unit::try_new(Vector3::from(model.jnt_axis()[j]), 1e-12)
                .ok_or_else(|| MujocoError::Unsupported(format!("joint \"{joint_name}\" has a zero axis")))?;
            robot_joint[j] = Some(joints.len());
            joints.push(Joint {
                name: joint_name,
                parent_body: carrier[b],
                child_body: bodies.len() - 1,
                origin: frames[carrier[b]].inverse() * frame,
                axis,
                kind,
                drive: Drive::Dof(0), // set below, once DoF numbers are known
            });
            frames.push(frame);
            carrier[b] = bodies.len() - 1;
            if coupled[j].is_none() {
                dof_joint.push(j);
            }
        }
    }

    let qpos0 = model.qpos0();
    let mut dofs = Vec::new();
    let mut narrowed = Vec::new();
    for &j in &dof_joint {
        let joint = robot_joint[j].expect("hinge and slide joints are robot joints");
        let zero = qpos0[model.jnt_qposadr()[j] as usize];
        let (mut lower, mut upper) = if model.jnt_limited()[j] {
            (model.jnt_range()[j][0] - zero, model.jnt_range()[j][1] - zero)
        } else {
            (f64::NEG_INFINITY, f64::INFINITY)
        };
        // A position servo reaches only its control range (Barkour's knees:
        // 0.1 rad inside the joint's ends): that is where the DoF can go.
        if let Some(a) = position_servo(model, j).filter(|&a| model.actuator_ctrllimited()[a]) {
            let [low, high] = model.actuator_ctrlrange()[a];
            if low - zero > lower + NARROWER || high - zero < upper - NARROWER {
                (lower, upper) = (lower.max(low - zero), upper.min(high - zero));
                narrowed.push(format!("{} [{low:.3}, {high:.3}]", joints[joint].name));
            }
        }
        if lower >= upper {
            return Err(MujocoError::Unsupported(format!(
                "joint \"{}\" has the range [{lower}, {upper}]: nothing to move",
                joints[joint].name
            )));
        }
        dofs.push(Dof {
            name: joints[joint].name.clone(),
            joint,
            kind: joints[joint].kind,
            lower,
            upper,
            max_velocity: NO_VELOCITY_LIMIT,
            // The model's own actuators carry its effort limits.
            max_effort: f64::INFINITY,
        });
    }
    for (j, robot) in robot_joint.iter().enumerate() {
        let Some(r) = *robot else { continue };
        joints[r].drive = match coupled[j] {
            None => Drive::Dof(dof_joint.iter().position(|&d| d == j).expect("uncoupled joints are DoFs")),
            Some(Coupling { master, multiplier, offset }) => {
                let dof = dof_joint.iter().position(|&d| d == master).ok_or_else(|| {
                    MujocoError::Unsupported(format!(
                        "joint \"{}\" follows \"{}\", which is not a DoF (a chain of couplings)",
                        joints[r].name,
                        name(model, MjtObjBase::mjOBJ_JOINT, master)
                    ))
                })?;
                Drive::Mimic { dof, multiplier, offset }
            }
        };
    }

    let links = (0..nbody)
        .map(|b| Link {
            name: name(model, MjtObjBase::mjOBJ_BODY, b),
            body: carrier[b],
            in_body: frames[carrier[b]].inverse() * world_pose(b),
            surface: if b == 0 { Surface::None } else { surface(model, b) },
            mass_kg: model.body_mass()[b],
            com: Point3::from(Vector3::from(model.body_ipos()[b])),
        })
        .collect();
    let robot = Robot::from_tree(name_of_robot.to_owned(), bodies, joints, dofs, links)?;
    Ok(Tree { robot, dof_joint, narrowed })
}

/// Mesh `id`'s triangles as MuJoCo compiled them, in the frame of the
/// geoms using it; `None` for no mesh.
fn mesh(model: &MjModel, id: i32) -> Option<Mesh> {
    let m = usize::try_from(id).ok()?;
    let (vert, face) = (model.mesh_vertadr()[m] as usize, model.mesh_faceadr()[m] as usize);
    let (verts, faces) = (model.mesh_vertnum()[m] as usize, model.mesh_facenum()[m] as usize);
    let vertices = model.mesh_vert().get(vert..vert + verts)?.iter().map(|v| Point3::from(v.map(f64::from))).collect();
    let faces =
        model.mesh_face().get(face..face + faces)?.iter().map(|f| f.map(|i| u32::try_from(i).unwrap_or(u32::MAX)));
    Some(Mesh::new(vertices, faces))
}

/// Where skin goes on MuJoCo body `b`: its collision geoms (those that
/// collide with something), else bones to its children and centre of mass,
/// as for a URDF link with only meshes.
fn surface(model: &MjModel, b: usize) -> Surface {
    let shapes: Vec<(Isometry3<f64>, Shape)> = (0..model.geom_type().len())
        .filter(|&g| model.geom_bodyid()[g] as usize == b)
        .filter(|&g| model.geom_contype()[g] != 0 || model.geom_conaffinity()[g] != 0)
        .filter_map(|g| {
            let pose = isometry(&model.geom_pos()[g], &model.geom_quat()[g]);
            let s = model.geom_size()[g];
            let shape = match model.geom_type()[g] {
                MjtGeomBase::mjGEOM_BOX => Shape::Box(Vector3::from(s) * 2.0),
                MjtGeomBase::mjGEOM_SPHERE => Shape::Sphere(s[0]),
                MjtGeomBase::mjGEOM_ELLIPSOID => Shape::Box(Vector3::from(s) * 2.0),
                MjtGeomBase::mjGEOM_CYLINDER => Shape::Cylinder { radius: s[0], length: 2.0 * s[1] },
                MjtGeomBase::mjGEOM_CAPSULE => Shape::Capsule { radius: s[0], length: 2.0 * s[1] },
                MjtGeomBase::mjGEOM_MESH => Shape::Mesh(Arc::new(mesh(model, model.geom_dataid()[g])?)),
                _ => return None,
            };
            Some((pose, shape)).filter(|(_, shape)| shape.has_area())
        })
        .collect();
    if !shapes.is_empty() {
        return Surface::Shapes(shapes);
    }
    let mass = model.body_mass()[b];
    let mut points: Vec<Point3<f64>> = (0..model.body_parentid().len())
        .filter(|&c| c != b && model.body_parentid()[c] as usize == b)
        .map(|c| Point3::from(Vector3::from(model.body_pos()[c])))
        .collect();
    if mass > 0.0 {
        points.push(Point3::from(Vector3::from(model.body_ipos()[b])));
    }
    if points.is_empty() && mass <= 0.0 {
        return Surface::None;
    }
    Surface::bones(points, mass)
}
