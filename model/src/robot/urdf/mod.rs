//! Reading a [`Robot`] from URDF.
//!
//! [`xml`] reads what the method needs and checks it against [`limits`];
//! this module turns it into bodies, joints and DoFs. Revolute, continuous
//! and prismatic joints become DoFs, mimic joints follow their master,
//! fixed joints weld links into one body. Everything the model cannot
//! represent is refused with an error naming the offending element.

mod error;
pub mod limits;
mod xml;

use std::collections::HashMap;
use std::io::Read;

use nalgebra::{Isometry3, Point3, Unit, Vector3};

pub use error::UrdfError;
use limits::{Quantity, MAX_BYTES, MAX_DOFS};
use xml::{Description, JointType, LinkDesc};

use super::{Body, Dof, DofKind, Drive, Joint, Link, Robot, Surface};

/// What a URDF joint becomes.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    Weld,
    Dof { kind: DofKind, lower: f64, upper: f64, max_velocity: f64 },
    Mimic { kind: DofKind, master: usize, multiplier: f64, offset: f64 },
}

/// The text of a URDF file, refused unread when it is over [`MAX_BYTES`].
pub(super) fn read_file(path: &std::path::Path) -> Result<String, UrdfError> {
    let failed = |source| UrdfError::Read { path: path.display().to_string(), source };
    let mut bytes = Vec::new();
    std::fs::File::open(path).and_then(|f| f.take(MAX_BYTES as u64 + 1).read_to_end(&mut bytes)).map_err(failed)?;
    if bytes.len() > MAX_BYTES {
        return Err(UrdfError::TooLarge { what: "bytes", limit: MAX_BYTES });
    }
    String::from_utf8(bytes).map_err(|e| UrdfError::Syntax(format!("not UTF-8 text: {e}")))
}

pub(super) fn parse(text: &str) -> Result<Robot, UrdfError> {
    let doc = xml::read(text)?;

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
        let (parent, child) = (find(&j.parent)?, find(&j.child)?);
        if let Some(first) = parent_of[child] {
            return Err(UrdfError::TwoParents {
                link: j.child.clone(),
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
    // URDF joint index -> index in `joints`, for movable joints.
    let mut movable: Vec<Option<usize>> = vec![None; doc.joints.len()];
    links[roots[0]] = Some(Link {
        name: doc.links[roots[0]].name.clone(),
        body: 0,
        in_body: Isometry3::identity(),
        surface: Surface::None,
        mass_kg: 0.0,
        com: Point3::origin(),
    });
    let mut stack = vec![roots[0]];
    while let Some(l) = stack.pop() {
        let (body, in_body) = {
            let link = links[l].as_ref().expect("links are visited after their parent");
            (link.body, link.in_body)
        };
        for &ji in children[l].iter().rev() {
            let j = &doc.joints[ji];
            let child = link_index[j.child.as_str()];
            let origin = in_body * j.origin.isometry();
            let (child_body, child_in_body) = match kinds[ji] {
                Kind::Weld => (body, origin),
                Kind::Dof { kind, .. } | Kind::Mimic { kind, .. } => {
                    bodies.push(Body { name: j.child.clone(), parent_joint: Some(joints.len()) });
                    movable[ji] = Some(joints.len());
                    joints.push(Joint {
                        name: j.name.clone(),
                        parent_body: body,
                        child_body: bodies.len() - 1,
                        origin,
                        axis: unit_axis(&j.name, j.axis)?,
                        kind,
                        drive: Drive::Dof(0), // set below, once DoF numbers are known
                    });
                    (bodies.len() - 1, Isometry3::identity())
                }
            };
            links[child] = Some(Link {
                name: j.child.clone(),
                body: child_body,
                in_body: child_in_body,
                surface: Surface::None,
                mass_kg: 0.0,
                com: Point3::origin(),
            });
            stack.push(child);
        }
    }
    if let Some(lost) = links.iter().position(Option::is_none) {
        // Every link has at most one parent and there is one root, so an
        // unreached link sits on a cycle of joints.
        let ji = parent_of[lost].expect("non-root links have a parent");
        return Err(UrdfError::TwoParents {
            link: doc.links[lost].name.clone(),
            first: doc.joints[ji].name.clone(),
            second: "a cycle of joints".into(),
        });
    }

    // DoFs in URDF document order.
    let mut dofs = Vec::new();
    let mut dof_of_joint: Vec<Option<usize>> = vec![None; doc.joints.len()];
    for (ji, j) in doc.joints.iter().enumerate() {
        if let Kind::Dof { kind, lower, upper, max_velocity } = kinds[ji] {
            if dofs.len() == MAX_DOFS {
                return Err(UrdfError::TooLarge { what: "DoFs", limit: MAX_DOFS });
            }
            dof_of_joint[ji] = Some(dofs.len());
            let joint = movable[ji].expect("DoF joints are movable");
            let max_effort = unlimited_if_zero(j.limit.effort);
            dofs.push(Dof { name: j.name.clone(), joint, kind, lower, upper, max_velocity, max_effort });
        }
    }
    if dofs.is_empty() {
        return Err(UrdfError::NoDofs);
    }
    for (ji, m) in movable.iter().enumerate() {
        let Some(m) = *m else { continue };
        joints[m].drive = match kinds[ji] {
            Kind::Dof { .. } => Drive::Dof(dof_of_joint[ji].expect("DoF joints have a DoF")),
            Kind::Mimic { master, multiplier, offset, .. } => {
                Drive::Mimic { dof: dof_of_joint[master].expect("mimics follow DoFs"), multiplier, offset }
            }
            Kind::Weld => unreachable!("welded joints are not movable"),
        };
    }

    let links = links
        .into_iter()
        .zip(&doc.links)
        .enumerate()
        .map(|(i, (link, desc))| {
            let child_origins: Vec<Point3<f64>> =
                children[i].iter().map(|&ji| Point3::from(doc.joints[ji].origin.xyz)).collect();
            Link {
                surface: surface(desc, &child_origins),
                mass_kg: desc.mass,
                com: Point3::from(desc.com.xyz),
                ..link.expect("every link was reached")
            }
        })
        .collect();
    let home = dofs.iter().map(|d| 0.0f64.clamp(d.lower, d.upper)).collect();
    Ok(Robot { name: doc.name, bodies, joints, dofs, links, home })
}

/// The joint axis as a unit vector; any finite non-zero axis will do.
fn unit_axis(joint: &str, axis: [f64; 3]) -> Result<Unit<Vector3<f64>>, UrdfError> {
    let v = Vector3::from(axis);
    // Scaled first, so that no finite axis overflows when squared.
    let scale = v.amax();
    (scale > 0.0)
        .then(|| Unit::try_new(v / scale, 1e-12))
        .flatten()
        .ok_or_else(|| UrdfError::ZeroAxis { joint: joint.to_owned() })
}

/// Decides what every joint becomes, resolving chains of mimics to a DoF.
fn classify(doc: &Description, joint_index: &HashMap<&str, usize>) -> Result<Vec<Kind>, UrdfError> {
    let base: Vec<Option<Kind>> = doc
        .joints
        .iter()
        .map(|j| {
            let kind = match j.kind {
                JointType::Fixed => return Ok(Some(Kind::Weld)),
                _ if j.mimic.is_some() => return Ok(None),
                JointType::Continuous => {
                    return Ok(Some(Kind::Dof {
                        kind: DofKind::Revolute,
                        lower: f64::NEG_INFINITY,
                        upper: f64::INFINITY,
                        max_velocity: unlimited_if_zero(j.limit.velocity),
                    }))
                }
                JointType::Revolute => DofKind::Revolute,
                JointType::Prismatic => DofKind::Prismatic,
            };
            let (lower, upper) = (j.limit.lower, j.limit.upper);
            if lower >= upper {
                let (kind, hint) = match kind {
                    DofKind::Revolute => ("revolute", ", or make it continuous"),
                    DofKind::Prismatic => ("prismatic", ", or make it fixed"),
                };
                return Err(UrdfError::BadLimits { kind, joint: j.name.clone(), lower, upper, hint });
            }
            Ok(Some(Kind::Dof { kind, lower, upper, max_velocity: unlimited_if_zero(j.limit.velocity) }))
        })
        .collect::<Result<_, _>>()?;

    // Mimics follow chains of mimics to a DoF (or a fixed joint); each
    // joint is resolved once, as `q = multiplier * q_target + offset`.
    let mut resolved: Vec<Option<(Option<usize>, f64, f64)>> = vec![None; base.len()];
    let mut on_path = vec![false; base.len()];
    for ji in 0..base.len() {
        let mut path = Vec::new();
        let mut at = ji;
        let mut value = loop {
            if let Some(v) = resolved[at] {
                break v;
            }
            match base[at] {
                Some(Kind::Dof { .. }) => break (Some(at), 1.0, 0.0),
                Some(_) => break (None, 1.0, 0.0),
                None => {
                    let mimic = doc.joints[at].mimic.as_ref().expect("unresolved joints are mimics");
                    let bad =
                        || UrdfError::BadMimic { joint: doc.joints[at].name.clone(), master: mimic.joint.clone() };
                    if std::mem::replace(&mut on_path[at], true) {
                        return Err(bad());
                    }
                    path.push(at);
                    at = *joint_index.get(mimic.joint.as_str()).ok_or_else(bad)?;
                }
            }
        };
        for &p in path.iter().rev() {
            let (j, mimic) = (&doc.joints[p], doc.joints[p].mimic.as_ref().expect("paths hold mimics"));
            let (target, m, o) = value;
            let at = |attr: &'static str| {
                move || format!("joint \"{}\" <mimic> {attr} (through its chain of mimics)", j.name)
            };
            value = (
                target,
                Quantity::Mimic.check(mimic.multiplier * m, at("multiplier"))?,
                Quantity::Mimic.check(mimic.multiplier * o + mimic.offset, at("offset"))?,
            );
            resolved[p] = Some(value);
        }
    }
    Ok(doc
        .joints
        .iter()
        .zip(base)
        .zip(resolved)
        .map(|((j, base), resolved)| match (base, resolved) {
            (Some(k), _) => k,
            (None, Some((Some(master), multiplier, offset))) => {
                let kind = if j.kind == JointType::Prismatic { DofKind::Prismatic } else { DofKind::Revolute };
                Kind::Mimic { kind, master, multiplier, offset }
            }
            (None, _) => {
                tracing::warn!(joint = %j.name, "mimic of a fixed joint: welded too");
                Kind::Weld
            }
        })
        .collect())
}

/// URDF writes 0 for "not given" (velocity and effort limits).
fn unlimited_if_zero(v: f64) -> f64 {
    if v > 0.0 {
        v
    } else {
        f64::INFINITY
    }
}

/// Where skin goes on a link: its primitive shapes if it has any, else
/// bones to its child joints, centre of mass and meshes, else nothing.
fn surface(link: &LinkDesc, child_origins: &[Point3<f64>]) -> Surface {
    let geometries = if link.collisions.is_empty() { &link.visuals } else { &link.collisions };
    let shapes: Vec<_> = geometries
        .iter()
        .filter_map(|(pose, shape)| shape.as_ref().filter(|s| s.has_area()).map(|s| (pose.isometry(), s.clone())))
        .collect();
    if !shapes.is_empty() {
        return Surface::Shapes(shapes);
    }
    let mass = link.mass;
    if geometries.is_empty() && mass <= 0.0 {
        return Surface::None;
    }
    let mut points: Vec<Point3<f64>> = child_origins.to_vec();
    if mass > 0.0 {
        points.push(Point3::from(link.com.xyz));
    }
    points.extend(geometries.iter().map(|(pose, _)| Point3::from(pose.xyz)));
    Surface::bones(points, mass)
}
