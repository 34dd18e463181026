//! The robot PC side of the skin.
//!
//! The host knows nothing of robot models: it talks to the robot only
//! through the [`robot::Robot`] trait (DoF count, velocity commands,
//! position feedback) and to the skin only through its samples, and learns
//! the rest from them. Only calibration and the live view read the robot's
//! own description (URDF, with `skin_model`'s reader and kinematics).
//!
//! The `sim` feature (on by default) adds the simulator (`skin-sim`, a
//! dependency only with this feature) and the glue to it: the
//! simulated robot, checks against its ground truth, the grasping
//! experiment with its simulated person and objects, and the report's
//! sections only a simulation can fill. Without it the library's API holds
//! no simulator type.
//!
//! - [`robot`]: the robot and sample-stream traits, and the simulated robot behind them.
//! - [`explore`]: kinematic self-exploration: activity matrix, kinematic tree, sensory-motor map.
//! - [`interface`]: the UDP interface to the skin: checks, counters, events, configuration writes.
//! - [`registry`]: the cells heard: IDs, neighbours, patches, health; the ID authority.
//! - [`config`]: the TOML configuration of the `skin` program.
//! - [`control`]: whole-body tactile reactions, events, touch areas, key poses and the grasp.
//! - `grasping` (the `sim` feature): the grasping experiment on an explored robot: teaching by proximity, grasps of Figure 16 objects.
//! - [`remote`]: a robot and its skin over UDP: the robot link and the interface as one rig.
//! - [`pipeline`]: the main job's steps: wait for the skin to organize, write the cell settings.
//! - [`update`]: firmware updates: update keys, signed images.
//! - [`report`]: the report folder: figures as SVG, `report.json`, `index.html`.
//! - [`ros`]: ROS 2 message types, their CDR encoding and type hashes, and the skin's topics.
//! - [`recording`]: a run recorded into an MCAP file (raw datagrams and ROS 2 topics), and read back.
//! - [`replay`]: a recording played back as a robot and skin, to explore again.
//! - [`mod@reference`]: the book's command-line and configuration references, generated.
//! - [`view`]: what a live viewer is told, over a queue that drops rather than blocks.
//! - `foxglove` (the `foxglove` feature): the live 3D view in Foxglove, over the SDK's WebSocket server.
// Denied, not forbidden: the batched receive of `interface::socket` calls
// `recvmmsg`/`sendmmsg`, and `ros::control`'s signal handling calls
// `sigaction`/`pthread_sigmask`; they are the modules allowed to.
#![deny(unsafe_code)]
#![warn(missing_docs)]

pub mod calibrate;
pub mod config;
pub mod control;
pub mod explore;
#[cfg(feature = "foxglove")]
pub mod foxglove;
#[cfg(feature = "sim")]
pub mod grasping;
pub mod health;
pub mod interface;
pub mod pipeline;
pub mod recording;
pub mod reference;
pub mod registry;
pub mod remote;
pub mod replay;
pub mod report;
pub mod robot;
pub mod ros;
pub mod update;
pub mod view;
