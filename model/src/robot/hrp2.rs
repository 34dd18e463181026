//! The built-in robot: an HRP-2-like upper body, the paper's test case.
//!
//! A static chest and two 7-DoF arms (shoulder pitch, roll, yaw; elbow
//! pitch; wrist yaw, pitch; one-DoF gripper), so D = 14 as in section
//! 4.2.5, with U = 74 skin cells. Dimensions follow the published HRP-2
//! kinematics (Kaneko et al., ICRA 2004, and the OpenHRP model): shoulders
//! 0.25 m either side of the chest axis and 0.181 m above the chest frame,
//! 0.25 m upper arm, 0.25 m forearm; limits and link shapes are rounded
//! approximations. The start pose is HRP-2's "half-sitting" arm posture,
//! elbows bent, so no arm axis starts aligned with gravity.

use std::fmt::Write;

use super::Robot;

/// Cells per link of the built-in skin: 14 on the chest and 30 per arm.
pub const SKIN: [(&str, usize); 15] = [
    ("CHEST", 14),
    ("RARM_LINK0", 2),
    ("RARM_LINK1", 4),
    ("RARM_LINK2", 8),
    ("RARM_LINK3", 8),
    ("RARM_LINK4", 2),
    ("RARM_LINK5", 4),
    ("RARM_LINK6", 2),
    ("LARM_LINK0", 2),
    ("LARM_LINK1", 4),
    ("LARM_LINK2", 8),
    ("LARM_LINK3", 8),
    ("LARM_LINK4", 2),
    ("LARM_LINK5", 4),
    ("LARM_LINK6", 2),
];

/// Cells of the built-in skin on the link named `link`.
pub fn skin_cells_on(link: &str) -> usize {
    SKIN.iter().filter(|(name, _)| *name == link).map(|(_, n)| n).sum()
}

/// One arm joint: axis, origin in the parent link, limits (right arm),
/// velocity and torque limits, and the child link's shape, mass and home angle.
///
/// No per-joint torque table of HRP-2 was at hand, so the torque limits are
/// an HRP-2-class assumption: about three times the gravity torque each
/// joint bears with the arm outstretched and 2 kg in the hand (shoulder
/// 24 N m, elbow and upper-arm yaw 11 N m, wrist 3 N m), rounded up; the
/// finger's 3 N m squeezes about 75 N at its tip. The arm so lifts a grasped
/// object with margin, and a hard pinch saturates its actuators.
struct ArmJoint {
    axis: &'static str,
    xyz: [f64; 3],
    lower: f64,
    upper: f64,
    velocity: f64,
    effort_nm: f64,
    geometry: &'static str,
    geometry_xyz: [f64; 3],
    geometry_rpy: &'static str,
    mass: f64,
    home: f64,
}

const ARM: [ArmJoint; 7] = [
    // Shoulder pitch: housing along the pitch axis.
    ArmJoint {
        axis: "0 1 0",
        xyz: [0.008, -0.25, 0.181],
        lower: -3.1,
        upper: 1.05,
        velocity: 3.0,
        effort_nm: 80.0,
        geometry: r#"<cylinder radius="0.055" length="0.10"/>"#,
        geometry_xyz: [0.0, 0.0, 0.0],
        geometry_rpy: "1.5708 0 0",
        mass: 1.5,
        home: 0.26,
    },
    // Shoulder roll.
    ArmJoint {
        axis: "1 0 0",
        xyz: [0.0, 0.0, 0.0],
        lower: -1.65,
        upper: 0.17,
        velocity: 3.0,
        effort_nm: 80.0,
        geometry: r#"<cylinder radius="0.05" length="0.06"/>"#,
        geometry_xyz: [0.0, 0.0, -0.06],
        geometry_rpy: "0 0 0",
        mass: 0.5,
        home: -0.17,
    },
    // Shoulder yaw: upper arm.
    ArmJoint {
        axis: "0 0 1",
        xyz: [0.0, 0.0, -0.10],
        lower: -1.6,
        upper: 1.6,
        velocity: 3.0,
        effort_nm: 40.0,
        geometry: r#"<cylinder radius="0.05" length="0.15"/>"#,
        geometry_xyz: [0.0, 0.0, -0.075],
        geometry_rpy: "0 0 0",
        mass: 1.5,
        home: 0.0,
    },
    // Elbow pitch: forearm.
    ArmJoint {
        axis: "0 1 0",
        xyz: [0.0, 0.0, -0.15],
        lower: -2.39,
        upper: 0.0,
        velocity: 3.0,
        effort_nm: 40.0,
        geometry: r#"<cylinder radius="0.045" length="0.14"/>"#,
        geometry_xyz: [0.0, 0.0, -0.09],
        geometry_rpy: "0 0 0",
        mass: 1.0,
        home: -0.52,
    },
    // Wrist yaw.
    ArmJoint {
        axis: "0 0 1",
        xyz: [0.0, 0.0, -0.18],
        lower: -1.6,
        upper: 1.6,
        velocity: 3.0,
        effort_nm: 10.0,
        geometry: r#"<cylinder radius="0.04" length="0.06"/>"#,
        geometry_xyz: [0.0, 0.0, -0.035],
        geometry_rpy: "0 0 0",
        mass: 0.4,
        home: 0.0,
    },
    // Wrist pitch: hand.
    ArmJoint {
        axis: "0 1 0",
        xyz: [0.0, 0.0, -0.07],
        lower: -1.05,
        upper: 1.05,
        velocity: 3.0,
        effort_nm: 10.0,
        geometry: r#"<box size="0.08 0.05 0.12"/>"#,
        geometry_xyz: [0.0, 0.0, -0.08],
        geometry_rpy: "0 0 0",
        mass: 0.6,
        home: 0.0,
    },
    // Gripper: one finger.
    ArmJoint {
        axis: "1 0 0",
        xyz: [0.03, 0.0, -0.12],
        lower: -0.28,
        upper: 1.05,
        velocity: 3.0,
        effort_nm: 3.0,
        geometry: r#"<box size="0.02 0.03 0.08"/>"#,
        geometry_xyz: [0.0, 0.0, -0.04],
        geometry_rpy: "0 0 0",
        mass: 0.1,
        home: 0.17,
    },
];

/// The URDF of the built-in robot (useful to inspect or edit and pass back
/// with `--urdf`).
pub fn urdf() -> String {
    let mut s = String::from(
        r#"<robot name="hrp2-like">
  <link name="CHEST">
    <inertial><mass value="15"/><inertia ixx="0.3" ixy="0" ixz="0" iyy="0.3" iyz="0" izz="0.2"/></inertial>
    <collision><origin xyz="0 0 0.05"/><geometry><box size="0.26 0.30 0.38"/></geometry></collision>
  </link>
"#,
    );
    for (side, mirror) in [("RARM", 1.0), ("LARM", -1.0)] {
        let mut parent = "CHEST".to_string();
        for (i, j) in ARM.iter().enumerate() {
            // Mirroring in y flips the sign of roll and yaw (axes x and z).
            let flip = if j.axis == "0 1 0" { 1.0 } else { mirror };
            let (lower, upper) = if flip > 0.0 { (j.lower, j.upper) } else { (-j.upper, -j.lower) };
            let link = format!("{side}_LINK{i}");
            let [x, y, z] = j.xyz;
            let [gx, gy, gz] = j.geometry_xyz;
            write!(
                s,
                r#"  <link name="{link}">
    <inertial><origin xyz="{gx} {gy} {gz}"/><mass value="{m}"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>
    <collision><origin xyz="{gx} {gy} {gz}" rpy="{rpy}"/><geometry>{geometry}</geometry></collision>
  </link>
  <joint name="{side}_JOINT{i}" type="revolute">
    <parent link="{parent}"/><child link="{link}"/>
    <origin xyz="{x} {y} {z}"/><axis xyz="{axis}"/>
    <limit lower="{lower}" upper="{upper}" effort="{effort}" velocity="{v}"/>
  </joint>
"#,
                m = j.mass,
                rpy = j.geometry_rpy,
                geometry = j.geometry,
                y = y * mirror,
                axis = j.axis,
                v = j.velocity,
                effort = j.effort_nm,
            )
            .expect("writing to a String cannot fail");
            parent = link;
        }
    }
    s.push_str("</robot>\n");
    s
}

/// The built-in robot in its start pose.
pub fn robot() -> Robot {
    let mut robot = Robot::from_urdf_str(&urdf()).expect("the built-in URDF is valid");
    // DoFs come in URDF order: the right arm, then the left, mirrored.
    let home: Vec<f64> = [1.0, -1.0]
        .into_iter()
        .flat_map(|mirror| ARM.iter().map(move |j| if j.axis == "0 1 0" { j.home } else { mirror * j.home }))
        .collect();
    robot.set_home(&home).expect("one home angle per DoF");
    robot
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_built_in_robot_has_the_papers_dimensions() {
        let r = robot();
        assert_eq!(r.dofs().len(), 14);
        assert_eq!(r.bodies().len(), 15);
        assert_eq!(SKIN.iter().map(|(_, n)| n).sum::<usize>(), 74);
        assert!(SKIN.iter().all(|(l, _)| r.link(l).is_some()));
        let home = r.home();
        assert_eq!(&home[..7], &[0.26, -0.17, 0.0, -0.52, 0.0, 0.0, 0.17]);
        assert_eq!(&home[7..], &[0.26, 0.17, 0.0, -0.52, 0.0, 0.0, -0.17]);
        for (d, q) in r.dofs().iter().zip(home) {
            assert!(d.lower <= *q && *q <= d.upper, "{} home {q} outside [{}, {}]", d.name, d.lower, d.upper);
        }
    }
}
