//! Where things are in the live view, in one frame `world`: the robot's
//! links from its description by forward kinematics, or the learned
//! tree drawn as a schematic, and every cell on one of them.
//!
//! The skin alone tells which body part a cell is on and which DoFs join
//! the parts, not how long a part is or which way a joint turns. Until a
//! description and a calibration say more, the learned tree is drawn as a
//! schematic: body parts fanned out from the root at [`PART_SPACING_M`],
//! each joint turning its DoFs about z, y, x in turn (sliding along them
//! when prismatic), and a part's cells on a small grid at its origin.

use std::collections::BTreeMap;
use std::f64::consts::TAU;

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use skin_model::robot::kinematics::{forward, BodyState, DofMotion};
use skin_model::robot::Robot as Description;

use crate::explore::KinematicTree;
use crate::robot::DofKind;
use crate::ros::skin::CellPose;

/// Distance between a body part and its child in the schematic, m.
pub const PART_SPACING_M: f64 = 0.25;
/// Angle between sibling parts off a non-root part, rad.
const SIBLING_SPREAD_RAD: f64 = 0.5;
/// Distance between neighbouring cells on a part's grid, m.
pub const CELL_PITCH_M: f64 = 0.03;

/// A frame of the robot and the segments that draw it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Skeleton {
    /// Named frames in `world`.
    pub frames: Vec<(String, Isometry3<f64>)>,
    /// Bones: from a parent's origin to its child's, in `world`.
    pub bones: Vec<[Point3<f64>; 2]>,
}

impl Skeleton {
    /// The pose of frame `name`, if drawn.
    pub fn frame(&self, name: &str) -> Option<&Isometry3<f64>> {
        self.frames.iter().find(|(n, _)| n == name).map(|(_, pose)| pose)
    }
}

/// The description's links at `positions` (the host's DoF order, named
/// by `dof_names`; a DoF the host does not drive stays at 0).
pub fn described(model: &Description, dof_names: &[String], positions: &[f64]) -> Skeleton {
    let q: Vec<f64> = model
        .dofs()
        .iter()
        .map(|d| dof_names.iter().position(|n| *n == d.name).and_then(|i| positions.get(i)).copied().unwrap_or(0.0))
        .collect();
    let still = vec![0.0; q.len()];
    let mut bodies: Vec<BodyState> = Vec::with_capacity(model.bodies().len());
    forward(
        model,
        &BodyState::at_rest(Isometry3::identity()),
        DofMotion { q: &q, qd: &still, qdd: &still },
        &mut bodies,
    );
    let frames = model.links().iter().map(|l| (l.name.clone(), bodies[l.body].pose * l.in_body)).collect();
    let bones = model
        .joints()
        .iter()
        .map(|j| {
            [bodies[j.parent_body].pose.translation.vector.into(), bodies[j.child_body].pose.translation.vector.into()]
        })
        .collect();
    Skeleton { frames, bones }
}

/// The frame of learned body part `k` in the view.
pub fn part_frame(k: usize) -> String {
    crate::ros::skin::part_frame(k)
}

/// The motion of one DoF in the schematic: the `n`-th DoF of a joint
/// turns about (or slides along) z, y, x in turn.
fn dof_motion(n: usize, kind: DofKind, position: f64) -> Isometry3<f64> {
    let axis = [Vector3::z_axis(), Vector3::y_axis(), Vector3::x_axis()][n % 3];
    match kind {
        DofKind::Prismatic => {
            Isometry3::from_parts(Translation3::from(axis.into_inner() * position), UnitQuaternion::identity())
        }
        _ => Isometry3::from_parts(Translation3::identity(), UnitQuaternion::from_axis_angle(&axis, position)),
    }
}

/// The learned tree at `positions` (the tree's DoF order) as a schematic.
pub fn learned(tree: &KinematicTree, kinds: &[DofKind], positions: &[f64]) -> Skeleton {
    let parts = tree.body_parts();
    let mut poses = vec![Isometry3::identity(); parts.len()];
    let mut heading = vec![0.0f64; parts.len()];
    let mut bones = Vec::new();
    let mut placed = vec![false; parts.len()];
    let mut todo = vec![tree.root()];
    while let Some(p) = todo.pop() {
        if std::mem::replace(&mut placed[p], true) {
            continue;
        }
        let children = &parts[p].child_joints;
        let n = children.len() as f64;
        for (i, joint) in children.iter().filter_map(|&j| tree.joints().get(j)).enumerate() {
            let i = i as f64;
            let angle = if p == tree.root() {
                TAU * (i + 0.5) / n
            } else {
                heading[p] + (i - (n - 1.0) / 2.0) * SIBLING_SPREAD_RAD
            };
            let offset = Translation3::new(0.0, PART_SPACING_M * angle.cos(), PART_SPACING_M * angle.sin());
            let motion = joint.dofs.iter().enumerate().fold(Isometry3::identity(), |m, (n, &dof)| {
                let kind = kinds.get(dof).copied().unwrap_or(DofKind::Revolute);
                m * dof_motion(n, kind, positions.get(dof).copied().unwrap_or(0.0))
            });
            let child = joint.child;
            if placed.get(child).is_none_or(|&done| done) {
                continue;
            }
            poses[child] = poses[p] * offset * motion;
            heading[child] = angle;
            bones.push([poses[p].translation.vector.into(), poses[child].translation.vector.into()]);
            todo.push(child);
        }
    }
    Skeleton { frames: poses.into_iter().enumerate().map(|(k, pose)| (part_frame(k), pose)).collect(), bones }
}

/// The `k`-th of `n` cells on a square grid about a frame's origin, in its x-y plane.
pub fn on_grid(k: usize, n: usize) -> Isometry3<f64> {
    let side = (n as f64).sqrt().ceil().max(1.0) as usize;
    let centre = (side as f64 - 1.0) / 2.0;
    let (row, col) = ((k / side) as f64, (k % side) as f64);
    Isometry3::translation((col - centre) * CELL_PITCH_M, (row - centre) * CELL_PITCH_M, 0.0)
}

/// Every cell's pose in `world`: on its link where a calibration placed
/// it, on its body part's grid where the tree has it, else on one grid at
/// the origin (`ids` are the cells heard, in order).
pub fn cells(
    ids: &[u16],
    poses: &BTreeMap<u16, CellPose>,
    tree: Option<&KinematicTree>,
    skeleton: &Skeleton,
) -> Vec<Isometry3<f64>> {
    let mut on_part: BTreeMap<u16, (usize, usize, usize)> = BTreeMap::new();
    for (k, part) in tree.map(KinematicTree::body_parts).unwrap_or_default().iter().enumerate() {
        for (i, cell) in part.cells.iter().enumerate() {
            on_part.insert(cell.0, (k, i, part.cells.len()));
        }
    }
    let placed = |id: &u16| {
        poses.get(id).and_then(|pose| skeleton.frame(&pose.frame).map(|frame| (pose, frame))).map(|(pose, frame)| {
            let [r, p, y] = pose.rpy;
            let local = Isometry3::from_parts(
                Translation3::new(pose.xyz[0], pose.xyz[1], pose.xyz[2]),
                UnitQuaternion::from_euler_angles(r, p, y),
            );
            frame * local
        })
    };
    let on_tree = |id: &u16| {
        let &(k, i, n) = on_part.get(id)?;
        skeleton.frame(&part_frame(k)).map(|frame| frame * on_grid(i, n))
    };
    let known: Vec<Option<Isometry3<f64>>> = ids.iter().map(|id| placed(id).or_else(|| on_tree(id))).collect();
    // The rest share one grid, in ID order.
    let loose = known.iter().filter(|k| k.is_none()).count();
    let mut next = 0;
    known
        .into_iter()
        .map(|k| {
            k.unwrap_or_else(|| {
                next += 1;
                on_grid(next - 1, loose)
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_grid_is_centred_and_spaced_by_the_pitch() {
        let p: Vec<Vector3<f64>> = (0..4).map(|k| on_grid(k, 4).translation.vector).collect();
        assert!((p[0] + p[3]).norm() < 1e-12, "centred: {p:?}");
        assert!(((p[1] - p[0]).norm() - CELL_PITCH_M).abs() < 1e-12);
        assert_eq!(on_grid(0, 1).translation.vector, Vector3::zeros());
    }

    #[test]
    fn a_described_robot_moves_its_links_with_the_named_dofs() {
        let model = skin_model::robot::hrp2::robot();
        let names: Vec<String> = model.dofs().iter().map(|d| d.name.clone()).collect();
        let rest = described(&model, &names, &vec![0.0; names.len()]);
        assert_eq!(rest.frames.len(), model.links().len());
        assert_eq!(rest.bones.len(), model.joints().len());
        // Turning every DoF moves some link; a DoF the host does not name stays put.
        let moved = described(&model, &names, &vec![0.5; names.len()]);
        assert!(rest
            .frames
            .iter()
            .zip(&moved.frames)
            .any(|(a, b)| (a.1.translation.vector - b.1.translation.vector).norm() > 0.01));
        let unnamed = described(&model, &[], &[]);
        assert_eq!(unnamed, rest);
    }

    #[test]
    fn a_calibrated_cell_sits_on_its_link_and_the_others_on_a_grid() {
        let model = skin_model::robot::hrp2::robot();
        let skeleton = described(&model, &[], &[]);
        let (link, frame) = skeleton.frames.last().unwrap().clone();
        let pose = CellPose { id: 7, frame: link, xyz: [0.1, 0.0, 0.0], rpy: [0.0; 3] };
        let poses = BTreeMap::from([(7, pose)]);
        let at = cells(&[3, 7, 9], &poses, None, &skeleton);
        let expected = frame * Point3::new(0.1, 0.0, 0.0);
        assert!((at[1].translation.vector - expected.coords).norm() < 1e-12);
        // The two loose cells share one grid of two.
        assert_eq!(at[0], on_grid(0, 2));
        assert_eq!(at[2], on_grid(1, 2));
    }
}
