//! The report folder of `skin demo` and `skin run`: every figure as an SVG
//! file, `report.json` with the data of every figure, and `index.html`
//! showing them together (open it in any browser; it needs nothing else).

pub mod figures;
mod html;

use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::explore::Exploration;
use crate::grasping::{write_traces, GraspRun, Lesson};
use crate::interface::InterfaceCounters;
use crate::pipeline::Organized;
use figures::{tree_colour, DrawnNode, Grid};

/// Why the report could not be written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ReportError {
    /// A file or the folder could not be written.
    #[error("cannot write {path}: {message} (choose another folder with --out DIR)")]
    Write {
        /// The file or folder.
        path: String,
        /// What went wrong.
        message: String,
    },
    /// A figure could not be drawn.
    #[error("cannot draw {file}: {message}")]
    Draw {
        /// The figure's file.
        file: String,
        /// What went wrong.
        message: String,
    },
}

/// The robot as it described itself on the robot link.
#[derive(Clone, Debug, Serialize)]
pub struct RobotSection {
    /// What was driven, e.g. the built-in simulated robot or an address.
    pub source: String,
    /// DoF names, command order.
    pub dof_names: Vec<String>,
    /// Control period, s.
    pub period_s: f64,
    /// One period per command (a simulator) rather than real time.
    pub lockstep: bool,
}

/// How long each step took, on the wall clock and on the robot's clock.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Timing {
    /// Everything, from the start until the report's files were written, wall clock, s.
    pub total_wall_s: f64,
    /// Self-organization, wall clock, s.
    pub organize_wall_s: f64,
    /// Structural and sensory-motor exploration, wall clock, s.
    pub explore_wall_s: f64,
    /// Teaching and grasping, wall clock, s.
    pub grasp_wall_s: f64,
    /// Self-organization, robot time, s.
    pub organize_robot_s: f64,
    /// Structural exploration, robot time, s.
    pub structure_robot_s: f64,
    /// Sensory-motor exploration, robot time, s.
    pub smm_robot_s: f64,
}

/// The robot link's trouble.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct LinkSection {
    /// Requests sent again.
    pub retries: u64,
    /// Datagrams that were not the answer awaited.
    pub ignored: u64,
}

/// One joint of the learned tree.
#[derive(Clone, Debug, Serialize)]
pub struct JointSection {
    /// Its DoFs by name.
    pub dofs: Vec<String>,
    /// The body part it is mounted on.
    pub parent_body_part: usize,
    /// The body part it moves.
    pub child_body_part: usize,
}

/// What the exploration learned.
#[derive(Clone, Debug, Serialize)]
pub struct ExplorationSection {
    /// Cell IDs, the rows of `activity` and `smm_weights`.
    pub cells: Vec<u16>,
    /// DoF names, their columns.
    pub dofs: Vec<String>,
    /// The activity matrix before merging: does DoF d move cell u.
    pub activity: Vec<Vec<bool>>,
    /// Body parts (merged cells), depth first from the root.
    pub body_parts: Vec<Vec<u16>>,
    /// Joints (merged DoFs); joint n carries body part n + 1.
    pub joints: Vec<JointSection>,
    /// The merged matrix, strictly lower triangular: body parts x joints.
    pub merged: Vec<Vec<bool>>,
    /// Body parts without child joints.
    pub leaves: Vec<usize>,
    /// Chains of joints from the root to each leaf.
    pub limbs: Vec<Vec<usize>>,
    /// The pose of the sensory-motor map's first tile, rad.
    pub smm_pose_rad: Vec<f64>,
    /// Its weights, cells x DoFs, in [-1, 1].
    pub smm_weights: Vec<Vec<f32>>,
    /// What the user should know.
    pub warnings: Vec<String>,
}

/// Latency of the skin network's sensor frames (from the simulator).
#[derive(Clone, Debug, Serialize)]
pub struct LatencySection {
    /// (microseconds, frames), smallest first.
    pub bins_us: Vec<(u64, u64)>,
    /// Frames counted.
    pub frames: u64,
    /// Median, us.
    pub p50_us: u64,
    /// 99th percentile, us.
    pub p99_us: u64,
    /// Largest, us.
    pub max_us: u64,
    /// Sensor frames lost in the network.
    pub sensor_frames_lost: u64,
}

impl LatencySection {
    /// From a histogram as (microseconds, frames).
    pub fn new(bins_us: Vec<(u64, u64)>, sensor_frames_lost: u64) -> LatencySection {
        let frames: u64 = bins_us.iter().map(|b| b.1).sum();
        let at = |q: f64| skin_sim::network::ledger::quantile(bins_us.iter().copied(), frames, q).unwrap_or(0);
        LatencySection {
            frames,
            p50_us: at(0.5),
            p99_us: at(0.99),
            max_us: bins_us.last().map_or(0, |b| b.0),
            sensor_frames_lost,
            bins_us,
        }
    }
}

/// Teaching and grasping.
#[derive(Clone, Debug, Serialize)]
pub struct GraspSection {
    /// How they were run.
    pub how: String,
    /// Each key pose taught.
    pub lessons: Vec<Lesson>,
    /// Each grasp (traces in the CSV and SVG files).
    pub runs: Vec<GraspRun>,
}

/// The host's results checked against what only the simulator knows.
#[derive(Clone, Debug, Serialize)]
pub struct TruthSection {
    /// Cells of the simulated skin.
    pub cells_in_skin: usize,
    /// Cells with an ID.
    pub cells_with_id: usize,
    /// No two cells share an ID.
    pub ids_unique: bool,
    /// Every cell's neighbour table in the registry is the true one.
    pub neighbours_correct: bool,
    /// The learned kinematic tree is the true one.
    pub tree_correct: bool,
    /// Activity matrix entries that differ from the truth.
    pub wrong_activity_entries: usize,
    /// Mean |w - w_true| of the sensory-motor map.
    pub smm_mean_abs_error: f64,
    /// The same where the DoF truly moves the cell.
    pub smm_mean_abs_error_moved: f64,
}

/// One figure of the report.
#[derive(Clone, Debug, Serialize)]
pub struct Figure {
    /// File name in the report folder.
    pub file: String,
    /// Heading.
    pub title: String,
    /// What it shows.
    pub caption: String,
}

/// Everything the report holds; serialized as `report.json`.
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    /// The robot.
    pub robot: RobotSection,
    /// How long each step took.
    pub timing: Timing,
    /// The organized skin.
    pub organization: Organized,
    /// What the interface counted.
    pub interface: InterfaceCounters,
    /// The robot link's trouble.
    pub link: LinkSection,
    /// What the exploration learned.
    pub exploration: ExplorationSection,
    /// Network latency (simulated skins only).
    pub latency: Option<LatencySection>,
    /// Teaching and grasps (simulation only).
    pub grasps: Option<GraspSection>,
    /// Checks against the simulator's truth (simulation only).
    pub truth: Option<TruthSection>,
    /// The figures, in the order `index.html` shows them.
    pub figures: Vec<Figure>,
}

impl ExplorationSection {
    /// The parts of an exploration the report shows.
    pub fn new(found: &Exploration) -> ExplorationSection {
        let tree = &found.tree;
        let tile = &found.smm.tiles()[0];
        ExplorationSection {
            cells: found.cells.iter().map(|a| a.0).collect(),
            dofs: found.dof_names.clone(),
            activity: found.activity.rows(),
            body_parts: tree.body_parts().iter().map(|p| p.cells.iter().map(|a| a.0).collect()).collect(),
            joints: tree
                .joints()
                .iter()
                .map(|j| JointSection {
                    dofs: j.dofs.iter().map(|&d| found.dof_names[d].clone()).collect(),
                    parent_body_part: j.parent,
                    child_body_part: j.child,
                })
                .collect(),
            merged: tree.lower_triangular(),
            leaves: tree.leaves(),
            limbs: tree.limbs(),
            smm_pose_rad: tile.pose().to_vec(),
            smm_weights: (0..found.cells.len()).map(|u| tile.weights(u).to_vec()).collect(),
            warnings: found.warnings.clone(),
        }
    }
}

impl Report {
    /// Draws every figure into `dir` (created if missing), then writes
    /// `report.json` and `index.html`; returns the files written.
    pub fn write(&mut self, dir: &Path) -> Result<Vec<PathBuf>, ReportError> {
        let fail = |path: &Path, e: &dyn std::fmt::Display| ReportError::Write {
            path: path.display().to_string(),
            message: e.to_string(),
        };
        std::fs::create_dir_all(dir).map_err(|e| fail(dir, &e))?;
        self.figures.clear();
        self.draw_activity(dir)?;
        self.draw_tree(dir)?;
        self.draw_smm(dir)?;
        self.draw_topology(dir)?;
        self.draw_latency(dir)?;
        self.draw_grasps(dir)?;
        let mut written: Vec<PathBuf> = self.figures.iter().map(|f| dir.join(&f.file)).collect();
        let json = dir.join("report.json");
        let text = serde_json::to_string_pretty(self).map_err(|e| fail(&json, &e))?;
        std::fs::write(&json, text).map_err(|e| fail(&json, &e))?;
        let index = dir.join("index.html");
        std::fs::write(&index, html::page(self)).map_err(|e| fail(&index, &e))?;
        written.extend([json, index]);
        Ok(written)
    }

    fn figure(
        &mut self,
        dir: &Path,
        file: &str,
        title: &str,
        caption: String,
        draw: impl FnOnce(&Path) -> Result<(), figures::DrawError>,
    ) -> Result<(), ReportError> {
        draw(&dir.join(file)).map_err(|e| ReportError::Draw { file: file.to_owned(), message: e.to_string() })?;
        self.figures.push(Figure { file: file.to_owned(), title: title.to_owned(), caption });
        Ok(())
    }

    fn draw_activity(&mut self, dir: &Path) -> Result<(), ReportError> {
        let e = self.exploration.clone();
        let as_values = |m: &[Vec<bool>]| -> Vec<Vec<f64>> {
            m.iter().map(|r| r.iter().map(|&b| f64::from(u8::from(b))).collect()).collect()
        };
        let rows: Vec<String> = e.cells.iter().map(|c| format!("cell {c}")).collect();
        let before = as_values(&e.activity);
        self.figure(
            dir,
            "activity_before.svg",
            "Activity matrix before merging",
            format!(
                "{} cells x {} DoFs: dark where stepping the DoF moved the cell (its gravity vector, or its lever arm's dynamic acceleration; section 4.2).",
                e.cells.len(),
                e.dofs.len()
            ),
            |path| {
                figures::grid(
                    path,
                    &Grid {
                        title: "activity: cells (rows) moved by DoFs (columns)",
                        rows: &rows,
                        columns: &e.dofs,
                        values: &before,
                        signed: false,
                    },
                )
            },
        )?;
        let parts: Vec<String> =
            e.body_parts.iter().enumerate().map(|(s, cells)| format!("part {s} ({} cells)", cells.len())).collect();
        let joints: Vec<String> =
            e.joints.iter().enumerate().map(|(n, j)| format!("joint {n}: {}", j.dofs.join("+"))).collect();
        let after = as_values(&e.merged);
        self.figure(
            dir,
            "activity_after.svg",
            "Activity matrix after merging",
            format!(
                "Equal rows merged into {} body parts, equal columns into {} joints, sorted strictly lower triangular: the kinematic tree's incidence.",
                e.body_parts.len(),
                e.joints.len()
            ),
            |path| {
                figures::grid(
                    path,
                    &Grid {
                        title: "merged activity: body parts (rows) moved by joints (columns)",
                        rows: &parts,
                        columns: &joints,
                        values: &after,
                        signed: false,
                    },
                )
            },
        )
    }

    fn draw_tree(&mut self, dir: &Path) -> Result<(), ReportError> {
        let e = &self.exploration;
        let nodes: Vec<DrawnNode> = e
            .body_parts
            .iter()
            .enumerate()
            .map(|(s, cells)| DrawnNode {
                label: format!("{s}: {}", cells.len()),
                parent: (s > 0).then(|| e.joints.get(s - 1).map(|j| (j.parent_body_part, j.dofs.join("+")))).flatten(),
                colour: tree_colour(if s == 0 { 3 } else { 0 }),
            })
            .collect();
        let caption = format!(
            "{} body parts (number: cells on it; 0 is the static root) joined by {} joints named by their DoFs; {} limbs.",
            e.body_parts.len(),
            e.joints.len(),
            e.limbs.len()
        );
        self.figure(dir, "kinematic_tree.svg", "Kinematic tree", caption, |path| {
            figures::forest(path, "learned kinematic tree: body parts and joints", &nodes, &[], &[])
        })
    }

    fn draw_smm(&mut self, dir: &Path) -> Result<(), ReportError> {
        let e = self.exploration.clone();
        let rows: Vec<String> = e.cells.iter().map(|c| format!("cell {c}")).collect();
        let values: Vec<Vec<f64>> = e.smm_weights.iter().map(|r| r.iter().map(|&w| f64::from(w)).collect()).collect();
        self.figure(
            dir,
            "sensory_motor_map.svg",
            "Sensory-motor map",
            "Weight of each DoF (column) for moving each cell (row) along its surface normal at the start pose (equations 10-12, decoupled): red moves the cell inward, blue outward, white not at all.".to_owned(),
            |path| {
                figures::grid(
                    path,
                    &Grid {
                        title: "sensory-motor map: cells x DoFs, weights in [-1, 1]",
                        rows: &rows,
                        columns: &e.dofs,
                        values: &values,
                        signed: true,
                    },
                )
            },
        )
    }

    fn draw_topology(&mut self, dir: &Path) -> Result<(), ReportError> {
        let cells = &self.organization.cells;
        let index: std::collections::HashMap<u16, usize> = cells.iter().enumerate().map(|(i, c)| (c.id, i)).collect();
        let mut ports: Vec<u8> = cells.iter().map(|c| c.interface).collect();
        ports.sort_unstable();
        ports.dedup();
        // One root node per interface port, then the cells.
        let mut nodes: Vec<DrawnNode> =
            ports.iter().map(|&k| DrawnNode { label: format!("I{k}"), parent: None, colour: tree_colour(k) }).collect();
        let port_node = |k: u8| ports.iter().position(|&p| p == k).unwrap_or(0);
        for c in cells {
            let parent = match c.parent.and_then(|p| index.get(&p)) {
                Some(&i) => ports.len() + i,
                None => port_node(c.interface),
            };
            nodes.push(DrawnNode {
                label: c.id.to_string(),
                parent: Some((parent, String::new())),
                colour: tree_colour(c.interface),
            });
        }
        let mut extra = Vec::new();
        for (i, c) in cells.iter().enumerate() {
            for [id, _] in c.neighbours.iter().flatten() {
                if let Some(&j) = index.get(id) {
                    let tree_edge = c.parent == Some(*id) || cells[j].parent == Some(c.id);
                    if i < j && !tree_edge {
                        extra.push((ports.len() + i, ports.len() + j));
                    }
                }
            }
        }
        let legend: Vec<(String, _)> = ports
            .iter()
            .map(|&k| {
                (
                    format!("interface port {k}: {} cells", cells.iter().filter(|c| c.interface == k).count()),
                    tree_colour(k),
                )
            })
            .collect();
        let caption = format!(
            "{} cells in {} master-port trees, one per interface port (coloured), as the cells reported them; grey: the other cell-to-cell links. Numbers are the IDs the host assigned.",
            cells.len(),
            ports.len()
        );
        self.figure(dir, "topology.svg", "Skin topology", caption, |path| {
            figures::forest(path, "skin topology: interface trees and links", &nodes, &extra, &legend)
        })
    }

    fn draw_latency(&mut self, dir: &Path) -> Result<(), ReportError> {
        let Some(l) = self.latency.clone() else { return Ok(()) };
        // The bulk up to half again the 99th percentile, in about 60 bins.
        let x_max = (l.p99_us.max(1) as f64 * 1.5).ceil();
        let width_us = (x_max / 60.0).ceil().max(1.0);
        let mut bins: Vec<(f64, u64)> = Vec::new();
        for &(us, n) in &l.bins_us {
            let lo = (us as f64 / width_us).floor() * width_us;
            match bins.last_mut() {
                Some(b) if b.0 == lo => b.1 += n,
                _ => bins.push((lo, n)),
            }
        }
        let caption = format!(
            "{} sensor frames from sampling to the host's socket: median {} us, 99% within {} us, longest {} us ({} frames beyond {x_max} us not drawn); {} lost.",
            l.frames,
            l.p50_us,
            l.p99_us,
            l.max_us,
            l.bins_us.iter().filter(|b| b.0 as f64 >= x_max).map(|b| b.1).sum::<u64>(),
            l.sensor_frames_lost
        );
        self.figure(dir, "latency.svg", "Network latency", caption, |path| {
            figures::histogram(path, "skin network: latency of sensor frames", "latency (us)", &bins, width_us, x_max)
        })
    }

    fn draw_grasps(&mut self, dir: &Path) -> Result<(), ReportError> {
        let Some(g) = &self.grasps else { return Ok(()) };
        let written = write_traces(dir, &g.runs)
            .map_err(|e| ReportError::Write { path: dir.display().to_string(), message: e.to_string() })?;
        for (run, svg) in
            g.runs.clone().iter().zip(written.iter().filter(|p| p.extension().is_some_and(|e| e == "svg")))
        {
            let file = svg.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default();
            self.figures.push(Figure {
                title: format!("Grasp: {}", run.object),
                caption: format!(
                    "{} in {:.1} s, ending in {}; largest force on one cell {:.2} N. Joint positions, summed force and highest proximity per touch area against time after the launching pat; grey lines mark state changes (Figure 18). Data: {}.",
                    if run.succeeded { "Held" } else { "NOT held" },
                    run.time_s,
                    run.final_state.name(),
                    run.max_cell_force_n,
                    file.replace(".svg", ".csv")
                ),
                file,
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::LatencySection;

    #[test]
    fn latency_quantiles_come_from_the_counts() {
        let l = LatencySection::new(vec![(100, 50), (200, 49), (900, 1)], 3);
        assert_eq!((l.frames, l.p50_us, l.p99_us, l.max_us, l.sensor_frames_lost), (100, 100, 200, 900, 3));
        let empty = LatencySection::new(Vec::new(), 0);
        assert_eq!((empty.frames, empty.p50_us, empty.max_us), (0, 0, 0));
    }
}
