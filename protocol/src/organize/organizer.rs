//! One cell's side of self-organization (see the module above).

use super::{Config, IdStore, Out, Outbox};
use crate::address::Address;
use crate::frame::{Frame, Header};
use crate::message::{Beacon, IdAssign, IdRequest, Message, Neighbour, NeighbourReport, Port, Probe};

#[derive(Clone, Copy, Debug)]
struct Link {
    last_rx_us: u64,
    neighbour: Option<Neighbour>,
    child: bool,
    /// The neighbour is lost (it said so in its last probe).
    lost: bool,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Route {
    port: Port,
    interface: u8,
    seq: u16,
    hops: u16,
    heard_us: u64,
    /// It missed its waves: the neighbours were asked for the next one.
    lost: bool,
}

/// Serial-number order of wrapping wave numbers: how far `a` is ahead of `b`.
fn seq_ahead(a: u16, b: u16) -> i16 {
    a.wrapping_sub(b) as i16
}

/// The self-organization state of one cell.
#[derive(Clone, Debug)]
pub struct Organizer {
    config: Config,
    id: Address,
    links: [Option<Link>; 4],
    route: Option<Route>,
    /// The table as last reported; `None` before the first report.
    reported: Option<NeighbourReport>,
    /// Repeats of the last report still to send, and when the next one is due.
    repeats: u8,
    next_report_us: u64,
    next_probe_us: u64,
    /// From when the next wave goes to spare links too.
    next_spare_us: u64,
    /// Probe rounds since the last one that probed every port.
    rounds: u8,
    next_id_request_us: u64,
}

/// Every this many probe rounds, busy ports are probed as well.
const REFRESH_ROUNDS: u8 = 10;

/// Delays of the repeats of a changed neighbour report, in report order.
const REPEAT_DELAYS_US: [u64; 2] = [200_000, 50_000];

impl Organizer {
    /// A cell booting at `now_us`, with the ID its store holds, if any.
    pub fn new(config: Config, store: &impl IdStore, now_us: u64) -> Organizer {
        let id = store.load().filter(|a| a.is_cell()).unwrap_or(Address::UNASSIGNED);
        Organizer {
            config,
            id,
            links: [None; 4],
            route: None,
            reported: None,
            repeats: 0,
            next_report_us: now_us + config.report_period_us,
            next_probe_us: now_us,
            next_spare_us: now_us,
            rounds: 0,
            next_id_request_us: now_us,
        }
    }

    /// The cell's address ([`Address::UNASSIGNED`] until phase 3).
    pub fn id(&self) -> Address {
        self.id
    }

    /// The port toward the nearest interface, once known.
    pub fn master(&self) -> Option<Port> {
        self.route.map(|r| r.port)
    }

    /// Hops to the interface port, once known.
    pub fn hops(&self) -> Option<u16> {
        self.route.map(|r| r.hops)
    }

    /// The interface port whose tree this cell is in.
    pub fn interface(&self) -> Option<u8> {
        self.route.map(|r| r.interface)
    }

    /// True while frames arrive on `port`.
    pub fn is_active(&self, port: Port) -> bool {
        self.links[port.index()].is_some()
    }

    /// True when the neighbour on `port` has us as its master.
    pub fn is_child(&self, port: Port) -> bool {
        self.links[port.index()].is_some_and(|l| l.child)
    }

    /// Who is on `port`, once it has said so.
    pub fn neighbour(&self, port: Port) -> Option<Neighbour> {
        self.links[port.index()].and_then(|l| l.neighbour)
    }

    /// The next time [`Organizer::poll`] has work to do; always later than
    /// the time of the last `poll`.
    pub fn poll_at(&self) -> u64 {
        let mut t = self.next_probe_us;
        for p in Port::ALL {
            if let Some(l) = self.links[p.index()] {
                t = t.min(l.last_rx_us + self.link_timeout(p) + 1);
            }
        }
        if let Some(r) = self.route {
            let timeout = if r.lost { self.config.route_timeout_us } else { self.config.wave_timeout_us };
            t = t.min(r.heard_us + timeout + 1);
        }
        if self.id != Address::UNASSIGNED {
            t = t.min(self.next_report_us);
        } else if self.parent().is_some() {
            t = t.min(self.next_id_request_us);
        }
        t
    }

    /// When the next probe round is due.
    pub fn next_probe_us(&self) -> u64 {
        self.next_probe_us
    }

    /// How long `port` may stay silent before it is down.
    fn link_timeout(&self, port: Port) -> u64 {
        if self.master() == Some(port) {
            self.config.link_timeout_us
        } else {
            self.config.keepalive_timeout_us
        }
    }

    /// True when the neighbour on `port` takes every beacon wave: a child,
    /// a lost neighbour, or one that has not said yet.
    fn wants_every_wave(&self, port: Port) -> bool {
        self.links[port.index()].is_some_and(|l| l.child || l.lost || l.neighbour.is_none())
    }

    /// No route, or one that missed its waves.
    fn lost(&self) -> bool {
        self.route.is_none_or(|r| r.lost)
    }

    /// Probes every active port: the neighbours learn at once that this
    /// cell has a route (or an ID) again.
    fn probe_all(&self, outs: &mut impl Outbox) {
        for p in Port::ALL.into_iter().filter(|p| self.is_active(*p)) {
            self.send_probe(p, outs);
        }
    }

    /// Queues a probe on `port`.
    fn send_probe(&self, port: Port, outs: &mut impl Outbox) {
        outs.send(Out::Link(port, self.link_frame(Message::Probe(self.probe(port)))));
    }

    /// The parent in the tree, once it has an address.
    fn parent(&self) -> Option<Neighbour> {
        self.master().and_then(|m| self.neighbour(m)).filter(|n| n.id != Address::UNASSIGNED)
    }

    fn probe(&self, port: Port) -> Probe {
        Probe {
            port,
            id: self.id,
            master: self.master() == Some(port),
            known: self.neighbour(port).is_some(),
            lost: self.lost(),
        }
    }

    fn link_frame(&self, message: Message) -> Frame {
        Frame::new(self.id, Address::BROADCAST, &message)
    }

    /// Notes that a valid frame arrived on `port`: the link is up.
    pub fn heard(&mut self, port: Port, now_us: u64) {
        match &mut self.links[port.index()] {
            Some(l) => l.last_rx_us = now_us,
            slot @ None => *slot = Some(Link { last_rx_us: now_us, neighbour: None, child: false, lost: false }),
        }
    }

    /// Handles a control message addressed to this cell's organizer: probes,
    /// acks and beacons from a neighbour, and ID assignments coming down.
    /// The caller has already called [`Organizer::heard`].
    pub fn handle(
        &mut self,
        port: Port,
        header: Header,
        message: &Message,
        now_us: u64,
        store: &mut impl IdStore,
        outs: &mut impl Outbox,
    ) {
        match *message {
            Message::Probe(p) | Message::ProbeAck(p) => {
                if matches!(message, Message::Probe(_)) && !p.known {
                    let ack = self.link_frame(Message::ProbeAck(self.probe(port)));
                    outs.send(Out::Link(port, ack));
                }
                if let Some(link) = &mut self.links[port.index()] {
                    link.neighbour = Some(Neighbour { id: p.id, port: p.port });
                    link.child = p.master;
                    link.lost = p.lost;
                }
                self.report(outs, now_us);
                self.request_id(outs, now_us);
            }
            Message::Beacon(b) => self.beacon(port, b, now_us, outs),
            Message::IdAssign(a) => self.assign(port, header, a, now_us, store, outs),
            _ => {}
        }
    }

    fn beacon(&mut self, port: Port, b: Beacon, now_us: u64, outs: &mut impl Outbox) {
        if self.is_child(port) {
            return; // a child never leads toward the interface
        }
        let hops = b.hops.saturating_add(1);
        let candidate = Route { port, interface: b.interface, seq: b.seq, hops, heard_us: now_us, lost: false };
        let take = match self.route {
            None => true,
            Some(r) if r.interface != b.interface => hops < r.hops || (hops == r.hops && b.interface < r.interface),
            Some(r) => {
                let ahead = seq_ahead(b.seq, r.seq);
                if port == r.port {
                    ahead > 0 || (ahead == 0 && hops < r.hops)
                } else {
                    // Another port: better in the same or a newer wave, or
                    // the master has missed a whole wave (a lost cell gets
                    // every wave from every neighbour).
                    (ahead >= 0 && hops < r.hops) || ahead >= 2
                }
            }
        };
        if !take {
            return;
        }
        let (old, was_lost) = (self.master(), self.lost());
        self.route = Some(candidate);
        if was_lost {
            // Neighbours stop sending us every wave; the parent learns it has
            // a child.
            self.probe_all(outs);
        } else if old != Some(port) {
            // Tell the old and the new parent at once, so downstream traffic
            // follows the tree without waiting for the next probe.
            for p in [old, Some(port)].into_iter().flatten().filter(|p| self.is_active(*p)) {
                self.send_probe(p, outs);
            }
        }
        // One wave per keep-alive period on spare links (half a beacon
        // period early, so that jitter does not make it one wave later).
        let spare_too = now_us >= self.next_spare_us;
        if spare_too {
            let period = self.config.keepalive_period_us.saturating_sub(self.config.beacon_period_us / 2);
            self.next_spare_us = now_us + period;
        }
        // Made only when some port takes it: a leaf relays no wave.
        let mut relay = None;
        for p in Port::ALL {
            if p != port && self.is_active(p) && (spare_too || self.wants_every_wave(p)) {
                let frame = *relay.get_or_insert_with(|| self.link_frame(Message::Beacon(Beacon { hops, ..b })));
                outs.send(Out::Link(p, frame));
            }
        }
        self.report(outs, now_us);
        self.request_id(outs, now_us);
    }

    fn assign(
        &mut self,
        port: Port,
        header: Header,
        a: IdAssign,
        now_us: u64,
        store: &mut impl IdStore,
        outs: &mut impl Outbox,
    ) {
        if header.dst == Address::UNASSIGNED {
            // For us, handed on by our parent.
            if self.id == Address::UNASSIGNED && self.master() == Some(port) && a.id.is_cell() {
                self.id = a.id;
                store.store(a.id);
                self.probe_all(outs);
                self.report(outs, now_us);
            }
        } else if header.dst == self.id && self.id != Address::UNASSIGNED {
            // For our child on `a.port`.
            let frame = Frame::new(header.src, Address::UNASSIGNED, &Message::IdAssign(a));
            outs.send(Out::Link(a.port, frame));
        }
    }

    /// Phase 3: ask for an ID once the parent has one.
    fn request_id(&mut self, outs: &mut impl Outbox, now_us: u64) {
        if self.id != Address::UNASSIGNED || now_us < self.next_id_request_us {
            return;
        }
        let Some(parent) = self.parent() else { return };
        self.next_id_request_us = now_us + self.config.id_retry_us;
        let request = Message::IdRequest(IdRequest { parent: parent.id, port: parent.port });
        outs.send(Out::Up(Frame::new(Address::UNASSIGNED, Address::HOST, &request)));
    }

    /// The neighbour table and master port as they are now; neighbours
    /// without an ID yet are left out until they have one.
    pub fn table(&self) -> NeighbourReport {
        NeighbourReport {
            neighbours: Port::ALL.map(|p| self.neighbour(p).filter(|n| n.id != Address::UNASSIGNED)),
            master: self.master(),
        }
    }

    /// Phase 4: reports the table when it changed, when a repeat of the last
    /// change is due, and as a heartbeat.
    fn report(&mut self, outs: &mut impl Outbox, now_us: u64) {
        if self.id == Address::UNASSIGNED {
            return;
        }
        let table = self.table();
        if self.reported != Some(table) {
            self.reported = Some(table);
            self.repeats = REPEAT_DELAYS_US.len() as u8;
            self.next_report_us = now_us;
        }
        if now_us < self.next_report_us {
            return;
        }
        self.next_report_us = match self.repeats.checked_sub(1) {
            Some(left) => {
                self.repeats = left;
                now_us + REPEAT_DELAYS_US[usize::from(left)]
            }
            None => now_us + self.config.report_period_us,
        };
        outs.send(Out::Up(Frame::new(self.id, Address::HOST, &Message::NeighbourReport(table))));
    }

    /// Does what time demands: probes, link and route timeouts, ID retries,
    /// the report heartbeat. `busy` has bit `p` set for each port that sent
    /// a frame other than a probe since the last probe round: those need no
    /// probe, as the neighbour heard from us anyway.
    pub fn poll(&mut self, now_us: u64, busy: u8, outs: &mut impl Outbox) {
        for p in Port::ALL {
            let Some(l) = self.links[p.index()] else { continue };
            if now_us > l.last_rx_us + self.link_timeout(p) {
                self.links[p.index()] = None;
            }
        }
        let was_lost = self.lost();
        if let Some(r) = self.route {
            let gone = !self.is_active(r.port) || now_us > r.heard_us + self.config.route_timeout_us;
            let missed = now_us > r.heard_us + self.config.wave_timeout_us;
            self.route = (!gone).then_some(Route { lost: r.lost || missed, ..r });
        }
        let lost = self.lost() && !was_lost;
        if lost || now_us >= self.next_probe_us {
            self.next_probe_us = now_us + self.config.keepalive_period_us;
            // Every few rounds a busy port is probed too, so that a lost
            // probe cannot leave the neighbour's view of us stale for good.
            // A cell that just got lost probes every port at once, so that
            // every neighbour sends it the next wave.
            self.rounds = (self.rounds + 1) % REFRESH_ROUNDS;
            let skip = if lost || self.rounds == 0 { 0 } else { busy };
            for p in Port::ALL.into_iter().filter(|p| skip & (1 << p.index()) == 0) {
                self.send_probe(p, outs);
            }
        }
        self.report(outs, now_us);
        self.request_id(outs, now_us);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::organize::Out;
    use heapless::Vec;

    type Outs = Vec<Out, 64>;

    /// A cell with ID 5 whose port 0 leads to an interface port; on port 1
    /// is its child, on port 2 a settled neighbour (a spare link), on
    /// port 3 a lost neighbour.
    fn settled() -> (Organizer, Option<Address>, Outs) {
        let mut store = Some(Address(5));
        let mut org = Organizer::new(Config::default(), &store, 0);
        let mut outs = Outs::new();
        for (port, master, lost) in [(Port::P1, true, false), (Port::P2, false, false), (Port::P3, false, true)] {
            let probe = Probe { port: Port::P0, id: Address(10 + port.index() as u16), master, known: true, lost };
            let frame = Frame::new(probe.id, Address::BROADCAST, &Message::Probe(probe));
            org.heard(port, 0);
            org.handle(port, frame.header(), &Message::Probe(probe), 0, &mut store, &mut outs);
        }
        (org, store, outs)
    }

    /// Wave `seq` of interface port 0, arriving on `port` at `seq` * 10 ms.
    fn wave(org: &mut Organizer, store: &mut Option<Address>, port: Port, seq: u16, outs: &mut Outs) -> u64 {
        let now = u64::from(seq) * 10_000;
        let b = Message::Beacon(Beacon { interface: 0, seq, hops: 0 });
        let frame = Frame::new(Address::interface(0).unwrap(), Address::BROADCAST, &b);
        org.heard(port, now);
        org.handle(port, frame.header(), &b, now, store, outs);
        now
    }

    fn relays(outs: &Outs, port: Port) -> usize {
        outs.iter()
            .filter(|o| matches!(o, Out::Link(p, f) if *p == port && f.kind() == crate::frame::Kind::Beacon))
            .count()
    }

    /// The ports probed in `outs`, with the probes' `lost` flag.
    fn probes(outs: &Outs) -> std::vec::Vec<(Port, bool)> {
        outs.iter()
            .filter_map(|o| match o {
                Out::Link(p, f) => match f.message() {
                    Ok(Message::Probe(probe)) => Some((*p, probe.lost)),
                    _ => None,
                },
                Out::Up(_) => None,
            })
            .collect()
    }

    #[test]
    fn every_wave_goes_to_children_and_lost_neighbours_one_in_ten_to_spare_links() {
        let (mut org, mut store, _) = settled();
        let mut outs = Outs::new();
        for seq in 1..=20 {
            wave(&mut org, &mut store, Port::P0, seq, &mut outs);
            outs.retain(|o| matches!(o, Out::Link(_, f) if f.kind() == crate::frame::Kind::Beacon));
        }
        assert_eq!(org.master(), Some(Port::P0));
        assert_eq!([Port::P0, Port::P1, Port::P2, Port::P3].map(|p| relays(&outs, p)), [0, 20, 2, 20]);
    }

    #[test]
    fn a_cell_whose_parent_falls_silent_asks_every_neighbour_and_takes_the_next_wave() {
        let (mut org, mut store, mut outs) = settled();
        let config = Config::default();
        let last = wave(&mut org, &mut store, Port::P0, 1, &mut outs);
        org.poll(last, 0, &mut outs); // the first keep-alive round
        outs.clear();
        // A wave missed: the cell keeps its route but asks every port.
        org.poll(last + config.wave_timeout_us + 1, 0, &mut outs);
        assert_eq!(org.master(), Some(Port::P0));
        assert_eq!(probes(&outs), Port::ALL.map(|p| (p, true)));
        // The next wave, from the spare neighbour, is taken at once, and
        // every neighbour hears that the cell is settled again.
        outs.clear();
        wave(&mut org, &mut store, Port::P2, 4, &mut outs);
        assert_eq!(org.master(), Some(Port::P2));
        assert_eq!(probes(&outs), [(Port::P0, false), (Port::P1, false), (Port::P2, false), (Port::P3, false)]);
    }

    #[test]
    fn the_master_port_times_out_after_the_link_timeout_the_others_after_the_keepalive_timeout() {
        let (mut org, mut store, mut outs) = settled();
        let config = Config::default();
        let last = wave(&mut org, &mut store, Port::P0, 1, &mut outs);
        org.poll(last + config.link_timeout_us, 0, &mut outs);
        assert!(org.is_active(Port::P0));
        org.poll(last + config.link_timeout_us + 1, 0, &mut outs);
        assert!(!org.is_active(Port::P0));
        assert_eq!(org.master(), None);
        // The other links, heard at 0, last a keep-alive timeout.
        org.poll(config.keepalive_timeout_us, 0, &mut outs);
        assert!(Port::ALL[1..].iter().all(|p| org.is_active(*p)));
        org.poll(config.keepalive_timeout_us + 1, 0, &mut outs);
        assert!(Port::ALL.iter().all(|p| !org.is_active(*p)));
    }
}
