//! The physical world the skin lives in.
//!
//! Only the simulator knows the robot's body: it loads a robot from URDF,
//! mounts skin cells on its links, moves it under velocity control on a
//! virtual clock and produces, tick by tick, the samples the real skin would
//! send. The host learns everything it knows from those samples and the
//! robot's position feedback; ground truth stays here, for checking.
//!
//! - [`robot`]: URDF loading, the built-in HRP-2-like robot, forward kinematics.
//! - [`scene`]: objects of Figure 16 and a hand: force through the foam, VCNL4010 proximity, sliding.
//! - [`skin`]: placing cells on link surfaces or from a skin file.
//! - [`accel`]: the BMA250 accelerometer model.
//! - [`world`]: robot, base and skin stepped together at 250 Hz.
//! - [`network`]: the cell network, every cell running the firmware's protocol code.
//! - [`endpoint`]: the simulated robot and skin served over UDP, as a real one is reached.
//! - [`round`]: `f64::round` and `f64::trunc` without libm, for the simulator's hot paths.
//! - [`spin_recv`]: the receive of a lockstep peer, which tries before it sleeps.
#![deny(unsafe_code)]
#![warn(missing_docs)]

pub mod accel;
pub mod endpoint;
pub mod network;
pub mod robot;
pub mod round;
pub mod scene;
pub mod skin;
pub mod spin_recv;
pub mod world;
