//! The watch on interface ports that stop delivering mid-run.
//!
//! Once every cell sends every sample (the exploration, the calibration),
//! a port that delivered and then falls silent means a skin that lost
//! power, a cut cable or an endpoint that restarted and is being dropped as
//! spoofed. Without a watch the exploration fills its traces with gaps and
//! reports a map of zeros; with it the run ends naming the port. Silence is
//! counted in robot time, the clock the skin's samples follow (a lockstep
//! simulator sends nothing while the host does not command it).

use super::ports::Ports;

/// Interface ports that delivered and then fell silent.
#[derive(Clone, Debug, PartialEq)]
pub struct Silent {
    /// Their port numbers.
    pub ports: Vec<u8>,
    /// The longest silence among them, s of robot time.
    pub silent_s: f64,
}

/// Accepted datagrams and the robot time they last grew, per port.
#[derive(Clone, Debug)]
pub struct SilenceWatch {
    bound_s: f64,
    /// By port index: datagrams accepted when last seen growing, and when, s.
    heard: Vec<Option<(u64, f64)>>,
}

impl SilenceWatch {
    /// A watch that reports a port silent for `bound_s` of robot time;
    /// ports that have never delivered are not watched.
    pub fn new(bound_s: f64) -> SilenceWatch {
        SilenceWatch { bound_s, heard: Vec::new() }
    }

    /// Takes the ports' counts at robot time `now_s`; the silent ones, if any.
    pub fn check(&mut self, ports: &Ports, now_s: f64) -> Result<(), Silent> {
        self.heard.resize(ports.len(), None);
        let mut silent = Silent { ports: Vec::new(), silent_s: 0.0 };
        for (port, heard) in ports.iter().zip(&mut self.heard) {
            let datagrams = port.stats().datagrams;
            match heard {
                Some((n, _)) if *n == datagrams => {}
                // Never delivered: nothing to miss.
                None if datagrams == 0 => continue,
                _ => *heard = Some((datagrams, now_s)),
            }
            let quiet_s = heard.map_or(0.0, |(_, at_s)| now_s - at_s);
            if quiet_s >= self.bound_s {
                silent.ports.push(port.number());
                silent.silent_s = silent.silent_s.max(quiet_s);
            }
        }
        if silent.ports.is_empty() {
            Ok(())
        } else {
            Err(silent)
        }
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

    #[test]
    fn a_port_that_delivered_and_stopped_is_named_after_the_bound() {
        let mut ports = ports();
        let mut watch = SilenceWatch::new(1.0);
        // Ports 0 and 2 deliver every 4 ms, port 2 only until tick 374;
        // port 4 never delivers and is not missed.
        let first_silent = (0..1000u32).find_map(|k| {
            deliver(&mut ports, 0);
            if k < 375 {
                deliver(&mut ports, 1);
            }
            watch.check(&ports, f64::from(k) * 0.004).err().map(|silent| (k, silent))
        });
        let (k, silent) = first_silent.expect("port 2 is named");
        assert!((624..=625).contains(&k), "named at tick {k}, 1 s after tick 374");
        assert_eq!(silent.ports, [2]);
        assert!((0.999..1.005).contains(&silent.silent_s), "{silent:?}");
    }

    #[test]
    fn every_silent_port_is_named_with_the_longest_silence() {
        let mut ports = ports();
        let mut watch = SilenceWatch::new(0.5);
        deliver(&mut ports, 0);
        deliver(&mut ports, 2);
        assert_eq!(watch.check(&ports, 10.0), Ok(()));
        deliver(&mut ports, 2);
        assert_eq!(watch.check(&ports, 10.25), Ok(()));
        assert_eq!(watch.check(&ports, 10.625).map_err(|s| s.ports), Err(vec![0]));
        let silent = watch.check(&ports, 10.75).unwrap_err();
        assert_eq!((silent.ports, silent.silent_s), (vec![0, 4], 0.75));
    }

    #[test]
    fn the_bound_follows_the_sample_rate() {
        assert_eq!(silence_bound_s(250.0), 0.05);
        assert_eq!(silence_bound_s(1.0), 10.0);
    }
}
