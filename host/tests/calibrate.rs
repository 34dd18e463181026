//! Skin self-calibration against the simulator's truth.

use skin_host::calibrate::check::check;
use skin_host::calibrate::{calibrate, CalibrateConfig};
use skin_host::explore::{explore, ExploreConfig};
use skin_host::robot::SimRobot;
use skin_sim::accel::Bma250Config;
use skin_sim::robot::hrp2;
use skin_sim::skin::Skin;
use skin_sim::world::{BaseConfig, World, WorldConfig};

#[test]
fn debug_ideal() {
    let robot = hrp2::robot();
    let skin = Skin::with_counts(&robot, &hrp2::SKIN, 0).unwrap();
    let world = World::new(robot.clone(), skin, WorldConfig { base: BaseConfig::rigid(), accel: Bma250Config { offset_max_mps2: 0.0, sensitivity_tolerance: 0.0, misalignment_max_rad: 0.0, ..Bma250Config::default() }, seed: 0, ..WorldConfig::default() });
    let mut rig = SimRobot::new(world);
    let found = explore(&mut rig, &ExploreConfig::default(), &mut |_| {}).unwrap();
    let c = calibrate(&mut rig, &robot, &found, &CalibrateConfig::default(), &mut |_| {}).unwrap();
    let t = check(&c, rig.world());
    panic!("{t:?}");
}
