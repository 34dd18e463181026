//! The robot link: what the control approach needs of a robot (section
//! 3.2), as one UDP datagram each way.
//!
//! The paper asks three things of a robot: (i) it publishes its number of
//! revolute DoFs, (ii) it accepts a velocity command per DoF and (iii) it
//! gives position feedback per DoF. The host sends [`ToRobot`] datagrams, the
//! robot answers each with one [`FromRobot`] datagram:
//!
//! ```text
//! bytes 0..2   magic "RL"
//! byte  2      version (1)
//! bytes 3..    postcard encoding of a ToRobot or FromRobot
//! ```
//!
//! | host sends                      | robot answers                              |
//! |---------------------------------|--------------------------------------------|
//! | `Hello`                         | `Info { dofs, period_us, lockstep }`       |
//! | `DofName { index }`             | `DofName { index, name }`                  |
//! | `DofKind { index }`             | `DofKind { index, kind }`                  |
//! | `Command { seq, velocities }`   | `State { seq, time_us, positions }`        |
//! | anything it cannot follow       | `Refused { seq, reason }`                  |
//!
//! A robot that runs in real time answers a command at once with its latest
//! feedback and holds the velocities until the next command (it should stop
//! by itself when commands cease). A simulated robot in *lockstep* advances
//! exactly one control period per new command and answers with the
//! feedback at its end, so simulated time runs as fast as the host goes. A
//! command repeating the last `seq` (the host's retry after a lost answer)
//! is answered again without moving.

use heapless::{String, Vec};
use serde::{Deserialize, Serialize};

/// Magic bytes at the start of every robot-link datagram.
pub const MAGIC: [u8; 2] = *b"RL";
/// The version this crate speaks.
pub const VERSION: u8 = 1;
/// Most DoFs a robot on the link may have (HRP-2 has 30; wheels, casters,
/// fingers and two arms make 101 on a common mobile manipulator). DoF
/// counts and indices travel as varints: below 128 their bytes are those
/// of the single bytes the first robots spoke, so those still understand.
pub const MAX_DOFS: usize = 256;
/// Longest DoF name, bytes of UTF-8.
pub const MAX_NAME: usize = 32;
/// Largest datagram either way: header, tag, seq, time, the count and
/// [`MAX_DOFS`] f64 values (2,069 bytes: one UDP datagram, fragmented
/// past an Ethernet MTU, which a host and robot on one network handle).
pub const MAX_DATAGRAM: usize = 3 + 1 + 5 + 10 + 2 + MAX_DOFS * 8;

/// From the host to the robot.
// Unboxed on purpose: no allocator on a robot's controller, and a message
// lives only between a socket and its handler.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum ToRobot {
    /// Who are you? Answered with [`FromRobot::Info`].
    Hello,
    /// The name of DoF `index`. Answered with [`FromRobot::DofName`].
    DofName {
        /// 0-based, in command order.
        index: u16,
    },
    /// Velocities per DoF (rad/s, or m/s for a prismatic DoF), in command
    /// order, held until the next command. Answered with [`FromRobot::State`].
    Command {
        /// Command number, one more for each new command (wrapping).
        seq: u32,
        /// One velocity per DoF, rad/s.
        velocities: Vec<f64, MAX_DOFS>,
    },
    /// How DoF `index` moves. Answered with [`FromRobot::DofKind`]; a robot
    /// that refuses it has revolute DoFs only. Last, so the encodings of
    /// the others stay those of the first version.
    DofKind {
        /// 0-based, in command order.
        index: u16,
    },
}

/// From the robot to the host.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum FromRobot {
    /// Requirement (i): the number of revolute DoFs, and how the robot keeps time.
    Info {
        /// Revolute DoFs under velocity control.
        dofs: u16,
        /// The robot's control period, microseconds.
        period_us: u32,
        /// True when the robot advances one period per command (a
        /// simulator), false when it runs in real time.
        lockstep: bool,
    },
    /// The name of a DoF.
    DofName {
        /// 0-based, in command order.
        index: u16,
        /// Its name, e.g. `RARM_JOINT3`.
        name: String<MAX_NAME>,
    },
    /// Requirement (iii): position feedback, after command `seq` (ii) was applied.
    State {
        /// The command answered.
        seq: u32,
        /// The robot's clock, microseconds since it started.
        time_us: u64,
        /// One position per DoF, rad.
        positions: Vec<f64, MAX_DOFS>,
    },
    /// A request the robot cannot follow; it keeps its last command.
    Refused {
        /// The command's `seq`, or 0 for a request without one.
        seq: u32,
        /// Why.
        reason: Refusal,
    },
    /// How a DoF moves.
    DofKind {
        /// 0-based, in command order.
        index: u16,
        /// Revolute or prismatic.
        kind: DofKind,
    },
}

/// How a DoF moves what it carries.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DofKind {
    /// Turns about an axis: positions in rad, velocities in rad/s.
    Revolute,
    /// Slides along an axis (torso lifts, grippers, linear axes): m and m/s.
    Prismatic,
}

/// Why a robot refused a request.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Refusal {
    /// A command with another number of velocities than the robot has DoFs.
    WrongLength,
    /// A NaN or infinite velocity.
    NotFinite,
    /// A DoF index the robot does not have.
    NoSuchDof,
    /// The robot serves another host: it obeys only the first that spoke
    /// to it.
    Busy,
}

impl Refusal {
    /// Why a command of `velocities` cannot drive a robot of `dofs` DoFs, if it cannot.
    pub fn of_command(velocities: &[f64], dofs: usize) -> Option<Refusal> {
        if velocities.len() != dofs {
            Some(Refusal::WrongLength)
        } else if velocities.iter().any(|v| !v.is_finite()) {
            Some(Refusal::NotFinite)
        } else {
            None
        }
    }
}

/// Why bytes are not a robot-link datagram.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum LinkError {
    /// Shorter than a header, or longer than [`MAX_DATAGRAM`].
    BadLength(usize),
    /// Does not start with [`MAGIC`].
    BadMagic,
    /// A version this crate does not speak.
    UnknownVersion(u8),
    /// The body is not a message of this version, or has bytes after it.
    BadBody,
    /// The message does not fit the buffer given to encode it.
    BufferTooSmall,
}

impl core::fmt::Display for LinkError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            LinkError::BadLength(n) => write!(f, "robot-link datagram of {n} bytes (3..={MAX_DATAGRAM})"),
            LinkError::BadMagic => f.write_str("datagram does not start with the robot-link magic"),
            LinkError::UnknownVersion(v) => write!(f, "robot-link version {v}, this build speaks {VERSION}"),
            LinkError::BadBody => f.write_str("robot-link datagram body is not a valid message"),
            LinkError::BufferTooSmall => f.write_str("robot-link message does not fit the buffer"),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for LinkError {}

/// Writes `message` as a datagram into `buf`; returns its length.
pub fn encode<T: Serialize>(message: &T, buf: &mut [u8]) -> Result<usize, LinkError> {
    if buf.len() < 3 {
        return Err(LinkError::BufferTooSmall);
    }
    buf[0..2].copy_from_slice(&MAGIC);
    buf[2] = VERSION;
    let body = postcard::to_slice(message, &mut buf[3..]).map_err(|_| LinkError::BufferTooSmall)?;
    Ok(3 + body.len())
}

/// Reads a datagram: the header, then exactly one message.
pub fn decode<'a, T: Deserialize<'a>>(bytes: &'a [u8]) -> Result<T, LinkError> {
    if !(3..=MAX_DATAGRAM).contains(&bytes.len()) {
        return Err(LinkError::BadLength(bytes.len()));
    }
    if bytes[0..2] != MAGIC {
        return Err(LinkError::BadMagic);
    }
    if bytes[2] != VERSION {
        return Err(LinkError::UnknownVersion(bytes[2]));
    }
    match postcard::take_from_bytes(&bytes[3..]) {
        Ok((message, [])) => Ok(message),
        _ => Err(LinkError::BadBody),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn roundtrip<T: Serialize + for<'a> Deserialize<'a> + PartialEq + core::fmt::Debug>(m: &T) {
        let mut buf = [0u8; MAX_DATAGRAM];
        let n = encode(m, &mut buf).expect("every message fits MAX_DATAGRAM");
        assert_eq!(decode::<T>(&buf[..n]).as_ref(), Ok(m));
        // Every proper prefix is refused, and so is a trailing byte.
        for k in 0..n {
            assert!(decode::<T>(&buf[..k]).is_err(), "prefix of {k} bytes accepted");
        }
        if n < MAX_DATAGRAM {
            assert_eq!(decode::<T>(&buf[..n + 1]), Err(LinkError::BadBody));
        }
    }

    #[test]
    fn a_command_is_refused_for_its_length_then_for_a_non_finite_value() {
        assert_eq!(Refusal::of_command(&[0.0, 1.0], 2), None);
        assert_eq!(Refusal::of_command(&[0.0], 2), Some(Refusal::WrongLength));
        assert_eq!(Refusal::of_command(&[f64::NAN], 2), Some(Refusal::WrongLength));
        assert_eq!(Refusal::of_command(&[0.0, f64::INFINITY], 2), Some(Refusal::NotFinite));
    }

    #[test]
    fn the_largest_messages_fit() {
        let full: Vec<f64, MAX_DOFS> = (0..MAX_DOFS).map(|_| f64::MAX).collect();
        roundtrip(&ToRobot::Command { seq: u32::MAX, velocities: full.clone() });
        roundtrip(&FromRobot::State { seq: u32::MAX, time_us: u64::MAX, positions: full });
        let name: String<MAX_NAME> = (0..MAX_NAME).map(|_| 'x').collect();
        let last = (MAX_DOFS - 1) as u16;
        roundtrip(&FromRobot::DofName { index: last, name });
        roundtrip(&FromRobot::Info { dofs: MAX_DOFS as u16, period_us: u32::MAX, lockstep: true });
        roundtrip(&FromRobot::Refused { seq: 7, reason: Refusal::NoSuchDof });
        roundtrip(&FromRobot::Refused { seq: 0, reason: Refusal::Busy });
        roundtrip(&ToRobot::Hello);
        roundtrip(&ToRobot::DofKind { index: last });
        roundtrip(&FromRobot::DofKind { index: last, kind: DofKind::Prismatic });
    }

    #[test]
    fn header_errors_are_named() {
        let mut buf = [0u8; MAX_DATAGRAM];
        let n = encode(&ToRobot::Hello, &mut buf).unwrap();
        assert_eq!(decode::<ToRobot>(&buf[..2]), Err(LinkError::BadLength(2)));
        buf[2] = 9;
        assert_eq!(decode::<ToRobot>(&buf[..n]), Err(LinkError::UnknownVersion(9)));
        buf[0] = b'X';
        assert_eq!(decode::<ToRobot>(&buf[..n]), Err(LinkError::BadMagic));
        assert_eq!(encode(&ToRobot::Hello, &mut buf[..3]), Err(LinkError::BufferTooSmall));
        // A command of 257 velocities (varint 0x81 0x02) cannot be decoded into 256.
        let mut long = std::vec![b'R', b'L', VERSION, 2, 0, 0x81, 0x02];
        long.extend(core::iter::repeat_n(0u8, 257 * 8));
        assert!(long.len() <= MAX_DATAGRAM);
        assert_eq!(decode::<ToRobot>(&long), Err(LinkError::BadBody));
    }

    #[test]
    fn counts_and_indices_below_128_keep_the_single_bytes_of_the_first_robots() {
        let mut buf = [0u8; MAX_DATAGRAM];
        encode(&FromRobot::Info { dofs: 30, period_us: 4000, lockstep: false }, &mut buf).unwrap();
        assert_eq!(&buf[3..5], &[0, 30], "tag, then the count as one byte");
        let n = encode(&ToRobot::DofName { index: 127 }, &mut buf).unwrap();
        assert_eq!(&buf[3..n], &[1, 127]);
    }

    proptest! {
        #[test]
        fn any_bytes_decode_or_fail_cleanly(bytes in proptest::collection::vec(any::<u8>(), 0..600)) {
            let _ = decode::<ToRobot>(&bytes);
            let _ = decode::<FromRobot>(&bytes);
        }

        #[test]
        fn any_bytes_after_the_header_decode_or_fail_cleanly(body in proptest::collection::vec(any::<u8>(), 0..560)) {
            let mut bytes = std::vec![b'R', b'L', VERSION];
            bytes.extend(body);
            // Whatever decodes means one thing: its canonical encoding
            // (postcard also reads over-long varints) decodes to a message
            // that encodes to the same bytes again (NaNs included).
            fn canonical<T: Serialize + for<'a> Deserialize<'a>>(m: &T) -> std::vec::Vec<u8> {
                let mut buf = [0u8; MAX_DATAGRAM];
                let n = encode(m, &mut buf).unwrap();
                buf[..n].to_vec()
            }
            if let Ok(m) = decode::<ToRobot>(&bytes) {
                let once = canonical(&m);
                prop_assert_eq!(canonical(&decode::<ToRobot>(&once).unwrap()), once);
            }
            if let Ok(m) = decode::<FromRobot>(&bytes) {
                let once = canonical(&m);
                prop_assert_eq!(canonical(&decode::<FromRobot>(&once).unwrap()), once);
            }
        }

        #[test]
        fn commands_and_states_roundtrip(
            seq: u32,
            time_us: u64,
            values in proptest::collection::vec(any::<f64>().prop_filter("NaN != NaN", |v| !v.is_nan()), 0..=MAX_DOFS),
        ) {
            let v: Vec<f64, MAX_DOFS> = values.iter().copied().collect();
            roundtrip(&ToRobot::Command { seq, velocities: v.clone() });
            roundtrip(&FromRobot::State { seq, time_us, positions: v });
        }
    }
}
