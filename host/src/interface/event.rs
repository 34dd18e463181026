//! What the interface hands to the rest of the host.

use skin_protocol::event::{FORCE_NAMES, PROXIMITY_NAMES};
use skin_protocol::message::{Channel, ConfigAck, NeighbourReport, Port, TactileEvent, UpdateReport};
use skin_protocol::{Address, Sample};

/// A tactile level change as people read it (`force 0 level 2 (medium
/// force)`): the monitor's lines and the live view's log say it alike.
pub fn tactile_text(t: &TactileEvent) -> String {
    let (channel, names) = match t.channel {
        Channel::Proximity => ("proximity", &PROXIMITY_NAMES),
        Channel::Force0 => ("force 0", &FORCE_NAMES),
        Channel::Force1 => ("force 1", &FORCE_NAMES),
        Channel::Force2 => ("force 2", &FORCE_NAMES),
    };
    let name = names.get(usize::from(t.level)).unwrap_or(&"?");
    format!("{channel} level {} ({name})", t.level)
}

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
