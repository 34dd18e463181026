//! The skin in ROS 2's formats, with no ROS installation: message types
//! described once ([`schema`]: `ros2msg` text and RIHS01 hashes), their
//! CDR encoding ([`cdr`], [`msgs`]), and the skin's topics built from
//! what the host knows ([`skin`]), and the live [`outlet`]s they go to
//! besides a recording (with the `ros2` feature: DDS as the default RMWs
//! speak it, the `dds` module, or Zenoh in rmw_zenoh's format, the
//! `rmw_zenoh` module), and a ros2_control robot driven over DDS (`control`).

pub mod cdr;
#[cfg(feature = "ros2")]
pub mod control;
#[cfg(feature = "ros2")]
pub mod dds;
pub mod msgs;
pub mod outlet;
#[cfg(feature = "ros2")]
pub mod rmw_zenoh;
pub mod schema;
pub mod skin;
