//! The program in every skin cell (section 2.1): sensor drivers, local
//! processing, persistent storage and the cell's network stack, glued by a
//! main loop that is generic over the board.
//!
//! Everything but the board modules builds and is tested on the robot PC:
//!
//! - [`drivers`]: VCNL4010, BMA250, LM71 and the capacitive force cells.
//! - [`sensors`]: one raw sample per period from the chips (or a stand-in).
//! - [`stimulus`]: the QEMU stand-in, fed with readings by the test harness.
//! - [`deframer`]: frames out of a UART byte stream.
//! - [`ring`]: index arithmetic of the DMA rings behind a board's ports.
//! - [`store`]: ID, offsets and settings in flash.
//! - [`node`]: the cell's logic: [`skin_protocol::cell::Cell`] and
//!   [`skin_protocol::processing::Processor`] on bytes and samples.
//! - [`board`]: what a board provides, and the main loop.
//! - [`boot`], [`boot_control`], [`loader`], [`flash_map`], [`flash_slot`],
//!   [`shared_flash`]: updates: the boot record and the bootloader's
//!   choice, the program's side of it, the bootloader's work, where each
//!   board keeps what, image slots on flash, one flash for all of them.
//! - [`cycle`]: a 250 Hz cycle of a cell, as its cost is measured.
//! - `boards`: `qemu` (mps2-an386) and `stm32f4` (STM32F405), target only.
#![cfg_attr(not(test), no_std)]
#![warn(missing_docs)]

pub mod board;
pub mod boot;
pub mod boot_control;
pub mod cycle;
pub mod deframer;
pub mod drivers;
pub mod flash_map;
pub mod flash_slot;
pub mod loader;
pub mod node;
pub mod ring;
pub mod sensors;
pub mod shared_flash;
pub mod stimulus;
pub mod store;

/// The ed25519 public key every image must be signed with: built in
/// (`SKIN_UPDATE_KEY` at build time, 64 hex digits), by default RFC 8032's
/// TEST 1 key, a development key whose secret is published.
pub const UPDATE_KEY: [u8; 32] = include!(concat!(env!("OUT_DIR"), "/update_key.rs"));

#[cfg(all(target_os = "none", any(feature = "qemu", feature = "stm32f4")))]
pub mod boards;
