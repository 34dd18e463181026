//! What a live viewer is told, and the one-way road it travels: the
//! receive thread hands [`Update`]s to a bounded [`Feed`] and goes on at
//! once; the viewer (the Foxglove server, with the `foxglove` feature)
//! drains it on a thread of its own.
//!
//! Why a queue and not a call: building and encoding a 3D scene of a
//! thousand cells costs more than a tick of the interface may spend, and
//! a viewer that stalls (a slow WebSocket client) must never stall the
//! robot. When the queue is full the update is dropped and counted
//! ([`Feed::dropped`]), never waited for.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{self, Receiver, SyncSender, TrySendError};
use std::sync::Arc;

use skin_sim::robot::Robot as Description;

use crate::control::grasp::Transition;
use crate::explore::KinematicTree;
use crate::interface::Event;
use crate::robot::DofKind;
use crate::ros::skin::CellPose;

/// Updates the queue holds before it drops: about a second of ticks at 250 Hz.
pub const FEED_CAPACITY: usize = 256;

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
#[derive(Debug)]
pub struct Feed {
    tx: SyncSender<Update>,
    dropped: Arc<AtomicU64>,
}

/// A feed of `capacity` updates, the receiving end, and the drop counter
/// both share (so the viewer can report it after the feed is gone).
pub fn feed(capacity: usize) -> (Feed, Receiver<Update>, Arc<AtomicU64>) {
    let (tx, rx) = mpsc::sync_channel(capacity);
    let dropped = Arc::new(AtomicU64::new(0));
    (Feed { tx, dropped: dropped.clone() }, rx, dropped)
}

impl Feed {
    /// Hands `update` over, or drops and counts it when the viewer is
    /// behind or gone.
    pub fn send(&self, update: Update) {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_full_feed_drops_and_counts_instead_of_blocking() {
        let (feed, rx, dropped) = feed(2);
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
}
