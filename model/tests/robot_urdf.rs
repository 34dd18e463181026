//! Loading robots from URDF: what becomes a DoF, what is welded or
//! followed, and a clear error naming the element for everything else.

use skin_model::robot::{DofKind, Drive, Robot, Surface, UrdfError};

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
fn revolute_continuous_and_prismatic_joints_are_dofs_the_rest_is_welded_or_followed() {
    let r = Robot::from_urdf_str(ARM).unwrap();
    let names: Vec<&str> = r.dofs().iter().map(|d| d.name.as_str()).collect();
    assert_eq!(names, ["pan", "elbow", "slide", "finger_a"]);
    let kinds: Vec<DofKind> = r.dofs().iter().map(|d| d.kind).collect();
    assert_eq!(kinds, [DofKind::Revolute, DofKind::Revolute, DofKind::Prismatic, DofKind::Revolute]);
    assert_eq!((r.dofs()[0].lower, r.dofs()[0].upper), (f64::NEG_INFINITY, f64::INFINITY));
    assert_eq!((r.dofs()[1].lower, r.dofs()[1].upper, r.dofs()[1].max_velocity), (-2.0, 0.5, 2.0));
    assert_eq!((r.dofs()[2].lower, r.dofs()[2].upper, r.dofs()[2].max_velocity), (0.0, 0.1, 1.0));
    // world+base, upper, fore, carriage, a+marker, b.
    assert_eq!(r.bodies().len(), 6);
    let body = |l: &str| r.link(l).unwrap().body;
    assert_eq!(body("world"), body("base"));
    assert_ne!(body("fore"), body("carriage"));
    assert_eq!(body("a"), body("marker"));
    assert!(r.moved_by(2)[body("carriage")] && !r.moved_by(2)[body("fore")]);
    assert!((r.link("marker").unwrap().in_body.translation.vector.x - 0.02).abs() < 1e-12);
    // The axis is normalized.
    assert!((r.joints()[0].axis.z - 1.0).abs() < 1e-12);
    // The mimic follows its master.
    let b = r.joints().iter().position(|j| j.name == "finger_b").unwrap();
    assert_eq!(r.joints()[b].drive, Drive::Mimic { dof: 3, multiplier: -1.0, offset: 0.1 });
    assert_eq!(r.joint_angles(&[0.0, 0.0, 0.0, 0.3])[b], -0.3 + 0.1);
    assert!(r.moved_by(3)[body("b")] && r.moved_by(3)[body("a")] && !r.moved_by(3)[body("carriage")]);
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
    assert_eq!(r.home(), &[0.0, 0.2, 0.0, 0.0]);
    r.set_home(&[1.0, 9.0, 0.5, -9.0]).unwrap();
    assert_eq!(r.home(), &[1.0, 0.5, 0.1, -1.0]);
    assert!(matches!(r.set_home(&[0.0]), Err(UrdfError::PoseLength { expected: 4, got: 1 })));
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
    assert!(error(&two(&format!("{ab}{}", bc.replace("0 0 1", "0 nan 1"))))
        .contains(r#"joint "j2" <axis> xyz contains a number that is not finite"#));
    let bad_mimic = hinge("j2", "b", "c", r#"<mimic joint="nowhere"/>"#);
    assert!(error(&two(&format!("{ab}{bad_mimic}"))).contains(r#"joint "j2" mimics "nowhere""#));
    let circle = format!(
        "{}{}",
        hinge("j1", "a", "b", r#"<mimic joint="j2"/>"#),
        hinge("j2", "b", "c", r#"<mimic joint="j1"/>"#)
    );
    assert!(error(&two(&circle)).contains("mimics"));
    let welded = r#"<joint name="f" type="fixed"><parent link="a"/><child link="b"/></joint><joint name="g" type="fixed"><parent link="b"/><child link="c"/></joint>"#;
    assert!(error(&two(welded)).contains("no revolute, continuous or prismatic joint"));
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
fn the_reference_robots_load_with_their_dofs() {
    // The panda's second finger mimics the first: one prismatic DoF.
    for (name, revolute, prismatic) in [("ur5", 6, 0), ("panda", 7, 1), ("simple_humanoid", 29, 0)] {
        if let Some(r) = shared_robot(name) {
            let count = |k| r.dofs().iter().filter(|d| d.kind == k).count();
            assert_eq!((count(DofKind::Revolute), count(DofKind::Prismatic)), (revolute, prismatic), "{name}");
        }
    }
}

/// Public descriptions kept as fixtures (see `fixtures/robots/README.md`):
/// they load, with their prismatic DoFs, and take skin.
#[test]
fn the_fixture_robots_load_with_their_dofs_and_take_skin() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/robots");
    for (file, revolute, prismatic) in [("ur5_robot", 6, 0), ("panda", 7, 1), ("baxter", 15, 2), ("pr2", 19, 1)] {
        let r = Robot::from_urdf_file(&dir.join(format!("{file}.urdf"))).unwrap();
        let count = |k| r.dofs().iter().filter(|d| d.kind == k).count();
        assert_eq!((count(DofKind::Revolute), count(DofKind::Prismatic)), (revolute, prismatic), "{file}");
        let skin = skin_model::skin::Skin::per_link(&r, 3, 1).unwrap();
        assert!(skin.cells().iter().all(|c| c.pose.translation.vector.iter().all(|v| v.is_finite())), "{file}");
    }
}

/// Loads every `*.urdf` of the folder `SKIN_URDF_DIR` (public descriptions
/// kept out of the repository), puts 3 cells on every link with a surface,
/// and prints a table: `SKIN_URDF_DIR=../robots-public cargo test -p
/// skin-model --test robot_urdf -- --ignored --nocapture`.
#[test]
#[ignore = "needs a folder of URDFs in SKIN_URDF_DIR"]
fn every_urdf_in_a_folder_loads() {
    let dir = std::env::var("SKIN_URDF_DIR").expect("set SKIN_URDF_DIR to a folder of URDF files");
    let mut paths: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "urdf"))
        .collect();
    paths.sort();
    println!(
        "{:<24} {:>4} {:>4} {:>6} {:>5} {:>6} {:>5} {:>5} {:>10} {:>6}",
        "file", "rev", "pri", "bodies", "links", "shapes", "bones", "none", "min_clr_mm", "<2mm"
    );
    let mut failed = Vec::new();
    for path in &paths {
        let name = path.file_name().unwrap().to_string_lossy();
        let r = match Robot::from_urdf_file(path) {
            Ok(r) => r,
            Err(e) => {
                println!("{name:<24} ERROR {e}");
                failed.push(name.to_string());
                continue;
            }
        };
        let count = |k| r.dofs().iter().filter(|d| d.kind == k).count();
        let surfaces = |f: fn(&Surface) -> bool| r.links().iter().filter(|l| f(&l.surface)).count();
        let skin = skin_model::skin::Skin::per_link(&r, 3, 1).unwrap();
        println!(
            "{name:<24} {:>4} {:>4} {:>6} {:>5} {:>6} {:>5} {:>5} {:>10.1} {:>6}",
            count(DofKind::Revolute),
            count(DofKind::Prismatic),
            r.bodies().len(),
            r.links().len(),
            surfaces(|s| matches!(s, Surface::Shapes(_))),
            surfaces(|s| matches!(s, Surface::Bones { .. })),
            surfaces(|s| *s == Surface::None),
            skin.min_axis_clearance_m() * 1e3,
            skin.cells().iter().filter(|c| c.axis_clearance_m < 2e-3).count(),
        );
    }
    assert!(failed.is_empty(), "{failed:?}");
}
