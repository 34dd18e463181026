//! A calibration as files other programs read: the skin description the
//! simulator's `--skin` takes (so a calibration can be fed back and
//! compared), and the user's URDF with one fixed `skin_cell_<ID>` link per
//! cell, which robot_state_publisher loads as it is.

use std::fmt::Write;

use nalgebra::{Isometry3, Point3, Vector3};
use serde::Serialize;
use skin_model::robot::kinematics::{self, BodyState, DofMotion};
use skin_model::robot::Robot as Model;
use skin_model::skin::{self, FileCell};

use super::{Calibration, CellPose};

/// Why the URDF cannot take the skin frames.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ExportError {
    /// The text has no closing `</robot>`.
    #[error("the URDF has no closing </robot> to add the skin frames before")]
    NoRobotEnd,
    /// A name the skin frames need is taken.
    #[error("the URDF already has an element named \"{0}\"")]
    NameTaken(String),
}

/// The cell's pose in its link's own frame (the body frame is that of
/// the body's first link, which is the one named).
fn in_link(model: &Model, cell: &CellPose) -> Isometry3<f64> {
    let pose = Isometry3::from_parts(cell.position.into(), cell.frame.into());
    match model.link(&cell.link) {
        Some(link) => link.in_body.inverse() * pose,
        None => pose,
    }
}

fn rpy(pose: &Isometry3<f64>) -> [f64; 3] {
    let (r, p, y) = pose.rotation.euler_angles();
    [r, p, y]
}

/// Every cell's frame on its link, as the ROS 2 topics place it.
pub fn ros_poses(model: &Model, calibration: &Calibration) -> Vec<crate::ros::skin::CellPose> {
    calibration
        .cells
        .iter()
        .map(|c| {
            let pose = in_link(model, c);
            crate::ros::skin::CellPose {
                id: c.id.0,
                frame: c.link.clone(),
                xyz: pose.translation.vector.into(),
                rpy: rpy(&pose),
            }
        })
        .collect()
}

/// The skin description (TOML), cells grouped by link, with their IDs.
pub fn skin_toml(model: &Model, calibration: &Calibration) -> String {
    let cells: Vec<FileCell<'_>> =
        calibration.cells.iter().map(|c| FileCell { id: c.id, link: &c.link, in_link: in_link(model, c) }).collect();
    "# Skin calibrated by `skin calibrate`: poses in each link's frame, z along the accelerometer's z.\n".to_owned()
        + &skin::skin_toml(&cells)
}

/// A calibrated cell's frame as the model files carry it.
#[derive(Clone, Debug, PartialEq)]
pub struct SkinFrame {
    /// `skin_cell_<ID>`.
    pub name: String,
    /// The link (a MuJoCo model's body) it sits on.
    pub link: String,
    /// The accelerometer's frame in the link's frame (zero along unobservable directions).
    pub pose: Isometry3<f64>,
}

/// Every calibrated cell's frame, in the calibration's order.
pub fn skin_frames(model: &Model, calibration: &Calibration) -> Vec<SkinFrame> {
    calibration
        .cells
        .iter()
        .map(|c| SkinFrame { name: format!("skin_cell_{}", c.id.0), link: c.link.clone(), pose: in_link(model, c) })
        .collect()
}

/// `urdf` with a fixed `skin_cell_<ID>` link per cell before its `</robot>`.
pub fn urdf_with_skin(urdf: &str, model: &Model, calibration: &Calibration) -> Result<String, ExportError> {
    let end = urdf.rfind("</robot>").ok_or(ExportError::NoRobotEnd)?;
    let mut frames = String::from("\n  <!-- Skin cells calibrated by `skin calibrate`: accelerometer frames. -->\n");
    for (c, SkinFrame { name, pose, .. }) in calibration.cells.iter().zip(skin_frames(model, calibration)) {
        for taken in [&name, &format!("{name}_joint")] {
            if urdf.contains(&format!("name=\"{taken}\"")) || urdf.contains(&format!("name='{taken}'")) {
                return Err(ExportError::NameTaken(taken.clone()));
            }
        }
        let t = pose.translation.vector;
        let [r, p, y] = rpy(&pose);
        let unknown: Vec<&str> =
            ["x", "y", "z"].into_iter().zip(c.observable()).filter(|(_, o)| !o).map(|(a, _)| a).collect();
        if !unknown.is_empty() {
            let _ = writeln!(frames, "  <!-- {name}: position along {} unobservable -->", unknown.join(", "));
        }
        let _ = write!(
            frames,
            "  <link name=\"{name}\"/>\n  <joint name=\"{name}_joint\" type=\"fixed\">\n    <parent link=\"{}\"/>\n    <child link=\"{name}\"/>\n    <origin xyz=\"{:.6} {:.6} {:.6}\" rpy=\"{:.6} {:.6} {:.6}\"/>\n  </joint>\n",
            escape(&c.link),
            t.x,
            t.y,
            t.z,
            r,
            p,
            y
        );
    }
    Ok(format!("{}{frames}{}", &urdf[..end], &urdf[end..]))
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;").replace('\'', "&apos;")
}

/// The calibrated skin on the robot in its start posture, world frame, m:
/// what the report's three views draw.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Picture {
    /// Bones from each body's parent origin to its own.
    pub bones: Vec<([f64; 3], [f64; 3])>,
    /// Each cell's estimated position and z axis.
    pub cells: Vec<([f64; 3], [f64; 3])>,
    /// Each cell's true position, in the order of `cells` (simulation only).
    pub truth: Vec<[f64; 3]>,
}

/// The picture of `calibration` on `model` in the posture `q` (description DoF order).
pub fn picture(model: &Model, calibration: &Calibration, q: &[f64]) -> Picture {
    let zero = vec![0.0; model.dofs().len()];
    let mut states = Vec::new();
    let base = BodyState::at_rest(Isometry3::identity());
    kinematics::forward(model, &base, DofMotion { q, qd: &zero, qdd: &zero }, &mut states);
    let origin = |b: usize| states[b].pose.translation.vector.into();
    let bones = model
        .bodies()
        .iter()
        .enumerate()
        .filter_map(|(b, body)| Some((origin(model.joints()[body.parent_joint?].parent_body), origin(b))))
        .collect();
    let cells = calibration
        .cells
        .iter()
        .map(|p| {
            let pose = states[p.body].pose;
            ((pose * Point3::from(p.position)).coords.into(), (pose.rotation * (p.frame * Vector3::z())).into())
        })
        .collect();
    Picture { bones, cells, truth: Vec::new() }
}
