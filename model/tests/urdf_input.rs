//! The URDF reader on real-world and hostile input: what the method does
//! not need is ignored, everything else is `Ok` or a one-line typed error,
//! never a panic, a stack overflow or a long wait.

use std::time::{Duration, Instant};

use proptest::prelude::*;
use skin_model::robot::limits::{MAX_DEPTH, MAX_DOFS, MAX_LINKS};
use skin_model::robot::{DofKind, Drive, Robot, Surface, UrdfError};
use skin_model::skin::Skin;

/// A gripper on a slide, written as exporters and xacro write them: every
/// element the method does not need, and meshes that are not there.
const CLUTTERED: &str = r#"<?xml version="1.0"?>
<!-- generated -->
<robot name="cluttered" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:property name="unused" value="1"/>
  <material name="grey"><color rgba="0.5 0.5 0.5 1"/><texture/></material>
  <link name="base" custom="ignored">
    <inertial><origin xyz="0 0 0.05"/><mass value="3"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial>
    <visual name="shell"><geometry><mesh filename="package://nowhere/meshes/base.dae" scale="0.001 0.001 0.001"/></geometry>
      <material name="grey"><texture/></material></visual>
    <collision><geometry><mesh filename="package://nowhere/meshes/base.stl"/></geometry></collision>
  </link>
  <link name="carriage">
    <visual><origin xyz="0 0 0.02"/><geometry><capsule radius="0.03" length="0.1"/></geometry></visual>
  </link>
  <link name="left"><visual><geometry><mesh filename="file:///missing/left.stl"/></geometry></visual></link>
  <link name="right"><visual><geometry><mesh filename="file:///missing/right.stl"/></geometry></visual></link>
  <joint name="lift" type="prismatic">
    <parent link="base"/><child link="carriage"/><origin xyz="0 0 0.1"/><axis xyz="0 0 1"/>
    <limit lower="0" upper="0.3" effort="100" velocity="0.1"/>
    <dynamics damping="1" friction="0.1"/>
    <safety_controller soft_lower_limit="0.01" soft_upper_limit="0.29" k_position="100" k_velocity="10"/>
    <calibration rising="0.0"/>
  </joint>
  <joint name="left_finger" type="prismatic">
    <parent link="carriage"/><child link="left"/><origin xyz="0 0.02 0.05"/><axis xyz="0 1 0"/>
    <limit lower="0" upper="0.04" velocity="0.05"/>
  </joint>
  <joint name="right_finger" type="prismatic">
    <parent link="carriage"/><child link="right"/><origin xyz="0 -0.02 0.05"/><axis xyz="0 -1 0"/>
    <limit lower="0" upper="0.04" velocity="0.05"/>
    <mimic joint="left_finger" multiplier="1" offset="0"/>
  </joint>
  <transmission name="lift_tr"><type>transmission_interface/SimpleTransmission</type>
    <joint name="lift"><hardwareInterface>EffortJointInterface</hardwareInterface></joint>
    <actuator name="lift_motor"><mechanicalReduction>1</mechanicalReduction></actuator></transmission>
  <gazebo reference="base"><material>Gazebo/Grey</material>
    <sensor name="imu" type="imu"><update_rate>100</update_rate></sensor></gazebo>
  <gazebo><plugin name="ros_control" filename="libgazebo_ros_control.so"/></gazebo>
  <ros2_control name="sys" type="system"><hardware><plugin>mock</plugin></hardware>
    <joint name="lift"><command_interface name="position"/></joint></ros2_control>
</robot>"#;

#[test]
fn what_the_method_does_not_need_is_ignored() {
    let r = Robot::from_urdf_str(CLUTTERED).unwrap();
    assert_eq!(r.name(), "cluttered");
    let dofs: Vec<(&str, DofKind)> = r.dofs().iter().map(|d| (d.name.as_str(), d.kind)).collect();
    assert_eq!(dofs, [("lift", DofKind::Prismatic), ("left_finger", DofKind::Prismatic)]);
    assert_eq!((r.dofs()[0].lower, r.dofs()[0].upper, r.dofs()[0].max_velocity), (0.0, 0.3, 0.1));
    // The right finger mimics the left, both sliding.
    let right = r.joints().iter().find(|j| j.name == "right_finger").unwrap();
    assert_eq!(right.kind, DofKind::Prismatic);
    assert_eq!(right.drive, Drive::Mimic { dof: 1, multiplier: 1.0, offset: 0.0 });
    let body = |l: &str| r.link(l).unwrap().body;
    assert!(r.moved_by(1)[body("right")] && r.moved_by(1)[body("left")] && !r.moved_by(1)[body("carriage")]);
    // Meshes are never read: mesh-only links get a stand-in surface, a
    // capsule becomes its straight part.
    assert!(matches!(r.link("base").unwrap().surface, Surface::Bones { .. }));
    assert!(matches!(r.link("left").unwrap().surface, Surface::Bones { .. }));
    assert!(matches!(r.link("carriage").unwrap().surface, Surface::Shapes(_)));
    let skin = Skin::per_link(&r, 5, 1).unwrap();
    assert_eq!(skin.cells().len(), 20);
    assert!(skin.cells().iter().all(|c| c.pose.translation.vector.iter().all(|v| v.is_finite())));
}

#[test]
fn defaults_are_the_specifications() {
    let r = Robot::from_urdf_str(
        r#"<robot name="d"><link name="a"/><link name="b"/>
        <joint name="j" type="revolute"><parent link="a"/><child link="b"/><limit lower="-1" upper="1"/></joint></robot>"#,
    )
    .unwrap();
    let j = &r.joints()[0];
    assert_eq!(j.axis.into_inner(), nalgebra::Vector3::x());
    assert_eq!(j.origin, nalgebra::Isometry3::identity());
    assert_eq!(r.dofs()[0].max_velocity, f64::INFINITY);
}

fn error(xml: &str) -> UrdfError {
    Robot::from_urdf_str(xml).unwrap_err()
}

/// A two-link robot whose joint carries `joint_extra` and whose child link holds `link_body`.
fn robot(joint_extra: &str, link_body: &str) -> String {
    format!(
        r#"<robot name="r"><link name="a"/><link name="b">{link_body}</link>
        <joint name="j" type="revolute"><parent link="a"/><child link="b"/>
        <limit lower="-1" upper="1" velocity="1"/>{joint_extra}</joint></robot>"#
    )
}

fn geometry(shape: &str) -> String {
    robot("", &format!("<collision><geometry>{shape}</geometry></collision>"))
}

#[test]
fn every_error_names_its_element_on_one_line() {
    let cases: Vec<(String, &str)> = vec![
        ("<robot name='r'><link name='a'></robot>".into(), "not a valid URDF document"),
        ("<model name='r'/>".into(), "the root element is <model>, not <robot>"),
        ("<robot><link name='a'/></robot>".into(), "<robot> has no name attribute"),
        ("<robot name='r'><link/></robot>".into(), "a <link> has no name attribute"),
        (robot("", "").replace(r#"<joint name="j""#, "<joint"), "a <joint> has no name attribute"),
        (robot("", "").replace(r#"type="revolute""#, ""), r#"joint "j" has no type attribute"#),
        (robot("", "").replace(r#"<parent link="a"/>"#, ""), r#"joint "j" has no <parent link="...">"#),
        (robot("", "").replace(r#"<child link="b"/>"#, "<child/>"), r#"joint "j" <child> has no link attribute"#),
        (robot(r#"<origin xyz="1 2"/>"#, ""), r#"joint "j" <origin> xyz: "1 2" is not 3 numbers"#),
        (robot(r#"<origin xyz="1 2 3 4"/>"#, ""), "is not 3 numbers"),
        (robot(r#"<origin rpy="0 ${pi} 0"/>"#, ""), r#"joint "j" <origin> rpy: "0 ${pi} 0" is not 3 numbers"#),
        (
            robot("", r#"<inertial><mass value="heavy"/></inertial>"#),
            r#"link "b" <mass> value: "heavy" is not a number"#,
        ),
        (robot("", r#"<inertial><mass/></inertial>"#), r#"link "b" <mass> has no value attribute"#),
        (geometry("<box/>"), r#"link "b" <collision> <box> has no size attribute"#),
        (robot(r#"<axis xyz="0 inf 0"/>"#, ""), r#"joint "j" <axis> xyz contains a number that is not finite"#),
        (robot(r#"<axis xyz="0 0 0"/>"#, ""), r#"joint "j" has a zero-length <axis>"#),
        (robot(r#"<mimic joint="nowhere"/>"#, ""), r#"joint "j" mimics "nowhere""#),
        (robot("", "").replace(r#"upper="1""#, r#"upper="-1""#), r#"revolute joint "j" has limits lower = -1"#),
        (robot("", "").replace("revolute", "floating"), r#"joint "j" is floating: only revolute"#),
        (robot("", "").replace("revolute", "planar"), r#"joint "j" is planar"#),
        (robot("", "").replace("revolute", "fixed"), "no revolute, continuous or prismatic joint"),
        (robot("", "").replace(r#"<link name="b">"#, r#"<link name="a">"#), r#"link "a" is defined twice"#),
        (robot("", "").replace(r#"<child link="b"/>"#, r#"<child link="c"/>"#), r#"refers to link "c""#),
        (robot("", "").replace(r#"<link name="a"/>"#, r#"<link name="a"/><link name="x"/>"#), r#"["a", "x"]"#),
    ];
    for (xml, expected) in cases {
        let message = error(&xml).to_string();
        assert!(message.contains(expected), "{message:?} should contain {expected:?}");
        assert!(!message.contains('\n'), "{message:?}");
    }
    let prismatic = robot("", "").replace("revolute", "prismatic").replace(r#"lower="-1""#, r#"lower="1""#);
    assert!(error(&prismatic).to_string().contains(r#"prismatic joint "j" has limits lower = 1, upper = 1"#));
    let dup_joint = robot("", "")
        .replace("</robot>", r#"<joint name="j" type="fixed"><parent link="a"/><child link="b"/></joint></robot>"#);
    assert!(matches!(error(&dup_joint), UrdfError::Duplicate { kind: "joint", .. }));
}

#[test]
fn huge_negative_or_absurd_numbers_are_refused_not_panicked_on() {
    let cases = [
        geometry(r#"<box size="1e300 1e300 1e300"/>"#),
        geometry(r#"<cylinder radius="1e200" length="1"/>"#),
        geometry(r#"<sphere radius="2000"/>"#),
        geometry(r#"<box size="0.1 -0.1 0.1"/>"#),
        geometry(r#"<cylinder radius="0.1" length="-1"/>"#),
        robot("", r#"<inertial><mass value="1e300"/></inertial>"#),
        robot("", r#"<inertial><mass value="-1"/></inertial>"#),
        robot(r#"<origin xyz="1e300 0 0"/>"#, ""),
        robot("", r#"<visual><origin xyz="0 0 -1e5"/><geometry><sphere radius="1"/></geometry></visual>"#),
        robot(r#"<origin rpy="0 1e300 0"/>"#, ""),
        robot("", "").replace(r#"velocity="1""#, r#"velocity="-1""#),
        robot("", "").replace(r#"upper="1""#, r#"upper="1e300""#),
    ];
    for xml in &cases {
        let e = error(xml);
        assert!(matches!(e, UrdfError::OutOfRange { .. }), "{xml}: {e}");
    }
    let message = error(&cases[3]).to_string();
    assert_eq!(message, r#"link "b" <collision> <box> size = -0.1 is out of range: from 0 to 1000 m"#);
    // A mimic chain whose gears multiply past any sane ratio.
    let chain = r#"<robot name="r"><link name="a"/><link name="b"/><link name="c"/><link name="d"/>
        <joint name="j1" type="continuous"><parent link="a"/><child link="b"/></joint>
        <joint name="j2" type="continuous"><parent link="b"/><child link="c"/><mimic joint="j1" multiplier="1000"/></joint>
        <joint name="j3" type="continuous"><parent link="c"/><child link="d"/><mimic joint="j2" multiplier="1000"/></joint>
        </robot>"#;
    assert!(error(chain).to_string().contains(r#"joint "j3" <mimic> multiplier"#), "{}", error(chain));
    // Zero-sized shapes are tolerated: no skin on them.
    let flat = Robot::from_urdf_str(&geometry(r#"<box size="0 0.1 0.1"/>"#)).unwrap();
    assert!(matches!(flat.link("b").unwrap().surface, Surface::Bones { .. }));
}

/// `levels` nested elements inside a link.
fn nested(levels: usize) -> String {
    format!(r#"<robot name="r"><link name="a">{}{}</link></robot>"#, "<x>".repeat(levels), "</x>".repeat(levels))
}

#[test]
fn deep_nesting_is_a_quick_error_not_a_stack_overflow() {
    // The robot and the link are two levels: this is as deep as it goes.
    assert!(matches!(error(&nested(MAX_DEPTH - 2)), UrdfError::NoDofs));
    for levels in [MAX_DEPTH - 1, 20_000, 200_000] {
        let start = Instant::now();
        let e = error(&nested(levels));
        assert!(matches!(e, UrdfError::TooLarge { what: "levels of element nesting", limit: MAX_DEPTH }), "{e}");
        assert!(start.elapsed() < Duration::from_secs(5), "{levels} levels took {:?}", start.elapsed());
    }
    assert!(error(&nested(200_000)).to_string().starts_with("the URDF has more than 64 levels of element nesting"));
}

#[test]
fn too_many_links_joints_dofs_or_bytes_are_refused() {
    let chain = |n: usize, kind: &str| {
        let mut s = String::from(r#"<robot name="chain"><link name="l0"/>"#);
        for i in 1..=n {
            s += &format!(
                r#"<link name="l{i}"/><joint name="j{i}" type="{kind}"><parent link="l{}"/><child link="l{i}"/><limit lower="-1" upper="1"/></joint>"#,
                i - 1
            );
        }
        s + "</robot>"
    };
    assert_eq!(Robot::from_urdf_str(&chain(MAX_DOFS, "revolute")).unwrap().dofs().len(), MAX_DOFS);
    assert!(matches!(error(&chain(MAX_DOFS + 1, "revolute")), UrdfError::TooLarge { what: "DoFs", .. }));
    assert!(error(&chain(1000, "revolute")).to_string().contains("more than 64 DoFs"));
    let start = Instant::now();
    assert!(matches!(error(&chain(MAX_LINKS, "fixed")), UrdfError::TooLarge { what: "links", .. }));
    assert!(start.elapsed() < Duration::from_secs(5));
    let padding = format!("<robot name='r'><!-- {} --></robot>", " ".repeat(33 << 20));
    assert!(matches!(error(&padding), UrdfError::TooLarge { what: "bytes", .. }));
    let many = format!("<robot name='r'>{}</robot>", "<x/>".repeat(3_000_000));
    assert!(matches!(error(&many), UrdfError::TooLarge { what: "XML nodes", .. }));
}

#[test]
fn files_are_refused_by_size_before_they_are_read() {
    let dir = std::env::temp_dir().join(format!("skin-sim-urdf-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let big = dir.join("big.urdf");
    std::fs::write(&big, vec![b' '; (32 << 20) + 1]).unwrap();
    assert!(matches!(Robot::from_urdf_file(&big), Err(UrdfError::TooLarge { what: "bytes", .. })));
    let binary = dir.join("binary.urdf");
    std::fs::write(&binary, [0xff, 0xfe, 0x00]).unwrap();
    assert!(Robot::from_urdf_file(&binary).unwrap_err().to_string().contains("not UTF-8"));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Pieces real and broken URDFs are made of, for documents that are
/// nearly right as often as plainly wrong.
fn fragment() -> impl Strategy<Value = String> {
    let number = prop_oneof![
        Just("0".to_owned()),
        Just("-1".to_owned()),
        Just("1e300".to_owned()),
        Just("nan".to_owned()),
        Just("-inf".to_owned()),
        Just("x".to_owned()),
        (-10.0f64..10.0).prop_map(|v| v.to_string()),
    ];
    let numbers = prop::collection::vec(number, 0..5).prop_map(|v| v.join(" "));
    let name = prop_oneof![Just("a"), Just("b"), Just("c"), Just("")];
    let kind = prop_oneof![Just("revolute"), Just("prismatic"), Just("continuous"), Just("fixed"), Just("planar")];
    prop_oneof![
        name.clone().prop_map(|n| format!(r#"<link name="{n}">"#)),
        Just("</link>".to_owned()),
        (name.clone(), kind).prop_map(|(n, k)| format!(r#"<joint name="{n}" type="{k}">"#)),
        Just("</joint>".to_owned()),
        name.clone().prop_map(|n| format!(r#"<parent link="{n}"/>"#)),
        name.clone().prop_map(|n| format!(r#"<child link="{n}"/>"#)),
        name.prop_map(|n| format!(r#"<mimic joint="{n}" multiplier="2"/>"#)),
        numbers.clone().prop_map(|v| format!(r#"<origin xyz="{v}" rpy="{v}"/>"#)),
        numbers.clone().prop_map(|v| format!(r#"<axis xyz="{v}"/>"#)),
        numbers.clone().prop_map(|v| format!(r#"<limit lower="{v}" upper="{v}" velocity="{v}"/>"#)),
        numbers.clone().prop_map(|v| format!(r#"<collision><geometry><box size="{v}"/></geometry></collision>"#)),
        numbers
            .clone()
            .prop_map(|v| format!(r#"<visual><geometry><cylinder radius="{v}" length="{v}"/></geometry></visual>"#)),
        numbers.prop_map(|v| format!(r#"<inertial><origin xyz="{v}"/><mass value="{v}"/></inertial>"#)),
        Just("<visual><geometry><mesh filename='package://x.stl'/></geometry></visual>".to_owned()),
        Just("<gazebo><texture/></gazebo>".to_owned()),
    ]
}

proptest! {
    #[test]
    fn any_text_is_ok_or_a_typed_error(text in ".{0,400}") {
        let _ = Robot::from_urdf_str(&text);
    }

    #[test]
    fn any_bytes_are_ok_or_a_typed_error(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
        let _ = Robot::from_urdf_str(&String::from_utf8_lossy(&bytes));
    }

    #[test]
    fn nearly_right_documents_are_ok_or_a_typed_error(parts in prop::collection::vec(fragment(), 0..30)) {
        let xml = format!(r#"<robot name="p"><link name="root"/>{}</robot>"#, parts.concat());
        if let Ok(r) = Robot::from_urdf_str(&xml) {
            // What loads can be skinned and moved.
            let _ = Skin::per_link(&r, 2, 0);
            let _ = r.moved_by(0);
        }
    }
}
