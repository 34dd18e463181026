//! The world's physics against equations (1)-(3) with an ideal sensor, and
//! the robot's velocity control and position feedback.

use skin_model::robot::Robot;
use skin_model::skin::Skin;
use skin_protocol::{Address, Sample};
use skin_sim::accel::{Bma250Config, G0};
use skin_sim::world::{BaseConfig, World, WorldConfig, WorldError};

/// A turntable: a continuous vertical joint carrying a disc, and a tilting
/// revolute joint with a tight range on top of it.
const TURNTABLE: &str = r#"<robot name="turntable">
  <link name="base"><collision><geometry><box size="0.4 0.4 0.1"/></geometry></collision></link>
  <joint name="spin" type="continuous"><parent link="base"/><child link="disc"/><origin xyz="0 0 0.1"/><axis xyz="0 0 1"/></joint>
  <link name="disc"><collision><geometry><cylinder radius="0.6" length="0.02"/></geometry></collision></link>
  <joint name="tilt" type="revolute"><parent link="disc"/><child link="flap"/><axis xyz="1 0 0"/>
    <limit lower="-0.2" upper="0.3" velocity="1.5"/></joint>
  <link name="flap"><collision><geometry><box size="0.1 0.1 0.01"/></geometry></collision></link>
</robot>"#;

/// One cell flat on the base, one on the disc 0.5 m from the axis.
const CELLS: &str = r#"
[[link]]
name = "base"
cell = [{ xyz = [0.1, 0.0, 0.05], id = 1 }]
[[link]]
name = "disc"
cell = [{ xyz = [0.5, 0.0, 0.01], id = 2 }]
"#;

fn turntable(base: BaseConfig) -> World {
    let robot = Robot::from_urdf_str(TURNTABLE).unwrap();
    let skin = Skin::from_toml_str(&robot, CELLS).unwrap();
    World::new(robot, skin, WorldConfig { base, accel: Bma250Config::ideal(), ..WorldConfig::default() })
}

/// Runs `ticks` ticks with the velocity command `omega(t)` and returns the last samples.
fn run(world: &mut World, ticks: usize, omega: impl Fn(f64) -> [f64; 2]) -> Vec<(Address, Sample)> {
    let mut out = Vec::new();
    for _ in 0..ticks {
        world.command(&omega(world.time_s())).unwrap();
        out.clear();
        world.step(&mut out);
    }
    out
}

fn counts(mps2: f64) -> i16 {
    (mps2 / G0 * 256.0).round() as i16
}

#[test]
fn at_rest_a_cell_reads_gravity_in_its_own_frame() {
    let mut upright = turntable(BaseConfig::rigid());
    let s = run(&mut upright, 10, |_| [0.0; 2]);
    assert_eq!(s.iter().map(|(a, _)| a.0).collect::<Vec<_>>(), [1, 2]);
    assert!(s.iter().all(|(_, s)| s.accel() == [0, 0, 256]), "{s:?}");
    // Lying on its back (pitched -90 degrees), the front (x) faces the sky.
    let mut lying = turntable(BaseConfig::lying());
    let s = run(&mut lying, 10, |_| [0.0; 2]);
    assert!(s.iter().all(|(_, s)| s.accel() == [256, 0, 0]), "{s:?}");
}

#[test]
fn spinning_adds_the_centripetal_term_of_equation_2() {
    let mut w = turntable(BaseConfig::rigid());
    let omega = 2.0;
    let s = run(&mut w, 250, |_| [omega, 0.0]);
    // The disc cell is pulled towards the axis (its -x): -omega^2 r.
    let disc = s[1].1.accel();
    assert!((disc[0] - counts(-omega * omega * 0.5)).abs() <= 1, "{disc:?}");
    assert!(disc[1].abs() <= 1 && disc[2] == 256, "{disc:?}");
    // The base cell does not move.
    assert_eq!(s[0].1.accel(), [0, 0, 256]);
}

#[test]
fn spinning_up_adds_the_tangential_term_of_equation_1() {
    let mut w = turntable(BaseConfig::rigid());
    let alpha = 4.0;
    let s = run(&mut w, 50, |t| [alpha * t, 0.0]);
    // After 0.2 s: tangential alpha r along +y, centripetal still small.
    let disc = s[1].1.accel();
    assert!((disc[1] - counts(alpha * 0.5)).abs() <= 2, "{disc:?}");
    let omega = alpha * 0.2;
    assert!((disc[0] - counts(-omega * omega * 0.5)).abs() <= 2, "{disc:?}");
}

#[test]
fn velocity_control_follows_commands_within_limits_with_position_feedback() {
    let mut w = turntable(BaseConfig::rigid());
    run(&mut w, 250, |_| [0.5, 0.1]);
    let q = w.positions();
    // 1 s at 0.5 rad/s, minus the servo's 10 ms lag.
    assert!((q[0] - 0.495).abs() < 2e-3, "{q:?}");
    assert!((q[1] - 0.099).abs() < 2e-3, "{q:?}");
    // The tilt stops at its upper limit (0.3) and clips to its velocity limit.
    run(&mut w, 250, |_| [0.0, 5.0]);
    assert_eq!(w.positions()[1], 0.3);
    run(&mut w, 25, |_| [0.0, -5.0]);
    assert!((w.positions()[1] - (0.3 - 1.5 * 0.1)).abs() < 0.02, "{:?}", w.positions());
    assert_eq!(w.command(&[0.0]), Err(WorldError::WrongLength { expected: 2, got: 1 }));
    assert_eq!(w.command(&[0.0, f64::NAN]), Err(WorldError::NotFinite(1)));
    assert!((w.time_s() - 525.0 * 0.004).abs() < 1e-9);
}

#[test]
fn a_world_is_reproducible_from_its_seed() {
    let samples = |seed| {
        let mut w = World::hrp2(seed);
        let mut out = Vec::new();
        for _ in 0..20 {
            w.step(&mut out);
        }
        out
    };
    assert_eq!(samples(3), samples(3));
    assert_ne!(samples(3), samples(4));
    let s = samples(3);
    assert_eq!(s.len(), 20 * 74);
    // Every cell sends every tick, with a running sequence number.
    assert_eq!(s[74].1.seq(), s[0].1.seq().wrapping_add(1));
}

/// A lift: a vertical prismatic joint carrying a shelf.
const LIFT: &str = r#"<robot name="lift">
  <link name="base"><collision><geometry><box size="0.4 0.4 0.1"/></geometry></collision></link>
  <joint name="lift" type="prismatic"><parent link="base"/><child link="shelf"/><origin xyz="0 0 0.1"/><axis xyz="0 0 1"/>
    <limit lower="0" upper="0.5" velocity="0.2"/></joint>
  <link name="shelf"><collision><geometry><box size="0.3 0.3 0.02"/></geometry></collision></link>
</robot>"#;

#[test]
fn a_prismatic_dof_moves_in_metres_and_its_acceleration_is_felt_along_its_axis() {
    let robot = Robot::from_urdf_str(LIFT).unwrap();
    let toml = "[[link]]\nname = \"shelf\"\ncell = [{ xyz = [0.1, 0.0, 0.01], id = 1 }]";
    let skin = Skin::from_toml_str(&robot, toml).unwrap();
    let cfg = WorldConfig { base: BaseConfig::rigid(), accel: Bma250Config::ideal(), ..WorldConfig::default() };
    let mut w = World::new(robot, skin, cfg);
    // Speeding up at 0.5 m/s^2 for 0.2 s (to 0.1 m/s): the cell feels it on top of gravity.
    let mut out = Vec::new();
    for _ in 0..50 {
        w.command(&[0.5 * (w.time_s() + 0.004)]).unwrap();
        out.clear();
        w.step(&mut out);
    }
    let z = out[0].1.accel()[2];
    assert!((z - counts(G0 + 0.5)).abs() <= 2, "{z}");
    // Position feedback in metres; the velocity limit (0.2 m/s) and the range (0.5 m) hold.
    run_lift(&mut w, 1000, 5.0);
    assert_eq!(w.positions()[0], 0.5);
    let before = w.positions()[0];
    run_lift(&mut w, 25, -5.0);
    assert!((before - w.positions()[0] - 0.2 * 0.1).abs() < 0.005, "{:?}", w.positions());
}

fn run_lift(w: &mut World, ticks: usize, v: f64) {
    let mut out = Vec::new();
    for _ in 0..ticks {
        w.command(&[v]).unwrap();
        w.step(&mut out);
    }
}
