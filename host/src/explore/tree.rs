//! Connectivity and the kinematic tree (sections 4.2.3 and 4.2.4).
//!
//! In a tree, the set of body parts a joint moves is everything beyond it,
//! so the sets of any two joints are either nested or disjoint, and the
//! body part a joint moves first (its child) is moved by exactly the joint
//! and its ancestors. Sorting body parts depth first from the root and
//! numbering each joint after its child puts the merged matrix in strictly
//! lower triangular form, and each joint connects the two rows that differ
//! only in its column: the secondary diagonal of the paper. Any matrix that
//! does not fit this shape is refused with the reason, never forced into a
//! wrong tree.

use std::fmt::Write;

use skin_protocol::Address;

use super::merge::Merged;

/// Why the activity matrix is not a kinematic tree.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum TreeError {
    /// No cell stays still under every DoF: the static reference body part
    /// carries no cells (or the base moved during the exploration). Named:
    /// the stillest cells (moved by the fewest joints) and those joints'
    /// DoFs, which moved what should have been the base.
    #[error("no cell stayed still under every DoF (the stillest, cells {cells:?}, moved with DoF(s) {dofs:?}): put cells on the static reference body part (torso, base)")]
    NoRoot {
        /// The cells moved by the fewest joints.
        cells: Vec<u16>,
        /// The DoFs of the joints that moved them.
        dofs: Vec<String>,
    },
    /// DoFs that move no cell: the body part after them carries no skin.
    #[error("DoF(s) {0:?} move no cell: the body part after them needs at least one cell")]
    IdleDofs(Vec<String>),
    /// Two joints move overlapping but not nested sets of body parts: a
    /// closed loop, or DoFs coupled across branches.
    #[error("joints of DoF(s) {first:?} and {second:?} move overlapping, not nested, sets of cells: a closed loop or coupled DoFs, which the method cannot handle")]
    Overlap {
        /// DoFs of one joint.
        first: Vec<String>,
        /// DoFs of the other.
        second: Vec<String>,
    },
    /// A body part between joints carries no cells, so the joints around it
    /// cannot be told apart.
    #[error(
        "the body part {side} the joint of DoF(s) {dofs:?} carries no cells: put at least one cell on every body part"
    )]
    EmptyBodyPart {
        /// DoFs of the joint.
        dofs: Vec<String>,
        /// "before" (its parent) or "after" (its child).
        side: &'static str,
    },
}

/// A body part: rigid, carrying cells.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BodyPart {
    /// Cells on it.
    pub cells: Vec<Address>,
    /// The joint that carries it (`None` for the root).
    pub parent_joint: Option<usize>,
    /// The joints it carries.
    pub child_joints: Vec<usize>,
}

/// A joint: one or more DoFs between two body parts.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TreeJoint {
    /// DoF indices (interface order).
    pub dofs: Vec<usize>,
    /// The body part it is mounted on.
    pub parent: usize,
    /// The body part it moves.
    pub child: usize,
}

/// The robot's kinematic tree as learned from its skin.
///
/// Body parts are numbered depth first from the root (0), and joint `n`
/// carries body part `n + 1`: the order of the strictly lower triangular
/// merged matrix.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct KinematicTree {
    body_parts: Vec<BodyPart>,
    joints: Vec<TreeJoint>,
    dof_names: Vec<String>,
}

impl KinematicTree {
    /// The tree of a merged activity matrix; `cells` and `dof_names` name
    /// its rows and columns.
    pub fn new(merged: &Merged, cells: &[Address], dof_names: &[String]) -> Result<KinematicTree, TreeError> {
        let names = |dofs: &[usize]| dofs.iter().map(|&d| dof_names[d].clone()).collect::<Vec<_>>();
        if !merged.idle_dofs.is_empty() {
            return Err(TreeError::IdleDofs(names(&merged.idle_dofs)));
        }
        let m = &merged.moves;
        let s_count = m.len();
        let j_count = merged.joints.len();
        let root = (0..s_count).find(|&s| !m[s].contains(&true)).ok_or_else(|| {
            let moved_by = |s: usize| m[s].iter().filter(|&&x| x).count();
            let stillest = (0..s_count).min_by_key(|&s| moved_by(s)).unwrap_or(0);
            let joints = (0..m[stillest].len()).filter(|&j| m[stillest][j]);
            TreeError::NoRoot {
                cells: merged.body_parts[stillest].iter().map(|&u| cells[u].0).collect(),
                dofs: joints.flat_map(|j| names(&merged.joints[j])).collect(),
            }
        })?;
        let moved: Vec<Vec<usize>> = (0..j_count).map(|j| (0..s_count).filter(|&s| m[s][j]).collect()).collect();

        // Laminar: nested or disjoint.
        for a in 0..j_count {
            for b in a + 1..j_count {
                let common = moved[a].iter().filter(|s| m[**s][b]).count();
                if common != 0 && common != moved[a].len() && common != moved[b].len() {
                    return Err(TreeError::Overlap {
                        first: names(&merged.joints[a]),
                        second: names(&merged.joints[b]),
                    });
                }
            }
        }
        // Ancestors of joint j: joints moving a strict superset of its body parts.
        let ancestors = |j: usize| -> Vec<bool> {
            (0..j_count).map(|k| k != j && moved[k].len() > moved[j].len() && m[moved[j][0]][k]).collect()
        };
        let mut child = vec![0; j_count];
        let mut parent = vec![0; j_count];
        for j in 0..j_count {
            let anc = ancestors(j);
            let mut expected = anc.clone();
            expected[j] = true;
            child[j] = (0..s_count)
                .find(|&s| m[s] == expected)
                .ok_or_else(|| TreeError::EmptyBodyPart { dofs: names(&merged.joints[j]), side: "after" })?;
            parent[j] = (0..s_count)
                .find(|&s| m[s] == anc)
                .ok_or_else(|| TreeError::EmptyBodyPart { dofs: names(&merged.joints[j]), side: "before" })?;
        }
        // Every non-root body part is the child of its deepest joint (its
        // row is that joint plus its ancestors), so children are distinct
        // and there are S = J + 1 body parts.
        debug_assert_eq!(s_count, j_count + 1);

        // Depth-first numbering from the root.
        let mut order = Vec::with_capacity(s_count);
        let mut stack = vec![root];
        while let Some(s) = stack.pop() {
            order.push(s);
            let mut kids: Vec<usize> = (0..j_count).filter(|&j| parent[j] == s).collect();
            kids.sort_by_key(|&j| merged.joints[j][0]);
            stack.extend(kids.iter().rev().map(|&j| child[j]));
        }
        let mut number = vec![0; s_count];
        for (n, &s) in order.iter().enumerate() {
            number[s] = n;
        }
        let mut joints: Vec<TreeJoint> = (0..j_count)
            .map(|j| TreeJoint { dofs: merged.joints[j].clone(), parent: number[parent[j]], child: number[child[j]] })
            .collect();
        joints.sort_by_key(|j| j.child);
        let body_parts = order
            .iter()
            .enumerate()
            .map(|(n, &s)| BodyPart {
                cells: merged.body_parts[s].iter().map(|&u| cells[u]).collect(),
                parent_joint: n.checked_sub(1),
                child_joints: (0..j_count).filter(|&j| joints[j].parent == n).collect(),
            })
            .collect();
        Ok(KinematicTree { body_parts, joints, dof_names: dof_names.to_vec() })
    }

    /// Body parts; 0 is the root.
    pub fn body_parts(&self) -> &[BodyPart] {
        &self.body_parts
    }

    /// Joints; joint `n` carries body part `n + 1`.
    pub fn joints(&self) -> &[TreeJoint] {
        &self.joints
    }

    /// DoF names, interface order.
    pub fn dof_names(&self) -> &[String] {
        &self.dof_names
    }

    /// The static reference body part: the null row.
    pub fn root(&self) -> usize {
        0
    }

    /// End effectors: body parts connected to a single joint.
    pub fn leaves(&self) -> Vec<usize> {
        (1..self.body_parts.len()).filter(|&s| self.body_parts[s].child_joints.is_empty()).collect()
    }

    /// Inner nodes: body parts connecting more than two joints, which can
    /// serve as intermediate references for limbs.
    pub fn inner_nodes(&self) -> Vec<usize> {
        (1..self.body_parts.len()).filter(|&s| self.body_parts[s].child_joints.len() >= 2).collect()
    }

    /// Limbs: chains of joints from a reference body part (the root or an
    /// inner node) to an end effector or the next inner node.
    pub fn limbs(&self) -> Vec<Vec<usize>> {
        let mut limbs = Vec::new();
        let references = std::iter::once(self.root()).chain(self.inner_nodes());
        for r in references {
            for &first in &self.body_parts[r].child_joints {
                let mut limb = vec![first];
                let mut s = self.joints[first].child;
                while let [only] = self.body_parts[s].child_joints[..] {
                    limb.push(only);
                    s = self.joints[only].child;
                }
                limbs.push(limb);
            }
        }
        limbs
    }

    /// The merged activity matrix in strictly lower triangular form: row
    /// `s` is body part `s`, column `n` joint `n`.
    pub fn lower_triangular(&self) -> Vec<Vec<bool>> {
        let mut rows = vec![vec![false; self.joints.len()]; self.body_parts.len()];
        for (s, row) in rows.iter_mut().enumerate() {
            let mut at = s;
            while let Some(j) = self.body_parts[at].parent_joint {
                row[j] = true;
                at = self.joints[j].parent;
            }
        }
        rows
    }

    /// The tree as indented text, one body part per line.
    pub fn draw(&self) -> String {
        let mut out = String::new();
        self.draw_from(0, "", &mut out);
        out
    }

    fn draw_from(&self, s: usize, indent: &str, out: &mut String) {
        let part = &self.body_parts[s];
        let label = if s == 0 {
            " (root)"
        } else if part.child_joints.is_empty() {
            " (leaf)"
        } else {
            ""
        };
        let ids: Vec<String> = part.cells.iter().map(|c| c.0.to_string()).collect();
        writeln!(out, "body part {s}{label}: {} cells [{}]", part.cells.len(), ids.join(" ")).expect("String write");
        for (i, &j) in part.child_joints.iter().enumerate() {
            let last = i + 1 == part.child_joints.len();
            let dofs: Vec<&str> = self.joints[j].dofs.iter().map(|&d| self.dof_names[d].as_str()).collect();
            write!(out, "{indent}{} joint {j} [{}] -> ", if last { "└─" } else { "├─" }, dofs.join(", "))
                .expect("String write");
            let deeper = format!("{indent}{}", if last { "   " } else { "│  " });
            self.draw_from(self.joints[j].child, &deeper, out);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::explore::merge::merge;
    use proptest::prelude::*;

    fn names(n: usize) -> Vec<String> {
        (0..n).map(|d| format!("d{d}")).collect()
    }

    fn cells(n: usize) -> Vec<Address> {
        (1..=n as u16).map(Address).collect()
    }

    /// Rows of the activity matrix of a random tree: `parents[j]` is the
    /// joint whose child carries joint `j` (`None`: the root), each body
    /// part gets `per_part` cells.
    fn tree_rows(parents: &[Option<usize>], per_part: usize) -> Vec<Vec<bool>> {
        let d = parents.len();
        let mut rows = vec![vec![false; d]; per_part];
        for j in 0..d {
            let mut row = vec![false; d];
            let mut at = Some(j);
            while let Some(k) = at {
                row[k] = true;
                at = parents[k];
            }
            rows.extend(std::iter::repeat_n(row, per_part));
        }
        rows
    }

    #[test]
    fn the_papers_humanoid_gives_two_limbs_from_the_chest() {
        // Two 3-joint arms on a chest.
        let parents = [None, Some(0), Some(1), None, Some(3), Some(4)];
        let rows = tree_rows(&parents, 2);
        let t = KinematicTree::new(&merge(&rows), &cells(rows.len()), &names(6)).unwrap();
        assert_eq!(t.body_parts().len(), 7);
        assert_eq!(t.body_parts()[0].cells, vec![Address(1), Address(2)]);
        assert_eq!(t.leaves(), vec![3, 6]);
        assert!(t.inner_nodes().is_empty());
        assert_eq!(t.limbs(), vec![vec![0, 1, 2], vec![3, 4, 5]]);
        assert_eq!(t.joints()[3].dofs, vec![3]);
        assert_eq!(t.joints()[3].parent, 0);
        let drawing = t.draw();
        assert!(drawing.starts_with("body part 0 (root): 2 cells [1 2]\n├─ joint 0 [d0] -> body part 1"), "{drawing}");
    }

    #[test]
    fn a_palm_with_two_fingers_is_an_inner_node() {
        let parents = [None, Some(0), Some(1), Some(1)];
        let rows = tree_rows(&parents, 1);
        let t = KinematicTree::new(&merge(&rows), &cells(rows.len()), &names(4)).unwrap();
        assert_eq!(t.inner_nodes(), vec![2]);
        assert_eq!(t.limbs(), vec![vec![0, 1], vec![2], vec![3]]);
    }

    #[test]
    fn matrices_that_are_not_trees_are_refused_with_the_reason() {
        let n = names(3);
        // No still cell.
        let rows = vec![vec![true, false, false], vec![true, true, false], vec![true, true, true]];
        assert_eq!(
            KinematicTree::new(&merge(&rows), &cells(3), &n),
            Err(TreeError::NoRoot { cells: vec![1], dofs: vec!["d0".into()] })
        );
        // DoF 2 moves nothing.
        let rows = vec![vec![false, false, false], vec![true, false, false], vec![true, true, false]];
        assert_eq!(KinematicTree::new(&merge(&rows), &cells(3), &n), Err(TreeError::IdleDofs(vec!["d2".into()])));
        // A closed loop: DoFs 0 and 1 both move cell 2, each also moves one other.
        let rows = vec![vec![false, false], vec![true, false], vec![true, true], vec![false, true]];
        assert!(matches!(KinematicTree::new(&merge(&rows), &cells(4), &n), Err(TreeError::Overlap { .. })));
        // Two fingers on a palm without cells: no row is "DoF 0 only".
        let rows = vec![vec![false, false, false], vec![true, true, false], vec![true, false, true]];
        assert_eq!(
            KinematicTree::new(&merge(&rows), &cells(3), &n),
            Err(TreeError::EmptyBodyPart { dofs: vec!["d0".into()], side: "after" })
        );
    }

    proptest! {
        #[test]
        fn any_tree_is_recovered_and_sorted_to_strictly_lower_triangular(
            links in prop::collection::vec(any::<prop::sample::Index>(), 1..40),
            shuffle in any::<u64>(),
        ) {
            // Joint j hangs off the root or off the child of an earlier joint.
            let parents: Vec<Option<usize>> =
                links.iter().enumerate().map(|(j, i)| i.index(j + 1).checked_sub(1)).collect();
            let mut rows = tree_rows(&parents, 1);
            // The host sees cells in an order unrelated to the tree.
            let mut order: Vec<usize> = (0..rows.len()).collect();
            order.sort_by_key(|&u| (u as u64).wrapping_mul(shuffle | 1).rotate_left(17));
            rows = order.iter().map(|&u| rows[u].clone()).collect();
            let t = KinematicTree::new(&merge(&rows), &cells(rows.len()), &names(parents.len())).unwrap();
            prop_assert_eq!(t.body_parts().len(), parents.len() + 1);
            let lt = t.lower_triangular();
            for (s, row) in lt.iter().enumerate() {
                for (n, &one) in row.iter().enumerate() {
                    prop_assert!(!one || n < s, "entry ({}, {}) above the diagonal", s, n);
                }
                if s > 0 {
                    prop_assert!(row[s - 1], "secondary diagonal broken at row {}", s);
                }
            }
            // Each joint's parent in the tree is the true parent.
            for tj in t.joints() {
                let d = tj.dofs[0];
                let parent_body = t.body_parts()[tj.parent].parent_joint.map(|pj| t.joints()[pj].dofs[0]);
                prop_assert_eq!(parent_body, parents[d]);
            }
        }
    }
}
