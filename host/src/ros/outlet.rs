//! Where the skin's ROS 2 messages go live, besides a recording: a
//! middleware (Zenoh, with the `ros2` feature) or a viewer. A message is
//! encoded once and handed to every outlet as CDR.

use super::schema::MsgType;

/// A live destination of ROS 2 messages. Publishing never fails the run:
/// an outlet that cannot deliver counts and logs what it dropped.
pub trait Outlet: Send + std::fmt::Debug {
    /// Announces that `topic` will carry `ty`, before its first message,
    /// so subscribers match its writer before it sends instead of racing
    /// it: with DDS writers made on their first message, rclpy once heard
    /// only 9 messages of /skin/imu in a whole demo.
    fn declare(&mut self, topic: &'static str, ty: &'static MsgType);

    /// Publishes one message of type `ty` on `topic`: `cdr` is the whole
    /// message, encapsulation header first; `time_ns` is its time since
    /// the Unix epoch.
    fn publish(&mut self, topic: &'static str, ty: &'static MsgType, time_ns: u64, cdr: &[u8]);
}
