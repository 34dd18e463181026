//! A skin laid as wired patches: cells one cell pitch apart on each link's
//! surface, each wired to the cells next to it (on its own body, or across
//! a joint where the links touch in the home posture), as a real skin is
//! assembled. Its neighbour tables follow its geometry, so a calibration
//! can use them; the random skin of [`Skin::on_surfaces`] has none.

use nalgebra::{Isometry3, Point3, Translation3, Vector3};
use rand::seq::SliceRandom;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use skin_protocol::message::Port;
use skin_protocol::Address;

use super::{clearance, frame_with_normal, joint_axes, surface_point, Cell, JOINT_CLEARANCE_M};
use crate::robot::kinematics::{self, BodyState, DofMotion};
use crate::robot::{Link, Robot, Surface};

/// Centre-to-centre distance of two wired cells, m (a hexagonal cell of
/// the paper's size with its flexible connector).
pub const CELL_PITCH_M: f64 = 0.025;
/// The connectors let the pitch vary by up to this fraction either way.
pub const PITCH_TOLERANCE: f64 = 0.05;
/// Two cells are wired only where their surfaces turn by at most this
/// between them, rad: a connector does not wrap around a sharp edge.
const MAX_WIRED_TURN_RAD: f64 = std::f64::consts::FRAC_PI_3;
/// Surface points drawn per link to lay its patch from.
const POOL: usize = 8000;

/// The far end of each of a cell's four ports: (cell index, its port).
pub(super) type Wires = [Option<(usize, Port)>; 4];

/// `count(link)` cells on each link, laid in patches at [`CELL_PITCH_M`],
/// and their wiring, deterministic for `seed`. Links are laid from the
/// leaves in: a link's patch starts as near a pitch from a cell of a link
/// jointed to it as its surface allows (so patches meet across joints, as
/// a real skin's do), and grows one cell at a time next to those laid,
/// toward the joint that carries the link.
pub(super) fn lay(robot: &Robot, count: impl Fn(&Link) -> usize, rng: &mut ChaCha8Rng) -> (Vec<Cell>, Vec<Wires>) {
    let home = home_poses(robot);
    let world = |c: &Cell| {
        (home[c.body] * Point3::from(c.pose.translation.vector), home[c.body].rotation * c.pose.rotation * Vector3::z())
    };
    let lo = CELL_PITCH_M * (1.0 - PITCH_TOLERANCE);
    let mut cells: Vec<Cell> = Vec::new();
    for link in robot.links().iter().rev() {
        let n = if link.surface == Surface::None { 0 } else { count(link) };
        if n == 0 {
            continue;
        }
        let axes = joint_axes(robot, link.body);
        let pool = candidates(link, &axes, rng);
        let first = cells.len();
        for _ in 0..n {
            // Cells this one must not overlap and may sit next to (own: of this patch).
            let near: Vec<(Point3<f64>, Vector3<f64>, bool)> = cells
                .iter()
                .enumerate()
                .filter(|(_, c)| c.body == link.body || jointed(robot, c.body, link.body))
                .map(|(i, c)| {
                    let (p, n) = world(c);
                    (p, n, i >= first)
                })
                .collect();
            let in_world =
                |(p, n, _): &(Point3<f64>, Vector3<f64>, f64)| (home[link.body] * p, home[link.body].rotation * n);
            let free: Vec<_> = pool
                .iter()
                .filter(|c| {
                    let (w, _) = in_world(c);
                    near.iter().all(|(q, _, _)| (w - q).norm() >= lo)
                })
                .collect();
            // How far from a pitch the candidate is from the nearest cell it could be wired to.
            let miss = |c: &(Point3<f64>, Vector3<f64>, f64), own: bool| {
                let (w, m) = in_world(c);
                near.iter()
                    .filter(|(_, n, o)| (*o || !own) && n.angle(&m) <= MAX_WIRED_TURN_RAD)
                    .map(|(q, _, _)| ((w - q).norm() - CELL_PITCH_M).abs())
                    .fold(f64::INFINITY, f64::min)
            };
            let own = cells.len() > first;
            // The joint carrying the body is at its origin.
            let toward_parent = |c: &&&(Point3<f64>, Vector3<f64>, f64)| c.0.coords.norm();
            // Next to this patch's cells, toward the joint carrying the link
            // (where its parent's patch will start); a new patch as near a
            // pitch from a jointed link's cells as there is room.
            let pick = free
                .iter()
                .filter(|c| own && miss(c, true) <= PITCH_TOLERANCE * CELL_PITCH_M)
                .min_by(|a, b| toward_parent(a).total_cmp(&toward_parent(b)))
                .or_else(|| free.iter().min_by(|a, b| miss(a, false).total_cmp(&miss(b, false))))
                .copied()
                .or(pool.first());
            let Some(&(p, normal, axis_clearance_m)) = pick else { break };
            cells.push(Cell {
                id: Address::UNASSIGNED,
                link: link.name.clone(),
                body: link.body,
                pose: Isometry3::from_parts(
                    Translation3::from(p.coords),
                    frame_with_normal(&normal, rng.random_range(0.0..std::f64::consts::TAU)),
                ),
                axis_clearance_m,
            });
        }
    }
    let wires = wire(robot, &cells, &home);
    (cells, wires)
}

/// Surface points of `link` (body frame) with their normals and clearance
/// from the joint `axes`, those keeping [`JOINT_CLEARANCE_M`] (all of
/// them on a link too small for it), in random order.
fn candidates(
    link: &Link,
    axes: &[(Point3<f64>, Vector3<f64>)],
    rng: &mut ChaCha8Rng,
) -> Vec<(Point3<f64>, Vector3<f64>, f64)> {
    let mut pool: Vec<_> = (0..POOL)
        .map(|_| {
            let (p, n) = surface_point(&link.surface, rng);
            let (p, n) = (link.in_body * p, link.in_body.rotation * n);
            (p, n, clearance(axes, &p))
        })
        .collect();
    if pool.iter().any(|c| c.2 >= JOINT_CLEARANCE_M) {
        pool.retain(|c| c.2 >= JOINT_CLEARANCE_M);
    }
    pool.shuffle(rng);
    pool
}

/// Whether a joint connects bodies `a` and `b`.
fn jointed(robot: &Robot, a: usize, b: usize) -> bool {
    robot.joints().iter().any(|j| (j.parent_body, j.child_body) == (a, b) || (j.parent_body, j.child_body) == (b, a))
}

/// Every body's pose in the home posture, the root at the origin.
fn home_poses(robot: &Robot) -> Vec<Isometry3<f64>> {
    let zero = vec![0.0; robot.dofs().len()];
    let mut states = Vec::new();
    let base = BodyState::at_rest(Isometry3::identity());
    kinematics::forward(robot, &base, DofMotion { q: robot.home(), qd: &zero, qdd: &zero }, &mut states);
    states.iter().map(|s| s.pose).collect()
}

/// Wires every pair of cells a pitch apart (within the tolerance) on one
/// body or on two jointed ones in the home posture, whose surfaces turn
/// little between them; the closest to the pitch first, on the first free
/// port of each, while ports last.
fn wire(robot: &Robot, cells: &[Cell], home: &[Isometry3<f64>]) -> Vec<Wires> {
    let world: Vec<(Point3<f64>, Vector3<f64>)> = cells
        .iter()
        .map(|c| {
            (
                home[c.body] * Point3::from(c.pose.translation.vector),
                home[c.body].rotation * c.pose.rotation * Vector3::z(),
            )
        })
        .collect();
    let mut pairs = Vec::new();
    for (a, ca) in cells.iter().enumerate() {
        for (b, cb) in cells.iter().enumerate().skip(a + 1) {
            if ca.body != cb.body && !jointed(robot, ca.body, cb.body) {
                continue;
            }
            let d = (world[a].0 - world[b].0).norm();
            let turn = world[a].1.angle(&world[b].1);
            if (d / CELL_PITCH_M - 1.0).abs() <= PITCH_TOLERANCE && turn <= MAX_WIRED_TURN_RAD {
                pairs.push(((d - CELL_PITCH_M).abs(), a, b));
            }
        }
    }
    pairs.sort_by(|x, y| x.0.total_cmp(&y.0));
    let mut wires = vec![[None; 4]; cells.len()];
    for (_, a, b) in pairs {
        let free = |w: &Wires| w.iter().position(Option::is_none);
        if let (Some(pa), Some(pb)) = (free(&wires[a]), free(&wires[b])) {
            wires[a][pa] = Some((b, Port::ALL[pb]));
            wires[b][pb] = Some((a, Port::ALL[pa]));
        }
    }
    wires
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::hrp2;
    use crate::skin::Skin;

    fn hrp2_patches(seed: u64) -> (Robot, Skin) {
        let robot = hrp2::robot();
        let skin = Skin::patches(&robot, |l| hrp2::skin_cells_on(&l.name), seed).unwrap();
        (robot, skin)
    }

    #[test]
    fn wired_cells_are_a_pitch_apart_and_the_tables_agree_both_ways() {
        let (robot, skin) = hrp2_patches(0);
        assert_eq!(skin.cells().len(), 74);
        let home = home_poses(&robot);
        let cells = skin.cells();
        let index = |id: Address| cells.iter().position(|c| c.id == id).unwrap();
        let tables = skin.neighbour_tables();
        let mut wires = 0;
        for (id, report) in &tables {
            for (port, n) in report.neighbours.iter().enumerate() {
                let Some(n) = n else { continue };
                wires += 1;
                let (a, b) = (&cells[index(*id)], &cells[index(n.id)]);
                let (pa, pb) = (
                    home[a.body] * Point3::from(a.pose.translation.vector),
                    home[b.body] * Point3::from(b.pose.translation.vector),
                );
                assert!(((pa - pb).norm() / CELL_PITCH_M - 1.0).abs() <= PITCH_TOLERANCE + 1e-12);
                assert!(a.body == b.body || jointed(&robot, a.body, b.body));
                let back = tables[index(n.id)].1.neighbours[n.port as usize].unwrap();
                assert_eq!((back.id, back.port as usize), (*id, port));
            }
        }
        // Most cells are wired, and patches meet across joints: the shoulder's
        // patch touches the upper arm's (as it does for most seeds).
        let lonely = tables.iter().filter(|(_, r)| r.neighbours.iter().all(Option::is_none)).count();
        assert!(wires / 2 >= 60 && lonely <= 2, "{wires} port ends, {lonely} cells without a neighbour");
        for side in ["RARM", "LARM"] {
            let body = |l: &str| robot.link(&format!("{side}_{l}")).unwrap().body;
            let across = tables.iter().any(|(id, r)| {
                cells[index(*id)].body == body("LINK0")
                    && r.neighbours.iter().flatten().any(|n| cells[index(n.id)].body == body("LINK1"))
            });
            assert!(across, "{side}: no wire from LINK0 to LINK1");
        }
    }

    #[test]
    fn a_skin_laid_at_random_has_no_wires_and_patches_are_deterministic() {
        let (robot, a) = hrp2_patches(5);
        let (_, b) = hrp2_patches(5);
        assert_eq!(a.cells(), b.cells());
        assert_eq!(a.neighbour_tables(), b.neighbour_tables());
        assert!(Skin::per_link(&robot, 2, 5).unwrap().neighbour_tables().is_empty());
    }
}
