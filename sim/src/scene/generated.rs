//! Objects and placements nobody tuned the grasp for: a seeded generator
//! of object files (shapes, sizes, masses, stiffnesses and frictions the
//! object files allow, of a size the arms reach around) and of placements
//! anywhere both arms reach, turned up to [`JITTER_YAW_RAD`] either way.
//!
//! Where both arms reach is the experimenters' geometry, not a guess: the
//! object put there stands clear of the robot in its home and open poses
//! (the arms swing open without bumping it), and closing the arms to the
//! closed pose drives each arm's contact area into it (each arm meets it
//! where the skin can feel it). Every placement drawn is checked so.

use nalgebra::{Isometry3, Point3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use skin_model::robot::Robot;

use super::experiment::{body_poses, intended_pose, object_pose, surface_points, Setup};
use super::held::Arm;
use super::object::Object;
use super::object_file::parse;
use super::placement::{Placement, JITTER_YAW_RAD, OBJECT_GAP_M};

/// How far forward of the default spot a placement is drawn, m.
pub const FORWARD_M: f64 = 0.20;
/// How far sideways of the default spot a placement is drawn, either way, m.
pub const SIDEWAYS_M: f64 = 0.20;
/// Radius of a generated cylinder's rims, m: rolled, as a can's or a
/// bucket's.
const CYLINDER_RIM_M: f64 = 0.005;
/// Draws tried per placement before saying no placement reaches the object.
const TRIES: usize = 2000;
/// Clearance of the object from the robot's surface in the home and open
/// poses beyond the skin's thickness, m: the arms open without touching it.
const CLEAR_M: f64 = 0.01;

/// One object file's text (`name`, a random shape of a size the arms reach
/// around, a mass they can pull, stiffness from sponge to packed box,
/// friction of cardboard to rubber), drawn from `rng`; no placement.
pub fn object_file(name: &str, rng: &mut impl Rng) -> String {
    let mut r = |lo: f64, hi: f64| rng.random_range(lo..=hi);
    let shape = match (r(0.0, 4.0)) as u32 {
        0 => format!(
            "{{ box = {{ half = [{:.3}, {:.3}, {:.3}], round_m = {:.3} }} }}",
            r(0.05, 0.10),
            r(0.10, 0.18),
            r(0.10, 0.17),
            r(0.005, 0.02)
        ),
        1 => format!(
            "{{ cylinder = {{ radius = {:.3}, half_height = {:.3}, round_m = {CYLINDER_RIM_M} }} }}",
            r(0.10, 0.14),
            r(0.10, 0.17)
        ),
        2 => format!("{{ sphere = {{ radius = {:.3} }} }}", r(0.10, 0.14)),
        _ => format!(
            "{{ blob = {{ semi = [{:.3}, {:.3}, {:.3}], bump_m = {:.3}, bump_rad_per_m = {:.1} }} }}",
            r(0.08, 0.12),
            r(0.11, 0.16),
            r(0.10, 0.14),
            r(0.0, 0.012),
            r(20.0, 30.0)
        ),
    };
    let stiffness = 10f64.powf(r(350f64.log10(), 20_000f64.log10()));
    format!(
        "name = \"{name}\"\nshape = {shape}\nmass_kg = {:.2}\nstiffness_n_per_m = {stiffness:.0}\nreflectance = {:.2}\nfriction = {:.2}\n",
        r(0.1, 0.8),
        r(0.5, 0.9),
        r(0.2, 0.5)
    )
}

/// No placement drawn lets both arms reach around this object.
#[derive(Debug, thiserror::Error)]
#[error("{0}: none of {TRIES} placements drawn lets both arms reach around it")]
pub struct Unreachable(pub String);

/// `count` object files drawn from `seed`, as (name, text): named
/// `gen{seed}_{k}`, each followed by a placement anywhere both arms of
/// `reach` reach around it, or by none (`skin grasp --jitter` places
/// them). The same seed and reach give the same files.
pub fn object_files(seed: u64, count: usize, reach: Option<&Reach>) -> Result<Vec<(String, String)>, Unreachable> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let width = count.saturating_sub(1).to_string().len().max(2);
    (0..count)
        .map(|k| {
            let name = format!("gen{seed}_{k:0width$}");
            let text = object_file(&name, &mut rng);
            let Some(reach) = reach else { return Ok((name, text)) };
            let object = parse(&text).expect("the generator writes valid object files").object;
            match reach.placement(&object, &mut rng) {
                Some(p) => Ok((name, text + &placement_keys(&p))),
                None => Err(Unreachable(name)),
            }
        })
        .collect()
}

/// The placement as object-file keys, to append to [`object_file`]'s text.
pub fn placement_keys(p: &Placement) -> String {
    let o = p.offset_m;
    format!("offset_m = [{:.4}, {:.4}, {:.4}]\nyaw_rad = {:.4}\n", o.x, o.y, o.z, p.yaw_rad)
}

/// One link's surface as the experimenters picture it.
struct LinkSurface {
    body: usize,
    /// The link's frame in its body's.
    in_body: Isometry3<f64>,
    /// Points on its surface, link frame.
    points: Vec<Point3<f64>>,
    /// The arm whose contact area it carries, if any.
    arm: Option<Arm>,
}

/// The experiment's robot surface: every link's surface points, and which
/// carry an arm's contact area.
pub struct Reach {
    robot: Robot,
    links: Vec<LinkSurface>,
    skin_offset_m: f64,
}

impl Reach {
    /// The reach of `robot` wearing `setup`'s skin, `skin_offset_m` thick.
    /// An arm reaches around an object where its contact area on the links
    /// the person guides it by (upper arm and forearm) meets it: an object
    /// only the hands meet is at the arms' fingertips, not in a hug.
    pub fn new(robot: &Robot, setup: &Setup, skin_offset_m: f64) -> Reach {
        let guided = |u: &usize| setup.guided_cells.iter().any(|arm| arm.contains(u));
        let contact_links: Vec<&str> = setup
            .areas
            .iter()
            .filter(|a| a.kind == "contact")
            .flat_map(|a| a.cells.iter().filter(|u| guided(u)).map(|&u| setup.skin.cells()[u].link.as_str()))
            .collect();
        let links = robot
            .links()
            .iter()
            .map(|l| {
                let arm = Arm::of_link(&l.name).filter(|_| contact_links.contains(&l.name.as_str()));
                LinkSurface { body: l.body, in_body: l.in_body, points: surface_points(&l.surface), arm }
            })
            .collect();
        Reach { robot: robot.clone(), links, skin_offset_m }
    }

    /// Whether both arms reach around `object` put at `placement`: clear
    /// of the robot at home and in the open pose, met by each arm's contact
    /// area in the closed pose.
    pub fn reaches(&self, object: &Object, placement: &Placement) -> bool {
        let pose = object_pose(object, placement, self.skin_offset_m);
        let depths = |name: &str| -> Vec<(Option<Arm>, f64)> {
            let q = intended_pose(&self.robot, name).expect("the experiment's key poses");
            let bodies = body_poses(&self.robot, &q);
            self.links
                .iter()
                .flat_map(|l| {
                    let to_object = pose.inverse() * bodies[l.body] * l.in_body;
                    l.points.iter().map(move |p| (l.arm, object.shape.distance(&(to_object * p))))
                })
                .collect()
        };
        let clear = |name: &str| depths(name).iter().all(|(_, d)| *d > self.skin_offset_m + CLEAR_M);
        let closed = depths("closed");
        let met = |arm: Arm| closed.iter().any(|(a, d)| *a == Some(arm) && *d < 0.0);
        clear("home") && clear("open") && met(Arm::Right) && met(Arm::Left)
    }

    /// A placement drawn uniformly from up to [`FORWARD_M`] forward,
    /// [`SIDEWAYS_M`] either way and [`JITTER_YAW_RAD`] of turn, redrawn
    /// until both arms reach `object` there; none when no draw of many does.
    pub fn placement(&self, object: &Object, rng: &mut impl Rng) -> Option<Placement> {
        (0..TRIES)
            .map(|_| Placement {
                offset_m: Vector3::new(
                    rng.random_range(-OBJECT_GAP_M..=FORWARD_M),
                    rng.random_range(-SIDEWAYS_M..=SIDEWAYS_M),
                    0.0,
                ),
                yaw_rad: rng.random_range(-JITTER_YAW_RAD..=JITTER_YAW_RAD),
            })
            .find(|p| self.reaches(object, p))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::SkinModel;
    use skin_model::robot::hrp2;

    #[test]
    fn generated_files_parse_and_placements_reach_around_them() {
        let robot = hrp2::robot();
        let setup = Setup::new(&robot, 0).unwrap();
        let reach = Reach::new(&robot, &setup, SkinModel::default().surface_offset_m);
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut sideways = Vec::new();
        for k in 0..12 {
            let text = object_file(&format!("gen_{k}"), &mut rng);
            let object = parse(&text).unwrap().object;
            let p = reach.placement(&object, &mut rng).expect("a placement both arms reach");
            assert!(reach.reaches(&object, &p));
            let placed = parse(&(text + &placement_keys(&p))).unwrap();
            assert!((placed.placement.offset_m - p.offset_m).norm() < 1e-4, "{:?} {p:?}", placed.placement);
            sideways.push(p.offset_m.y);
        }
        // Past the few centimetres of the jitter: the arms reach further.
        assert!(sideways.iter().any(|y| y.abs() > 0.03), "{sideways:?}");
        let bin = Object::by_name("trash_bin").unwrap();
        assert!(reach.reaches(&bin, &Placement::default()), "the default spot is reached");
        let far = Placement { offset_m: Vector3::new(0.6, 0.0, 0.0), yaw_rad: 0.0 };
        assert!(!reach.reaches(&bin, &far), "beyond the hands");
        let aside = Placement { offset_m: Vector3::new(0.0, 0.4, 0.0), yaw_rad: 0.0 };
        assert!(!reach.reaches(&bin, &aside), "in the left arm's way");
    }

    #[test]
    fn a_seed_gives_the_same_named_files_placed_or_not() {
        let robot = hrp2::robot();
        let reach = Reach::new(&robot, &Setup::new(&robot, 0).unwrap(), SkinModel::default().surface_offset_m);
        let placed = object_files(3, 4, Some(&reach)).unwrap();
        let names: Vec<&str> = placed.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["gen3_00", "gen3_01", "gen3_02", "gen3_03"]);
        assert_eq!(object_files(3, 4, Some(&reach)).unwrap(), placed, "seeded");
        for (name, text) in &placed {
            let at = parse(text).unwrap();
            assert_eq!(&at.object.name, name);
            assert!(reach.reaches(&at.object, &at.placement), "{name} at {:?}", at.placement);
        }
        let unplaced = object_files(3, 101, None).unwrap();
        assert_eq!(unplaced[100].0, "gen3_100");
        assert!(unplaced.iter().all(|(_, text)| !text.contains("offset_m") && parse(text).is_ok()));
        // The first object is drawn before any placement.
        assert!(placed[0].1.starts_with(&object_files(3, 1, None).unwrap()[0].1));
    }

    #[test]
    fn an_object_only_the_hands_meet_is_not_reached() {
        let robot = hrp2::robot();
        let setup = Setup::new(&robot, 0).unwrap();
        let offset = SkinModel::default().surface_offset_m;
        let reach = Reach::new(&robot, &setup, offset);
        // 12 cm: the arms' height is 5-7 cm below its middle, where a
        // smaller ball is narrower than the closed pose's forearms.
        let ball = parse(
            "name = \"ball\"\nshape = { sphere = { radius = 0.12 } }\nmass_kg = 0.3\n\
             stiffness_n_per_m = 3000\nreflectance = 0.7\nfriction = 0.4\n",
        )
        .unwrap()
        .object;
        let closed = body_poses(&robot, &intended_pose(&robot, "closed").unwrap());
        // Whether both hands are inside the ball at `placement` in the closed pose.
        let hands_meet = |placement: &Placement| {
            let pose = object_pose(&ball, placement, offset);
            ["RARM_LINK5", "LARM_LINK5"].iter().all(|name| {
                let link = robot.link(name).unwrap();
                let to_ball = pose.inverse() * closed[link.body] * link.in_body;
                surface_points(&link.surface).iter().any(|p| ball.shape.distance(&(to_ball * p)) < 0.0)
            })
        };
        let at = |x: f64| Placement { offset_m: Vector3::new(x, 0.0, 0.0), yaw_rad: 0.0 };
        assert!(reach.reaches(&ball, &at(0.0)), "the default spot: the forearms meet it");
        let fingertips: Vec<f64> = (0..40)
            .map(|k| f64::from(k) * 0.01)
            .filter(|&x| hands_meet(&at(x)) && !reach.reaches(&ball, &at(x)))
            .collect();
        assert!(!fingertips.is_empty(), "some spot forward is met by the hands alone, and not reached");
    }
}
