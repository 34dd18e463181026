//! Network self-organization (section 2.2.2, Figure 7), one cell at a time.
//!
//! The four phases run side by side as a pure state machine: a received
//! frame (or the passing of time) goes in, frames to send come out.
//!
//! 1. **Active ports.** Every cell probes each port on which it sent nothing
//!    but probes for a keep-alive period; a probe from a neighbour that does
//!    not know us yet is answered at once. A port is active while frames
//!    arrive on it, so a link busy with data or beacons needs no keep-alive.
//! 2. **Master-port trees.** Every interface port ([`Sink`]) starts a beacon
//!    wave each period. A cell takes as master port the port with the fewest
//!    hops to an interface, and relays only the waves that reach it through
//!    its master port, away from it. A cell cut off from its interface thus
//!    falls silent, and no stale route outlives it; newer waves replace older
//!    ones, so routes are loop free (as in DSDV). Every interface port is the
//!    sink of its own tree.
//!
//!    Only a cell's parent must be heard often: its waves are the cell's
//!    route. Every wave goes to children and to lost neighbours: those
//!    without a route, or whose next wave is half a period late (they say
//!    so in their probes, sent on every port the moment they are lost). A
//!    cell whose parent fell silent thus takes the very next wave from any
//!    neighbour (a newer wave on another port wins), as soon as it would
//!    have if every link carried every wave; a wave lost to a bit error
//!    costs a few probes, not a stall. A settled neighbour on a spare link
//!    gets one wave per keep-alive period, enough to keep the link alive
//!    and to offer it a shorter route. The master port times out after a
//!    few beacon periods, the others after a few keep-alive periods. A
//!    settled, quiet skin thus carries about one frame per cell per beacon
//!    period.
//! 3. **Unique IDs.** A cell without an ID names itself by its parent and the
//!    parent's port and asks the host ([`Allocator`]); the answer comes down
//!    the tree to the parent, which hands it through that port. An ID held in
//!    persistent storage ([`IdStore`]) is kept and never asked for again.
//! 4. **Neighbours.** Probes carry the sender's ID and port, so each cell
//!    knows who is on each port; it reports the whole table upstream in one
//!    frame when it changes (repeated twice, as upstream bursts may overflow
//!    a queue on the way) and as a slow heartbeat.
//!
//! When a link or a cell disappears, the ports time out, cells behind it
//! take the next wave through another path, and keep their IDs.

//!
//! - [`Organizer`] (`organizer.rs`): one cell's side.
//! - [`Sink`] (`sink.rs`): the interface port's side of a link.
//! - [`Allocator`] (`allocator.rs`, with `std`): the host's ID allocator.

mod organizer;
mod sink;

#[cfg(feature = "std")]
mod allocator;

#[cfg(feature = "std")]
pub use allocator::Allocator;
pub use organizer::Organizer;
pub use sink::{FromCell, Sink};

use heapless::Vec;

use crate::address::Address;
use crate::frame::Frame;
use crate::message::Port;

/// Timing of self-organization, in microseconds of the cell's clock.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    /// Period of the probes on ports that sent nothing else (the link
    /// keep-alive), and of the beacon waves relayed on spare links.
    pub keepalive_period_us: u64,
    /// A port other than the master port with nothing received for this
    /// long is down.
    pub keepalive_timeout_us: u64,
    /// The master port with nothing received for this long is down (the
    /// parent relays every beacon wave on it).
    pub link_timeout_us: u64,
    /// Period of the beacon waves started by interface ports.
    pub beacon_period_us: u64,
    /// A route that relayed no wave for this long is lost: the cell asks
    /// every neighbour for the next wave (its parent may be gone, or a bit
    /// error took the wave), keeping the route meanwhile. One and a half
    /// beacon periods: the ask reaches the neighbours before the next wave.
    pub wave_timeout_us: u64,
    /// A route that relayed no wave for this long is given up.
    pub route_timeout_us: u64,
    /// Time between repeated ID requests.
    pub id_retry_us: u64,
    /// Period of the neighbour-table heartbeat.
    pub report_period_us: u64,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            keepalive_period_us: 100_000,
            keepalive_timeout_us: 350_000,
            link_timeout_us: 35_000,
            beacon_period_us: 10_000,
            wave_timeout_us: 15_000,
            route_timeout_us: 35_000,
            id_retry_us: 50_000,
            report_period_us: 4_000_000,
        }
    }
}

/// Where a cell keeps its ID across power cycles (flash on a real cell).
pub trait IdStore {
    /// The stored ID, if any.
    fn load(&self) -> Option<Address>;
    /// Stores a newly assigned ID.
    fn store(&mut self, id: Address);
}

/// A store in RAM, for tests and the simulator (it survives a simulated
/// reboot when kept outside the cell).
impl IdStore for Option<Address> {
    fn load(&self) -> Option<Address> {
        *self
    }
    fn store(&mut self, id: Address) {
        *self = Some(id);
    }
}

/// A frame the organizer wants sent.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Out {
    /// Across one link only.
    Link(Port, Frame),
    /// Upstream to the host, through the master port.
    Up(Frame),
}

/// Where the organizer puts the frames it wants sent: the cell's router,
/// or a plain vector in tests.
pub trait Outbox {
    /// Takes one frame to send.
    fn send(&mut self, out: Out);
}

impl<const N: usize> Outbox for Vec<Out, N> {
    fn send(&mut self, out: Out) {
        // Sized by the caller; a push past it is a bug in the test, not a
        // network condition.
        debug_assert!(self.len() < N, "outbox of {N} overflows");
        let _ = self.push(out);
    }
}
