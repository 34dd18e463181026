//! What the interface hands to the rest of the host.

use skin_protocol::message::{ConfigAck, NeighbourReport, Port, TactileEvent, UpdateReport};
use skin_protocol::{Address, Sample};

/// One thing that happened on the skin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Event {
    /// The interface port it came through.
    pub interface: u8,
    /// The interface's clock when the datagram started, in microseconds.
    pub timestamp_us: u64,
    /// The cell it is about.
    pub cell: Address,
    /// What happened.
    pub kind: EventKind,
}

/// The kinds of [`Event`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EventKind {
    /// The cell was heard for the first time.
    Joined,
    /// The cell is now heard through another interface port: the network
    /// re-organized around a fault.
    Moved {
        /// The port it was heard through before.
        from: u8,
    },
    /// A sensor sample.
    Sample(Sample),
    /// A change of tactile level.
    Tactile(TactileEvent),
    /// The cell's neighbour table changed (repeats and heartbeats of an
    /// unchanged table are not events).
    Neighbours(NeighbourReport),
    /// The cell acknowledged a configuration write.
    ConfigAck(ConfigAck),
    /// The cell reported on a firmware update.
    UpdateReport(UpdateReport),
    /// The host answered an ID request: `cell` is the ID given to the cell
    /// on `port` of `parent` (again, when the request was repeated).
    IdAssigned {
        /// The asking cell's parent: a cell or an interface port.
        parent: Address,
        /// The parent's port toward the asking cell.
        port: Port,
    },
}
