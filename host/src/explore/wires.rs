//! Activity entries the skin's wiring settles, without any assumption.
//!
//! A wire joins two cells of one body part, or of two parts one joint
//! apart: a connector spans a pitch, not a limb. Two adjacent parts' rows
//! of the activity matrix differ exactly in the DoFs of the joint between
//! them. So when two wired cells are decided different for a DoF `e`,
//! they sit on either side of `e`'s joint, and for every DoF `d` surely of
//! another joint (some cell is decided moved by one and still by the
//! other; the DoFs of one joint move the same cells) their entries agree:
//! one decided settles the other. Wires only one end reports are not used.

use std::collections::HashMap;

use skin_protocol::message::NeighbourReport;
use skin_protocol::Address;

use super::activity::{Activity, ActivityMatrix, Basis};

/// The wires both ends report, as pairs of row indices of `cells`.
pub(crate) fn pairs(cells: &[Address], tables: &[(Address, NeighbourReport)]) -> Vec<(usize, usize)> {
    let row: HashMap<Address, usize> = cells.iter().enumerate().map(|(u, a)| (*a, u)).collect();
    let table: HashMap<Address, &NeighbourReport> = tables.iter().map(|(a, r)| (*a, r)).collect();
    let reports =
        |a: Address, b: Address| table.get(&a).is_some_and(|r| r.neighbours.iter().flatten().any(|n| n.id == b));
    let mut pairs: Vec<(usize, usize)> = tables
        .iter()
        .flat_map(|(a, r)| r.neighbours.iter().flatten().map(move |n| (*a, n.id)))
        .filter(|&(a, b)| a < b && reports(b, a))
        .filter_map(|(a, b)| Some((*row.get(&a)?, *row.get(&b)?)))
        .collect();
    pairs.sort_unstable();
    pairs.dedup();
    pairs
}

/// DoFs `d` and `e` surely belong to different joints: a cell is decided
/// moved by one and still by the other.
fn different_joints(m: &ActivityMatrix, d: usize, e: usize) -> bool {
    (0..m.cells()).any(|w| {
        let (a, b) = (m.get(w, d), m.get(w, e));
        a != Activity::Unknown && b != Activity::Unknown && a != b
    })
}

/// Settles what the wires imply (see the module's documentation); true if
/// an entry changed. Never turns a decided entry.
pub(crate) fn settle(m: &mut ActivityMatrix, wires: &[(usize, usize)]) -> bool {
    let dofs = m.dofs();
    let mut changed = false;
    for &(u, v) in wires {
        let across: Vec<usize> = (0..dofs)
            .filter(|&e| {
                let (a, b) = (m.get(u, e), m.get(v, e));
                a != Activity::Unknown && b != Activity::Unknown && a != b
            })
            .collect();
        let Some(&e) = across.first() else { continue };
        for d in 0..dofs {
            let (a, b) = (m.get(u, d), m.get(v, d));
            if (a == Activity::Unknown) == (b == Activity::Unknown) || !different_joints(m, d, e) {
                continue;
            }
            let (open, known) = if a == Activity::Unknown { (u, b) } else { (v, a) };
            changed |= m.or(open, d, known, Basis::Wire);
        }
    }
    changed
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use skin_protocol::message::{Neighbour, Port};

    /// A chain of two joints on a root: rows of parts 0 (root), 1, 2.
    fn part_rows() -> [[bool; 2]; 3] {
        [[false, false], [true, false], [true, true]]
    }

    #[test]
    fn a_cell_wired_across_another_joint_takes_its_neighbours_entry() {
        // Cell 0 on the root, undecided for DoF 1, is wired to cell 1 on
        // part 1, across DoF 0's joint; cell 1 is still for DoF 1, so DoF 1
        // is another joint, and cell 0 is still for it too.
        let mut m = ActivityMatrix::unknown(2, 2);
        m.or(0, 0, Activity::Still, Basis::Static { posture: 0 });
        m.or(1, 0, Activity::Moved, Basis::Static { posture: 0 });
        m.or(1, 1, Activity::Still, Basis::Static { posture: 0 });
        assert!(settle(&mut m, &[(0, 1)]));
        assert_eq!(m.get(0, 1), Activity::Still);
        assert_eq!(m.basis(0, 1), Some(Basis::Wire));
    }

    #[test]
    fn dofs_that_may_be_one_joint_settle_nothing() {
        // Cell 1 moves with both DoFs, and nothing yet tells them apart: if
        // they were one joint, cell 0 would be still for both; if two, it
        // could be moved by DoF 1. Open.
        let mut m = ActivityMatrix::unknown(2, 2);
        m.or(0, 0, Activity::Still, Basis::Static { posture: 0 });
        m.or(1, 0, Activity::Moved, Basis::Static { posture: 0 });
        m.or(1, 1, Activity::Moved, Basis::Static { posture: 0 });
        assert!(!settle(&mut m, &[(0, 1)]));
        assert_eq!(m.get(0, 1), Activity::Unknown);
    }

    #[test]
    fn only_wires_both_ends_report_are_used() {
        let cells = [Address(10), Address(11), Address(12)];
        let link = |id: u16| Some(Neighbour { id: Address(id), port: Port::P0 });
        let mut a = NeighbourReport::default();
        a.neighbours[0] = link(11);
        a.neighbours[1] = link(12);
        let mut b = NeighbourReport::default();
        b.neighbours[2] = link(10);
        let tables = [(Address(10), a), (Address(11), b), (Address(12), NeighbourReport::default())];
        assert_eq!(pairs(&cells, &tables), vec![(0, 1)]);
    }

    proptest! {
        /// Whatever is known of a true chain's matrix, and whichever cells
        /// are wired within a part or across one joint, the wires never
        /// contradict the truth.
        #[test]
        fn wires_never_contradict_the_truth(
            parts in prop::collection::vec(0usize..3, 6),
            known in prop::collection::vec(any::<bool>(), 12),
            wired in prop::collection::vec((0usize..6, 0usize..6), 0..8),
        ) {
            let rows = part_rows();
            let mut m = ActivityMatrix::unknown(6, 2);
            for (i, &k) in known.iter().enumerate() {
                let (u, d) = (i / 2, i % 2);
                if k {
                    let a = if rows[parts[u]][d] { Activity::Moved } else { Activity::Still };
                    m.or(u, d, a, Basis::Static { posture: 0 });
                }
            }
            let wires: Vec<(usize, usize)> =
                wired.into_iter().filter(|&(u, v)| u != v && parts[u].abs_diff(parts[v]) <= 1).collect();
            while settle(&mut m, &wires) {}
            for (u, &part) in parts.iter().enumerate() {
                for (d, &moved) in rows[part].iter().enumerate() {
                    let truth = if moved { Activity::Moved } else { Activity::Still };
                    prop_assert!(m.get(u, d) == Activity::Unknown || m.get(u, d) == truth, "cell {} DoF {}", u, d);
                }
            }
        }
    }
}
