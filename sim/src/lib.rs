//! The physical world the skin lives in.
//!
//! The simulator takes a robot and its skin as `skin_model` describes them,
//! moves the robot under velocity control on a virtual clock and produces,
//! tick by tick, the samples the real skin would send. The host learns everything it knows from those samples and the
//! robot's position feedback; ground truth stays here, for checking.
//!
//! - [`scene`]: objects of Figure 16 and a hand: force through the foam, VCNL4010 proximity, sliding.
//! - [`accel`]: the BMA250 accelerometer model.
//! - [`world`]: robot, base and skin stepped together at 250 Hz.
//! - [`network`]: the cell network, every cell running the firmware's protocol code.
//! - [`endpoint`]: the simulated robot and skin served over UDP, as a real one is reached.
//! - [`round`]: `f64::round` and `f64::trunc` without libm, for the simulator's hot paths.
#![deny(unsafe_code)]
#![warn(missing_docs)]

pub mod accel;
pub mod endpoint;
#[cfg(feature = "mujoco")]
pub mod mujoco;
pub mod network;
pub mod round;
pub mod scene;
pub mod world;
