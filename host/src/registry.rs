//! What the host knows about each cell: its ID, the interface port it is
//! heard through, its neighbours, when it was last heard, its latest sample
//! and levels, and its health.
//!
//! Work is per frame received and O(1): a cell is found by indexing a table
//! with its ID, so a quiet cell costs nothing. Whole-skin views (patches,
//! hops to the interface, liveness) are computed when asked for.
//!
//! The registry is also the ID authority of phase 3: it answers ID
//! requests with [`Allocator`], which never hands out an ID already seen.

use std::collections::VecDeque;

use serde::Serialize;
use skin_protocol::message::{Channel, IdRequest, NeighbourReport, TactileEvent};
use skin_protocol::organize::Allocator;
use skin_protocol::{Address, Frame, Sample};

/// Length of the window over which a cell's sample rate is measured.
pub const RATE_WINDOW_US: u64 = 1_000_000;

/// How a cell is doing, as seen from the host.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Health {
    /// Samples received.
    pub samples: u64,
    /// Samples the cell's sample counter says never arrived.
    pub samples_missing: u64,
    /// Samples that arrived after a later one; each fills a gap that was
    /// counted missing.
    pub samples_late: u64,
    /// Tactile events received.
    pub events: u64,
    /// Frames with a valid CRC from this cell whose payload or addresses
    /// were wrong. (A frame with a bad CRC cannot be trusted to name its
    /// sender; the interface port counts those.)
    pub bad_frames: u64,
    rate_hz: f32,
    window_start_us: u64,
    window_samples: u32,
    last_seq: Option<u8>,
}

impl Health {
    fn sample(&mut self, seq: u8, now_us: u64) {
        self.samples += 1;
        match self.last_seq {
            Some(last) => {
                // Serial-number order on the 8-bit counter: ahead by 1..=127.
                let ahead = seq.wrapping_sub(last) as i8;
                if ahead > 0 {
                    self.samples_missing += u64::from(ahead as u8 - 1);
                    self.last_seq = Some(seq);
                } else {
                    self.samples_late += 1;
                    self.samples_missing = self.samples_missing.saturating_sub(1);
                }
            }
            None => self.last_seq = Some(seq),
        }
        self.window_samples += 1;
        let elapsed = now_us.saturating_sub(self.window_start_us);
        if elapsed >= RATE_WINDOW_US {
            self.rate_hz = self.window_samples as f32 * 1e6 / elapsed as f32;
            self.window_start_us = now_us;
            self.window_samples = 0;
        }
    }

    /// Samples per second over the last full window; a cell that fell quiet
    /// decays toward zero instead of keeping its old rate.
    pub fn sample_rate_hz(&self, now_us: u64) -> f32 {
        let elapsed = now_us.saturating_sub(self.window_start_us);
        if elapsed >= 2 * RATE_WINDOW_US {
            self.window_samples as f32 * 1e6 / elapsed as f32
        } else {
            self.rate_hz
        }
    }
}

/// One cell.
#[derive(Clone, Debug, PartialEq)]
pub struct CellRecord {
    id: Address,
    interface: u8,
    first_seen_us: u64,
    last_seen_us: u64,
    neighbours: Option<NeighbourReport>,
    sample: Option<Sample>,
    levels: [u8; 4],
    health: Health,
}

impl CellRecord {
    fn new(id: Address, interface: u8, now_us: u64) -> CellRecord {
        CellRecord {
            id,
            interface,
            first_seen_us: now_us,
            last_seen_us: now_us,
            neighbours: None,
            sample: None,
            levels: [0; 4],
            health: Health { window_start_us: now_us, ..Health::default() },
        }
    }

    /// The cell's ID.
    pub fn id(&self) -> Address {
        self.id
    }
    /// The interface port it was last heard through: the root of its tree.
    pub fn interface(&self) -> u8 {
        self.interface
    }
    /// Host clock when first heard, in microseconds.
    pub fn first_seen_us(&self) -> u64 {
        self.first_seen_us
    }
    /// Host clock when last heard, in microseconds.
    pub fn last_seen_us(&self) -> u64 {
        self.last_seen_us
    }
    /// Its latest neighbour table, once reported.
    pub fn neighbours(&self) -> Option<&NeighbourReport> {
        self.neighbours.as_ref()
    }
    /// Its latest sample.
    pub fn sample(&self) -> Option<&Sample> {
        self.sample.as_ref()
    }
    /// The latest tactile level of `channel` (0 until an event says otherwise).
    pub fn level(&self, channel: Channel) -> u8 {
        self.levels[channel_index(channel)]
    }
    /// Its health.
    pub fn health(&self) -> &Health {
        &self.health
    }
}

fn channel_index(c: Channel) -> usize {
    match c {
        Channel::Proximity => 0,
        Channel::Force0 => 1,
        Channel::Force1 => 2,
        Channel::Force2 => 3,
    }
}

/// What a frame from a cell changed in the registry.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Seen {
    /// Heard before, through the same interface port.
    Known,
    /// Heard for the first time.
    New,
    /// Now heard through another interface port (the network re-organized).
    Moved {
        /// The port it was heard through before.
        from: u8,
    },
}

/// The whole-skin view, computed on demand from the neighbour reports.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Topology {
    /// Connected groups of cells (a cell with no reported link is a patch of
    /// its own), largest first, each sorted by ID.
    pub patches: Vec<Vec<Address>>,
    /// Hops from each cell to its nearest interface port along reported
    /// links (the depth the cell's master-port tree gives it), by ID; cells
    /// with no reported path to an interface port are left out.
    pub hops: Vec<(Address, u16)>,
}

/// Every cell the host has heard.
#[derive(Clone, Debug, Default)]
pub struct Registry {
    /// Indexed by cell ID; grows to the largest ID heard.
    cells: Vec<Option<CellRecord>>,
    len: usize,
    allocator: Allocator,
    topology_version: u64,
}

impl Registry {
    /// An empty registry.
    pub fn new() -> Registry {
        Registry::default()
    }

    /// Notes a frame from cell `id` through interface port `interface`; returns
    /// the cell's record and what changed. `id` must be a cell ID.
    pub(crate) fn heard(&mut self, id: Address, interface: u8, now_us: u64) -> (&mut CellRecord, Seen) {
        debug_assert!(id.is_cell());
        let i = usize::from(id.0);
        if self.cells.len() <= i {
            self.cells.resize(i + 1, None);
        }
        let seen = match &self.cells[i] {
            Some(c) if c.interface == interface => Seen::Known,
            Some(c) => Seen::Moved { from: c.interface },
            None => {
                self.len += 1;
                self.allocator.observe(id);
                Seen::New
            }
        };
        let cell = self.cells[i].get_or_insert_with(|| CellRecord::new(id, interface, now_us));
        cell.interface = interface;
        cell.last_seen_us = now_us;
        (cell, seen)
    }

    /// Stores a sample of a cell just [`heard`](Registry::heard).
    pub(crate) fn sample(cell: &mut CellRecord, sample: Sample, now_us: u64) {
        cell.health.sample(sample.seq(), now_us);
        cell.sample = Some(sample);
    }

    /// Stores a tactile event of a cell.
    pub(crate) fn tactile(cell: &mut CellRecord, event: &TactileEvent) {
        cell.health.events += 1;
        cell.levels[channel_index(event.channel)] = event.level;
    }

    /// Stores a neighbour table; true when it differs from the last one.
    pub(crate) fn neighbours(&mut self, id: Address, report: NeighbourReport) -> bool {
        let Some(cell) = self.cells.get_mut(usize::from(id.0)).and_then(Option::as_mut) else { return false };
        let changed = cell.neighbours != Some(report);
        if changed {
            cell.neighbours = Some(report);
            self.topology_version += 1;
        }
        changed
    }

    /// Counts a bad frame against a known cell.
    pub(crate) fn bad_frame(&mut self, id: Address) {
        if let Some(cell) = self.cells.get_mut(usize::from(id.0)).and_then(Option::as_mut) {
            cell.health.bad_frames += 1;
        }
    }

    /// The answer to an ID request: an `IdAssign` frame to send down the
    /// interface port the request came from; `None` when every ID is taken.
    pub(crate) fn assign(&mut self, request: IdRequest) -> Option<Frame> {
        self.allocator.request(request)
    }

    /// Takes back an ID handed out that no cell has used (see
    /// [`Allocator::release`]); false when it was heard or not pending.
    pub(crate) fn release(&mut self, id: Address) -> bool {
        self.allocator.release(id)
    }

    /// The record of cell `id`.
    pub fn get(&self, id: Address) -> Option<&CellRecord> {
        self.cells.get(usize::from(id.0)).and_then(Option::as_ref)
    }

    /// Every cell, by ID.
    pub fn cells(&self) -> impl Iterator<Item = &CellRecord> {
        self.cells.iter().flatten()
    }

    /// Number of cells heard.
    pub fn len(&self) -> usize {
        self.len
    }

    /// True before any cell was heard.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Cells heard within `timeout_us` before `now_us`.
    pub fn alive(&self, now_us: u64, timeout_us: u64) -> usize {
        self.cells().filter(|c| now_us.saturating_sub(c.last_seen_us) <= timeout_us).count()
    }

    /// Goes up by one whenever a cell reports a changed neighbour table.
    pub fn topology_version(&self) -> u64 {
        self.topology_version
    }

    /// Patches and hops from the latest neighbour reports. A link counts
    /// when either end reports it, so a report lost on the way hides none.
    pub fn topology(&self) -> Topology {
        let n = self.cells.len();
        let mut adjacent: Vec<Vec<usize>> = vec![Vec::new(); n];
        let mut roots = Vec::new();
        for cell in self.cells() {
            let a = usize::from(cell.id.0);
            for nb in cell.neighbours.iter().flat_map(|r| r.neighbours).flatten() {
                let b = usize::from(nb.id.0);
                if nb.id.interface_number().is_some() {
                    roots.push(a);
                } else if nb.id.is_cell() && self.get(nb.id).is_some() {
                    adjacent[a].push(b);
                    adjacent[b].push(a);
                }
            }
        }
        let mut patches = Vec::new();
        let mut seen = vec![false; n];
        for cell in self.cells() {
            let start = usize::from(cell.id.0);
            if seen[start] {
                continue;
            }
            seen[start] = true;
            let mut patch = vec![cell.id];
            let mut queue = VecDeque::from([start]);
            while let Some(a) = queue.pop_front() {
                for &b in &adjacent[a] {
                    if !seen[b] {
                        seen[b] = true;
                        patch.push(Address(b as u16));
                        queue.push_back(b);
                    }
                }
            }
            patch.sort();
            patches.push(patch);
        }
        patches.sort_by(|a, b| b.len().cmp(&a.len()).then(a[0].cmp(&b[0])));

        let mut hops: Vec<Option<u16>> = vec![None; n];
        let mut queue = VecDeque::new();
        for r in roots {
            if hops[r].is_none() {
                hops[r] = Some(1);
                queue.push_back(r);
            }
        }
        while let Some(a) = queue.pop_front() {
            let h = hops[a].unwrap_or_default();
            for &b in &adjacent[a] {
                if hops[b].is_none() {
                    hops[b] = Some(h + 1);
                    queue.push_back(b);
                }
            }
        }
        let hops = hops.into_iter().enumerate().filter_map(|(i, h)| Some((Address(i as u16), h?))).collect();
        Topology { patches, hops }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use skin_protocol::message::{Neighbour, Port};

    fn report(neighbours: [Option<(u16, Port)>; 4]) -> NeighbourReport {
        NeighbourReport {
            neighbours: neighbours.map(|n| n.map(|(id, port)| Neighbour { id: Address(id), port })),
            master: None,
        }
    }

    #[test]
    fn patches_and_hops_from_reports() {
        let mut r = Registry::new();
        for id in [1, 2, 3, 7, 9] {
            r.heard(Address(id), 0, 0);
        }
        // 0xFF00 is interface port 0: 1 - 2 - 3 is a chain hanging off it,
        // 7 - 9 is a patch reported only by 7, with no interface port.
        assert!(r.neighbours(Address(1), report([Some((0xFF00, Port::P0)), Some((2, Port::P3)), None, None])));
        assert!(r.neighbours(Address(2), report([None, None, Some((3, Port::P0)), Some((1, Port::P1))])));
        assert!(r.neighbours(Address(7), report([Some((9, Port::P2)), None, None, None])));
        assert!(!r.neighbours(Address(7), report([Some((9, Port::P2)), None, None, None])), "a repeat changes nothing");
        let t = r.topology();
        assert_eq!(t.patches, vec![vec![Address(1), Address(2), Address(3)], vec![Address(7), Address(9)]]);
        assert_eq!(t.hops, vec![(Address(1), 1), (Address(2), 2), (Address(3), 3)]);
        assert_eq!(r.topology_version(), 3);
    }

    #[test]
    fn health_counts_gaps_late_samples_and_rate() {
        let mut h = Health::default();
        let mut now = 0;
        for seq in (0..=255u8).chain(0..=99) {
            if seq % 10 != 3 {
                h.sample(seq, now);
            }
            now += 4000;
        }
        h.sample(93, now); // late, fills one gap
        assert_eq!(h.samples_missing, 35);
        assert_eq!(h.samples_late, 1);
        // 90% of 250 Hz.
        assert!((h.sample_rate_hz(now) - 225.0).abs() < 5.0, "{}", h.sample_rate_hz(now));
        // Quiet for 10 s: the rate decays.
        assert!(h.sample_rate_hz(now + 10_000_000) < 10.0);
    }

    #[test]
    fn a_cell_moving_to_another_port_is_noticed_and_its_id_is_never_reassigned() {
        let mut r = Registry::new();
        assert_eq!(r.heard(Address(1), 0, 0).1, Seen::New);
        assert_eq!(r.heard(Address(1), 0, 5).1, Seen::Known);
        assert_eq!(r.heard(Address(1), 2, 9).1, Seen::Moved { from: 0 });
        assert_eq!(r.len(), 1);
        let reply = r.assign(IdRequest { parent: Address(1), port: Port::P2 }).unwrap();
        match reply.message().unwrap() {
            skin_protocol::Message::IdAssign(a) => assert_eq!(a.id, Address(2), "1 is taken"),
            m => panic!("{m:?}"),
        }
        assert_eq!(r.alive(9, 0), 1);
        assert_eq!(r.alive(10, 0), 0);
    }
}
