//! The wiring of a hexagonal patch.
//!
//! Cells sit on axial hex coordinates; each wires four of its six sides
//! (Figure 6): east (port 0), north-east (port 1), west (port 2) and
//! south-west (port 3), so a link always joins port `d` of one cell to port
//! `d + 2` of the other.

use std::collections::{BTreeMap, BTreeSet, VecDeque};

use skin_protocol::message::Port;

const DIRS: [(i32, i32); 4] = [(1, 0), (1, -1), (-1, 0), (-1, 1)];

/// One end of a link: a cell and its port.
pub type End = (usize, Port);

/// Which port of which cell is joined to which.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Wiring {
    cells: usize,
    peer: BTreeMap<End, End>,
}

fn distance((q, r): (i32, i32)) -> i32 {
    (q.abs() + r.abs() + (q + r).abs()) / 2
}

impl Wiring {
    /// `n` cells filling hexagonal rings around a centre: 7 make the
    /// flower, 19 the next ring.
    pub fn patch(n: usize) -> Wiring {
        let radius = (0..).find(|k: &i32| 3 * k * (k + 1) + 1 >= n as i32).unwrap_or(0);
        let mut coords: Vec<(i32, i32)> =
            (-radius..=radius).flat_map(|q| (-radius..=radius).map(move |r| (q, r))).collect();
        coords.retain(|c| distance(*c) <= radius);
        // Ring by ring, each ring in angular order: deterministic and compact.
        let angle = |(q, r): (i32, i32)| {
            let (x, y) = (f64::from(q) + f64::from(r) / 2.0, f64::from(r) * 3f64.sqrt() / 2.0);
            y.atan2(x)
        };
        coords.sort_by(|a, b| distance(*a).cmp(&distance(*b)).then(angle(*a).total_cmp(&angle(*b))));
        coords.truncate(n);
        let mut peer = BTreeMap::new();
        for (i, &(q, r)) in coords.iter().enumerate() {
            for (d, (dq, dr)) in DIRS.iter().enumerate().take(2) {
                if let Some(j) = coords.iter().position(|c| *c == (q + dq, r + dr)) {
                    let (a, b) = ((i, Port::ALL[d]), (j, Port::ALL[d + 2]));
                    peer.insert(a, b);
                    peer.insert(b, a);
                }
            }
        }
        Wiring { cells: n, peer }
    }

    /// Number of cells.
    pub fn cells(&self) -> usize {
        self.cells
    }

    /// The far end of a port, if it is wired.
    pub fn peer(&self, end: End) -> Option<End> {
        self.peer.get(&end).copied()
    }

    /// Every link once, the lower end first.
    pub fn links(&self) -> Vec<(End, End)> {
        self.peer.iter().filter(|(a, b)| a < b).map(|(a, b)| (*a, *b)).collect()
    }

    /// Ports wired to nothing, in cell order.
    pub fn free_ports(&self) -> Vec<End> {
        (0..self.cells).flat_map(|i| Port::ALL.map(|p| (i, p))).filter(|e| !self.peer.contains_key(e)).collect()
    }

    /// The same wiring with one cell's links cut (the cell is dead).
    pub fn without(&self, cell: usize) -> Wiring {
        let peer = self.peer.iter().filter(|(a, b)| a.0 != cell && b.0 != cell).map(|(a, b)| (*a, *b)).collect();
        Wiring { cells: self.cells, peer }
    }

    /// Cells reachable from `root` (including it).
    pub fn reachable(&self, root: usize) -> BTreeSet<usize> {
        let mut seen = BTreeSet::from([root]);
        let mut queue = VecDeque::from([root]);
        while let Some(i) = queue.pop_front() {
            for p in Port::ALL {
                if let Some((j, _)) = self.peer((i, p)) {
                    if seen.insert(j) {
                        queue.push_back(j);
                    }
                }
            }
        }
        seen
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_flower_is_connected_with_ports_d_to_d_plus_2() {
        let w = Wiring::patch(7);
        // The centre wires all four ports; of the six rim pairs, the four
        // that lie along a port direction are wired.
        assert_eq!(w.links().len(), 8);
        assert!(Port::ALL.iter().all(|p| w.peer((0, *p)).is_some()));
        assert_eq!(w.reachable(0).len(), 7);
        for ((_, p), (_, q)) in w.links() {
            assert_eq!((p.index() + 2) % 4, q.index());
        }
        assert_eq!(w.free_ports().len(), 7 * 4 - 2 * 8);
        // Without the centre the rim falls apart into two arcs of three.
        assert_eq!(w.without(0).reachable(1).len(), 3);
    }
}
