//! End-to-end tests across the crates.
//!
//! - [`qemu`]: a patch of QEMU skin cells running the real firmware, wired
//!   hexagonally through their UARTs, with an interface port that speaks
//!   UDP to a host on loopback (`cargo run -p skin-tests --bin qemu-net`).
pub mod qemu;
