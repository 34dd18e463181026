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

    fn states(q: &[f64], qd: &[f64], qdd: &[f64]) -> (Robot, Vec<BodyState>) {
        let robot = Robot::from_urdf_str(ARM).unwrap();
        let mut out = Vec::new();
        forward(&robot, &BodyState::at_rest(Isometry3::identity()), DofMotion { q, qd, qdd }, &mut out);
        (robot, out)
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

    #[test]
    fn tangential_direction_matches_a_finite_difference_of_the_acceleration() {
        let q = [0.3, -0.7];
        let (robot, at_rest) = states(&q, &[0.0; 2], &[0.0; 2]);
        let p_body = Point3::new(0.2, 0.05, 0.1);
        let p = at_rest[2].pose * p_body;
        for dof in 0..2 {
            let mut qdd = [0.0; 2];
            qdd[dof] = 1.0;
            let (_, moving) = states(&q, &[0.0; 2], &qdd);
            let direct = moving[2].point_accel(&p_body);
            let t = tangential(&robot, &at_rest, 2, &p, dof);
            assert!((direct - t).norm() < 1e-12, "dof {dof}: {direct} vs {t}");
        }
    }
}
