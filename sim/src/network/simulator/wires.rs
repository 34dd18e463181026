//! The cell-2-cell wires: transmitters, frames in flight, bit errors, and
//! what a frame does when it reaches a cell or an interface port.

use skin_protocol::app::Delivered;
use skin_protocol::frame::{Frame, FRAME_LEN};
use skin_protocol::message::Port;
use skin_protocol::organize::FromCell;

use super::super::ledger::DropReason;
use super::super::topology::PortRef;
use super::cells::Followed;
use super::prefetch;
use super::{is_data, Event, Network, Power, ALL_PORTS};

/// One end of a wire.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum End {
    /// A cell and its port.
    Cell(u16, Port),
    /// An interface port.
    Interface(u8),
}

// Every cell index fits an `End`.
const _: () = assert!(super::super::topology::MAX_CELLS <= 1 << 16);

impl End {
    pub(super) fn cell(p: PortRef) -> End {
        End::Cell(p.cell as u16, p.port)
    }
}

/// What reaches the far end of a wire.
#[derive(Clone, Copy, Debug)]
pub(super) enum Signal {
    /// The frame as sent: its CRC was computed when it was made, and no
    /// bit changed since, so the receiver takes it without parsing again.
    Intact(Frame),
    /// Bytes with flipped bits: the receiver parses them and checks the CRC.
    Corrupted([u8; FRAME_LEN]),
}

impl Network {
    /// Starts cell `i`'s transmitter on port `p` if it is idle and has a
    /// frame, or makes sure it is woken when it is free.
    pub(super) fn kick_cell(&mut self, i: usize, p: Port) {
        let now_ns = self.events.now_ns();
        let n = &mut self.pulses[i];
        let Some(cell) = self.stacks[i].app.as_mut() else { return };
        let busy = n.busy_until_ns[p.index()];
        // A busy transmitter that will be woken asks for its frame then.
        if busy > now_ns && n.waking[p.index()] || !cell.has_pending(p) {
            return;
        }
        if busy > now_ns {
            n.waking[p.index()] = true;
            self.events.at(busy, Event::TxFree(End::Cell(i as u16, p)));
            return;
        }
        let Some((frame, trace)) = cell.transmit_meta(p) else { return };
        let end_ns = now_ns + self.frame_ns;
        let followed = trace.map(|t| {
            let stay = end_ns - t.since_ns;
            self.m.forwarding_any_ns = self.m.forwarding_any_ns.max(stay);
            if t.head {
                self.m.forwarding_head_ns = self.m.forwarding_head_ns.max(stay);
            }
            t.frame
        });
        n.busy_until_ns[p.index()] = end_ns;
        // At most one wake-up per transmitter: one may be due right now.
        if !n.waking[p.index()] && cell.has_pending(p) {
            n.waking[p.index()] = true;
            self.events.after(self.frame_ns, Event::TxFree(End::Cell(i as u16, p)));
        }
        self.put_on_wire(End::Cell(i as u16, p), frame, followed);
    }

    pub(super) fn kick_interface(&mut self, k: u8) {
        let now_ns = self.events.now_ns();
        let i = &mut self.interfaces[usize::from(k)];
        if !i.alive {
            return;
        }
        if i.busy_until_ns > now_ns {
            if i.sink.queued() > 0 && !i.waking {
                i.waking = true;
                self.events.at(i.busy_until_ns, Event::TxFree(End::Interface(k)));
            }
            return;
        }
        let Some(frame) = i.sink.transmit() else { return };
        i.busy_until_ns = now_ns + self.frame_ns;
        if !i.waking && i.sink.queued() > 0 {
            i.waking = true;
            self.events.after(self.frame_ns, Event::TxFree(End::Interface(k)));
        }
        self.put_on_wire(End::Interface(k), frame, None);
    }

    pub(super) fn peer(&self, end: End) -> Option<End> {
        match end {
            End::Cell(i, p) => self.peers[i as usize][p.index()],
            End::Interface(k) => self.interfaces[usize::from(k)].at.map(End::cell),
        }
    }

    pub(super) fn put_on_wire(&mut self, from: End, frame: Frame, followed: Option<Followed>) {
        self.m.ledger.transmitted += 1;
        let Some(to) = self.peer(from) else {
            self.m.ledger.lost_no_link += 1;
            if let Some(f) = followed {
                self.m.ledger.drop_upstream(DropReason::NoLink, 1, u64::from(f.sensor));
            }
            return;
        };
        let mut bytes = *frame.as_bytes();
        let signal =
            if self.bit_errors.corrupt(&mut bytes) > 0 { Signal::Corrupted(bytes) } else { Signal::Intact(frame) };
        self.on_wires += 1;
        self.followed_on_wires += u64::from(followed.is_some());
        let processing = match to {
            End::Cell(j, _) => {
                if self.prefetch {
                    prefetch::cell(&self.pulses[usize::from(j)], &self.stacks[usize::from(j)]);
                }
                self.config.timing.processing_ns
            }
            End::Interface(_) => 0,
        };
        self.events.after(self.frame_ns + processing, Event::Arrive { from, to, signal, followed });
    }

    pub(super) fn arrive(&mut self, from: End, to: End, signal: Signal, followed: Option<Followed>) {
        self.on_wires -= 1;
        self.followed_on_wires -= u64::from(followed.is_some());
        let lost = |net: &mut Network, reason| {
            if let Some(f) = followed {
                net.m.ledger.drop_upstream(reason, 1, u64::from(f.sensor));
            }
        };
        if self.peer(from) != Some(to) {
            self.m.ledger.lost_no_link += 1;
            return lost(self, DropReason::NoLink);
        }
        let corrupted = matches!(signal, Signal::Corrupted(_));
        let valid = match &signal {
            Signal::Intact(_) => true,
            Signal::Corrupted(bytes) => Frame::parse(bytes).is_ok_and(|f| f.message().is_ok()),
        };
        match to {
            End::Cell(i, p) => {
                let i = i as usize;
                if self.pulses[i].power != Power::On {
                    self.m.ledger.lost_dead_receiver += 1;
                    return lost(self, DropReason::DeadCell);
                }
                self.m.ledger.received += 1;
                self.count_corruption(corrupted, valid);
                let master = self.master_port(i);
                let upstream = match signal {
                    Signal::Intact(f) => !f.kind().is_link_local() && master & 1 << p.index() == 0,
                    Signal::Corrupted(_) => false,
                };
                // A followed frame the router refuses comes back from it,
                // with the reason; one that is no frame is lost here.
                let delivered = self.receive(i, p, signal, followed, valid);
                if !valid {
                    lost(self, DropReason::Corrupt);
                }
                match delivered {
                    Some(Delivered::Config(w)) => self.configure(i, &w),
                    Some(Delivered::Update(u)) => self.update(i, &u),
                    None => {}
                }
                // A frame from below only ever waits for the master port
                // (which it cannot change); anything else may go anywhere.
                let ports = if upstream { master } else { ALL_PORTS };
                self.settle(i, ports);
            }
            End::Interface(k) => {
                let now_us = self.now_us();
                let measuring = self.events.now_ns() >= self.measure_from_ns;
                let i = &mut self.interfaces[usize::from(k)];
                if !i.alive {
                    self.m.ledger.lost_dead_receiver += 1;
                    return lost(self, DropReason::DeadInterface);
                }
                self.m.ledger.received += 1;
                // An intact frame was checked when it was made.
                let from_cell = match &signal {
                    Signal::Intact(frame) => i.sink.receive_frame(*frame, now_us),
                    Signal::Corrupted(bytes) => i.sink.receive(bytes, now_us),
                };
                match from_cell {
                    Err(_) => {
                        self.m.ledger.corrupt_rejected += 1;
                        lost(self, DropReason::Corrupt);
                    }
                    Ok(from_cell) => {
                        if measuring {
                            i.from_cell += 1;
                        }
                        if let FromCell::Host(frame) = from_cell {
                            if measuring && is_data(frame.kind()) {
                                i.data_from_cell += 1;
                            }
                            i.up.push_back((frame, followed));
                        }
                        if corrupted {
                            self.m.ledger.corrupt_accepted += 1;
                        }
                        self.kick_interface(k);
                        self.flush();
                    }
                }
            }
        }
    }

    fn count_corruption(&mut self, corrupted: bool, valid: bool) {
        match (corrupted, valid) {
            (true, true) => self.m.ledger.corrupt_accepted += 1,
            (_, false) => self.m.ledger.corrupt_rejected += 1,
            (false, true) => {}
        }
    }
}
