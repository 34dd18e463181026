//! Dense indexing of cells and the sparse set of cells that need work.
//!
//! The map, the reactions and the events keep per-cell state in plain
//! vectors indexed by the cell's row in the sensory-motor map, so a sample
//! costs one table look-up; the [`SparseSet`] lists the few rows that are
//! stimulated, so a control step visits those and no others.

use skin_protocol::Address;

use super::ControlError;

const NONE: u32 = u32::MAX;

/// Address to row and back, for the cells the sensory-motor map knows.
#[derive(Clone, Debug)]
pub struct CellIndex {
    cells: Vec<Address>,
    row_of: Vec<u32>,
}

impl CellIndex {
    /// Rows in the order given; an address that is not a cell ID or is
    /// listed twice is refused.
    pub fn new(cells: &[Address]) -> Result<CellIndex, ControlError> {
        let mut row_of = vec![NONE; usize::from(u16::MAX) + 1];
        for (row, &a) in cells.iter().enumerate() {
            if !a.is_cell() {
                return Err(ControlError::NotACell(a.0));
            }
            let slot = &mut row_of[usize::from(a.0)];
            if *slot != NONE {
                return Err(ControlError::DuplicateCell(a.0));
            }
            *slot = row as u32;
        }
        Ok(CellIndex { cells: cells.to_vec(), row_of })
    }

    /// The row of a cell, `None` for a cell the map does not know.
    pub fn row(&self, cell: Address) -> Option<usize> {
        let r = self.row_of[usize::from(cell.0)];
        (r != NONE).then_some(r as usize)
    }

    /// The cell of a row.
    pub fn address(&self, row: usize) -> Address {
        self.cells[row]
    }

    /// All cells in row order.
    pub fn cells(&self) -> &[Address] {
        &self.cells
    }

    /// Number of cells.
    pub fn len(&self) -> usize {
        self.cells.len()
    }

    /// True when there are no cells.
    pub fn is_empty(&self) -> bool {
        self.cells.is_empty()
    }
}

/// A set of rows `0..n` with O(1) insert, remove and membership, and
/// iteration over members only.
#[derive(Clone, Debug)]
pub struct SparseSet {
    members: Vec<u32>,
    position: Vec<u32>,
}

impl SparseSet {
    /// An empty set over rows `0..n`.
    pub fn new(n: usize) -> SparseSet {
        SparseSet { members: Vec::new(), position: vec![NONE; n] }
    }

    /// Adds a row (no-op when present).
    pub fn insert(&mut self, row: usize) {
        if self.position[row] == NONE {
            self.position[row] = self.members.len() as u32;
            self.members.push(row as u32);
        }
    }

    /// Removes a row (no-op when absent).
    pub fn remove(&mut self, row: usize) {
        let p = self.position[row];
        if p != NONE {
            let last = *self.members.last().expect("a member exists");
            self.members.swap_remove(p as usize);
            if last as usize != row {
                self.position[last as usize] = p;
            }
            self.position[row] = NONE;
        }
    }

    /// Whether a row is in the set.
    pub fn contains(&self, row: usize) -> bool {
        self.position[row] != NONE
    }

    /// The members, in no particular order.
    pub fn rows(&self) -> impl Iterator<Item = usize> + '_ {
        self.members.iter().map(|&r| r as usize)
    }

    /// Number of members.
    pub fn len(&self) -> usize {
        self.members.len()
    }

    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.members.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::collections::BTreeSet;

    #[test]
    fn index_refuses_duplicates_and_non_cells() {
        assert!(matches!(CellIndex::new(&[Address(3), Address(3)]), Err(ControlError::DuplicateCell(3))));
        assert!(matches!(CellIndex::new(&[Address::HOST]), Err(ControlError::NotACell(0xFFFE))));
        let ix = CellIndex::new(&[Address(7), Address(2)]).unwrap();
        assert_eq!(ix.row(Address(2)), Some(1));
        assert_eq!(ix.row(Address(5)), None);
        assert_eq!(ix.row(Address::BROADCAST), None);
        assert_eq!(ix.address(0), Address(7));
    }

    proptest! {
        /// The sparse set behaves like an ordered set under any sequence of
        /// inserts and removes.
        #[test]
        fn sparse_set_is_a_set(ops in proptest::collection::vec((any::<bool>(), 0usize..50), 0..300)) {
            let mut s = SparseSet::new(50);
            let mut model = BTreeSet::new();
            for (insert, row) in ops {
                if insert { s.insert(row); model.insert(row); } else { s.remove(row); model.remove(&row); }
                prop_assert_eq!(s.len(), model.len());
                prop_assert_eq!(s.rows().collect::<BTreeSet<_>>(), model.clone());
                prop_assert!((0..50).all(|r| s.contains(r) == model.contains(&r)));
            }
        }
    }
}
