//! What both ends of a skin wire agree on.
//!
//! Every skin cell, the network simulator and the robot PC compile this one
//! crate, so a frame means the same thing everywhere. Each piece is a pure
//! state machine in the smoltcp style: frames and a time go in, frames and
//! state changes come out, and nothing here does I/O but [`file`]'s
//! capped read of a whole file, which every std crate shares. Any byte sequence fed
//! to a decoder gives a value or a typed error, never a panic.
//!
//! - [`frame`]: the 20-byte cell-2-cell frame (header, postcard payload, CRC-16).
//! - [`message`]: the payload of every message kind.
//! - [`sample`]: one multi-modal sensor sample, bit-packed into a frame.
//! - [`router`]: one cell's bounded, round-robin forwarding.
//! - [`organize`]: the four-phase network self-organization of one cell,
//!   the interface-port side of it, and the ID allocator of the host.
//! - [`cell`]: one cell's network stack, `organize` and `router` joined.
//! - [`app`]: one cell's application (settings, acknowledgements, refused
//!   sends, boot), on that stack or on any uplink.
//! - [`event`]: Table 3 tactile levels with hysteresis, and send-on-delta.
//! - [`processing`]: a cell's local filtering, offsets, events and send decision.
//! - [`image`]: the signed firmware image (header, CRC-32, ed25519 signature).
//! - [`update`]: a cell's side of a firmware update over the network.
//! - [`interface`]: the UDP datagram between an interface port and the host.
//! - [`robot_link`]: the UDP datagram between the host and a robot (section 3.2).
//! - [`file`] (std): a whole file read under a cap.
#![cfg_attr(not(feature = "std"), no_std)]
// Unsafe only where a cell is written in place (`CellApp::new_in`).
#![deny(unsafe_code)]
#![warn(missing_docs)]

pub mod address;
pub mod app;
pub mod cell;
pub mod event;
#[cfg(feature = "std")]
pub mod file;
pub mod frame;
pub mod image;
pub mod interface;
pub mod message;
pub mod organize;
pub mod processing;
pub mod robot_link;
pub mod router;
pub mod sample;
pub mod update;

pub use address::Address;
pub use frame::{Frame, FrameError, Header, Kind, FRAME_LEN};
pub use message::{Message, Port};
pub use sample::Sample;
