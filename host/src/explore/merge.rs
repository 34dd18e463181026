//! Segment and joint merging (section 4.2.2).
//!
//! Cells that the same DoFs move ride on the same rigid body part; DoFs
//! that move the same cells sit between the same two body parts and form
//! one joint. What remains is the merged activity matrix: one row per body
//! part, one column per joint.

/// The merged activity matrix.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Merged {
    /// Cells (row indices of the activity matrix) of each body part, in the
    /// order of their first cell.
    pub body_parts: Vec<Vec<usize>>,
    /// DoFs of each joint, in the order of their first DoF.
    pub joints: Vec<Vec<usize>>,
    /// DoFs that move no cell at all.
    pub idle_dofs: Vec<usize>,
    /// `moves[s][j]`: joint `j` moves body part `s`.
    pub moves: Vec<Vec<bool>>,
}

/// Merges identical rows into body parts and identical columns into joints.
pub fn merge(rows: &[Vec<bool>]) -> Merged {
    let dofs = rows.first().map_or(0, Vec::len);
    let mut body_parts: Vec<Vec<usize>> = Vec::new();
    for (u, row) in rows.iter().enumerate() {
        match body_parts.iter_mut().find(|cells| rows[cells[0]] == *row) {
            Some(cells) => cells.push(u),
            None => body_parts.push(vec![u]),
        }
    }
    let column = |d: usize| -> Vec<bool> { body_parts.iter().map(|cells| rows[cells[0]][d]).collect() };
    let mut joints: Vec<(Vec<bool>, Vec<usize>)> = Vec::new();
    let mut idle_dofs = Vec::new();
    for d in 0..dofs {
        let col = column(d);
        if !col.contains(&true) {
            idle_dofs.push(d);
            continue;
        }
        match joints.iter_mut().find(|(c, _)| *c == col) {
            Some((_, ds)) => ds.push(d),
            None => joints.push((col, vec![d])),
        }
    }
    let moves = (0..body_parts.len()).map(|s| joints.iter().map(|(col, _)| col[s]).collect()).collect();
    Merged { body_parts, joints: joints.into_iter().map(|(_, ds)| ds).collect(), idle_dofs, moves }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_two_dof_shoulder_without_cells_between_becomes_one_joint() {
        // Cells 0, 3 on the base; 1 on the upper arm (DoFs 0, 1); 2 on the forearm (+ DoF 2).
        let rows =
            vec![vec![false, false, false], vec![true, true, false], vec![true, true, true], vec![false, false, false]];
        let m = merge(&rows);
        assert_eq!(m.body_parts, vec![vec![0, 3], vec![1], vec![2]]);
        assert_eq!(m.joints, vec![vec![0, 1], vec![2]]);
        assert!(m.idle_dofs.is_empty());
        assert_eq!(m.moves, vec![vec![false, false], vec![true, false], vec![true, true]]);
    }

    #[test]
    fn a_dof_that_moves_nothing_is_set_aside() {
        let m = merge(&[vec![false, false], vec![true, false]]);
        assert_eq!(m.joints, vec![vec![0]]);
        assert_eq!(m.idle_dofs, vec![1]);
    }
}
