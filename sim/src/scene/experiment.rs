//! The grasping experiment of section 6.5 on the built-in HRP-2-like robot.
//!
//! Everything here is the experimenters' knowledge, not the robot's: where
//! the skin was glued (74 cells as in the paper: the chest front, patches
//! on the inner side of each upper arm, forearm, wrist and hand where
//! objects are held, and cells on the arms' outer sides so a hand can
//! guide them inwards),
//! which cells the operator assigned to which touch area (written as the
//! host's area file, by cell ID), the key poses the person means to teach,
//! and where an object is put between the arms.

use std::fmt::Write;

use nalgebra::{Isometry3, Point3, UnitQuaternion, Vector3};
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::object::Object;
use super::placement::{Placement, OBJECT_GAP_M};
use super::{Placed, Scene, SharedScene, SkinModel};
use crate::world::{World, WorldConfig};
use skin_model::robot::kinematics::{self, BodyState, DofMotion};
use skin_model::robot::{Robot, Shape as RobotShape, Surface};
use skin_model::skin::{Skin, SkinError};
use skin_protocol::Address;

/// Where the object stands: centre height above the chest frame origin, m.
/// The person holds it with its middle above the arms (their axes run
/// 15-17 cm up in the closed and pulled poses, the chest's upper cells 17
/// cm), so the arms close under its widest part and carry it. Under
/// MuJoCo's gravity and friction, at 15 cm the arms closed above the
/// middle of round objects and squeezed them down, onto the person's
/// hands while pulling and out of the arms once let go; of 100 generated
/// objects MuJoCo held 66 at 19 cm, 71 at 21, 72 at 22, 68 at 23 and 36
/// at 25 (the grasping results in the book have the figures).
pub const OBJECT_HEIGHT_M: f64 = 0.22;
/// Front of the chest (its box is 0.26 m deep, centred on the chest frame), m.
pub const CHEST_FRONT_M: f64 = 0.13;

/// One arm's intended key poses (right arm; the left is its mirror image):
/// shoulder pitch, roll, yaw, elbow, wrist yaw, wrist pitch, gripper.
const OPEN: [f64; 7] = [-1.3, -0.7, 1.4, -0.5, 0.0, 0.0, 0.17];
const CLOSED: [f64; 7] = [-1.5, 0.1, 1.57, -0.8, 0.0, 0.0, 0.17];
const PULLED: [f64; 7] = [-1.5, 0.17, 1.57, -1.6, 0.0, 0.0, 0.17];

/// Touch-area role of a skin cell, as the operator assigns it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Role {
    Pat,
    Contact,
    Chest,
    Other,
}

/// One planned cell: link, position and outward normal in the link frame.
struct Planned {
    link: String,
    xyz: Vector3<f64>,
    normal: Vector3<f64>,
    role: Role,
    side: &'static str,
}

/// The built-in robot with the experiment's skin, and the operator's
/// touch areas.
#[derive(Clone, Debug)]
pub struct Setup {
    /// The skin.
    pub skin: Skin,
    /// The touch areas the operator assigned, by skin index: see
    /// [`Setup::areas_toml`] for the host's area file.
    pub areas: Vec<Area>,
    /// Skin indices of the cells a person guides each arm by (upper arm,
    /// upper arm and forearm; wrist and hand are left as they are), right
    /// then left.
    pub guided_cells: [Vec<usize>; 2],
    /// Skin index of the cell the person pats (top of the right shoulder).
    pub pat_cell: usize,
    /// The robot's surface, as points every 1.5 cm on its links' shapes,
    /// each link's points in the frame of one of its cells (skin index).
    pub surface: Vec<(usize, Vec<Point3<f64>>)>,
}

/// A touch area as the operator assigned it.
#[derive(Clone, Debug, PartialEq)]
pub struct Area {
    /// What the operator calls it.
    pub name: &'static str,
    /// The host's area kind: `pat`, `contact` or `chest`.
    pub kind: &'static str,
    /// Its cells, by skin index.
    pub cells: Vec<usize>,
}

/// The mirror image of a right-arm pose for the left arm: roll, yaw and
/// the gripper turn the other way.
fn mirrored(right: &[f64; 7]) -> [f64; 7] {
    let mut left = *right;
    for i in [1, 2, 4, 6] {
        left[i] = -left[i];
    }
    left
}

/// A whole-robot pose (right arm, then left) from a right-arm pose.
fn both(right: &[f64; 7]) -> Vec<f64> {
    right.iter().chain(mirrored(right).iter()).copied().collect()
}

/// The key poses the person means to teach, by name; home is where the
/// robot starts.
pub fn intended_pose(robot: &Robot, name: &str) -> Option<Vec<f64>> {
    match name {
        "home" => Some(robot.home().to_vec()),
        "open" => Some(both(&OPEN)),
        "closed" => Some(both(&CLOSED)),
        "pulled" => Some(both(&PULLED)),
        _ => None,
    }
}

/// Body poses of `robot` at rest in `pose`, chest frame.
pub fn body_poses(robot: &Robot, pose: &[f64]) -> Vec<Isometry3<f64>> {
    let zero = vec![0.0; pose.len()];
    let mut states = Vec::new();
    let base = BodyState::at_rest(Isometry3::identity());
    kinematics::forward(robot, &base, DofMotion { q: pose, qd: &zero, qdd: &zero }, &mut states);
    states.into_iter().map(|s| s.pose).collect()
}

/// How far a placed object reaches behind its centre, towards the chest, m,
/// as it stands now.
pub fn back_extent(placed: &Placed) -> f64 {
    placed.object.shape.extent(&(placed.pose.rotation.inverse() * -Vector3::x()))
}

/// The pose of an object put down between the arms: by default centred,
/// its back `OBJECT_GAP_M` in front of the chest's skin; then moved and
/// turned by `placement`.
pub fn object_pose(object: &Object, placement: &Placement, skin_offset_m: f64) -> Isometry3<f64> {
    let turned = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), placement.yaw_rad);
    let back = object.shape.extent(&(turned.inverse() * -Vector3::x()));
    let spot = Vector3::new(CHEST_FRONT_M + skin_offset_m + OBJECT_GAP_M + back, 0.0, OBJECT_HEIGHT_M);
    Isometry3::from_parts((spot + placement.offset_m).into(), turned)
}

/// Ground truth: how far a placed object's back is from the chest's skin,
/// given its [`back_extent`], m.
pub fn gap_to_chest_m(placed: &Placed, back_m: f64, skin_offset_m: f64) -> f64 {
    placed.pose.translation.x - back_m - CHEST_FRONT_M - skin_offset_m
}

impl Setup {
    /// The experiment's skin on `robot` (the built-in one), cell IDs a
    /// seeded shuffle.
    pub fn new(robot: &Robot, seed: u64) -> Result<Setup, SkinError> {
        let closed = body_poses(robot, &both(&CLOSED));
        let mut plan = Vec::new();
        for y in [-0.09, -0.045, 0.0, 0.045, 0.09, -0.0675, 0.0675] {
            for z in [0.08, 0.17] {
                plan.push(Planned {
                    link: "CHEST".into(),
                    xyz: Vector3::new(CHEST_FRONT_M, y, z),
                    normal: Vector3::x(),
                    role: Role::Chest,
                    side: "",
                });
            }
        }
        let quarter = std::f64::consts::FRAC_PI_2;
        for side in ["RARM", "LARM"] {
            let link = |i: usize| format!("{side}_LINK{i}");
            // The ring angle (about the link's z axis) facing the body's
            // midline, where the object is held, in the closed pose.
            let towards_midline = if side == "RARM" { Vector3::y() } else { -Vector3::y() };
            let inward = |i: usize| {
                let b = robot.link(&link(i)).expect("the built-in robot has its arm links").body;
                let v = closed[b].inverse_transform_vector(&towards_midline);
                v.y.atan2(v.x)
            };
            // Shoulder housing (a cylinder along y): two cells on top, the
            // right arm's first is patted.
            for (k, y) in [0.02, -0.02].into_iter().enumerate() {
                let role = if side == "RARM" && k == 0 { Role::Pat } else { Role::Other };
                plan_top(&mut plan, link(0), y, role, side);
            }
            // Two cells on the shoulder's roll housing, front and back.
            ring(&mut plan, link(1), side, 0.05, &[-0.06], &[0.0, 2.0 * quarter], |_| Role::Other);
            // Upper arm (two rings) and forearm (three): per ring two cells
            // side by side facing the midline (the contact area) and two
            // facing away, for a hand to push the arm inwards.
            let spread = 0.35;
            for (i, radius, zs) in [(2, 0.05, vec![-0.035, -0.115]), (3, 0.045, vec![-0.04, -0.09, -0.14])] {
                let a0 = inward(i);
                let angles =
                    [a0 - spread, a0 + spread, a0 + 2.0 * quarter - 1.5 * spread, a0 + 2.0 * quarter + 1.5 * spread];
                let near = move |a: f64| if (a - a0).cos() > 0.0 { Role::Contact } else { Role::Other };
                ring(&mut plan, link(i), side, radius, &zs, &angles, near);
            }
            // The wrist's two cells face the midline side by side, in the
            // contact area: big objects press on the wrist (the paper's
            // wrist cover bore no force and cancelled such grasps; a bare
            // wrist squeezed large boxes with 15-50 N unfelt).
            let a4 = inward(4);
            ring(&mut plan, link(4), side, 0.04, &[-0.035], &[a4 - spread, a4 + spread], |_| Role::Contact);
            // The hand (a box) has three cells and the finger one. Big
            // objects touch the hand's side facing them ("big objects are
            // likely to touch the wrist", section 6.5): a cell there is in
            // the contact area, so the grasp feels the hand's squeeze (a
            // bare hand pressed large boxes with 20-60 N unfelt); the other
            // two sit above and below, off the object's way.
            let a5 = inward(5);
            for (a, role) in [(a5 + quarter, Role::Other), (a5, Role::Contact), (a5 - quarter, Role::Other)] {
                plan.push(Planned { role, ..on_box(link(5), side, [0.04, 0.025], -0.08, a) });
            }
            plan.push(on_box(link(6), side, [0.01, 0.015], -0.04, inward(6) + 2.0 * quarter));
        }
        let mut ids: Vec<u16> = (1..=plan.len() as u16).collect();
        ids.shuffle(&mut ChaCha8Rng::seed_from_u64(seed));
        let mut toml = String::new();
        for (p, id) in plan.iter().zip(&ids) {
            let rot = UnitQuaternion::rotation_between(&Vector3::z(), &p.normal)
                .unwrap_or_else(|| UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI));
            let (r, pitch, yaw) = rot.euler_angles();
            let [x, y, z] = [p.xyz.x, p.xyz.y, p.xyz.z];
            writeln!(
                toml,
                "[[link]]\nname = \"{}\"\n[[link.cell]]\nid = {id}\nxyz = [{x}, {y}, {z}]\nrpy = [{r}, {pitch}, {yaw}]",
                p.link
            )
            .expect("writing to a String cannot fail");
        }
        let skin = Skin::from_toml_str(robot, &toml)?;
        let cells = |role: Role, side: &str| -> Vec<u16> {
            plan.iter()
                .zip(&ids)
                .filter(|(p, _)| p.role == role && (side.is_empty() || p.side == side))
                .map(|(_, id)| *id)
                .collect()
        };
        let index_of =
            |id: u16| skin.cells().iter().position(|c| c.id.0 == id).expect("every planned cell is in the skin");
        let guided = ["_LINK1", "_LINK2", "_LINK3"];
        let arm = |side: &str| {
            plan.iter()
                .zip(&ids)
                .filter(|(p, _)| p.side == side && guided.iter().any(|g| p.link.ends_with(g)))
                .map(|(_, id)| index_of(*id))
                .collect()
        };
        let pat_cell = index_of(cells(Role::Pat, "")[0]);
        let areas = [
            ("shoulder pat", "pat", Role::Pat, ""),
            ("right arm", "contact", Role::Contact, "RARM"),
            ("left arm", "contact", Role::Contact, "LARM"),
            ("chest", "chest", Role::Chest, ""),
        ]
        .into_iter()
        .map(|(name, kind, role, side)| Area {
            name,
            kind,
            cells: cells(role, side).into_iter().map(index_of).collect(),
        })
        .collect();
        let surface = robot
            .links()
            .iter()
            .filter_map(|link| {
                let u = skin.cells().iter().position(|c| c.link == link.name)?;
                let to_cell = skin.cells()[u].pose.inverse() * link.in_body;
                Some((u, surface_points(&link.surface).into_iter().map(|p| to_cell * p).collect()))
            })
            .collect();
        Ok(Setup { guided_cells: [arm("RARM"), arm("LARM")], pat_cell, areas, surface, skin })
    }

    /// The experiment's world: `robot` (the built-in one) with this skin,
    /// feeling a scene that holds the robot's bare surface and, later, the
    /// person's hands and the objects. Noise is drawn from `seed`.
    pub fn world(&self, robot: Robot, seed: u64) -> (World, SharedScene) {
        let mut world = World::new(robot, self.skin.clone(), WorldConfig { seed, ..WorldConfig::default() });
        let mut scene = Scene::new(SkinModel::default());
        for (cell, points) in &self.surface {
            scene.add_bare_surface(*cell, points.clone());
        }
        let scene = SharedScene::new(scene);
        world.set_tactile(scene.tactile(seed.wrapping_add(1)));
        (world, scene)
    }

    /// The host's area file (TOML `[[area]]` tables) with the cells named
    /// by `ids` (by skin index): the skin's own IDs, or those a network
    /// assigned. On a real robot the operator writes this file after
    /// touching each area's cells and reading their IDs in `skin monitor`.
    pub fn areas_toml(&self, ids: &[Address]) -> String {
        let mut toml = String::new();
        for area in &self.areas {
            let cells: Vec<u16> = area.cells.iter().map(|&u| ids[u].0).collect();
            writeln!(toml, "[[area]]\nname = \"{}\"\nkind = \"{}\"\ncells = {cells:?}\n", area.name, area.kind)
                .expect("writing to a String cannot fail");
        }
        toml
    }
}

/// Cells around a link's z axis: at each height, one per angle, facing out.
fn ring(
    plan: &mut Vec<Planned>,
    link: String,
    side: &'static str,
    radius: f64,
    heights: &[f64],
    angles: &[f64],
    role: impl Fn(f64) -> Role,
) {
    for &z in heights {
        for &a in angles {
            let n = Vector3::new(a.cos(), a.sin(), 0.0);
            plan.push(Planned {
                link: link.clone(),
                xyz: n * radius + Vector3::z() * z,
                normal: n,
                role: role(a),
                side,
            });
        }
    }
}

/// Spacing of the points laid on a link's collision shapes, m.
const POINT_STEP_M: f64 = 0.015;

/// Intervals of about [`POINT_STEP_M`] over `length` (at least one).
fn steps(length: f64) -> usize {
    (length / POINT_STEP_M).ceil().max(1.0) as usize
}

/// Points about [`POINT_STEP_M`] apart from `-length / 2` to `length / 2`.
fn spread(length: f64) -> impl Iterator<Item = f64> {
    let n = steps(length);
    (0..=n).map(move |k| length * (k as f64 / n as f64 - 0.5))
}

/// Points about [`POINT_STEP_M`] apart on a cylinder's side (z its axis).
fn tube(radius: f64, length: f64) -> Vec<Point3<f64>> {
    let around = steps(std::f64::consts::TAU * radius);
    spread(length)
        .flat_map(|z| {
            (0..around).map(move |k| {
                let a = std::f64::consts::TAU * k as f64 / around as f64;
                Point3::new(radius * a.cos(), radius * a.sin(), z)
            })
        })
        .collect()
}

/// Points about [`POINT_STEP_M`] apart on a sphere of radius `r`.
fn ball(r: f64) -> Vec<Point3<f64>> {
    let n = steps(std::f64::consts::PI * r);
    (0..=n)
        .flat_map(|i| {
            let polar = std::f64::consts::PI * i as f64 / n as f64;
            let around = steps(std::f64::consts::TAU * r * polar.sin()).max(1);
            (0..around).map(move |k| {
                let a = std::f64::consts::TAU * k as f64 / around as f64;
                Point3::new(r * polar.sin() * a.cos(), r * polar.sin() * a.sin(), r * polar.cos())
            })
        })
        .collect()
}

/// Points about [`POINT_STEP_M`] apart on a link's collision shapes, link frame.
pub(super) fn surface_points(surface: &Surface) -> Vec<Point3<f64>> {
    let Surface::Shapes(shapes) = surface else { return Vec::new() };
    let mut points = Vec::new();
    for (pose, shape) in shapes {
        let local: Vec<Point3<f64>> = match *shape {
            RobotShape::Box(size) => {
                let mut v = Vec::new();
                for axis in 0..3 {
                    let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
                    for sign in [-0.5, 0.5] {
                        for u in spread(size[a]) {
                            for w in spread(size[b]) {
                                let mut p = Vector3::zeros();
                                p[axis] = sign * size[axis];
                                p[a] = u;
                                p[b] = w;
                                v.push(Point3::from(p));
                            }
                        }
                    }
                }
                v
            }
            RobotShape::Cylinder { radius, length } => tube(radius, length),
            RobotShape::Capsule { radius, length } => {
                let mut v = tube(radius, length);
                // Each cap: its half of a sphere around its end of the axis.
                let caps = ball(radius)
                    .into_iter()
                    .map(|p| p + Vector3::z() * (length / 2.0).copysign(p.z))
                    .filter(|p| p.z.abs() > length / 2.0);
                v.extend(caps);
                v
            }
            RobotShape::Sphere(r) => ball(r),
            RobotShape::Mesh(ref mesh) => {
                let mut v = mesh.vertices().to_vec();
                for (f, face) in mesh.faces().iter().enumerate() {
                    let [a, b, c] = face.map(|i| mesh.vertices()[i as usize]);
                    let n = steps((b - a).norm().max((c - a).norm()).max((c - b).norm()));
                    for i in 0..=n {
                        for j in 0..=n - i {
                            v.push(mesh.point_on(f, i as f64 / n as f64, j as f64 / n as f64).0);
                        }
                    }
                }
                v
            }
        };
        points.extend(local.into_iter().map(|p| pose * p));
    }
    points
}

/// A cell on the side of a box (half extents x, y about the link's z axis,
/// at height z) met by the direction at `angle`, facing out of that side.
fn on_box(link: String, side: &'static str, half: [f64; 2], z: f64, angle: f64) -> Planned {
    let (c, s) = (angle.cos(), angle.sin());
    let (xyz, normal) = if c.abs() * half[1] >= s.abs() * half[0] {
        (Vector3::new(half[0] * c.signum(), half[0] * s / c.abs(), z), Vector3::x() * c.signum())
    } else {
        (Vector3::new(half[1] * c / s.abs(), half[1] * s.signum(), z), Vector3::y() * s.signum())
    };
    Planned { link, xyz, normal, role: Role::Other, side }
}

/// A cell on top of the shoulder housing (a cylinder along the link's y).
fn plan_top(plan: &mut Vec<Planned>, link: String, y: f64, role: Role, side: &'static str) {
    plan.push(Planned { link, xyz: Vector3::new(0.0, y, 0.055), normal: Vector3::z(), role, side });
}

#[cfg(test)]
mod tests {
    use super::*;
    use skin_model::robot::hrp2;

    #[test]
    fn seventy_four_cells_in_the_papers_layout() {
        let robot = hrp2::robot();
        let s = Setup::new(&robot, 3).unwrap();
        assert_eq!(s.skin.cells().len(), 74);
        assert_eq!(s.guided_cells[0].len(), 22, "2 + 8 + 12 cells from shoulder to elbow");
        assert_eq!(s.guided_cells[1].len(), 22);
        assert_eq!(s.skin.cells()[s.pat_cell].link, "RARM_LINK0");
        // Every link with cells has its surface sampled; the forearm's
        // points lie on its cylinder (radius 0.045) in the link frame.
        assert_eq!(s.surface.len(), 15, "the chest and seven links per arm carry cells");
        let (u, points) = s.surface.iter().find(|(u, _)| s.skin.cells()[*u].link == "RARM_LINK3").unwrap();
        let cell = &s.skin.cells()[*u];
        for p in points {
            let in_link = cell.pose * p;
            assert!((in_link.coords.xy().norm() - 0.045).abs() < 1e-9, "{in_link}");
        }
        assert!(points.len() > 50);
        // At the closed pose the contact cells of the upper arms and forearms
        // face the midline, where the object is, and the others face away.
        let bodies = body_poses(&robot, &intended_pose(&robot, "closed").unwrap());
        let contact: Vec<usize> =
            s.areas.iter().filter(|a| a.kind == "contact").flat_map(|a| a.cells.iter().copied()).collect();
        assert_eq!(contact.len(), 26, "per arm 4 on the upper arm, 6 on the forearm, 2 on the wrist, 1 on the hand");
        for (u, c) in
            s.skin.cells().iter().enumerate().filter(|(_, c)| c.link.ends_with("LINK2") || c.link.ends_with("LINK3"))
        {
            let pose = bodies[c.body] * c.pose;
            let to_midline = -(pose * Point3::origin()).y.signum() * (pose.rotation * Vector3::z()).y;
            assert_eq!(to_midline > 0.0, contact.contains(&u), "cell {} on {}", c.id, c.link);
        }
        // The area file names the cells by the IDs given.
        let ids: Vec<Address> = s.skin.cells().iter().map(|c| c.id).collect();
        let toml = s.areas_toml(&ids);
        let pat = ids[s.pat_cell].0;
        assert!(
            toml.starts_with(&format!("[[area]]\nname = \"shoulder pat\"\nkind = \"pat\"\ncells = [{pat}]\n")),
            "{toml}"
        );
        assert_eq!(toml.matches("[[area]]").count(), 4);
    }

    #[test]
    fn objects_are_put_down_turned_and_moved_clear_of_the_chest() {
        let offset = 0.008;
        for object in Object::figure_16() {
            for yaw_rad in [-0.3, 0.0, 0.3] {
                let pose = object_pose(&object, &Placement { yaw_rad, ..Placement::default() }, offset);
                let placed = Placed { object: object.clone(), pose };
                let gap = gap_to_chest_m(&placed, back_extent(&placed), offset);
                assert!((gap - OBJECT_GAP_M).abs() < 1e-9, "{} at {yaw_rad} rad: {gap} m", object.name);
                // Nothing of it is nearer the chest's skin than the gap (a
                // grid over its back half).
                for y in -20..=20 {
                    for z in -20..=20 {
                        let p = Point3::new(
                            CHEST_FRONT_M + offset,
                            f64::from(y) * 0.01,
                            OBJECT_HEIGHT_M + f64::from(z) * 0.01,
                        );
                        let d = object.shape.distance(&pose.inverse_transform_point(&p));
                        assert!(d > 0.0, "{} at {yaw_rad} rad reaches the chest at {p}", object.name);
                    }
                }
            }
            let moved = Placement { offset_m: Vector3::new(0.01, 0.03, 0.0), yaw_rad: 0.0 };
            let shift = object_pose(&object, &moved, offset).translation.vector
                - object_pose(&object, &Placement::default(), offset).translation.vector;
            assert!((shift - moved.offset_m).norm() < 1e-12);
        }
    }
}
