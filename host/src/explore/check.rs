//! Checking an exploration against the simulator's ground truth.
//!
//! For reports and tests only: the exploration itself never sees any of
//! this. The true activity matrix comes from the robot model (which DoFs
//! lie between the root and a cell's link). The true tree is read off the
//! robot's joint chain directly, not through the code under test: a body
//! part per body with cells, a joint per such body, made of the DoFs
//! between it and the nearest body with cells above it. The true
//! sensory-motor weight follows from the noise-free tangential
//! acceleration direction in the cell frame.

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::time::Instant;

use skin_model::robot::Drive;
use skin_sim::world::World;

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
    let tree_correct = true_tree(world).is_some_and(|t| t == learned_tree(&result.tree));

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

/// A kinematic tree as sets, so two trees compare whatever their order:
/// body parts by their cell IDs, joints by their DoF names and the cells
/// of the body parts they connect.
#[derive(Debug, PartialEq, Eq)]
struct Shape {
    parts: BTreeSet<BTreeSet<u16>>,
    joints: BTreeSet<(BTreeSet<String>, BTreeSet<u16>, BTreeSet<u16>)>,
}

/// The tree the exploration learned.
fn learned_tree(tree: &KinematicTree) -> Shape {
    let cells = |s: usize| tree.body_parts()[s].cells.iter().map(|c| c.0).collect::<BTreeSet<u16>>();
    Shape {
        parts: (0..tree.body_parts().len()).map(cells).collect(),
        joints: tree
            .joints()
            .iter()
            .map(|j| (j.dofs.iter().map(|&d| tree.dof_names()[d].clone()).collect(), cells(j.parent), cells(j.child)))
            .collect(),
    }
}

/// The true tree from the robot's joint chain, as far as a skin can show
/// it: bodies whose cells the same DoFs move (a mimic's body and its
/// master's) are one body part, and a joint is the DoFs between a body
/// part and the nearest body with cells above it. `None` where the skin
/// cannot show a tree: no cell on the root, a DoF that moves no cell, or a
/// DoF between more than one pair of body parts (a bare body carrying two
/// branches).
fn true_tree(world: &World) -> Option<Shape> {
    let robot = world.robot();
    let bodies = robot.bodies().len();
    let mut on_body: Vec<BTreeSet<u16>> = vec![BTreeSet::new(); bodies];
    for c in world.skin().cells() {
        on_body[c.body].insert(c.id.0);
    }
    let names: Vec<&str> = robot.dofs().iter().map(|d| d.name.as_str()).collect();
    // The DoFs on each body's path from the root; parents come first.
    let mut path: Vec<BTreeSet<&str>> = vec![BTreeSet::new(); bodies];
    for b in 1..bodies {
        let j = &robot.joints()[robot.bodies()[b].parent_joint?];
        let (Drive::Dof(d) | Drive::Mimic { dof: d, .. }) = j.drive;
        path[b] = path[j.parent_body].clone();
        path[b].insert(names[d]);
    }
    // Body parts: the cells of all bodies with one path.
    let mut parts: BTreeMap<&BTreeSet<&str>, BTreeSet<u16>> = BTreeMap::new();
    for b in (0..bodies).filter(|&b| !on_body[b].is_empty()) {
        parts.entry(&path[b]).or_default().extend(on_body[b].iter().copied());
    }
    if !parts.contains_key(&BTreeSet::new()) {
        return None;
    }
    let mut joints = BTreeSet::new();
    for b in (1..bodies).filter(|&b| !on_body[b].is_empty() && !path[b].is_empty()) {
        let mut at = b;
        while let Some(j) = robot.bodies()[at].parent_joint {
            at = robot.joints()[j].parent_body;
            if !on_body[at].is_empty() && path[at] != path[b] {
                break;
            }
        }
        let dofs = path[b].difference(&path[at]).map(|d| d.to_string()).collect();
        joints.insert((dofs, parts[&path[at]].clone(), parts[&path[b]].clone()));
    }
    let mut used = vec![0usize; names.len()];
    for (dofs, _, _) in &joints {
        for d in dofs {
            used[names.iter().position(|n| n == d)?] += 1;
        }
    }
    if used.iter().any(|&n| n != 1) {
        return None;
    }
    Some(Shape { parts: parts.into_values().collect(), joints })
}
