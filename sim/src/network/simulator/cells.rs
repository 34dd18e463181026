//! What happens in a cell: power-up, polls, samples, frames received and
//! configuration writes, and the traces its router carries.

use skin_protocol::app::{CellApp, Delivered, MemoryStore};
use skin_protocol::cell::{Arrived, Received, SendError};
use skin_protocol::frame::Frame;
use skin_protocol::message::{ConfigWrite, Message, Port};

use super::firmware::Firmware;
use skin_protocol::organize::Config;
use skin_protocol::router::{Counters, Discard, Meta, Source, Stamp};

use super::super::ledger::DropReason;
use super::wires::Signal;
use super::{add, is_data, Event, Measurements, Network, Power, ALL_PORTS};

/// An upstream frame the simulator follows from its making to the host.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Followed {
    pub(super) created_ns: u64,
    /// A sample or tactile event.
    pub(super) sensor: bool,
}

/// What a router carries beside an upstream frame in the simulator: the
/// frame as followed, and its stay in this cell.
#[derive(Clone, Copy, Debug)]
pub struct Trace {
    pub(super) frame: Followed,
    /// When it was received (for a forwarded frame) or made.
    pub(super) since_ns: u64,
    /// It entered an empty queue: its wait is bounded by one round robin.
    pub(super) head: bool,
}

impl Meta for Trace {
    fn queued(&mut self, ahead: usize) {
        self.head = ahead == 0;
    }
}

impl Trace {
    /// A followed frame received at `now_ns` after `processing_ns`.
    fn arrived(frame: Followed, now_ns: u64, processing_ns: u64) -> Trace {
        Trace { frame, since_ns: now_ns - processing_ns, head: false }
    }
}

/// A simulated cell: its application while powered, and its store (ID,
/// offsets, settings), which survives a reboot as flash would. The
/// application comes first (`repr(C)`): its network stack is what every
/// event of the cell reads.
#[derive(Debug)]
#[repr(C)]
pub struct SimCell {
    pub(super) app: Option<CellApp<MemoryStore, Trace>>,
    /// The store as of the last power-off.
    store: MemoryStore,
    /// Router counters of earlier lives (before reboots).
    pub(super) retired: Counters,
    /// Its update side, when the skin runs updates (it survives reboots).
    pub(super) firmware: Option<Box<Firmware>>,
}

impl SimCell {
    /// An unpowered cell whose store holds `store`.
    pub fn new(store: MemoryStore, firmware: Option<Box<Firmware>>) -> SimCell {
        SimCell { app: None, store, retired: Counters::default(), firmware }
    }

    /// Boots the cell at `now_us` from its store: the ID and the settings
    /// the host wrote come back, as in the firmware.
    pub fn power_on(&mut self, config: Config, now_us: u64) {
        self.app = Some(CellApp::new(config, self.store, now_us));
    }

    /// Cuts the power: the application is gone (it is returned, for the
    /// books), the store stays.
    pub fn power_off(&mut self) -> Option<CellApp<MemoryStore, Trace>> {
        let app = self.app.take()?;
        self.store = *app.store();
        add(&mut self.retired, app.cell().router().counters());
        Some(app)
    }

    /// The application while powered.
    pub fn app(&self) -> Option<&CellApp<MemoryStore, Trace>> {
        self.app.as_ref()
    }

    /// The application while powered, to drive it.
    pub fn app_mut(&mut self) -> Option<&mut CellApp<MemoryStore, Trace>> {
        self.app.as_mut()
    }
}

/// Traces of the frames that enter the books in one call of a cell: made
/// by it, or received without a trace.
#[derive(Debug)]
pub struct Stamper {
    now_ns: u64,
    processing_ns: u64,
    /// Frames that entered.
    entered: u64,
}

impl Stamper {
    /// The stamp of a call at `now_ns`, of a cell that takes
    /// `processing_ns` to take in a frame.
    pub fn new(now_ns: u64, processing_ns: u64) -> Stamper {
        Stamper { now_ns, processing_ns, entered: 0 }
    }

    /// Frames that entered the books so far.
    pub fn entered(&self) -> u64 {
        self.entered
    }
}

impl Stamp<Trace> for Stamper {
    fn made(&mut self, frame: &Frame, from: Source) -> Trace {
        self.entered += 1;
        let since_ns = match from {
            Source::Own => self.now_ns,
            Source::Port(_) => self.now_ns - self.processing_ns,
        };
        Trace { frame: Followed { created_ns: self.now_ns, sensor: is_data(frame.kind()) }, since_ns, head: false }
    }
}

impl Network {
    pub(super) fn stamper(&self) -> Stamper {
        Stamper::new(self.events.now_ns(), self.config.timing.processing_ns)
    }

    /// Books what a call of cell `i` stamped and what its router gave up.
    pub(super) fn book(&mut self, i: usize, stamp: Stamper) {
        self.m.ledger.entered += stamp.entered;
        let Some(app) = self.stacks[i].app.as_mut() else { return };
        while let Some((trace, why)) = app.take_discarded() {
            let reason = match why {
                Discard::QueueFull => DropReason::QueueFull,
                Discard::Reroute => DropReason::Reroute,
            };
            self.m.ledger.drop_upstream(reason, 1, u64::from(trace.frame.sensor));
        }
    }

    pub(super) fn power_on(&mut self, i: usize) {
        use rand::Rng;
        let now_us = self.now_us();
        let phase_ns = self.phases.random_range(0..self.period_ns);
        let n = &mut self.pulses[i];
        if n.power == Power::Dead {
            return;
        }
        n.power = Power::On;
        n.epoch += 1;
        n.sample_ns = self.events.now_ns() + phase_ns;
        self.events.at(n.sample_ns, Event::Sample(i, n.epoch));
        self.stacks[i].power_on(self.config.organize, now_us);
        self.settle(i, ALL_PORTS);
    }

    /// Cell `i`'s wake-up event, of its life `epoch`.
    pub(super) fn poll(&mut self, i: usize, epoch: u32) {
        let now_us = self.now_us();
        let n = &mut self.pulses[i];
        if n.epoch != epoch || n.power != Power::On || n.poll_ns != self.events.now_ns() {
            return;
        }
        if n.deadline_ns > n.poll_ns {
            n.poll_ns = n.deadline_ns;
            self.events.at(n.poll_ns, Event::Poll(i, epoch));
            return;
        }
        n.poll_ns = u64::MAX;
        let mut stamp = self.stamper();
        let app = self.stacks[i].app.as_mut().expect("only powered cells are polled");
        debug_assert!(app.poll_at() <= now_us);
        app.poll(now_us, &mut stamp);
        self.book(i, stamp);
        self.settle(i, ALL_PORTS);
    }

    /// A signal reaches port `p` of powered cell `i`, `valid` when it is a
    /// frame; returns the message it delivered to the application.
    pub(super) fn receive(
        &mut self,
        i: usize,
        p: Port,
        signal: Signal,
        followed: Option<Followed>,
        valid: bool,
    ) -> Option<Delivered> {
        let mut stamp = self.stamper();
        let (now_ns, processing_ns) = (stamp.now_ns, stamp.processing_ns);
        // A frame that is not one is lost as corrupt by the caller.
        let meta = followed.filter(|_| valid).map(|f| Trace::arrived(f, now_ns, processing_ns));
        let app = self.stacks[i].app.as_mut().expect("only powered cells receive");
        let write = match signal {
            Signal::Intact(frame) => app.receive_frame(Arrived { port: p, frame, meta }, now_ns / 1000, &mut stamp),
            Signal::Corrupted(bytes) => {
                app.receive(Received { port: p, bytes: &bytes, meta }, now_ns / 1000, &mut stamp)
            }
        };
        self.book(i, stamp);
        write
    }

    /// Cell `i` applies, keeps and acknowledges a configuration write, its
    /// processing first brought up to date.
    pub(super) fn configure(&mut self, i: usize, write: &ConfigWrite) {
        self.wake(i);
        let mut stamp = self.stamper();
        let app = self.stacks[i].app.as_mut().expect("only powered cells are configured");
        let (m, window, w) = (&mut self.m, &mut self.window, self.events.now_ns() / self.period_ns);
        app.configure(write, &mut stamp, |message, result| book_sent(m, window, w, message, result, false));
        self.book(i, stamp);
    }

    /// After a cell was touched: start idle transmitters that have frames,
    /// and wake the cell at its next deadline. Only the transmitters in
    /// `ports` (bit `p` for port `p`) can have been given a frame.
    pub(super) fn settle(&mut self, i: usize, ports: u8) {
        for p in Port::ALL.into_iter().filter(|p| ports & 1 << p.index() != 0) {
            self.kick_cell(i, p);
        }
        let n = &self.pulses[i];
        let Some(app) = &self.stacks[i].app else { return };
        debug_assert!(
            Port::ALL.iter().all(|p| !app.has_pending(*p) || n.waking[p.index()]),
            "cell {i}: a transmitter with a frame will not be woken"
        );
        let has_id = app.id().is_cell();
        let at = app.poll_at().saturating_mul(1000).max(self.events.now_ns());
        if n.has_id != has_id {
            // The samples it skipped so far were taken with the old state.
            self.count_skipped(i);
            self.pulses[i].has_id = has_id;
        }
        let n = &mut self.pulses[i];
        n.deadline_ns = at;
        if at < n.poll_ns {
            n.poll_ns = at;
            self.events.at(at, Event::Poll(i, n.epoch));
        }
    }

    /// Cell `i`'s master port as a port bit (none when it has no master).
    pub(super) fn master_port(&self, i: usize) -> u8 {
        let master = self.stacks[i].app.as_ref().and_then(|a| a.cell().router().master());
        master.map_or(0, |p| 1 << p.index())
    }

    /// Cell `i` takes the sample due now (first the ones it skipped while
    /// at rest), and perhaps rests from the next one on.
    pub(super) fn sample(&mut self, i: usize) {
        let now_ns = self.events.now_ns();
        if let Some(r) = self.rests[i] {
            self.end_rest(i, r, now_ns - 1);
        }
        let raw = self.stimulus.raw(i, now_ns as f64 * 1e-9);
        let measuring = now_ns >= self.measure_from_ns;
        let mut stamp = self.stamper();
        let app = self.stacks[i].app.as_mut().expect("only powered cells sample");
        let (m, window, w) = (&mut self.m, &mut self.window, now_ns / self.period_ns);
        let mut sent = false;
        app.sample(&raw, &mut stamp, |message, result| {
            sent = true;
            book_sent(m, window, w, message, result, measuring);
        });
        self.book(i, stamp);
        self.schedule_sample(i);
        self.update_pulse(i);
        if measuring && self.pulses[i].has_id {
            self.m.samples += 1;
        }
        // A sample that sends nothing leaves the cell as it was; what it
        // sends waits on the master port.
        if sent {
            self.settle(i, self.master_port(i));
        }
    }
}

/// Books a message a cell sent (or could not) on its own, in sampling
/// period `w`.
pub(super) fn book_sent(
    m: &mut Measurements,
    window: &mut (u64, u64),
    w: u64,
    message: &Message,
    result: Result<(), SendError>,
    measuring: bool,
) {
    let sensor = is_data(message.kind());
    match result {
        Ok(()) if measuring && sensor => {
            m.data_frames += 1;
            if w != window.0 {
                m.peak_data_frames_per_period = m.peak_data_frames_per_period.max(window.1);
                *window = (w, 0);
            }
            window.1 += 1;
        }
        Ok(()) | Err(SendError::NoId) => {}
        Err(SendError::QueueFull) => {
            m.ledger.entered += 1;
            m.ledger.drop_upstream(DropReason::QueueFull, 1, u64::from(sensor));
        }
    }
}
