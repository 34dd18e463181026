//! The watch on interface ports that stop delivering mid-run.
//!
//! Once every cell sends every sample (the exploration, the calibration),
//! a port that delivered and then falls silent means a skin that lost
//! power, a cut cable or an endpoint that restarted and is being dropped as
//! spoofed. Without a watch the exploration fills its traces with gaps and
//! reports a map of zeros; with it the run ends naming the port.
//!
//! Silence is judged in both clocks at once. Robot time is the clock the
//! skin's samples follow (a lockstep simulator sends nothing while the host
//! does not command it); wall-clock time is the clock that delivers them. A
//! lockstep robot runs as fast as the host asks, so behind a relay or on a
//! loaded machine its clock runs ahead of datagrams still on their way. A
//! port is [`Heard::Behind`], to be waited for, when it has been quiet for a
//! fifth of the robot-time bound (two sample periods), or when its latest
//! datagram is stamped that far before the robot's clock: a lockstep
//! simulator steps its skin on the robot's clock, and a relay delays
//! datagrams without stopping them, so only their stamps show how far
//! behind they are. A port whose stamps follow another clock is told with
//! [`SilenceWatch::off_clock`] and judged by its counts alone. Only a port
//! quiet past both bounds is [`Silent`].

use std::time::{Duration, Instant};

use super::ports::Ports;

/// Wall-clock time a port may be silent on top of the robot-time bound:
/// longer than any relay or scheduler delay a datagram meets on a working
/// path, short enough that a skin that stops is named within a fraction of
/// a second.
pub const WALL_BOUND: Duration = Duration::from_millis(200);

/// The part of the robot-time bound after which a quiet port is waited for.
const BEHIND_PART: f64 = 0.2;

/// Interface ports that delivered and then fell silent.
#[derive(Clone, Debug, PartialEq)]
pub struct Silent {
    /// Their port numbers.
    pub ports: Vec<u8>,
    /// The longest silence among them, s of robot time.
    pub silent_s: f64,
    /// The longest silence among them, s of wall-clock time.
    pub silent_wall_s: f64,
}

/// What the ports delivered, judged in both clocks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Heard {
    /// Every port that delivered before is within both bounds.
    All,
    /// Some port is quiet past a fifth of the robot-time bound but not yet
    /// past both bounds: its datagrams may still be on their way, until the
    /// instant given.
    Behind(Instant),
}

/// A port's accepted datagrams when last seen growing, and when in each clock.
#[derive(Clone, Copy, Debug)]
struct Growth {
    datagrams: u64,
    robot_s: f64,
    wall: Instant,
}

/// Accepted datagrams and the robot and wall-clock times they last grew, per port.
#[derive(Clone, Debug)]
pub struct SilenceWatch {
    bound_s: f64,
    bound_wall: Duration,
    /// By port index.
    heard: Vec<Option<Growth>>,
    /// By port index: its stamps follow another clock than the robot's.
    off_clock: Vec<bool>,
}

impl SilenceWatch {
    /// A watch that reports a port silent for `bound_s` of robot time and
    /// `bound_wall` of wall-clock time; ports that have never delivered are
    /// not watched.
    pub fn new(bound_s: f64, bound_wall: Duration) -> SilenceWatch {
        SilenceWatch { bound_s, bound_wall, heard: Vec::new(), off_clock: Vec::new() }
    }

    /// Takes the ports' counts at robot time `now_s` and wall-clock time
    /// `now`; the silent ones, if any.
    pub fn check(&mut self, ports: &Ports, now_s: f64, now: Instant) -> Result<Heard, Silent> {
        self.heard.resize(ports.len(), None);
        self.off_clock.resize(ports.len(), false);
        let mut silent = Silent { ports: Vec::new(), silent_s: 0.0, silent_wall_s: 0.0 };
        let mut behind: Option<Instant> = None;
        let behind_s = self.bound_s * BEHIND_PART;
        for ((port, heard), &off_clock) in ports.iter().zip(&mut self.heard).zip(&self.off_clock) {
            let datagrams = port.stats().datagrams;
            let growth = match heard {
                Some(g) if g.datagrams == datagrams => *g,
                // Never delivered: nothing to miss.
                None if datagrams == 0 => continue,
                _ => *heard.insert(Growth { datagrams, robot_s: now_s, wall: now }),
            };
            let (quiet_s, quiet_wall) = (now_s - growth.robot_s, now.saturating_duration_since(growth.wall));
            let stamped_s = port.stats().latest_timestamp_us.filter(|_| !off_clock).map(|us| us as f64 / 1e6);
            let late = stamped_s.is_some_and(|at_s| now_s - at_s >= behind_s);
            if quiet_s < behind_s && !late {
                continue;
            }
            if quiet_s >= self.bound_s && quiet_wall >= self.bound_wall {
                silent.ports.push(port.number());
                silent.silent_s = silent.silent_s.max(quiet_s);
                silent.silent_wall_s = silent.silent_wall_s.max(quiet_wall.as_secs_f64());
            } else {
                let until = if late { now + self.bound_wall } else { growth.wall + self.bound_wall };
                behind = Some(behind.map_or(until, |b| b.min(until)));
            }
        }
        match (silent.ports.is_empty(), behind) {
            (false, _) => Err(silent),
            (true, Some(until)) => Ok(Heard::Behind(until)),
            (true, None) => Ok(Heard::All),
        }
    }

    /// The ports whose latest stamp lies a fifth of the bound or more before
    /// robot time `now_s`: their stamps are taken to follow another clock
    /// from now on, and they are judged by their counts alone. Returns
    /// their numbers.
    pub fn off_clock(&mut self, ports: &Ports, now_s: f64) -> Vec<u8> {
        self.off_clock.resize(ports.len(), false);
        let mut marked = Vec::new();
        for (port, off) in ports.iter().zip(&mut self.off_clock) {
            let stamped_s = port.stats().latest_timestamp_us.map(|us| us as f64 / 1e6);
            if !*off && stamped_s.is_some_and(|at_s| now_s - at_s >= self.bound_s * BEHIND_PART) {
                *off = true;
                marked.push(port.number());
            }
        }
        marked
    }
}

/// Robot time a port may be silent while every cell sends every sample:
/// ten sample periods at `sample_rate_hz`, and at least 50 ms. A running
/// skin delivers a datagram a period on each port, so this is a dozen
/// datagrams lost in a row; and it is shorter than the exploration's
/// shortest averaging window (0.1 s), so a port that dies is named before
/// a window finds one of its cells short of samples.
pub fn silence_bound_s(sample_rate_hz: f64) -> f64 {
    (10.0 / sample_rate_hz).max(0.05)
}

#[cfg(test)]
mod tests {
    use std::net::SocketAddr;

    use super::*;
    use crate::config::PortConfig;

    fn ports() -> Ports {
        let addr = |p: u16| Some(SocketAddr::from(([127, 0, 0, 1], p)));
        Ports::new(&[
            PortConfig { number: 0, address: addr(100) },
            PortConfig { number: 2, address: addr(200) },
            PortConfig { number: 4, address: None },
        ])
    }

    fn deliver(ports: &mut Ports, index: usize) {
        ports.get_mut(index).stats_mut().datagrams += 1;
    }

    /// Wall-clock time `s` after `start`.
    fn at(start: Instant, s: f64) -> Instant {
        start + Duration::from_secs_f64(s)
    }

    #[test]
    fn a_port_that_delivered_and_stopped_is_named_after_the_bound() {
        let (mut ports, start) = (ports(), Instant::now());
        let mut watch = SilenceWatch::new(1.0, Duration::from_secs(1));
        // Ports 0 and 2 deliver every 4 ms of both clocks, port 2 only
        // until tick 374; port 4 never delivers and is not missed.
        let first_silent = (0..1000u32).find_map(|k| {
            deliver(&mut ports, 0);
            if k < 375 {
                deliver(&mut ports, 1);
            }
            let t = f64::from(k) * 0.004;
            watch.check(&ports, t, at(start, t)).err().map(|silent| (k, silent))
        });
        let (k, silent) = first_silent.expect("port 2 is named");
        assert!((624..=625).contains(&k), "named at tick {k}, 1 s after tick 374");
        assert_eq!(silent.ports, [2]);
        assert!((0.999..1.005).contains(&silent.silent_s), "{silent:?}");
        assert!((0.999..1.005).contains(&silent.silent_wall_s), "{silent:?}");
    }

    #[test]
    fn every_silent_port_is_named_with_the_longest_silence() {
        let (mut ports, start) = (ports(), Instant::now());
        let mut watch = SilenceWatch::new(0.5, Duration::ZERO);
        deliver(&mut ports, 0);
        deliver(&mut ports, 2);
        assert_eq!(watch.check(&ports, 10.0, start), Ok(Heard::All));
        deliver(&mut ports, 2);
        // Port 0 quiet past a fifth of the bound: waited for.
        assert_eq!(watch.check(&ports, 10.25, start), Ok(Heard::Behind(start)));
        assert_eq!(watch.check(&ports, 10.625, start).map_err(|s| s.ports), Err(vec![0]));
        let silent = watch.check(&ports, 10.75, start).unwrap_err();
        assert_eq!((silent.ports, silent.silent_s), (vec![0, 4], 0.75));
    }

    #[test]
    fn a_clock_running_ahead_of_delivery_is_waited_for_in_wall_clock_time() {
        // A lockstep robot 100 times faster than the wall clock: 0.05 s of
        // its time pass in 0.5 ms, far less than a relay's latency.
        let (mut ports, start) = (ports(), Instant::now());
        let mut watch = SilenceWatch::new(0.05, WALL_BOUND);
        deliver(&mut ports, 0);
        assert_eq!(watch.check(&ports, 0.0, start), Ok(Heard::All));
        let behind = watch.check(&ports, 0.06, at(start, 0.0006));
        assert_eq!(behind, Ok(Heard::Behind(start + WALL_BOUND)));
        // The late datagram arrives: heard again.
        deliver(&mut ports, 0);
        assert_eq!(watch.check(&ports, 0.06, at(start, 0.02)), Ok(Heard::All));
        // Then nothing in either clock: silent once both bounds have passed.
        assert_eq!(watch.check(&ports, 0.065, at(start, 0.021)), Ok(Heard::All));
        assert!(matches!(watch.check(&ports, 0.2, at(start, 0.2)), Ok(Heard::Behind(_))));
        let silent = watch.check(&ports, 0.2, at(start, 0.221)).unwrap_err();
        assert_eq!(silent.ports, [0]);
        assert!((0.14..0.15).contains(&silent.silent_s) && (0.2..0.21).contains(&silent.silent_wall_s), "{silent:?}");
    }

    #[test]
    fn a_port_delivering_stamps_behind_the_robot_is_waited_for_until_told_off_clock() {
        let (mut ports, start) = (ports(), Instant::now());
        let mut watch = SilenceWatch::new(0.05, WALL_BOUND);
        let stamp = |ports: &mut Ports, us| {
            deliver(ports, 0);
            ports.get_mut(0).stats_mut().latest_timestamp_us = Some(us);
        };
        stamp(&mut ports, 100_000);
        assert_eq!(watch.check(&ports, 0.105, start), Ok(Heard::All));
        // Delivering, but stamped 0.02 s before the robot's clock: behind.
        stamp(&mut ports, 101_000);
        assert!(matches!(watch.check(&ports, 0.121, start), Ok(Heard::Behind(_))));
        assert_eq!(watch.off_clock(&ports, 0.121), vec![0]);
        stamp(&mut ports, 102_000);
        assert_eq!(watch.check(&ports, 0.125, start), Ok(Heard::All));
    }

    #[test]
    fn the_bound_follows_the_sample_rate() {
        assert_eq!(silence_bound_s(250.0), 0.05);
        assert_eq!(silence_bound_s(1.0), 10.0);
    }
}
