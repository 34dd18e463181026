//! What a live viewer is told, and the one-way road it travels: the
//! receive thread hands [`Update`]s to a bounded [`Feed`] and goes on at
//! once; the viewer (the Foxglove server, with the `foxglove` feature)
//! drains it on a thread of its own.
//!
//! Why a queue and not a call: building and encoding a 3D scene of a
//! thousand cells costs more than a tick of the interface may spend, and
//! a viewer that stalls (a slow WebSocket client) must never stall the
//! robot. When the queue is full the update is dropped and counted
//! ([`Feed::dropped`]), never waited for. The feed gathers events and
//! keeps only the latest positions for [`BATCH`] before it hands them on,
//! so a host that polls thousands of times a second sends a hundred
//! updates, not thousands.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{self, Receiver, SyncSender, TrySendError};
use std::sync::Arc;
use std::time::{Duration, Instant};

use skin_model::robot::Robot as Description;

use crate::control::grasp::Transition;
use crate::explore::KinematicTree;
use crate::interface::Event;
use crate::robot::DofKind;
use crate::ros::skin::CellPose;

/// Updates the queue holds before it drops: over a second of batches.
pub const FEED_CAPACITY: usize = 256;
/// How long the feed gathers events (and keeps the latest positions) before handing them on.
pub const BATCH: Duration = Duration::from_millis(10);

/// One thing the host learned or heard, owned, for a viewer.
#[derive(Clone, Debug)]
#[non_exhaustive]
pub enum Update {
    /// Everything the skin said in one tick (or one poll of the monitor).
    Events(Vec<Event>),
    /// The robot's DoF names, command order, sent before its first positions.
    Dofs(Vec<String>),
    /// The robot's positions, command order, rad or m.
    Positions(Vec<f64>),
    /// The robot's own description (`--urdf`): its links are drawn from it.
    Description(Box<Description>),
    /// The learned kinematic tree and the kinds of its DoFs.
    Tree(Box<KinematicTree>, Vec<DofKind>),
    /// Every cell's pose on a link of the description (the calibration).
    Poses(Vec<CellPose>),
    /// The grasp entered a state.
    Grasp(Transition),
}

/// The sending end: cheap to use on the receive thread, never blocks.
/// What it gathers goes out with the next batch, the next other update,
/// or when it is dropped.
#[derive(Debug)]
pub struct Feed {
    tx: SyncSender<Update>,
    dropped: Arc<AtomicU64>,
    events: Vec<Event>,
    positions: Option<Vec<f64>>,
    flushed: Instant,
}

/// A feed of `capacity` updates, the receiving end, and the drop counter
/// both share (so the viewer can report it after the feed is gone).
pub fn feed(capacity: usize) -> (Feed, Receiver<Update>, Arc<AtomicU64>) {
    let (tx, rx) = mpsc::sync_channel(capacity);
    let dropped = Arc::new(AtomicU64::new(0));
    let feed = Feed { tx, dropped: dropped.clone(), events: Vec::new(), positions: None, flushed: Instant::now() };
    (feed, rx, dropped)
}

impl Feed {
    /// Hands over what was gathered, then `update`; drops and counts
    /// what the viewer has no room for (it is behind, or gone).
    pub fn send(&mut self, update: Update) {
        self.flush();
        self.hand_over(update);
    }

    /// Gathers what the skin said, handed over with the next batch.
    pub fn events(&mut self, events: &[Event]) {
        self.events.extend_from_slice(events);
        self.flush_when_due();
    }

    /// The robot's positions now; only the latest of a batch is handed over.
    pub fn positions(&mut self, positions: &[f64]) {
        let kept = self.positions.get_or_insert_with(Vec::new);
        kept.clear();
        kept.extend_from_slice(positions);
        self.flush_when_due();
    }

    fn flush_when_due(&mut self) {
        if self.flushed.elapsed() >= BATCH {
            self.flush();
        }
    }

    /// Hands over what was gathered.
    pub fn flush(&mut self) {
        self.flushed = Instant::now();
        if !self.events.is_empty() {
            let events = std::mem::take(&mut self.events);
            self.hand_over(Update::Events(events));
        }
        if let Some(q) = self.positions.take() {
            self.hand_over(Update::Positions(q));
        }
    }

    fn hand_over(&self, update: Update) {
        match self.tx.try_send(update) {
            Ok(()) => {}
            Err(TrySendError::Full(_) | TrySendError::Disconnected(_)) => {
                self.dropped.fetch_add(1, Ordering::Relaxed);
            }
        }
    }

    /// Updates dropped so far.
    pub fn dropped(&self) -> u64 {
        self.dropped.load(Ordering::Relaxed)
    }
}

impl Drop for Feed {
    fn drop(&mut self) {
        self.flush();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_full_feed_drops_and_counts_instead_of_blocking() {
        let (mut feed, rx, dropped) = feed(2);
        for k in 0..5 {
            feed.send(Update::Positions(vec![f64::from(k)]));
        }
        assert_eq!((feed.dropped(), dropped.load(Ordering::Relaxed)), (3, 3));
        let kept: Vec<f64> = rx.try_iter().map(|u| if let Update::Positions(p) = u { p[0] } else { -1.0 }).collect();
        assert_eq!(kept, [0.0, 1.0], "the oldest are kept, the newest dropped");
        drop(rx);
        feed.send(Update::Dofs(Vec::new()));
        assert_eq!(feed.dropped(), 4, "a viewer that is gone drops too");
    }

    #[test]
    fn events_and_positions_are_batched_in_order_with_the_other_updates() {
        use skin_protocol::Address;

        use crate::interface::EventKind;
        let (mut feed, rx, _) = feed(16);
        let e = |cell| Event { interface: 0, timestamp_us: 0, cell: Address(cell), kind: EventKind::Joined };
        // A batch that is never due: only other updates and the drop flush it.
        feed.flushed = Instant::now() + Duration::from_secs(3600);
        feed.events(&[e(1)]);
        feed.positions(&[0.1]);
        feed.events(&[e(2), e(3)]);
        feed.positions(&[0.2]);
        assert!(rx.try_recv().is_err(), "gathered, not sent, within a batch");
        feed.send(Update::Dofs(vec!["j".into()]));
        feed.events(&[e(4)]);
        drop(feed);
        let got: Vec<String> = rx
            .try_iter()
            .map(|u| match u {
                Update::Events(v) => format!("events {:?}", v.iter().map(|e| e.cell.0).collect::<Vec<_>>()),
                Update::Positions(q) => format!("positions {q:?}"),
                Update::Dofs(_) => "dofs".into(),
                other => format!("{other:?}"),
            })
            .collect();
        assert_eq!(got, ["events [1, 2, 3]", "positions [0.2]", "dofs", "events [4]"]);
    }
}
