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
//! - [`cycle`]: a 250 Hz cycle of a cell, as its cost is measured.
//! - `boards`: `qemu` (mps2-an386) and `stm32f4` (STM32F405), target only.
#![cfg_attr(not(test), no_std)]
#![warn(missing_docs)]

pub mod board;
pub mod boot;
pub mod cycle;
pub mod deframer;
pub mod drivers;
pub mod flash_slot;
pub mod node;
pub mod ring;
pub mod sensors;
pub mod stimulus;
pub mod store;

#[cfg(all(target_os = "none", any(feature = "qemu", feature = "stm32f4")))]
pub mod boards;
