//! The robot PC side of the skin.
//!
//! - [`interface`]: the UDP interface to the skin: checks, counters, events, configuration writes.
//! - [`registry`]: the cells heard: IDs, neighbours, patches, health; the ID authority.
//! - [`config`]: the TOML configuration of the `skin` program.
// Denied, not forbidden: the batched receive of `interface::socket` calls
// `recvmmsg`/`sendmmsg` and is the one module allowed to.
#![deny(unsafe_code)]
#![warn(missing_docs)]

pub mod config;
pub mod interface;
pub mod registry;
