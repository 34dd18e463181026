//! Forward kinematics to second order: the pose, angular velocity, angular
//! acceleration and origin acceleration of every body, in the world frame.
//!
//! This is what equations (1)-(3) need for any point on a body: its
//! acceleration `a_o + alpha x r + omega x (omega x r)` holds the tangential
//! and centripetal terms of every moving DoF at once (and their cross terms
//! when several move), so a single DoF motion reduces to the paper's case.
//! A prismatic joint adds no rotation: it carries its child along the axis,
//! so the child's origin gains the slide's own acceleration and the Coriolis
//! term of sliding within a turning parent.

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};

use super::{drive_rate, drive_value, DofKind, Robot};

/// Motion of one rigid body in the world frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodyState {
    /// Body frame in the world frame.
    pub pose: Isometry3<f64>,
    /// Angular velocity, rad/s.
    pub omega: Vector3<f64>,
    /// Angular acceleration, rad/s^2.
    pub alpha: Vector3<f64>,
    /// Acceleration of the body frame's origin, m/s^2.
    pub accel: Vector3<f64>,
}

impl BodyState {
    /// A body at rest at `pose`.
    pub fn at_rest(pose: Isometry3<f64>) -> BodyState {
        BodyState { pose, omega: Vector3::zeros(), alpha: Vector3::zeros(), accel: Vector3::zeros() }
    }

    /// Acceleration (world frame) of the point `p` given in body coordinates.
    pub fn point_accel(&self, p: &Point3<f64>) -> Vector3<f64> {
        let r = self.pose.rotation * p.coords;
        self.accel + self.alpha.cross(&r) + self.omega.cross(&self.omega.cross(&r))
    }
}

/// Joint positions, velocities and accelerations of every DoF.
#[derive(Clone, Copy, Debug)]
pub struct DofMotion<'a> {
    /// Positions, rad (m for prismatic DoFs).
    pub q: &'a [f64],
    /// Velocities, rad/s (m/s).
    pub qd: &'a [f64],
    /// Accelerations, rad/s^2 (m/s^2).
    pub qdd: &'a [f64],
}

/// Fills `out` with the state of every body (indexed like
/// [`Robot::bodies`]) for the root moving as `base`.
pub fn forward(robot: &Robot, base: &BodyState, m: DofMotion<'_>, out: &mut Vec<BodyState>) {
    out.clear();
    out.push(*base);
    for body in &robot.bodies()[1..] {
        let j = &robot.joints()[body.parent_joint.expect("non-root bodies have a parent joint")];
        let parent = out[j.parent_body];
        let (value, rate, accel) = (drive_value(j.drive, m.q), drive_rate(j.drive, m.qd), drive_rate(j.drive, m.qdd));
        let mount = parent.pose * j.origin;
        let pose = match j.kind {
            DofKind::Revolute => mount * UnitQuaternion::from_axis_angle(&j.axis, value),
            DofKind::Prismatic => mount * Translation3::from(j.axis.into_inner() * value),
        };
        // The axis is the same in the joint frame and the child frame.
        let axis = pose.rotation * j.axis.into_inner();
        let r = pose.translation.vector - parent.pose.translation.vector;
        // The child origin's acceleration as a point fixed to the parent.
        let carried = parent.accel + parent.alpha.cross(&r) + parent.omega.cross(&parent.omega.cross(&r));
        let state = match j.kind {
            DofKind::Revolute => {
                let spin = axis * rate;
                BodyState {
                    pose,
                    omega: parent.omega + spin,
                    alpha: parent.alpha + axis * accel + parent.omega.cross(&spin),
                    accel: carried,
                }
            }
            DofKind::Prismatic => BodyState {
                pose,
                omega: parent.omega,
                alpha: parent.alpha,
                accel: carried + axis * accel + 2.0 * parent.omega.cross(&(axis * rate)),
            },
        };
        out.push(state);
    }
}

/// World-frame acceleration of a point fixed at `p` (world coordinates, on
/// body `body`) per unit acceleration of `dof`, the robot otherwise at rest:
/// the direction of the tangential acceleration of equation (1), scaled by
/// the lever arm, for a joint that turns; the axis itself for one that
/// slides (per m/s^2). Zero if `dof` does not move the body.
pub fn tangential(robot: &Robot, states: &[BodyState], body: usize, p: &Point3<f64>, dof: usize) -> Vector3<f64> {
    let mut t = Vector3::zeros();
    let mut b = body;
    while let Some(ji) = robot.bodies()[b].parent_joint {
        let j = &robot.joints()[ji];
        let gain = drive_rate(j.drive, &unit(robot.dofs().len(), dof));
        if gain != 0.0 {
            let s = &states[j.child_body];
            let axis = s.pose.rotation * j.axis.into_inner();
            t += gain
                * match j.kind {
                    DofKind::Revolute => axis.cross(&(p - Point3::from(s.pose.translation.vector))),
                    DofKind::Prismatic => axis,
                };
        }
        b = j.parent_body;
    }
    t
}

fn unit(n: usize, i: usize) -> Vec<f64> {
    let mut v = vec![0.0; n];
    v[i] = 1.0;
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    const ARM: &str = r#"<robot name="arm">
        <link name="base"/>
        <link name="upper"/>
        <link name="fore"/>
        <joint name="shoulder" type="continuous">
            <parent link="base"/><child link="upper"/><axis xyz="0 0 1"/>
        </joint>
        <joint name="elbow" type="revolute">
            <parent link="upper"/><child link="fore"/>
            <origin xyz="0.5 0 0" rpy="0 0 0"/><axis xyz="0 1 0"/>
            <limit lower="-2" upper="2" velocity="1"/>
        </joint>
    </robot>"#;

    /// The body states of the robot `urdf` in motion, base at rest.
    fn states_of(urdf: &str, q: &[f64], qd: &[f64], qdd: &[f64]) -> (Robot, Vec<BodyState>) {
        let robot = Robot::from_urdf_str(urdf).unwrap();
        let mut out = Vec::new();
        forward(&robot, &BodyState::at_rest(Isometry3::identity()), DofMotion { q, qd, qdd }, &mut out);
        (robot, out)
    }

    fn states(q: &[f64], qd: &[f64], qdd: &[f64]) -> (Robot, Vec<BodyState>) {
        states_of(ARM, q, qd, qdd)
    }

    #[test]
    fn a_spinning_arm_has_the_centripetal_and_tangential_terms_of_equations_1_and_2() {
        let (_, s) = states(&[0.0, 0.0], &[2.0, 0.0], &[3.0, 0.0]);
        // Elbow origin at r = 0.5 m on x: centripetal -w^2 r x, tangential alpha r y.
        let a = s[2].accel;
        assert!((a - Vector3::new(-4.0 * 0.5, 3.0 * 0.5, 0.0)).norm() < 1e-12, "{a}");
        // A point 0.3 m further out on the forearm.
        let p = s[2].point_accel(&Point3::new(0.3, 0.0, 0.0));
        assert!((p - Vector3::new(-4.0 * 0.8, 3.0 * 0.8, 0.0)).norm() < 1e-12, "{p}");
    }

    /// On every body, for every DoF, of a revolute arm and of one with a slide.
    #[test]
    fn tangential_direction_matches_a_finite_difference_of_the_acceleration() {
        for (urdf, q) in [(ARM, &[0.3, -0.7][..]), (SLIDER, &[0.4, 0.1, -0.3][..])] {
            let zero = vec![0.0; q.len()];
            let (robot, at_rest) = states_of(urdf, q, &zero, &zero);
            let p_body = Point3::new(0.2, 0.05, 0.1);
            for body in 1..at_rest.len() {
                let p = at_rest[body].pose * p_body;
                for dof in 0..q.len() {
                    let (_, moving) = states_of(urdf, q, &zero, &unit(q.len(), dof));
                    let direct = moving[body].point_accel(&p_body);
                    let t = tangential(&robot, &at_rest, body, &p, dof);
                    assert!((direct - t).norm() < 1e-12, "{} body {body} dof {dof}: {direct} vs {t}", robot.name());
                }
            }
        }
    }

    /// A turntable carrying a slide carrying a wrist: every coupling of a
    /// prismatic joint with revolute ones, above and below it.
    const SLIDER: &str = r#"<robot name="slider">
        <link name="base"/><link name="table"/><link name="carriage"/><link name="hand"/>
        <joint name="turn" type="continuous">
            <parent link="base"/><child link="table"/><origin xyz="0 0 0.1"/><axis xyz="0 0 1"/>
        </joint>
        <joint name="slide" type="prismatic">
            <parent link="table"/><child link="carriage"/>
            <origin xyz="0.2 0 0.05" rpy="0.3 0 0.4"/><axis xyz="1 0.5 0"/>
            <limit lower="-0.5" upper="0.5" velocity="1"/>
        </joint>
        <joint name="wrist" type="revolute">
            <parent link="carriage"/><child link="hand"/><origin xyz="0.1 0 0"/><axis xyz="0 1 0"/>
            <limit lower="-2" upper="2" velocity="1"/>
        </joint>
    </robot>"#;

    fn slider_states(q: &[f64], qd: &[f64], qdd: &[f64]) -> (Robot, Vec<BodyState>) {
        states_of(SLIDER, q, qd, qdd)
    }

    #[test]
    fn a_prismatic_joint_slides_its_child_along_the_axis_without_turning_it() {
        let (robot, zero) = slider_states(&[0.4, 0.0, 0.2], &[0.0; 3], &[0.0; 3]);
        let (_, slid) = slider_states(&[0.4, 0.3, 0.2], &[0.0; 3], &[0.0; 3]);
        let j = &robot.joints()[1];
        let axis = zero[j.child_body].pose.rotation * j.axis.into_inner();
        let moved = slid[j.child_body].pose.translation.vector - zero[j.child_body].pose.translation.vector;
        assert!((moved - 0.3 * axis).norm() < 1e-12, "{moved} vs {axis}");
        assert!(slid[j.child_body].pose.rotation.angle_to(&zero[j.child_body].pose.rotation) < 1e-12);
    }

    /// Every term of the acceleration, velocity terms included, against a
    /// second difference of the position along `q(t) = q + qd t + qdd t^2 / 2`.
    #[test]
    fn the_acceleration_of_a_point_matches_a_second_difference_of_its_position() {
        let (q, qd, qdd) = ([0.4, 0.1, -0.3], [0.7, -0.5, 1.1], [0.9, 1.3, -0.6]);
        let p_body = Point3::new(0.05, -0.03, 0.08);
        let at = |t: f64| {
            let q: Vec<f64> = (0..3).map(|i| q[i] + qd[i] * t + 0.5 * qdd[i] * t * t).collect();
            let (_, s) = slider_states(&q, &[0.0; 3], &[0.0; 3]);
            s.iter().map(|b| (b.pose * p_body).coords).collect::<Vec<_>>()
        };
        let h = 1e-4;
        let (before, now, after) = (at(-h), at(0.0), at(h));
        let (_, moving) = slider_states(&q, &qd, &qdd);
        for body in 1..4 {
            let numeric = (after[body] - 2.0 * now[body] + before[body]) / (h * h);
            let direct = moving[body].point_accel(&p_body);
            assert!((numeric - direct).norm() < 1e-5, "body {body}: {numeric} vs {direct}");
        }
    }

    #[test]
    fn the_tangential_direction_of_a_prismatic_dof_is_its_axis() {
        let (robot, at_rest) = slider_states(&[0.4, 0.1, -0.3], &[0.0; 3], &[0.0; 3]);
        let axis = at_rest[2].pose.rotation * robot.joints()[1].axis.into_inner();
        for body in 2..4 {
            let p = at_rest[body].pose * Point3::new(0.05, -0.03, 0.08);
            assert!((tangential(&robot, &at_rest, body, &p, 1) - axis).norm() < 1e-12);
        }
    }
}
