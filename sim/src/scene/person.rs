//! A person who pats the robot and guides it by proximity (sections 5.3
//! and 6.2).
//!
//! The person knows what they want, a key pose they picture, and sees where
//! the arms are; they never touch the robot's controller. To guide, they
//! hold a hand in front of the cell that should move inwards (its
//! evasion is what they want), closer for a bigger correction, and pick
//! another cell every so often as the arm moves. Both arms are guided at
//! once, one hand each.

use nalgebra::{Isometry3, Point3, Vector3};

use super::experiment::body_poses;
use super::hand::Hand;
use super::proximity::Vcnl4010;
use skin_model::robot::Robot;
use skin_model::skin::Skin;

/// How the person guides.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Guiding {
    /// A hand stays at a cell this long before the person looks again, s.
    pub dwell_s: f64,
    /// Intensity asked per metre still to go (a bigger correction, a
    /// closer hand), 1/m.
    pub intensity_per_m: f64,
    /// The closest the hand comes (the strongest push), normalized intensity.
    pub max_intensity: f64,
    /// An arm whose cells are this close to the picture is left alone, m.
    pub tolerance_m: f64,
}

impl Default for Guiding {
    fn default() -> Guiding {
        Guiding { dwell_s: 0.2, intensity_per_m: 10.0, max_intensity: 0.8, tolerance_m: 0.02 }
    }
}

/// A person teaching one key pose.
#[derive(Clone, Debug)]
pub struct Teacher {
    targets: Vec<Point3<f64>>,
    arms: [Vec<usize>; 2],
    guiding: Guiding,
    hands: [Option<(usize, f64)>; 2],
    looked_at_s: f64,
}

impl Teacher {
    /// A person picturing the robot in `pose`, guiding the cells of each
    /// arm (skin indices).
    pub fn new(robot: &Robot, skin: &Skin, pose: &[f64], arms: [Vec<usize>; 2], guiding: Guiding) -> Teacher {
        let bodies = body_poses(robot, pose);
        let targets = skin.cells().iter().map(|c| bodies[c.body] * c.pose * Point3::origin()).collect();
        Teacher { targets, arms, guiding, hands: [None, None], looked_at_s: f64::NEG_INFINITY }
    }

    /// How far each arm's cells are from the picture (root mean square), m.
    pub fn error_m(&self, poses: &[Isometry3<f64>]) -> [f64; 2] {
        self.arms.clone().map(|cells| {
            let sum: f64 = cells.iter().map(|&u| (self.targets[u] - poses[u] * Point3::origin()).norm_squared()).sum();
            (sum / cells.len().max(1) as f64).sqrt()
        })
    }

    /// Whether both arms look like the picture.
    pub fn satisfied(&self, poses: &[Isometry3<f64>]) -> bool {
        self.error_m(poses).iter().all(|e| *e <= self.guiding.tolerance_m)
    }

    /// Where the hands are at `time_s` for cells at `poses`.
    pub fn hands(&mut self, time_s: f64, poses: &[Isometry3<f64>], skin_offset_m: f64, sensor: &Vcnl4010) -> Vec<Hand> {
        if time_s - self.looked_at_s >= self.guiding.dwell_s {
            self.looked_at_s = time_s;
            let errors = self.error_m(poses);
            for (arm, hand) in self.hands.iter_mut().enumerate() {
                *hand = if errors[arm] <= self.guiding.tolerance_m {
                    None
                } else {
                    best_push(&self.arms[arm], &self.targets, poses).map(|(u, to_go)| {
                        let intensity = (0.01 + self.guiding.intensity_per_m * to_go).min(self.guiding.max_intensity);
                        (u, sensor.distance_for(intensity))
                    })
                };
            }
        }
        self.hands.iter().flatten().map(|&(u, gap)| Hand::facing(&poses[u], skin_offset_m, gap)).collect()
    }
}

/// The cell whose inward motion (its evasion) best serves the picture,
/// and how far it should go that way, m.
fn best_push(cells: &[usize], targets: &[Point3<f64>], poses: &[Isometry3<f64>]) -> Option<(usize, f64)> {
    cells
        .iter()
        .map(|&u| {
            let inward = -(poses[u].rotation * Vector3::z());
            (u, inward.dot(&(targets[u] - poses[u] * Point3::origin())))
        })
        .filter(|(_, to_go)| *to_go > 0.0)
        .max_by(|a, b| a.1.total_cmp(&b.1))
}

/// A hand patting the cell at `cell`: pressed `depth_m` into the skin.
pub fn pat(cell: &Isometry3<f64>, skin_offset_m: f64, depth_m: f64) -> Hand {
    Hand::facing(cell, skin_offset_m, -depth_m)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::experiment::{intended_pose, Setup};
    use skin_model::robot::hrp2;

    #[test]
    fn the_person_pushes_cells_that_should_move_inwards() {
        let robot = hrp2::robot();
        let setup = Setup::new(&robot, 1).unwrap();
        let open = intended_pose(&robot, "open").unwrap();
        let mut t = Teacher::new(&robot, &setup.skin, &open, setup.guided_cells.clone(), Guiding::default());
        let bodies = body_poses(&robot, robot.home());
        let poses: Vec<_> = setup.skin.cells().iter().map(|c| bodies[c.body] * c.pose).collect();
        let sensor = Vcnl4010::default();
        let hands = t.hands(0.0, &poses, 0.008, &sensor);
        assert_eq!(hands.len(), 2, "both arms are away from the open pose");
        assert!(t.error_m(&poses).iter().all(|e| *e > 0.05));
        // At the pictured pose itself there is nothing to do.
        let bodies = body_poses(&robot, &open);
        let there: Vec<_> = setup.skin.cells().iter().map(|c| bodies[c.body] * c.pose).collect();
        assert!(t.satisfied(&there));
        assert!(t.hands(1.0, &there, 0.008, &sensor).is_empty());
    }
}
