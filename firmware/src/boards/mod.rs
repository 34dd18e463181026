//! The boards a cell runs on; each exists only for its target and feature.

#[cfg(feature = "qemu")]
pub mod qemu;
pub mod stack;
#[cfg(feature = "stm32f4")]
pub mod stm32f4;
pub mod systick;
