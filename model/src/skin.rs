//! Skin cells on the robot's links, and their ground truth.
//!
//! Cells are placed either on the surface of every link that has geometry
//! or mass, a chosen number per link and deterministic for a seed, or from a
//! skin file (TOML or JSON) listing the cells of each link with their poses.
//! A cell frame has z along the outward surface normal, as the force and
//! proximity sensors face. Where a cell is (link, pose) is ground truth:
//! the host never sees it. A skin laid in wired patches ([`Skin::patches`])
//! also knows which cell is wired to which: the neighbour tables its
//! self-organization would report.

mod file;
mod patches;

use nalgebra::{Isometry3, Matrix3, Point3, Rotation3, Translation3, UnitQuaternion, Vector3};
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use skin_protocol::message::{Neighbour, NeighbourReport, Port};
use skin_protocol::Address;

pub use file::{skin_toml, FileCell};
pub use patches::{CELL_PITCH_M, PITCH_TOLERANCE};

use crate::robot::{DofKind, Link, Robot, Shape, Surface};

/// Skin is not laid over a joint: a placed cell keeps at least this far
/// from the axes of the revolute joints at its body, where the robot bends,
/// when the link leaves room for it (see [`Cell::axis_clearance_m`]).
pub const JOINT_CLEARANCE_M: f64 = 0.02;
/// Bones are covered between these fractions of their length.
const BONE_SPAN: (f64, f64) = (0.15, 0.85);

/// One skin cell mounted on a body.
#[derive(Clone, Debug, PartialEq)]
pub struct Cell {
    /// The cell's network ID.
    pub id: Address,
    /// URDF link the cell is mounted on.
    pub link: String,
    /// Body of that link.
    pub body: usize,
    /// Cell frame in the body frame; z is the outward surface normal.
    pub pose: Isometry3<f64>,
    /// Distance from the cell to the nearest axis of a revolute joint at
    /// its body (the one carrying it or one it carries), m; `inf` if there
    /// is none. Placement aims for [`JOINT_CLEARANCE_M`] but takes the best
    /// of its tries on links too small for it, so this is the truth: a cell
    /// close to the axis of the joint that carries it barely moves with it.
    pub axis_clearance_m: f64,
}

/// Why a skin cannot be built.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SkinError {
    /// The skin file could not be read.
    #[error("cannot read skin file {path}: {source}")]
    Read {
        /// The file.
        path: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The file name does not say TOML or JSON.
    #[error("skin file {0}: name it *.toml or *.json")]
    Format(String),
    /// The file is not a valid skin description.
    #[error("skin file is not valid: {0}")]
    Parse(String),
    /// A link that the robot does not have.
    #[error("the robot has no link \"{0}\" to put skin on")]
    UnknownLink(String),
    /// A cell ID outside 1..=0xFEFF.
    #[error("cell ID {0} is outside 1..=65279")]
    BadId(u32),
    /// Two cells with one ID.
    #[error("cell ID {0} is used twice")]
    DuplicateId(u16),
    /// A NaN or infinite pose.
    #[error("a cell on link \"{0}\" has a pose that is not finite")]
    NotFinite(String),
    /// No cell at all.
    #[error("the skin has no cells: give a positive count per link or list cells in the skin file")]
    NoCells,
    /// More cells than the network can address.
    #[error("{0} cells are more than the 65279 a skin network can address")]
    TooMany(usize),
}

/// The cells of a robot's skin.
#[derive(Clone, Debug)]
pub struct Skin {
    cells: Vec<Cell>,
    /// Per cell, who is on each port (empty: the skin was not laid wired).
    wires: Vec<patches::Wires>,
}

impl Skin {
    /// `per_link` cells on every link with a surface.
    pub fn per_link(robot: &Robot, per_link: usize, seed: u64) -> Result<Skin, SkinError> {
        Skin::on_surfaces(robot, |l| if l.surface == Surface::None { 0 } else { per_link }, seed)
    }

    /// The listed number of cells on each named link (others get none).
    pub fn with_counts(robot: &Robot, counts: &[(&str, usize)], seed: u64) -> Result<Skin, SkinError> {
        if let Some((name, _)) = counts.iter().find(|(name, _)| robot.link(name).is_none()) {
            return Err(SkinError::UnknownLink((*name).to_owned()));
        }
        Skin::on_surfaces(robot, |l| counts.iter().filter(|(n, _)| *n == l.name).map(|(_, c)| c).sum(), seed)
    }

    /// `count(link)` cells spread over each link's surface, deterministic
    /// for `seed`; IDs are a seeded shuffle of `1..=U`, so nothing can be
    /// read from their order.
    pub fn on_surfaces(robot: &Robot, count: impl Fn(&Link) -> usize, seed: u64) -> Result<Skin, SkinError> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut cells = Vec::new();
        for link in robot.links() {
            let n = if link.surface == Surface::None { 0 } else { count(link) };
            let axes = joint_axes(robot, link.body);
            for _ in 0..n {
                let (pose, axis_clearance_m) = place(&axes, link, &mut rng);
                cells.push(Cell {
                    id: Address::UNASSIGNED,
                    link: link.name.clone(),
                    body: link.body,
                    pose,
                    axis_clearance_m,
                });
            }
        }
        Skin::numbered(cells, Vec::new(), &mut rng)
    }

    /// `count(link)` cells on each link laid in wired patches at
    /// [`CELL_PITCH_M`], deterministic for `seed`: neighbours follow the
    /// geometry (see [`Skin::neighbour_tables`]). A link whose surface has
    /// no room for its count's patch gets its remaining cells wherever
    /// they fit, unwired.
    pub fn patches(robot: &Robot, count: impl Fn(&Link) -> usize, seed: u64) -> Result<Skin, SkinError> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let (cells, wires) = patches::lay(robot, count, &mut rng);
        Skin::numbered(cells, wires, &mut rng)
    }

    /// The skin with IDs a seeded shuffle of `1..=U`, so nothing can be
    /// read from their order.
    fn numbered(mut cells: Vec<Cell>, wires: Vec<patches::Wires>, rng: &mut ChaCha8Rng) -> Result<Skin, SkinError> {
        check_count(cells.len())?;
        let mut ids: Vec<u16> = (1..=cells.len() as u16).collect();
        ids.shuffle(rng);
        for (c, id) in cells.iter_mut().zip(ids) {
            c.id = Address(id);
        }
        Ok(Skin { cells, wires })
    }

    /// Each cell's neighbour table, as its self-organization reports it
    /// (IDs and ports only); empty for a skin not laid wired.
    pub fn neighbour_tables(&self) -> Vec<(Address, NeighbourReport)> {
        self.wires
            .iter()
            .zip(&self.cells)
            .map(|(w, c)| {
                let neighbours = w.map(|end| end.map(|(i, port)| Neighbour { id: self.cells[i].id, port }));
                (c.id, NeighbourReport { neighbours, master: None })
            })
            .collect()
    }

    /// All cells.
    pub fn cells(&self) -> &[Cell] {
        &self.cells
    }

    /// Who is on each port of each cell, as laid by [`Skin::patches`]: the
    /// far end's cell index and port; empty for a skin not laid wired.
    pub fn wires(&self) -> &[[Option<(usize, Port)>; 4]] {
        &self.wires
    }

    /// The smallest [`Cell::axis_clearance_m`] of all cells, m.
    pub fn min_axis_clearance_m(&self) -> f64 {
        self.cells.iter().map(|c| c.axis_clearance_m).fold(f64::INFINITY, f64::min)
    }

    /// The same cells under other IDs, `ids[i]` for cell `i`: the IDs a
    /// host assigned during self-organization, so ground truth can be
    /// looked up by them.
    pub fn relabeled(&self, ids: &[Address]) -> Result<Skin, SkinError> {
        if ids.len() != self.cells.len() {
            return Err(SkinError::Parse(format!("{} IDs for {} cells", ids.len(), self.cells.len())));
        }
        let mut seen = std::collections::HashSet::new();
        for id in ids {
            if !id.is_cell() {
                return Err(SkinError::BadId(u32::from(id.0)));
            }
            if !seen.insert(*id) {
                return Err(SkinError::DuplicateId(id.0));
            }
        }
        let cells = self.cells.iter().zip(ids).map(|(c, id)| Cell { id: *id, ..c.clone() }).collect();
        Ok(Skin { cells, wires: self.wires.clone() })
    }
}

fn check_count(n: usize) -> Result<(), SkinError> {
    match n {
        0 => Err(SkinError::NoCells),
        n if n > usize::from(Address::MAX_CELL) => Err(SkinError::TooMany(n)),
        _ => Ok(()),
    }
}

/// A random cell pose on `link`, in its body frame, away from the joint
/// `axes` of its body, and its clearance from them (m).
fn place(axes: &[(Point3<f64>, Vector3<f64>)], link: &Link, rng: &mut ChaCha8Rng) -> (Isometry3<f64>, f64) {
    let mut best: Option<(f64, Point3<f64>, Vector3<f64>)> = None;
    for _ in 0..200 {
        let (p, n) = surface_point(&link.surface, rng);
        let (p, n) = (link.in_body * p, link.in_body.rotation * n);
        let c = clearance(axes, &p);
        if best.as_ref().is_none_or(|b| c > b.0) {
            best = Some((c, p, n));
        }
        if c >= JOINT_CLEARANCE_M {
            break;
        }
    }
    let (c, p, n) = best.expect("at least one candidate");
    let pose = Isometry3::from_parts(
        Translation3::from(p.coords),
        frame_with_normal(&n, rng.random_range(0.0..std::f64::consts::TAU)),
    );
    (pose, c)
}

/// Distance from `p` to the nearest of the axis lines `axes`, m (`inf` if none).
fn clearance(axes: &[(Point3<f64>, Vector3<f64>)], p: &Point3<f64>) -> f64 {
    axes.iter().map(|(o, a)| (p - o).cross(a).norm()).fold(f64::INFINITY, f64::min)
}

/// Axis lines (point, unit direction) of the revolute joints at `body`,
/// body frame: the one carrying it and those it carries. A prismatic joint
/// bends nothing, and its motion is the same for every point of its child.
fn joint_axes(robot: &Robot, body: usize) -> Vec<(Point3<f64>, Vector3<f64>)> {
    robot
        .joints()
        .iter()
        .filter(|j| j.kind == DofKind::Revolute)
        .filter_map(|j| {
            if j.child_body == body {
                Some((Point3::origin(), j.axis.into_inner()))
            } else if j.parent_body == body {
                Some((Point3::from(j.origin.translation.vector), j.origin.rotation * j.axis.into_inner()))
            } else {
                None
            }
        })
        .collect()
}

/// A uniformly random point on a link surface and its outward normal, link frame.
fn surface_point(surface: &Surface, rng: &mut ChaCha8Rng) -> (Point3<f64>, Vector3<f64>) {
    match surface {
        Surface::None => unreachable!("no cells are placed on links without a surface"),
        Surface::Shapes(shapes) => {
            let areas: Vec<f64> = shapes.iter().map(|(_, s)| area(s)).collect();
            let (pose, shape) = &shapes[pick(&areas, rng)];
            let (p, n) = shape_point(shape, rng);
            (pose * p, pose.rotation * n)
        }
        Surface::Bones { points, radius } => {
            if points.is_empty() {
                let n = random_unit(rng);
                return (Point3::from(n * *radius), n);
            }
            let lengths: Vec<f64> = points.iter().map(|p| p.coords.norm()).collect();
            let end = points[pick(&lengths, rng)];
            let along = end.coords * rng.random_range(BONE_SPAN.0..BONE_SPAN.1);
            let n = perpendicular(&end.coords, rng.random_range(0.0..std::f64::consts::TAU));
            (Point3::from(along + n * *radius), n)
        }
    }
}

fn area(shape: &Shape) -> f64 {
    match *shape {
        Shape::Box(s) => 2.0 * (s.x * s.y + s.y * s.z + s.z * s.x),
        Shape::Cylinder { radius, length } => std::f64::consts::TAU * radius * (radius + length),
        Shape::Capsule { radius, length } => std::f64::consts::TAU * radius * (2.0 * radius + length),
        Shape::Sphere(r) => 2.0 * std::f64::consts::TAU * r * r,
        Shape::Mesh(ref mesh) => mesh.area(),
    }
}

fn shape_point(shape: &Shape, rng: &mut ChaCha8Rng) -> (Point3<f64>, Vector3<f64>) {
    match *shape {
        Shape::Box(s) => {
            let faces = [s.y * s.z, s.y * s.z, s.z * s.x, s.z * s.x, s.x * s.y, s.x * s.y];
            let face = pick(&faces, rng);
            let axis = face / 2;
            let sign = if face.is_multiple_of(2) { 1.0 } else { -1.0 };
            let mut p = Vector3::from_fn(|i, _| s[i] * rng.random_range(-0.5..0.5));
            p[axis] = sign * s[axis] / 2.0;
            let mut n = Vector3::zeros();
            n[axis] = sign;
            (Point3::from(p), n)
        }
        Shape::Cylinder { radius, length } => {
            let side = length / (length + radius);
            if rng.random_bool(side) {
                let h = length * rng.random_range(-0.5..0.5);
                let n = perpendicular(&Vector3::z(), rng.random_range(0.0..std::f64::consts::TAU));
                (Point3::from(n * radius + Vector3::z() * h), n)
            } else {
                // A cap: uniform over the disc.
                let sign = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
                let r = radius * rng.random_range(0.0f64..1.0).sqrt();
                let d = perpendicular(&Vector3::z(), rng.random_range(0.0..std::f64::consts::TAU));
                (Point3::from(d * r + Vector3::z() * sign * length / 2.0), Vector3::z() * sign)
            }
        }
        Shape::Capsule { radius, length } => {
            // The straight part's share of the area; the rest is the two caps.
            let side = length / (length + 2.0 * radius);
            if rng.random_bool(side) {
                let h = length * rng.random_range(-0.5..0.5);
                let n = perpendicular(&Vector3::z(), rng.random_range(0.0..std::f64::consts::TAU));
                (Point3::from(n * radius + Vector3::z() * h), n)
            } else {
                // A cap: uniform over its hemisphere, around the end of the axis.
                let n = random_unit(rng);
                let end = Vector3::z() * (length / 2.0).copysign(n.z);
                (Point3::from(end + n * radius), n)
            }
        }
        Shape::Sphere(r) => {
            let n = random_unit(rng);
            (Point3::from(n * r), n)
        }
        Shape::Mesh(ref mesh) => {
            // A face by its area, then a uniform point on it.
            let f = pick(mesh.face_areas(), rng);
            let (a, b): (f64, f64) = (rng.random_range(0.0..1.0), rng.random_range(0.0..1.0));
            let (u, v) = if a + b > 1.0 { (1.0 - a, 1.0 - b) } else { (a, b) };
            mesh.point_on(f, u, v)
        }
    }
}

/// Index drawn with probability proportional to `weights` (uniform if they
/// sum to zero, or to more than `f64` holds: never a panic in the sampler).
fn pick(weights: &[f64], rng: &mut ChaCha8Rng) -> usize {
    let total: f64 = weights.iter().sum();
    if !(total > 0.0 && total.is_finite()) {
        return rng.random_range(0..weights.len());
    }
    let mut x = rng.random_range(0.0..total);
    for (i, w) in weights.iter().enumerate() {
        if x < *w {
            return i;
        }
        x -= w;
    }
    weights.len() - 1
}

fn random_unit(rng: &mut ChaCha8Rng) -> Vector3<f64> {
    let z: f64 = rng.random_range(-1.0..1.0);
    let phi = rng.random_range(0.0..std::f64::consts::TAU);
    let s = (1.0 - z * z).sqrt();
    Vector3::new(s * phi.cos(), s * phi.sin(), z)
}

/// The unit vector at angle `angle` around `axis`, perpendicular to it.
fn perpendicular(axis: &Vector3<f64>, angle: f64) -> Vector3<f64> {
    let a = axis.normalize();
    let helper = if a.x.abs() < 0.9 { Vector3::x() } else { Vector3::y() };
    let e1 = a.cross(&helper).normalize();
    let e2 = a.cross(&e1);
    e1 * angle.cos() + e2 * angle.sin()
}

/// A rotation whose z axis is `normal`, turned by `angle` about it.
fn frame_with_normal(normal: &Vector3<f64>, angle: f64) -> UnitQuaternion<f64> {
    let z = normal.normalize();
    let x = perpendicular(&z, angle);
    let y = z.cross(&x);
    UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x, y, z])))
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeSet;

    use super::*;

    #[test]
    fn relabeling_keeps_the_cells_and_checks_the_ids() {
        let robot = crate::robot::hrp2::robot();
        let skin = Skin::per_link(&robot, 1, 0).unwrap();
        let n = skin.cells().len();
        let ids: Vec<Address> = (0..n as u16).map(|i| Address(100 + i)).collect();
        let relabeled = skin.relabeled(&ids).unwrap();
        assert!(relabeled.cells().iter().zip(skin.cells()).all(|(a, b)| a.link == b.link && a.pose == b.pose));
        assert_eq!(relabeled.cells()[3].id, Address(103));
        assert!(skin.relabeled(&ids[1..]).is_err());
        let mut twice = ids.clone();
        twice[1] = twice[0];
        assert!(matches!(skin.relabeled(&twice), Err(SkinError::DuplicateId(100))));
        twice[1] = Address::UNASSIGNED;
        assert!(matches!(skin.relabeled(&twice), Err(SkinError::BadId(0))));
    }
    use crate::robot::hrp2;

    #[test]
    fn placement_is_deterministic_and_ids_are_a_permutation() {
        let robot = hrp2::robot();
        let a = Skin::with_counts(&robot, &hrp2::SKIN, 7).unwrap();
        let b = Skin::with_counts(&robot, &hrp2::SKIN, 7).unwrap();
        let c = Skin::with_counts(&robot, &hrp2::SKIN, 8).unwrap();
        assert_eq!(a.cells(), b.cells());
        assert_ne!(a.cells(), c.cells());
        let ids: BTreeSet<u16> = a.cells().iter().map(|c| c.id.0).collect();
        assert_eq!(ids, (1..=74).collect());
    }

    #[test]
    fn cells_lie_on_their_link_surface_facing_out() {
        let robot = hrp2::robot();
        let skin = Skin::with_counts(&robot, &[("RARM_LINK2", 50)], 1).unwrap();
        // The upper arm is a cylinder of radius 0.05 along z, centred 0.075 m down.
        for c in skin.cells() {
            let p = c.pose.translation.vector;
            let n = c.pose.rotation * Vector3::z();
            let radial = Vector3::new(p.x, p.y, 0.0);
            let on_side = (radial.norm() - 0.05).abs() < 1e-9 && (n - radial.normalize()).norm() < 1e-9;
            let on_cap = ((p.z + 0.075).abs() - 0.075).abs() < 1e-9 && n.x == 0.0 && n.y == 0.0;
            assert!(on_side || on_cap, "cell {} at {p} normal {n}", c.id);
        }
    }

    #[test]
    fn cells_on_a_capsule_lie_on_its_side_and_its_round_caps_facing_out() {
        let robot = Robot::from_urdf_str(
            r#"<robot name="c"><link name="base"/><link name="arm"><collision><geometry><capsule radius="0.04" length="0.2"/></geometry></collision></link>
            <joint name="j" type="continuous"><parent link="base"/><child link="arm"/><axis xyz="1 0 0"/></joint></robot>"#,
        )
        .unwrap();
        let skin = Skin::with_counts(&robot, &[("arm", 60)], 4).unwrap();
        let mut on_caps = 0;
        for c in skin.cells() {
            let p = c.pose.translation.vector;
            let n = c.pose.rotation * Vector3::z();
            // From the nearest point of the axis segment: the radius, along the normal.
            let from_axis = p - Vector3::z() * p.z.clamp(-0.1, 0.1);
            assert!((from_axis.norm() - 0.04).abs() < 1e-9, "cell {} at {p}", c.id);
            assert!((n - from_axis / 0.04).norm() < 1e-9, "cell {} at {p} normal {n}", c.id);
            on_caps += usize::from(p.z.abs() > 0.1);
        }
        // The caps are 2r / (L + 2r) = 2/7 of the area: about 17 of 60.
        assert!((8..=28).contains(&on_caps), "{on_caps} of 60 cells on the caps");
    }

    #[test]
    fn every_cell_knows_its_true_clearance_from_the_joint_axes_at_its_body() {
        let robot = hrp2::robot();
        let skin = Skin::with_counts(&robot, &hrp2::SKIN, 1).unwrap();
        for c in skin.cells() {
            let axes = joint_axes(&robot, c.body);
            assert_eq!(c.axis_clearance_m, clearance(&axes, &Point3::from(c.pose.translation.vector)));
        }
        // A 1 cm ball between two hinges has no room for 2 cm: the cell is
        // placed all the same, and says how close it is.
        let tiny = Robot::from_urdf_str(
            r#"<robot name="t"><link name="a"/><link name="b"><collision><geometry><sphere radius="0.01"/></geometry></collision></link>
            <link name="c"/>
            <joint name="j1" type="continuous"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/></joint>
            <joint name="j2" type="continuous"><parent link="b"/><child link="c"/><axis xyz="1 0 0"/></joint></robot>"#,
        )
        .unwrap();
        let skin = Skin::with_counts(&tiny, &[("b", 5)], 1).unwrap();
        assert_eq!(skin.cells().len(), 5);
        assert!(skin.min_axis_clearance_m() <= 0.01 + 1e-12, "{}", skin.min_axis_clearance_m());
        // Cells from a file: on the axis of the joint carrying them.
        let on_axis = Skin::from_toml_str(&tiny, "[[link]]\nname = \"b\"\ncell = [{ xyz = [0, 0, 0.01] }]").unwrap();
        assert_eq!(on_axis.cells()[0].axis_clearance_m, 0.0);
    }
}
