//! The learned tree on the robot's own description: which URDF body each
//! learned body part is, and which URDF DoF each interface DoF is.
//!
//! The robot link names its DoFs, so the DoFs match by name. A body part is
//! then the URDF body moved by exactly the DoFs on its path from the root.
//! Several bodies can share that set (a mimic joint's child and its
//! master's): all of them stay candidates and the still fit, whose gravity
//! directions differ between them, chooses.

use std::collections::HashMap;

use skin_model::robot::Robot as Model;
use skin_protocol::Address;

use super::CalibrateError;
use crate::explore::Exploration;

/// Where the learned tree sits on the description.
#[derive(Clone, Debug)]
pub struct Matching {
    /// `urdf_dof[d]`: the description's DoF for interface DoF `d`.
    pub urdf_dof: Vec<usize>,
    /// For each cell (exploration order), the bodies it may sit on.
    pub candidates: Vec<Vec<usize>>,
}

/// Matches `found` onto `model`.
pub fn matching(found: &Exploration, model: &Model) -> Result<Matching, CalibrateError> {
    let names: Vec<&str> = model.dofs().iter().map(|d| d.name.as_str()).collect();
    let missing: Vec<String> = found.dof_names.iter().filter(|n| !names.contains(&n.as_str())).cloned().collect();
    let unused: Vec<String> =
        names.iter().filter(|n| !found.dof_names.iter().any(|f| f == *n)).map(|n| (*n).to_owned()).collect();
    if !missing.is_empty() || !unused.is_empty() {
        return Err(CalibrateError::DofMismatch { missing, unused });
    }
    let urdf_dof: Vec<usize> =
        found.dof_names.iter().map(|n| names.iter().position(|m| m == n).expect("checked above")).collect();

    let moved: Vec<Vec<bool>> = (0..names.len()).map(|d| model.moved_by(d)).collect();
    let bodies = model.bodies().len();
    let tree = &found.tree;
    let mut by_cell: HashMap<Address, Vec<usize>> = HashMap::new();
    for (part_index, part) in tree.body_parts().iter().enumerate() {
        // The DoFs on the path from the root.
        let mut path = vec![false; names.len()];
        let mut at = part_index;
        while let Some(j) = tree.body_parts()[at].parent_joint {
            let joint = &tree.joints()[j];
            for &d in &joint.dofs {
                path[urdf_dof[d]] = true;
            }
            at = joint.parent;
        }
        let candidates: Vec<usize> =
            (0..bodies).filter(|&b| (0..names.len()).all(|d| moved[d][b] == path[d])).collect();
        if candidates.is_empty() {
            let dofs: Vec<&str> = (0..names.len()).filter(|&d| path[d]).map(|d| names[d]).collect();
            return Err(CalibrateError::NoSuchBody { cells: part.cells.clone(), dofs: dofs.join(", ") });
        }
        by_cell.extend(part.cells.iter().map(|c| (*c, candidates.clone())));
    }
    let candidates = found.cells.iter().map(|c| by_cell.remove(c).unwrap_or_default()).collect();
    Ok(Matching { urdf_dof, candidates })
}
