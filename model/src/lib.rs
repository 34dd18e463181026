//! The robot and its skin as descriptions: what a robot is made of and
//! where the cells sit on it, with no world around them.
//!
//! Every world the skin lives in (the built-in simulator, a MuJoCo model, a
//! real robot) and the host stand on this one description, so a URDF is
//! read, and a pose computed, the same way everywhere.
//!
//! - [`robot`]: a robot from URDF (bodies, joint kinds, limits, mimics), its
//!   forward kinematics to second order, and the built-in HRP-2-like robot.
//! - [`skin`]: skin cells on links: the skin file (TOML or JSON) and cells
//!   laid on link surfaces, at random or in wired patches.
//! - [`mod@file`]: a whole file read under a cap, so that a wrong path such as
//!   `/dev/zero` is refused naming the cap instead of filling memory.
//! - [`spin_recv`]: the receive at either end of a robot link in lockstep,
//!   which tries before it sleeps.
#![deny(unsafe_code)]
#![warn(missing_docs)]

pub mod file;
pub mod robot;
pub mod skin;
pub mod spin_recv;
