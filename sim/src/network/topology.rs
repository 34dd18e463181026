//! The wiring of a skin: cells, the links between their ports, and the
//! interface ports attached to free cell ports.
//!
//! Hexagonal patches are wired as on the real cell (Figure 6): each cell
//! connects 4 of its 6 sides, east (port 0), north-east (1), west (2) and
//! south-west (3), so every port meets its opposite (0-2, 1-3) on the
//! neighbour. Patches can be joined by cables between free ports, and any
//! graph can be read from a TOML or JSON file.

use std::collections::{BTreeSet, VecDeque};
use std::path::Path;

use serde::Deserialize;
use skin_protocol::message::Port;

use super::NetworkError;

/// Centre-to-centre distance of two adjacent cells: a regular hexagon of
/// the 665 mm^2 cell surface of Table 2 has a width across flats of 27.7 mm.
pub const CELL_PITCH_M: f64 = 0.0277;

/// One port of one cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct PortRef {
    /// Cell index, `0..cells`.
    pub cell: usize,
    /// The cell's port.
    pub port: Port,
}

impl PortRef {
    /// Port `port` of cell `cell`.
    pub fn new(cell: usize, port: Port) -> PortRef {
        PortRef { cell, port }
    }
}

/// Axial hex directions of ports 0..4 (east, north-east, west, south-west).
const DIRS: [(i64, i64); 4] = [(1, 0), (1, -1), (-1, 0), (-1, 1)];

/// A skin's wiring; every port is in at most one link or interface.
#[derive(Clone, Debug, PartialEq)]
pub struct Topology {
    positions_m: Vec<[f64; 2]>,
    links: Vec<(PortRef, PortRef)>,
    interfaces: Vec<PortRef>,
}

/// A graph file: `cells`, optional `positions_m` (one `[x, y]` per cell),
/// `links` as `[cell_a, port_a, cell_b, port_b]` and optional
/// `interfaces` as `[cell, port]`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct GraphFile {
    cells: usize,
    #[serde(default)]
    positions_m: Option<Vec<[f64; 2]>>,
    #[serde(default)]
    links: Vec<[usize; 4]>,
    #[serde(default)]
    interfaces: Vec<[usize; 2]>,
}

/// The largest skin this simulator builds; cell IDs are 16 bit.
pub const MAX_CELLS: usize = 60_000;

/// The largest topology file read: tens of bytes per cell for a million cells.
pub const MAX_FILE_BYTES: usize = 32 * skin_model::file::MIB;

impl Topology {
    /// A graph of `cells` cells at `positions_m` (or in a row when `None`),
    /// checked: ports in range, each port used once, no cell linked to itself.
    pub fn new(
        cells: usize,
        positions_m: Option<Vec<[f64; 2]>>,
        links: Vec<(PortRef, PortRef)>,
        interfaces: Vec<PortRef>,
    ) -> Result<Topology, NetworkError> {
        let bad = |why: String| Err(NetworkError::Topology(why));
        if cells == 0 || cells > MAX_CELLS {
            return bad(format!("{cells} cells; a skin has 1..={MAX_CELLS}"));
        }
        let most = usize::from(skin_protocol::Address::MAX_INTERFACES);
        if interfaces.len() > most {
            return bad(format!("{} interface ports; addresses name at most {most}", interfaces.len()));
        }
        let positions_m = match positions_m {
            Some(p) if p.len() != cells => return bad(format!("{} positions for {cells} cells", p.len())),
            Some(p) if p.iter().flatten().any(|v| !v.is_finite()) => return bad("a position is not finite".into()),
            Some(p) => p,
            None => (0..cells).map(|i| [i as f64 * CELL_PITCH_M, 0.0]).collect(),
        };
        let mut used = BTreeSet::new();
        for end in links.iter().flat_map(|(a, b)| [*a, *b]).chain(interfaces.iter().copied()) {
            if end.cell >= cells {
                return bad(format!("cell {} does not exist (there are {cells})", end.cell));
            }
            if !used.insert(end) {
                return bad(format!("port {} of cell {} is wired twice", end.port.index(), end.cell));
            }
        }
        if let Some((a, _)) = links.iter().find(|(a, b)| a.cell == b.cell) {
            return bad(format!("cell {} is linked to itself", a.cell));
        }
        Ok(Topology { positions_m, links, interfaces })
    }

    /// A hexagonal patch of `rows` rows of `cols` cells (odd rows shifted
    /// half a cell east), wired as on the real cell.
    pub fn hex(rows: usize, cols: usize) -> Result<Topology, NetworkError> {
        if rows == 0 || cols == 0 || rows.saturating_mul(cols) > MAX_CELLS {
            return Err(NetworkError::Topology(format!(
                "a {rows}x{cols} patch; rows and columns >= 1, at most {MAX_CELLS} cells"
            )));
        }
        // Offset coordinates to axial: q = col - floor(row / 2).
        let axial = |r: usize, c: usize| (c as i64 - (r as i64) / 2, r as i64);
        let index = |q: i64, r: i64| -> Option<usize> {
            let (r, c) = (usize::try_from(r).ok()?, usize::try_from(q + r / 2).ok()?);
            (r < rows && c < cols).then_some(r * cols + c)
        };
        let mut positions = Vec::with_capacity(rows * cols);
        let mut links = Vec::new();
        for r in 0..rows {
            for c in 0..cols {
                let (q, ar) = axial(r, c);
                positions
                    .push([CELL_PITCH_M * (q as f64 + ar as f64 / 2.0), CELL_PITCH_M * 3f64.sqrt() / 2.0 * ar as f64]);
                // Each link once: from its port 0 (east) or port 1 (north-east) end.
                for (p, (dq, dr)) in DIRS.iter().enumerate().take(2) {
                    if let Some(j) = index(q + dq, ar + dr) {
                        links.push((PortRef::new(r * cols + c, Port::ALL[p]), PortRef::new(j, Port::ALL[p + 2])));
                    }
                }
            }
        }
        Topology::new(rows * cols, Some(positions), links, Vec::new())
    }

    /// This skin and `other` side by side, `other`'s cells numbered after
    /// ours and placed east of ours, joined by one cable from the last free
    /// port of our last cell that has one to the first free port of
    /// `other`'s first cell that has one.
    pub fn join(&self, other: &Topology) -> Result<Topology, NetworkError> {
        let n = self.cells();
        let shift = self.positions_m.iter().map(|p| p[0]).fold(f64::MIN, f64::max) + 2.0 * CELL_PITCH_M;
        let mut positions = self.positions_m.clone();
        positions.extend(other.positions_m.iter().map(|p| [p[0] + shift, p[1]]));
        let moved = |e: PortRef| PortRef::new(e.cell + n, e.port);
        let mut links = self.links.clone();
        links.extend(other.links.iter().map(|(a, b)| (moved(*a), moved(*b))));
        let mut interfaces = self.interfaces.clone();
        interfaces.extend(other.interfaces.iter().copied().map(moved));
        let (Some(a), Some(b)) = (self.free_ports().last().copied(), other.free_ports().first().copied()) else {
            return Err(NetworkError::Topology("a patch has no free port for the cable".into()));
        };
        links.push((a, moved(b)));
        Topology::new(n + other.cells(), Some(positions), links, interfaces)
    }

    /// `cells` cells in a row, each one's east port (0) wired to the next
    /// one's west port (2), with an interface port on the first one's west
    /// port: the deepest tree `cells` cells can make.
    pub fn chain(cells: usize) -> Result<Topology, NetworkError> {
        // In a row, as `new` places them; links for no more cells than a
        // skin may have, so `chain:4294967296` is refused, not allocated.
        let links =
            (1..cells.min(MAX_CELLS + 1)).map(|i| (PortRef::new(i - 1, Port::P0), PortRef::new(i, Port::P2))).collect();
        Topology::new(cells, None, links, vec![PortRef::new(0, Port::P2)])
    }

    /// The skin of HRP-2 in the paper: 74 cells in five patches, each arm an
    /// upper-arm patch (3x6) cabled to a forearm patch (3x4), and a chest
    /// patch (2x7), on the five ports of the interface: two per arm, one on
    /// the chest.
    pub fn hrp2() -> Topology {
        let arm = || -> Result<Topology, NetworkError> {
            Topology::hex(3, 6)?.join(&Topology::hex(3, 4)?)?.with_interfaces(2)
        };
        let skin = || -> Result<Topology, NetworkError> {
            arm()?.join(&arm()?)?.join(&Topology::hex(2, 7)?.with_interfaces(1)?)
        };
        skin().expect("the HRP-2 skin is a valid topology")
    }

    /// The wiring a skin was laid with (see [`skin_model::skin::Skin::patches`]):
    /// `wires[i][p]` is the far end (cell, port) of port `p` of cell `i`.
    /// Each group of cells wired together gets one interface port, on the
    /// first free port of its first cell that has one, as a skin whose
    /// patches are each cabled to the interface.
    pub fn from_wires(wires: &[[Option<(usize, Port)>; 4]]) -> Result<Topology, NetworkError> {
        let mut links = Vec::new();
        for (i, ends) in wires.iter().enumerate() {
            for (p, end) in Port::ALL.into_iter().zip(ends) {
                let Some((j, q)) = *end else { continue };
                if wires.get(j).and_then(|w| w[q.index()]) != Some((i, p)) {
                    return Err(NetworkError::Topology(format!(
                        "port {} of cell {i} is wired to port {} of cell {j}, which is not wired back",
                        p.index(),
                        q.index()
                    )));
                }
                if (i, p) < (j, q) {
                    links.push((PortRef::new(i, p), PortRef::new(j, q)));
                }
            }
        }
        let wired = Topology::new(wires.len(), None, links, Vec::new())?;
        let peers = wired.peers();
        let mut group = vec![None; wires.len()];
        let mut interfaces = Vec::new();
        for first in 0..wires.len() {
            if group[first].is_some() {
                continue;
            }
            // The group of `first`, by breadth-first search.
            let mut members = vec![first];
            group[first] = Some(interfaces.len());
            let mut k = 0;
            while let Some(&c) = members.get(k) {
                for peer in peers[c].iter().flatten() {
                    if group[peer.cell].is_none() {
                        group[peer.cell] = Some(interfaces.len());
                        members.push(peer.cell);
                    }
                }
                k += 1;
            }
            members.sort_unstable();
            let free = |c: usize| Port::ALL.into_iter().find(|p| peers[c][p.index()].is_none());
            let Some(port) = members.iter().find_map(|&c| free(c).map(|p| PortRef::new(c, p))) else {
                return Err(NetworkError::Topology(format!("the cells wired to cell {first} have no free port")));
            };
            interfaces.push(port);
        }
        Topology::new(wires.len(), None, wired.links, interfaces)
    }

    /// Reads a graph from a `.toml` or `.json` file.
    pub fn from_file(path: &Path) -> Result<Topology, NetworkError> {
        let file = |why: String| NetworkError::File { path: path.display().to_string(), why };
        let json = match path.extension().and_then(|e| e.to_str()) {
            Some("toml") => false,
            Some("json") => true,
            _ => return Err(file("the file name must end in .toml or .json".into())),
        };
        let text = skin_model::file::read_text_capped(path, MAX_FILE_BYTES)
            .map_err(|source| NetworkError::Read { path: path.to_owned(), source })?;
        Topology::from_text(&text, json).map_err(|e| match e {
            NetworkError::Topology(why) => file(why),
            e => e,
        })
    }

    /// Parses a graph in the file format, TOML or JSON.
    pub fn from_text(text: &str, json: bool) -> Result<Topology, NetworkError> {
        let file = NetworkError::Topology;
        let graph: GraphFile = if json {
            serde_json::from_str(text).map_err(|e| file(e.to_string()))?
        } else {
            toml::from_str(text).map_err(|e| file(e.to_string()))?
        };
        let port = |cell: usize, p: usize| {
            Port::from_index(p)
                .map(|port| PortRef::new(cell, port))
                .ok_or_else(|| file(format!("port {p} of cell {cell}: ports are 0..=3")))
        };
        let links = graph
            .links
            .iter()
            .map(|[a, pa, b, pb]| Ok((port(*a, *pa)?, port(*b, *pb)?)))
            .collect::<Result<Vec<_>, NetworkError>>()?;
        let interfaces = graph.interfaces.iter().map(|[c, p]| port(*c, *p)).collect::<Result<Vec<_>, _>>()?;
        Topology::new(graph.cells, graph.positions_m, links, interfaces)
    }

    /// Parses a topology spec: `hex:ROWSxCOLS`, several joined with `+`
    /// (`hex:3x6+hex:3x4`), `chain:N`, `hrp2`, or the path of a graph file.
    pub fn parse(spec: &str) -> Result<Topology, NetworkError> {
        if spec == "hrp2" {
            return Ok(Topology::hrp2());
        }
        if let Some(n) = spec.strip_prefix("chain:") {
            let n =
                n.parse().map_err(|_| NetworkError::Topology(format!("`{spec}`: write chain:CELLS, e.g. chain:20")))?;
            return Topology::chain(n);
        }
        if !spec.starts_with("hex:") {
            return Topology::from_file(Path::new(spec));
        }
        let mut skin: Option<Topology> = None;
        for part in spec.split('+') {
            let dims = part.strip_prefix("hex:").and_then(|d| d.split_once('x'));
            let Some((Ok(rows), Ok(cols))) = dims.map(|(r, c)| (r.parse::<usize>(), c.parse::<usize>())) else {
                return Err(NetworkError::Topology(format!(
                    "`{part}` is not a patch; write hex:ROWSxCOLS, e.g. hex:8x10, joined with +"
                )));
            };
            let patch = Topology::hex(rows, cols)?;
            skin = Some(match skin {
                None => patch,
                Some(s) => s.join(&patch)?,
            });
        }
        skin.ok_or_else(|| NetworkError::Topology("empty topology spec".into()))
    }

    /// The same wiring with `n` more interface ports, on free ports of
    /// boundary cells spread evenly along the list of free ports (one per
    /// cell at most while there are enough cells).
    pub fn with_interfaces(&self, n: usize) -> Result<Topology, NetworkError> {
        let free = self.free_ports();
        let mut one_per_cell = free.clone();
        one_per_cell.dedup_by_key(|e| e.cell);
        let pool = if one_per_cell.len() >= n { one_per_cell } else { free };
        if n > pool.len() || n + self.interfaces.len() > usize::from(skin_protocol::Address::MAX_INTERFACES) {
            return Err(NetworkError::Topology(format!(
                "{n} more interface ports, but only {} free ports (and at most {} interface ports)",
                pool.len(),
                skin_protocol::Address::MAX_INTERFACES
            )));
        }
        let mut interfaces = self.interfaces.clone();
        interfaces.extend((0..n).map(|k| pool[(2 * k + 1) * pool.len() / (2 * n)]));
        Topology::new(self.cells(), Some(self.positions_m.clone()), self.links.clone(), interfaces)
    }

    /// Number of cells.
    pub fn cells(&self) -> usize {
        self.positions_m.len()
    }

    /// Cell positions on the skin surface, in metres.
    pub fn positions_m(&self) -> &[[f64; 2]] {
        &self.positions_m
    }

    /// Cell-to-cell links.
    pub fn links(&self) -> &[(PortRef, PortRef)] {
        &self.links
    }

    /// The cell ports interface ports are attached to; interface port `k`
    /// is the `k`th.
    pub fn interfaces(&self) -> &[PortRef] {
        &self.interfaces
    }

    /// Ports in no link and no interface, in cell and port order.
    pub fn free_ports(&self) -> Vec<PortRef> {
        let used: BTreeSet<PortRef> =
            self.links.iter().flat_map(|(a, b)| [*a, *b]).chain(self.interfaces.iter().copied()).collect();
        (0..self.cells()).flat_map(|c| Port::ALL.map(|p| PortRef::new(c, p))).filter(|e| !used.contains(e)).collect()
    }

    /// For every cell and port, the other end of its link, if any.
    pub fn peers(&self) -> Vec<[Option<PortRef>; 4]> {
        let mut peers = vec![[None; 4]; self.cells()];
        for (a, b) in &self.links {
            peers[a.cell][a.port.index()] = Some(*b);
            peers[b.cell][b.port.index()] = Some(*a);
        }
        peers
    }

    /// Hops from every cell to its nearest interface port (1 for a cell on
    /// an interface) over the given live links, by breadth-first search;
    /// `None` for a cell cut off from every interface.
    pub fn hops(peers: &[[Option<PortRef>; 4]], interfaces: &[PortRef]) -> Vec<Option<u16>> {
        let mut hops = vec![None; peers.len()];
        let mut queue = VecDeque::new();
        for i in interfaces {
            if hops[i.cell].is_none() {
                hops[i.cell] = Some(1u16);
                queue.push_back(i.cell);
            }
        }
        while let Some(c) = queue.pop_front() {
            for peer in peers[c].iter().flatten() {
                if hops[peer.cell].is_none() {
                    hops[peer.cell] = hops[c].map(|h| h + 1);
                    queue.push_back(peer.cell);
                }
            }
        }
        hops
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn wires_become_links_with_an_interface_port_per_wired_group() {
        use Port::{P0, P1, P2};
        // Cells 0-1-2 wired in a row, cell 3 alone; cell 1 has ports 0 and 2 taken.
        let mut wires = vec![[None; 4]; 4];
        wires[0][0] = Some((1, P2));
        wires[1][2] = Some((0, P0));
        wires[1][0] = Some((2, P1));
        wires[2][1] = Some((1, P0));
        let t = Topology::from_wires(&wires).unwrap();
        assert_eq!(
            t.links(),
            &[(PortRef::new(0, P0), PortRef::new(1, P2)), (PortRef::new(1, P0), PortRef::new(2, P1))]
        );
        assert_eq!(t.interfaces(), &[PortRef::new(0, P1), PortRef::new(3, P0)]);
        assert_eq!(Topology::hops(&t.peers(), t.interfaces()), vec![Some(1), Some(2), Some(3), Some(1)]);
        // A wire one end does not know of is refused.
        wires[2][1] = None;
        let e = Topology::from_wires(&wires).unwrap_err().to_string();
        assert!(e.contains("port 0 of cell 1 is wired to port 1 of cell 2, which is not wired back"), "{e}");
    }

    proptest! {
        /// Any text is a graph or a typed error.
        #[test]
        fn any_text_parses_or_is_refused(text in "\\PC{0,200}", json: bool) {
            let _ = Topology::from_text(&text, json);
        }

        /// Graphs of any numbers are built or refused, never half-checked.
        #[test]
        fn any_graph_is_checked(
            cells in 0usize..70_000,
            links in proptest::collection::vec([0usize..12, 0usize..6, 0usize..12, 0usize..6], 0..20),
            interfaces in proptest::collection::vec([0usize..12, 0usize..6], 0..4),
        ) {
            let text = serde_json::json!({ "cells": cells, "links": links, "interfaces": interfaces }).to_string();
            if let Ok(t) = Topology::from_text(&text, true) {
                prop_assert_eq!(t.cells(), cells);
                let mut ends: Vec<PortRef> = t.links().iter().flat_map(|(a, b)| [*a, *b]).collect();
                ends.extend(t.interfaces());
                let n = ends.len();
                ends.sort();
                ends.dedup();
                prop_assert_eq!(ends.len(), n, "a port wired twice");
                prop_assert!(ends.iter().all(|e| e.cell < cells));
            }
        }
    }

    #[test]
    fn hex_patch_links_opposite_ports_of_adjacent_cells() {
        let t = Topology::hex(4, 5).unwrap();
        assert_eq!(t.cells(), 20);
        for (a, b) in t.links() {
            assert_eq!((a.port.index() + 2) % 4, b.port.index());
            let (pa, pb) = (t.positions_m()[a.cell], t.positions_m()[b.cell]);
            let d = ((pa[0] - pb[0]).powi(2) + (pa[1] - pb[1]).powi(2)).sqrt();
            assert!((d - CELL_PITCH_M).abs() < 1e-9, "cells {} and {} are {d} m apart", a.cell, b.cell);
        }
        // Inner cells use all four ports.
        let peers = t.peers();
        assert!(peers[6].iter().all(Option::is_some));
        let hops = Topology::hops(&peers, &[PortRef::new(0, Port::P2)]);
        assert!(hops.iter().all(Option::is_some), "a patch is connected: {hops:?}");
    }

    #[test]
    fn specs_files_and_mistakes() {
        assert_eq!(Topology::parse("hex:3x6+hex:3x4").unwrap().cells(), 30);
        assert_eq!(Topology::hrp2().cells(), 74);
        assert_eq!(Topology::hrp2().interfaces().len(), 5);
        let chain = Topology::parse("chain:5").unwrap();
        let hops = Topology::hops(&chain.peers(), chain.interfaces());
        assert_eq!(hops, [1, 2, 3, 4, 5].map(Some));
        assert!(Topology::parse("chain:0").is_err() && Topology::parse("chain:x").is_err());
        for bad in ["hex:0x3", "hex:3", "hex:axb", "hex:3x3+", "nofile.yaml", "missing.toml"] {
            assert!(Topology::parse(bad).is_err(), "{bad}");
        }
        let p = |c, p| PortRef::new(c, Port::ALL[p]);
        assert!(Topology::new(2, None, vec![(p(0, 0), p(1, 2)), (p(0, 0), p(1, 1))], vec![]).is_err());
        assert!(Topology::new(2, None, vec![(p(0, 0), p(0, 2))], vec![]).is_err());
        assert!(Topology::new(2, None, vec![(p(0, 0), p(2, 2))], vec![]).is_err());
        assert!(Topology::hex(1, 1).unwrap().with_interfaces(5).is_err());
        let two = Topology::hex(3, 3).unwrap().with_interfaces(2).unwrap();
        assert_ne!(two.interfaces()[0].cell, two.interfaces()[1].cell);
    }
}
