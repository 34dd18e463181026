//! The MuJoCo library links and loads at run time with nothing set by hand
//! (the rpath the build script adds), and its accelerometer reads gravity
//! the way the skin's world expects: +9.81 m/s^2 along a resting site's up.

use mujoco_rs::prelude::*;

/// A box on a hinge about the vertical (gravity holds it still), one site
/// tilted a quarter turn about x so that the world's up is the site's +y:
/// the reading must follow the site's frame. A second box has no joint.
const MODEL: &str = r#"
<mujoco>
  <worldbody>
    <body name="arm" pos="0 0 0.5">
      <joint type="hinge" axis="0 0 1"/>
      <geom type="box" size="0.1 0.1 0.1"/>
      <site name="flat" pos="0 0 0.1"/>
      <site name="tilted" pos="0.1 0 0" euler="90 0 0"/>
    </body>
    <body name="static" pos="0 0 1.5">
      <geom type="box" size="0.1 0.1 0.1"/>
      <site name="fixed" pos="0 0 0.1"/>
    </body>
  </worldbody>
  <sensor>
    <accelerometer name="flat_acc" site="flat"/>
    <accelerometer name="tilted_acc" site="tilted"/>
    <accelerometer name="static_acc" site="fixed"/>
  </sensor>
</mujoco>
"#;

fn reading(model: &MjModel, data: &MjData<&MjModel>, name: &str) -> [f64; 3] {
    let id = model.name_to_id(MjtObjBase::mjOBJ_SENSOR, name).expect("the test's model names the sensor");
    let adr = model.sensor_adr()[id] as usize;
    let values = &data.sensordata()[adr..adr + 3];
    [values[0], values[1], values[2]]
}

#[test]
fn an_accelerometer_at_rest_reads_gravity_along_its_sites_up() {
    let path = std::env::temp_dir().join(format!("skin-mujoco-smoke-{}.xml", std::process::id()));
    std::fs::write(&path, MODEL).expect("the temporary folder is writable");
    let model = MjModel::from_xml(&path).expect("MuJoCo compiles the test's model");
    let _ = std::fs::remove_file(&path);
    let mut data = model.make_data();
    for _ in 0..10 {
        data.step();
    }
    let g = 9.81;
    let flat = reading(&model, &data, "flat_acc");
    let tilted = reading(&model, &data, "tilted_acc");
    for (axis, (got, want)) in flat.iter().zip([0.0, 0.0, g]).enumerate() {
        assert!((got - want).abs() < 1e-6, "flat site axis {axis}: {got} m/s^2, want {want}");
    }
    for (axis, (got, want)) in tilted.iter().zip([0.0, g, 0.0]).enumerate() {
        assert!((got - want).abs() < 1e-6, "tilted site axis {axis}: {got} m/s^2, want {want}");
    }
    // MuJoCo skips the sensors of a body welded to the world (no degree of
    // freedom between them): it reads zero. The skin's world reads its
    // cells' velocities instead (see the engine), which has no such gap.
    assert_eq!(reading(&model, &data, "static_acc"), [0.0; 3], "a static body's accelerometer");
}
