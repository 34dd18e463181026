//! The sensor-stimulus channel of the QEMU board (UART0).
//!
//! QEMU has no proximity, acceleration, temperature or force sensors, so the
//! test harness plays the physics: it sends the raw readings the chips would
//! give, and the cell samples the latest ones at its own rate. A stimulus is
//! an ordinary 20-byte frame carrying a [`Message::Sample`] from the host to
//! the unassigned address, so it has the cell's own framing and CRC; any
//! other frame on this channel is counted and ignored.

use skin_protocol::frame::{self, FRAME_LEN};
use skin_protocol::message::{AccelRange, Message};
use skin_protocol::{Address, Sample};

use crate::deframer::Deframer;
use crate::sensors::{SensorError, Sensors};

/// The wire form of a stimulus: the raw readings of one moment.
pub fn encode(raw: &Sample) -> [u8; FRAME_LEN] {
    frame::encode(Address::HOST, Address::UNASSIGNED, &Message::Sample(*raw))
}

/// Sensors whose readings arrive as stimulus frames.
#[derive(Clone, Debug, Default)]
pub struct Stimulated {
    deframer: Deframer,
    latest: Option<Sample>,
    ignored: u32,
}

impl Stimulated {
    /// Sensors that are not ready until the first stimulus.
    pub fn new() -> Stimulated {
        Stimulated::default()
    }

    /// Takes one byte from the stimulus channel.
    pub fn feed(&mut self, byte: u8) {
        let Some(frame) = self.deframer.push(byte) else { return };
        match frame.message() {
            Ok(Message::Sample(s)) => self.latest = Some(s),
            _ => self.ignored += 1,
        }
    }

    /// Valid frames on the channel that were not a stimulus.
    pub fn ignored(&self) -> u32 {
        self.ignored
    }
}

impl Sensors for Stimulated {
    /// The latest stimulus; none yet is an error, so that no sample (and
    /// no calibration) is made of readings the harness never sent.
    fn read(&mut self, _now_us: u64) -> Result<Sample, SensorError> {
        self.latest.ok_or(SensorError::NoStimulus)
    }

    /// The stimulus is in counts of whatever range the harness plays.
    fn set_accel_range(&mut self, _range: AccelRange) -> Result<(), SensorError> {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use skin_protocol::message::{ConfigAck, Message};

    #[test]
    fn the_latest_stimulus_is_read_and_other_frames_are_ignored() {
        let mut s = Stimulated::new();
        assert_eq!(s.read(0), Err(SensorError::NoStimulus));
        let raw = Sample::new(900, [1, 2, 3], [-4, 5, 256], 800, 0).unwrap();
        let ack = frame::encode(Address(3), Address::HOST, &Message::ConfigAck(ConfigAck { tag: 1, accepted: true }));
        for b in [0x55].iter().chain(&ack).chain(&encode(&raw)) {
            s.feed(*b);
        }
        assert_eq!(s.read(4_000).unwrap(), raw);
        assert_eq!(s.ignored(), 1);
    }
}
