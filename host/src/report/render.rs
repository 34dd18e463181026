//! Draws the report's figures from its data, into the report folder.

use std::path::Path;

use super::figures::{self, tree_colour, DrawnNode, Grid};
use super::schema::{Figure, Report};
use super::ReportError;

/// Draws figures from a report into a folder, and lists them.
pub(super) struct Renderer<'a> {
    pub(super) report: &'a Report,
    pub(super) dir: &'a Path,
    /// The figures drawn so far.
    pub(super) figures: Vec<Figure>,
}

impl<'a> Renderer<'a> {
    /// Draws every figure.
    pub(super) fn draw_all(&mut self) -> Result<(), ReportError> {
        self.draw_activity()?;
        self.draw_tree()?;
        self.draw_smm()?;
        self.draw_topology()?;
        #[cfg(feature = "sim")]
        self.draw_latency()?;
        self.draw_calibration()?;
        #[cfg(feature = "sim")]
        self.draw_grasps()?;
        Ok(())
    }

    fn draw_calibration(&mut self) -> Result<(), ReportError> {
        let Some(c) = &self.report.calibration else { return Ok(()) };
        let p = &c.picture;
        self.figure(
            "calibration.svg",
            "The calibrated skin",
            format!(
                "Every cell where the calibration puts it on the robot's description, start posture, from the front, the side and above: {} cells in 3D, {} in part, {} unobservable; the stroke is each accelerometer's z axis.",
                c.cells_3d, c.cells_partial, c.cells_unobservable
            ),
            |path| {
                figures::skin_views(
                    path,
                    &figures::SkinViews {
                        title: "calibrated skin (blue: estimate and its z axis; red ring: truth where known)",
                        bones: &p.bones,
                        cells: &p.cells,
                        truth: &p.truth,
                    },
                )
            },
        )
    }

    pub(super) fn figure(
        &mut self,
        file: &str,
        title: &str,
        caption: String,
        draw: impl FnOnce(&Path) -> Result<(), figures::DrawError>,
    ) -> Result<(), ReportError> {
        draw(&self.dir.join(file)).map_err(|e| ReportError::Draw { file: file.to_owned(), message: e.to_string() })?;
        self.figures.push(Figure { file: file.to_owned(), title: title.to_owned(), caption });
        Ok(())
    }

    fn draw_activity(&mut self) -> Result<(), ReportError> {
        let e = &self.report.exploration;
        let as_values = |m: &[Vec<bool>]| -> Vec<Vec<f64>> {
            m.iter().map(|r| r.iter().map(|&b| f64::from(u8::from(b))).collect()).collect()
        };
        let rows: Vec<String> = e.cells.iter().map(|c| format!("cell {c}")).collect();
        let before = as_values(&e.activity);
        self.figure(
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

    fn draw_tree(&mut self) -> Result<(), ReportError> {
        let e = &self.report.exploration;
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
        self.figure("kinematic_tree.svg", "Kinematic tree", caption, |path| {
            figures::forest(path, "learned kinematic tree: body parts and joints", &nodes, &[], &[])
        })
    }

    fn draw_smm(&mut self) -> Result<(), ReportError> {
        let e = &self.report.exploration;
        let rows: Vec<String> = e.cells.iter().map(|c| format!("cell {c}")).collect();
        let values: Vec<Vec<f64>> = e.smm_weights.iter().map(|r| r.iter().map(|&w| f64::from(w)).collect()).collect();
        self.figure(
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

    fn draw_topology(&mut self) -> Result<(), ReportError> {
        let cells = &self.report.organization.cells;
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
        self.figure("topology.svg", "Skin topology", caption, |path| {
            figures::forest(path, "skin topology: interface trees and links", &nodes, &extra, &legend)
        })
    }
}
