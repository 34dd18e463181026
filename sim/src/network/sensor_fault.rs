//! Broken sensors: a cell whose accelerometer, proximity sensor or force
//! cell reads wrong, for the host's sensor screening to find.
//!
//! Written on the command line as `KIND:CELL` (the network's cell index,
//! from 0): `accel-saturated:N` reads +511 counts on every axis (a shorted
//! chip), `accel-stuck:N` repeats its first reading for good, `accel-axis:N.A`
//! reads 0 on axis A (0, 1, 2), `accel-weak:N` reads a quarter of what it
//! should (far from 1 g at rest), `proximity-rail:N` reads the top of its
//! range, `force-rail:N.C` reads the top of force channel C.

use skin_protocol::sample::{ACCEL_MAX, FORCE_MAX, PROXIMITY_MAX};
use skin_protocol::Sample;

use super::NetworkError;

/// What is broken.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SensorFaultKind {
    /// The accelerometer reads full scale on every axis.
    AccelSaturated,
    /// The accelerometer repeats its first reading.
    AccelStuck,
    /// One accelerometer axis reads 0.
    AccelAxisSilent(usize),
    /// The accelerometer reads a quarter of the true acceleration.
    AccelWeak,
    /// The proximity sensor reads the top of its range.
    ProximityRail,
    /// One force channel reads the top of its range.
    ForceRail(usize),
}

/// A broken sensor of one cell, from power-up on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorFault {
    /// The network's index of the cell.
    pub cell: usize,
    /// What is broken.
    pub kind: SensorFaultKind,
}

impl std::str::FromStr for SensorFault {
    type Err = NetworkError;
    fn from_str(s: &str) -> Result<SensorFault, NetworkError> {
        let bad = |why: &str| {
            NetworkError::Flag(format!(
                "sensor fault `{s}`: {why}; write accel-saturated:CELL, accel-stuck:CELL, accel-axis:CELL.AXIS, \
                 accel-weak:CELL, proximity-rail:CELL or force-rail:CELL.CHANNEL"
            ))
        };
        let (kind, target) = s.split_once(':').ok_or_else(|| bad("no `:`"))?;
        let number = |t: &str, what: &str| t.parse::<usize>().map_err(|_| bad(&format!("the {what} is not a number")));
        let channel = |t: &str| -> Result<(usize, usize), NetworkError> {
            let (cell, k) = t.split_once('.').ok_or_else(|| bad("no `.AXIS` or `.CHANNEL`"))?;
            let k = number(k, "axis or channel")?;
            if k > 2 {
                return Err(bad("axes and force channels are 0, 1 and 2"));
            }
            Ok((number(cell, "cell")?, k))
        };
        let (cell, kind) = match kind {
            "accel-saturated" => (number(target, "cell")?, SensorFaultKind::AccelSaturated),
            "accel-stuck" => (number(target, "cell")?, SensorFaultKind::AccelStuck),
            "accel-weak" => (number(target, "cell")?, SensorFaultKind::AccelWeak),
            "proximity-rail" => (number(target, "cell")?, SensorFaultKind::ProximityRail),
            "accel-axis" => channel(target).map(|(c, a)| (c, SensorFaultKind::AccelAxisSilent(a)))?,
            "force-rail" => channel(target).map(|(c, k)| (c, SensorFaultKind::ForceRail(k)))?,
            _ => return Err(bad("unknown kind")),
        };
        Ok(SensorFault { cell, kind })
    }
}

/// A fault with what it remembers (a stuck sensor's reading).
#[derive(Clone, Debug)]
pub(crate) struct Broken {
    pub(crate) fault: SensorFault,
    stuck: Option<[i16; 3]>,
}

impl Broken {
    pub(crate) fn new(fault: SensorFault) -> Broken {
        Broken { fault, stuck: None }
    }

    /// What the broken cell reads instead of `sample`.
    pub(crate) fn read(&mut self, sample: Sample) -> Sample {
        let (mut proximity, mut force, mut accel) = (sample.proximity(), sample.force(), sample.accel());
        match self.fault.kind {
            SensorFaultKind::AccelSaturated => accel = [ACCEL_MAX; 3],
            SensorFaultKind::AccelStuck => accel = *self.stuck.get_or_insert(accel),
            SensorFaultKind::AccelAxisSilent(a) => accel[a] = 0,
            SensorFaultKind::AccelWeak => accel = accel.map(|c| c / 4),
            SensorFaultKind::ProximityRail => proximity = PROXIMITY_MAX,
            SensorFaultKind::ForceRail(k) => force[k] = FORCE_MAX,
        }
        Sample::saturating(proximity, force, accel, sample.temperature(), sample.seq())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn faults_are_read_from_the_flag_and_mistakes_named() {
        let f: SensorFault = "accel-axis:17.2".parse().unwrap();
        assert_eq!(f, SensorFault { cell: 17, kind: SensorFaultKind::AccelAxisSilent(2) });
        assert_eq!("accel-saturated:3".parse::<SensorFault>().unwrap().kind, SensorFaultKind::AccelSaturated);
        for bad in ["accel-axis:17.3", "melted:1", "accel-stuck", "force-rail:2", "accel-weak:x"] {
            assert!(bad.parse::<SensorFault>().unwrap_err().to_string().starts_with(&format!("sensor fault `{bad}`")));
        }
    }

    #[test]
    fn a_broken_cell_reads_what_its_fault_makes_it() {
        let sample = |a: i16| Sample::saturating(100, [1, 2, 3], [a, -a, 2 * a], 0, 0);
        let mut stuck = Broken::new(SensorFault { cell: 0, kind: SensorFaultKind::AccelStuck });
        assert_eq!(stuck.read(sample(10)).accel(), [10, -10, 20]);
        assert_eq!(stuck.read(sample(50)).accel(), [10, -10, 20]);
        let mut saturated = Broken::new(SensorFault { cell: 0, kind: SensorFaultKind::AccelSaturated });
        assert_eq!(saturated.read(sample(50)).accel(), [511; 3]);
        let mut rail = Broken::new(SensorFault { cell: 0, kind: SensorFaultKind::ForceRail(1) });
        assert_eq!(rail.read(sample(50)).force(), [1, 4095, 3]);
    }
}
