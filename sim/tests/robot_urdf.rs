//! Loading robots from URDF: what becomes a DoF, what is welded, locked or
//! followed, and a clear error naming the element for everything else.

use skin_sim::robot::{Drive, Robot, Surface, UrdfError};

/// A small arm exercising every joint kind the loader accepts.
const ARM: &str = r#"<robot name="arm">
  <link name="world"/>
  <joint name="mount" type="fixed"><parent link="world"/><child link="base"/><origin xyz="0 0 0.1"/></joint>
  <link name="base"><collision><geometry><cylinder radius="0.07" length="0.1"/></geometry></collision></link>
  <joint name="pan" type="continuous"><parent link="base"/><child link="upper"/><axis xyz="0 0 2"/></joint>
  <link name="upper"><inertial><origin xyz="0 0 0.2"/><mass value="2"/>
    <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  <joint name="elbow" type="revolute"><parent link="upper"/><child link="fore"/>
    <origin xyz="0 0 0.4" rpy="0 1.5708 0"/><axis xyz="0 1 0"/><limit lower="-2" upper="0.5" velocity="2"/></joint>
  <link name="fore"><visual><geometry><mesh filename="fore.stl"/></geometry></visual></link>
  <joint name="slide" type="prismatic"><parent link="fore"/><child link="carriage"/><axis xyz="1 0 0"/>
    <limit lower="0" upper="0.1" velocity="1"/></joint>
  <link name="carriage"><collision><geometry><box size="0.05 0.05 0.05"/></geometry></collision></link>
  <joint name="finger_a" type="revolute"><parent link="carriage"/><child link="a"/><origin xyz="0.05 0 0"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" velocity="1"/></joint>
  <link name="a"><collision><geometry><sphere radius="0.01"/></geometry></collision></link>
  <joint name="finger_b" type="revolute"><parent link="carriage"/><child link="b"/><origin xyz="-0.05 0 0"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" velocity="1"/><mimic joint="finger_a" multiplier="-1" offset="0.1"/></joint>
  <link name="b"><collision><geometry><sphere radius="0.01"/></geometry></collision></link>
  <link name="marker"/>
  <joint name="tip" type="fixed"><parent link="a"/><child link="marker"/><origin xyz="0.02 0 0"/></joint>
</robot>"#;

#[test]
fn revolute_and_continuous_joints_are_dofs_the_rest_is_welded_locked_or_followed() {
    let r = Robot::from_urdf_str(ARM).unwrap();
    let names: Vec<&str> = r.dofs().iter().map(|d| d.name.as_str()).collect();
    assert_eq!(names, ["pan", "elbow", "finger_a"]);
    assert_eq!((r.dofs()[0].lower, r.dofs()[0].upper), (f64::NEG_INFINITY, f64::INFINITY));
    assert_eq!((r.dofs()[1].lower, r.dofs()[1].upper, r.dofs()[1].max_velocity), (-2.0, 0.5, 2.0));
    // world+base, upper, fore+carriage (prismatic locked), a+marker, b.
    assert_eq!(r.bodies().len(), 5);
    let body = |l: &str| r.link(l).unwrap().body;
    assert_eq!(body("world"), body("base"));
    assert_eq!(body("fore"), body("carriage"));
    assert_eq!(body("a"), body("marker"));
    assert!((r.link("marker").unwrap().in_body.translation.vector.x - 0.02).abs() < 1e-12);
    // The axis is normalized.
    assert!((r.joints()[0].axis.z - 1.0).abs() < 1e-12);
    // The mimic follows its master.
    let b = r.joints().iter().position(|j| j.name == "finger_b").unwrap();
    assert_eq!(r.joints()[b].drive, Drive::Mimic { dof: 2, multiplier: -1.0, offset: 0.1 });
    assert_eq!(r.joint_angles(&[0.0, 0.0, 0.3])[b], -0.3 + 0.1);
    assert!(r.moved_by(2)[body("b")] && r.moved_by(2)[body("a")] && !r.moved_by(2)[body("fore")]);
    assert!(r.moved_by(0).iter().skip(1).all(|m| *m));
}

#[test]
fn skin_goes_on_shapes_or_bones_but_not_on_massless_frames() {
    let r = Robot::from_urdf_str(ARM).unwrap();
    assert_eq!(r.link("world").unwrap().surface, Surface::None);
    assert_eq!(r.link("marker").unwrap().surface, Surface::None);
    assert!(matches!(r.link("base").unwrap().surface, Surface::Shapes(_)));
    // Mass only: a bone to the centre of mass and one to the child joint.
    match &r.link("upper").unwrap().surface {
        Surface::Bones { points, radius } => {
            assert_eq!(points.len(), 2);
            assert!(*radius >= 0.03 && *radius <= 0.1);
        }
        other => panic!("{other:?}"),
    }
    // A mesh only: bones too.
    assert!(matches!(r.link("fore").unwrap().surface, Surface::Bones { .. }));
}

#[test]
fn the_home_pose_is_zero_clamped_into_the_limits() {
    let xml = ARM.replace(r#"lower="-2" upper="0.5""#, r#"lower="0.2" upper="0.5""#);
    let mut r = Robot::from_urdf_str(&xml).unwrap();
    assert_eq!(r.home(), &[0.0, 0.2, 0.0]);
    r.set_home(&[1.0, 9.0, -9.0]).unwrap();
    assert_eq!(r.home(), &[1.0, 0.5, -1.0]);
    assert!(matches!(r.set_home(&[0.0]), Err(UrdfError::PoseLength { expected: 3, got: 1 })));
}

fn error(xml: &str) -> String {
    Robot::from_urdf_str(xml).unwrap_err().to_string()
}

#[test]
fn broken_files_get_an_error_naming_the_element() {
    let two =
        |joint: &str| format!(r#"<robot name="r"><link name="a"/><link name="b"/><link name="c"/>{joint}</robot>"#);
    let hinge = |name: &str, parent: &str, child: &str, extra: &str| {
        format!(
            r#"<joint name="{name}" type="revolute"><parent link="{parent}"/><child link="{child}"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" velocity="1"/>{extra}</joint>"#
        )
    };
    let ab = hinge("j1", "a", "b", "");
    let bc = hinge("j2", "b", "c", "");

    assert!(error("<robot").contains("not a valid URDF"));
    assert!(error(&two(&format!("{ab}{}", hinge("j2", "b", "x", "")))).contains(r#"joint "j2" refers to link "x""#));
    let loop_ = format!("{ab}{bc}{}", hinge("j3", "a", "c", ""));
    assert!(error(&two(&loop_)).contains(r#"link "c" is the child of both joint "j2" and joint "j3""#));
    assert!(error(&two(&ab)).contains(r#"["a", "c"]"#), "{}", error(&two(&ab)));
    let floating = format!(r#"{ab}<joint name="free" type="floating"><parent link="b"/><child link="c"/></joint>"#);
    assert!(error(&two(&floating)).contains(r#"joint "free" is floating"#));
    assert!(error(&two(&format!("{ab}{}", bc.replace("0 0 1", "0 0 0")))).contains(r#"joint "j2" has a zero-length"#));
    let reversed = bc.replace(r#"lower="-1" upper="1""#, r#"lower="1" upper="-1""#);
    assert!(error(&two(&format!("{ab}{reversed}"))).contains(r#"revolute joint "j2" has limits lower = 1"#));
    let no_limit = bc.replace(r#"<limit lower="-1" upper="1" velocity="1"/>"#, "");
    assert!(error(&two(&format!("{ab}{no_limit}"))).contains(r#"revolute joint "j2""#));
    assert!(error(&two(&format!("{ab}{}", bc.replace("0 0 1", "0 nan 1")))).contains(r#"joint "j2" contains a number"#));
    let bad_mimic = hinge("j2", "b", "c", r#"<mimic joint="nowhere"/>"#);
    assert!(error(&two(&format!("{ab}{bad_mimic}"))).contains(r#"joint "j2" mimics "nowhere""#));
    let circle = format!(
        "{}{}",
        hinge("j1", "a", "b", r#"<mimic joint="j2"/>"#),
        hinge("j2", "b", "c", r#"<mimic joint="j1"/>"#)
    );
    assert!(error(&two(&circle)).contains("mimics"));
    let welded = r#"<joint name="f" type="fixed"><parent link="a"/><child link="b"/></joint><joint name="g" type="fixed"><parent link="b"/><child link="c"/></joint>"#;
    assert!(error(&two(welded)).contains("no revolute or continuous joint"));
    assert!(
        error(r#"<robot name="r"><link name="a"/><link name="a"/></robot>"#).contains(r#"link "a" is defined twice"#)
    );
    let missing = Robot::from_urdf_file(std::path::Path::new("/nonexistent/robot.urdf")).unwrap_err();
    assert!(missing.to_string().contains("/nonexistent/robot.urdf"));
}

/// The reference robots of `../shared/robots`, when present.
fn shared_robot(name: &str) -> Option<Robot> {
    let dir = std::env::var("SKIN_ROBOTS_DIR")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|_| std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/robots"));
    let path = dir.join(format!("{name}.urdf"));
    if !path.exists() {
        println!("skipped: {} not found (set SKIN_ROBOTS_DIR)", path.display());
        return None;
    }
    Some(Robot::from_urdf_file(&path).unwrap())
}

#[test]
fn the_reference_robots_load_with_their_revolute_dofs() {
    for (name, dofs) in [("ur5", 6), ("panda", 7), ("simple_humanoid", 29)] {
        if let Some(r) = shared_robot(name) {
            assert_eq!(r.dofs().len(), dofs, "{name}");
        }
    }
}
