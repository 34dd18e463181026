//! The skin in ROS 2's formats, with no ROS installation: message types
//! described once ([`schema`]: `ros2msg` text and RIHS01 hashes), their
//! CDR encoding ([`cdr`], [`msgs`]), and the skin's topics built from
//! what the host knows ([`skin`]), and the live [`outlet`]s they go to
//! besides a recording (Zenoh in rmw_zenoh's format: the `rmw_zenoh` module, with
//! the `ros2` feature).

pub mod cdr;
pub mod msgs;
pub mod outlet;
#[cfg(feature = "ros2")]
pub mod rmw_zenoh;
pub mod schema;
pub mod skin;
