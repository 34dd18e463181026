//! Reading a [`Robot`] from URDF (through `urdf-rs`).
//!
//! Revolute and continuous joints become DoFs, mimic joints follow their
//! master, fixed joints weld links into one body, and prismatic joints are
//! locked at zero with a warning: the exploration method covers revolute
//! DoFs only (section 3.2). Everything else that the model cannot represent
//! is refused with an error naming the offending element.

use std::collections::HashMap;

use nalgebra::{Isometry3, Point3, Translation3, Unit, UnitQuaternion, Vector3};
use urdf_rs::{Geometry, JointType, Pose};

use super::{Body, Dof, Drive, Joint, Link, Robot, Shape, Surface};

/// Why a URDF document is not a robot the simulator can run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum UrdfError {
    /// The file could not be read.
    #[error("cannot read URDF file {path}: {source}")]
    Read {
        /// The file.
        path: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// Not well-formed URDF (XML syntax, missing attribute, bad number).
    #[error("not a valid URDF document: {0}")]
    Syntax(String),
    /// Two links or two joints share a name.
    #[error("{kind} \"{name}\" is defined twice")]
    Duplicate {
        /// "link" or "joint".
        kind: &'static str,
        /// The repeated name.
        name: String,
    },
    /// A joint names a link that does not exist.
    #[error("joint \"{joint}\" refers to link \"{link}\", which is not defined")]
    UnknownLink {
        /// The joint.
        joint: String,
        /// The missing link.
        link: String,
    },
    /// A link is the child of two joints: a closed kinematic loop.
    #[error(
        "link \"{link}\" is the child of both joint \"{first}\" and joint \"{second}\": closed loops are not supported"
    )]
    TwoParents {
        /// The link.
        link: String,
        /// One parent joint.
        first: String,
        /// The other parent joint.
        second: String,
    },
    /// Not exactly one link without a parent.
    #[error("a robot needs exactly one root link (a link that is no joint's child), found: {0:?}")]
    Roots(Vec<String>),
    /// A joint type the method cannot handle.
    #[error(
        "joint \"{joint}\" is {kind}: only revolute, continuous, fixed and (locked) prismatic joints are supported"
    )]
    UnsupportedJoint {
        /// The joint.
        joint: String,
        /// Its URDF type.
        kind: String,
    },
    /// A joint axis of zero length.
    #[error("joint \"{joint}\" has a zero-length <axis>")]
    ZeroAxis {
        /// The joint.
        joint: String,
    },
    /// A revolute joint whose range is empty or reversed.
    #[error(
        "revolute joint \"{joint}\" has limits lower = {lower}, upper = {upper}: give it a <limit> with lower < upper, or make it continuous"
    )]
    BadLimits {
        /// The joint.
        joint: String,
        /// Lower limit, rad.
        lower: f64,
        /// Upper limit, rad.
        upper: f64,
    },
    /// A NaN or infinite number where a finite one is needed.
    #[error("{element} contains a number that is not finite")]
    NotFinite {
        /// The element, e.g. `joint "elbow" <origin>`.
        element: String,
    },
    /// A mimic joint follows a joint that does not exist, or mimics go round in a circle.
    #[error("joint \"{joint}\" mimics \"{master}\", which is not a joint it can follow")]
    BadMimic {
        /// The mimic joint.
        joint: String,
        /// The master it names.
        master: String,
    },
    /// Nothing to explore.
    #[error("the robot has no revolute or continuous joint")]
    NoDofs,
    /// A pose with another number of values than the robot has DoFs.
    #[error("a pose of {got} values for a robot with {expected} DoFs")]
    PoseLength {
        /// DoFs of the robot.
        expected: usize,
        /// Values given.
        got: usize,
    },
}

/// What a URDF joint becomes.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    Weld,
    Revolute { lower: f64, upper: f64, max_velocity: f64 },
    Mimic { master: usize, multiplier: f64, offset: f64 },
}

pub(super) fn parse(xml: &str) -> Result<Robot, UrdfError> {
    let doc = urdf_rs::read_from_string(xml).map_err(|e| UrdfError::Syntax(e.to_string()))?;
    check_finite(&doc)?;

    let mut link_index = HashMap::new();
    for (i, l) in doc.links.iter().enumerate() {
        if link_index.insert(l.name.as_str(), i).is_some() {
            return Err(UrdfError::Duplicate { kind: "link", name: l.name.clone() });
        }
    }
    let mut joint_index = HashMap::new();
    let mut parent_of: Vec<Option<usize>> = vec![None; doc.links.len()];
    let mut children: Vec<Vec<usize>> = vec![Vec::new(); doc.links.len()];
    for (i, j) in doc.joints.iter().enumerate() {
        if joint_index.insert(j.name.as_str(), i).is_some() {
            return Err(UrdfError::Duplicate { kind: "joint", name: j.name.clone() });
        }
        let find = |name: &str| {
            link_index
                .get(name)
                .copied()
                .ok_or_else(|| UrdfError::UnknownLink { joint: j.name.clone(), link: name.to_owned() })
        };
        let (parent, child) = (find(&j.parent.link)?, find(&j.child.link)?);
        if let Some(first) = parent_of[child] {
            return Err(UrdfError::TwoParents {
                link: j.child.link.clone(),
                first: doc.joints[first].name.clone(),
                second: j.name.clone(),
            });
        }
        parent_of[child] = Some(i);
        children[parent].push(i);
    }
    let roots: Vec<usize> = (0..doc.links.len()).filter(|&l| parent_of[l].is_none()).collect();
    if roots.len() != 1 {
        return Err(UrdfError::Roots(roots.iter().map(|&l| doc.links[l].name.clone()).collect()));
    }

    let kinds = classify(&doc, &joint_index)?;

    // Depth-first from the root: parents before children, welded links
    // share their parent's body. Links not reached hang in a loop.
    let mut bodies = vec![Body { name: doc.links[roots[0]].name.clone(), parent_joint: None }];
    let mut links: Vec<Option<Link>> = vec![None; doc.links.len()];
    let mut joints = Vec::new();
    let mut dof_of_joint: HashMap<usize, usize> = HashMap::new();
    links[roots[0]] = Some(Link {
        name: doc.links[roots[0]].name.clone(),
        body: 0,
        in_body: Isometry3::identity(),
        surface: Surface::None,
    });
    let mut stack = vec![roots[0]];
    let mut movable = Vec::new();
    while let Some(l) = stack.pop() {
        let (body, in_body) = {
            let link = links[l].as_ref().expect("links are visited after their parent");
            (link.body, link.in_body)
        };
        for &ji in children[l].iter().rev() {
            let j = &doc.joints[ji];
            let child = link_index[j.child.link.as_str()];
            let origin = in_body * isometry(&j.origin);
            let (child_body, child_in_body) = match kinds[ji] {
                Kind::Weld => (body, origin),
                Kind::Revolute { .. } | Kind::Mimic { .. } => {
                    let axis = Unit::try_new(Vector3::from(j.axis.xyz.0), 1e-12)
                        .ok_or_else(|| UrdfError::ZeroAxis { joint: j.name.clone() })?;
                    bodies.push(Body { name: j.child.link.clone(), parent_joint: Some(joints.len()) });
                    movable.push(ji);
                    joints.push(Joint {
                        name: j.name.clone(),
                        parent_body: body,
                        child_body: bodies.len() - 1,
                        origin,
                        axis,
                        drive: Drive::Dof(0), // set below, once DoF numbers are known
                    });
                    (bodies.len() - 1, Isometry3::identity())
                }
            };
            links[child] = Some(Link {
                name: j.child.link.clone(),
                body: child_body,
                in_body: child_in_body,
                surface: Surface::None,
            });
            stack.push(child);
        }
    }
    let mut links: Vec<Link> = links.into_iter().flatten().collect();
    if links.len() != doc.links.len() {
        // Every link has at most one parent and there is one root, so an
        // unreached link sits on a cycle of joints.
        let reached: Vec<&str> = links.iter().map(|l| l.name.as_str()).collect();
        let lost = doc.links.iter().find(|l| !reached.contains(&l.name.as_str())).expect("a link was not reached");
        let ji = parent_of[link_index[lost.name.as_str()]].expect("non-root links have a parent");
        return Err(UrdfError::TwoParents {
            link: lost.name.clone(),
            first: doc.joints[ji].name.clone(),
            second: "a cycle of joints".into(),
        });
    }

    // DoFs in URDF document order.
    let mut dofs = Vec::new();
    for (ji, j) in doc.joints.iter().enumerate() {
        if let Kind::Revolute { lower, upper, max_velocity } = kinds[ji] {
            let joint = movable.iter().position(|&m| m == ji).expect("revolute joints are movable");
            dof_of_joint.insert(ji, dofs.len());
            dofs.push(Dof { name: j.name.clone(), joint, lower, upper, max_velocity });
        }
    }
    if dofs.is_empty() {
        return Err(UrdfError::NoDofs);
    }
    for (joint, &ji) in joints.iter_mut().zip(&movable) {
        joint.drive = match kinds[ji] {
            Kind::Revolute { .. } => Drive::Dof(dof_of_joint[&ji]),
            Kind::Mimic { master, multiplier, offset } => {
                Drive::Mimic { dof: dof_of_joint[&master], multiplier, offset }
            }
            Kind::Weld => unreachable!("welded joints are not movable"),
        };
    }

    for link in &mut links {
        let l = &doc.links[link_index[link.name.as_str()]];
        let child_origins: Vec<Point3<f64>> = children[link_index[link.name.as_str()]]
            .iter()
            .map(|&ji| Point3::from(doc.joints[ji].origin.xyz.0))
            .collect();
        link.surface = surface(l, &child_origins);
    }
    let home = dofs.iter().map(|d| 0.0f64.clamp(d.lower, d.upper)).collect();
    Ok(Robot { name: doc.name, bodies, joints, dofs, links, home })
}

/// Decides what every joint becomes; prismatic joints (and mimics of them)
/// are locked with a warning.
fn classify(doc: &urdf_rs::Robot, joint_index: &HashMap<&str, usize>) -> Result<Vec<Kind>, UrdfError> {
    let base: Vec<Option<Kind>> = doc
        .joints
        .iter()
        .map(|j| match j.joint_type {
            JointType::Fixed => Ok(Some(Kind::Weld)),
            JointType::Prismatic => {
                tracing::warn!(joint = %j.name, "prismatic joint locked at 0: the method covers revolute DoFs only");
                Ok(Some(Kind::Weld))
            }
            JointType::Revolute | JointType::Continuous if j.mimic.is_some() => Ok(None),
            JointType::Continuous => Ok(Some(Kind::Revolute {
                lower: f64::NEG_INFINITY,
                upper: f64::INFINITY,
                max_velocity: velocity_limit(j.limit.velocity),
            })),
            JointType::Revolute => {
                let (lower, upper) = (j.limit.lower, j.limit.upper);
                if lower >= upper {
                    return Err(UrdfError::BadLimits { joint: j.name.clone(), lower, upper });
                }
                Ok(Some(Kind::Revolute { lower, upper, max_velocity: velocity_limit(j.limit.velocity) }))
            }
            ref other => {
                Err(UrdfError::UnsupportedJoint { joint: j.name.clone(), kind: format!("{other:?}").to_lowercase() })
            }
        })
        .collect::<Result<_, _>>()?;

    // Resolve mimics, following chains of mimics to a real DoF.
    let mut kinds = Vec::with_capacity(base.len());
    for (ji, j) in doc.joints.iter().enumerate() {
        if let Some(k) = base[ji] {
            kinds.push(k);
            continue;
        }
        let (mut at, mut multiplier, mut offset) = (ji, 1.0, 0.0);
        let mut hops = 0;
        let kind = loop {
            let mimic = doc.joints[at].mimic.as_ref().expect("unresolved joints are mimics");
            let bad = || UrdfError::BadMimic { joint: j.name.clone(), master: mimic.joint.clone() };
            let master = *joint_index.get(mimic.joint.as_str()).ok_or_else(bad)?;
            let (m, o) = (mimic.multiplier.unwrap_or(1.0), mimic.offset.unwrap_or(0.0));
            offset += multiplier * o;
            multiplier *= m;
            hops += 1;
            if master == ji || hops > doc.joints.len() || !multiplier.is_finite() {
                return Err(bad());
            }
            match base[master] {
                Some(Kind::Revolute { .. }) => break Kind::Mimic { master, multiplier, offset },
                Some(Kind::Weld) => {
                    tracing::warn!(joint = %j.name, master = %mimic.joint, "mimic of a locked joint: locked too");
                    break Kind::Weld;
                }
                Some(Kind::Mimic { .. }) => unreachable!("base kinds hold no mimics"),
                None => at = master,
            }
        };
        kinds.push(kind);
    }
    Ok(kinds)
}

/// URDF writes 0 for "not given".
fn velocity_limit(v: f64) -> f64 {
    if v > 0.0 {
        v
    } else {
        f64::INFINITY
    }
}

/// Where skin goes on a link: its primitive shapes if it has any, else
/// bones to its child joints, centre of mass and meshes, else nothing.
fn surface(link: &urdf_rs::Link, child_origins: &[Point3<f64>]) -> Surface {
    let geometries: Vec<(&Pose, &Geometry)> = if link.collision.is_empty() {
        link.visual.iter().map(|v| (&v.origin, &v.geometry)).collect()
    } else {
        link.collision.iter().map(|c| (&c.origin, &c.geometry)).collect()
    };
    let shapes: Vec<(Isometry3<f64>, Shape)> = geometries
        .iter()
        .filter_map(|(pose, g)| {
            let shape = match g {
                Geometry::Box { size } => Shape::Box(Vector3::from(size.0)),
                Geometry::Cylinder { radius, length } => Shape::Cylinder { radius: *radius, length: *length },
                // A capsule's skin lies on its straight part.
                Geometry::Capsule { radius, length } => Shape::Cylinder { radius: *radius, length: *length },
                Geometry::Sphere { radius } => Shape::Sphere(*radius),
                Geometry::Mesh { .. } => return None,
            };
            Some((isometry(pose), shape))
        })
        .filter(|(_, s)| match *s {
            Shape::Box(size) => size.min() > 0.0,
            Shape::Cylinder { radius, length } => radius > 0.0 && length > 0.0,
            Shape::Sphere(r) => r > 0.0,
        })
        .collect();
    if !shapes.is_empty() {
        return Surface::Shapes(shapes);
    }
    let mass = link.inertial.mass.value;
    if geometries.is_empty() && mass <= 0.0 {
        return Surface::None;
    }
    let mut points: Vec<Point3<f64>> = child_origins.to_vec();
    if mass > 0.0 {
        points.push(Point3::from(link.inertial.origin.xyz.0));
    }
    points.extend(geometries.iter().map(|(pose, _)| Point3::from(pose.xyz.0)));
    points.retain(|p| p.coords.norm() > 1e-3);
    // A uniform body of water density, roughly: 3 kg gives about 7 cm.
    let radius = if mass > 0.0 { (0.045 * mass.cbrt()).clamp(0.03, 0.1) } else { 0.04 };
    Surface::Bones { points, radius }
}

fn isometry(pose: &Pose) -> Isometry3<f64> {
    let [r, p, y] = pose.rpy.0;
    Isometry3::from_parts(Translation3::from(Vector3::from(pose.xyz.0)), UnitQuaternion::from_euler_angles(r, p, y))
}

fn check_finite(doc: &urdf_rs::Robot) -> Result<(), UrdfError> {
    let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
    let pose_ok = |p: &Pose| finite(&p.xyz.0) && finite(&p.rpy.0);
    let geometry_ok = |g: &Geometry| match g {
        Geometry::Box { size } => finite(&size.0),
        Geometry::Cylinder { radius, length } | Geometry::Capsule { radius, length } => finite(&[*radius, *length]),
        Geometry::Sphere { radius } => radius.is_finite(),
        Geometry::Mesh { .. } => true,
    };
    for l in &doc.links {
        let ok = pose_ok(&l.inertial.origin)
            && l.inertial.mass.value.is_finite()
            && l.visual.iter().all(|v| pose_ok(&v.origin) && geometry_ok(&v.geometry))
            && l.collision.iter().all(|c| pose_ok(&c.origin) && geometry_ok(&c.geometry));
        if !ok {
            return Err(UrdfError::NotFinite { element: format!("link \"{}\"", l.name) });
        }
    }
    for j in &doc.joints {
        let limits = [j.limit.velocity, j.limit.effort];
        let range_ok = j.joint_type == JointType::Continuous || finite(&[j.limit.lower, j.limit.upper]);
        let mimic_ok = j.mimic.as_ref().is_none_or(|m| finite(&[m.multiplier.unwrap_or(1.0), m.offset.unwrap_or(0.0)]));
        if !(pose_ok(&j.origin) && finite(&j.axis.xyz.0) && finite(&limits) && range_ok && mimic_ok) {
            return Err(UrdfError::NotFinite { element: format!("joint \"{}\"", j.name) });
        }
    }
    Ok(())
}
