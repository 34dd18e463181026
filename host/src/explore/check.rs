//! Checking an exploration against the simulator's ground truth.
//!
//! For reports and tests only: the exploration itself never sees any of
//! this. The true activity matrix comes from the robot model (which DoFs
//! lie between the root and a cell's link), the true tree is what the tree
//! algorithm makes of it, and the true sensory-motor weight follows from
//! the noise-free tangential acceleration direction in the cell frame.

use std::collections::{BTreeMap, HashMap};
use std::time::Instant;

use skin_sim::world::World;

use super::merge::merge;
use super::{explore, Exploration, ExploreConfig, ExploreError, KinematicTree};
use crate::robot::SimRobot;

/// One exploration of a simulated world, checked against its truth.
#[derive(Debug)]
pub struct Trial {
    /// The exploration and its check, or why it failed.
    pub outcome: Result<(Exploration, TruthReport), ExploreError>,
    /// Wall-clock time of the exploration, s.
    pub wall_time_s: f64,
}

impl Trial {
    /// Explores `world` with `cfg` and checks the result.
    pub fn run(world: World, cfg: &ExploreConfig) -> Trial {
        let mut rig = SimRobot::new(world);
        let start = Instant::now();
        let result = explore(&mut rig, cfg, &mut |_| ());
        let wall_time_s = start.elapsed().as_secs_f64();
        let outcome = result.map(|found| {
            let truth = check(&found, rig.world());
            (found, truth)
        });
        Trial { outcome, wall_time_s }
    }

    /// The exploration succeeded and its tree is the true one.
    pub fn tree_correct(&self) -> bool {
        self.outcome.as_ref().is_ok_and(|(_, t)| t.tree_correct)
    }
}

/// How an exploration compares with the truth.
#[derive(Clone, Debug, PartialEq)]
pub struct TruthReport {
    /// The link of every cell, by cell ID.
    pub cell_links: BTreeMap<u16, String>,
    /// The learned tree equals the true one: same body parts (cells), same
    /// joints (DoFs) connecting the same body parts.
    pub tree_correct: bool,
    /// Activity matrix entries that differ from the truth.
    pub wrong_entries: usize,
    /// Mean `|w - w_true|` over all decoupled weights of the first tile.
    pub smm_mean_abs_error: f64,
    /// The same over the weights of cells the DoF truly moves.
    pub smm_mean_abs_error_moved: f64,
}

/// Compares `result` with the ground truth of `world`.
pub fn check(result: &Exploration, world: &World) -> TruthReport {
    let skin = world.skin().cells();
    let at: HashMap<_, _> = skin.iter().enumerate().map(|(i, c)| (c.id, i)).collect();
    let order: Vec<usize> = result.cells.iter().map(|a| at[a]).collect();
    let truth = world.true_activity();
    let rows: Vec<Vec<bool>> = order.iter().map(|&i| truth[i].clone()).collect();

    let learned = result.activity.rows();
    let wrong_entries = rows.iter().zip(&learned).map(|(t, l)| t.iter().zip(l).filter(|(a, b)| a != b).count()).sum();
    let expected = KinematicTree::new(&merge(&rows), &result.cells, &result.dof_names);
    let tree_correct = expected.as_ref() == Ok(&result.tree);

    let tile = &result.smm.tiles()[0];
    let tangential = world.true_tangential(tile.pose());
    let (mut all, mut moved, mut n_moved) = (0.0, 0.0, 0usize);
    for (u, &i) in order.iter().enumerate() {
        for (d, (&raw, &truly)) in tile.raw_weights(u).iter().zip(&rows[u]).enumerate() {
            let w = if result.activity.is_moved(u, d) { f64::from(raw) } else { 0.0 };
            let t = tangential[i][d];
            let l1 = t.x.abs() + t.y.abs() + t.z.abs();
            // Equation (11)'s sign: positive when the DoF pushes the cell inward.
            let w_true = if truly && l1 > 0.0 { -t.z / l1 } else { 0.0 };
            let e = (w - w_true).abs();
            all += e;
            if truly {
                moved += e;
                n_moved += 1;
            }
        }
    }
    let n_all = (order.len() * result.dof_names.len()).max(1);
    TruthReport {
        cell_links: skin.iter().map(|c| (c.id.0, c.link.clone())).collect(),
        tree_correct,
        wrong_entries,
        smm_mean_abs_error: all / n_all as f64,
        smm_mean_abs_error_moved: moved / n_moved.max(1) as f64,
    }
}
