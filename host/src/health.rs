//! Sensor screening: cells whose sensors read what no working sensor can,
//! found from their own data while the robot rests after organizing.
//!
//! A cell whose accelerometer is saturated, stuck, silent on one axis or
//! reads far from 1 g at rest can never settle an exploration entry: the
//! exploration would spend its whole robot-time budget on it, silently. So
//! the cells are screened first; a cell with a broken accelerometer is named
//! in a warning and left out of the exploration and the map
//! ([`Screened`]), and the rest of the skin explores as if it were not
//! there. A proximity or force channel stuck at the top of its range is
//! named too; the accelerometer of that cell still explores.
//!
//! A stuck reading is only told from a still one where the skin's other
//! cells show sensor noise: on a noise-free skin (a simulation without
//! noise) every reading is constant at rest, and no cell is called stuck.

use std::collections::{BTreeMap, BTreeSet};

use serde::Serialize;
use skin_protocol::message::AccelRange;
use skin_protocol::sample::{ACCEL_MAX, ACCEL_MIN, FORCE_MAX, PROXIMITY_MAX};
use skin_protocol::{Address, Sample};

use crate::robot::{DofKind, Robot, RobotError, SampleSource};

/// Robot time the cells are listened to at rest before the exploration, s:
/// 125 samples at 250 Hz.
pub const SCREEN_S: f64 = 0.5;

/// Fewest samples a cell must send in the window to be judged.
const MIN_SAMPLES: usize = 10;

/// Mean acceleration at rest, in g, beyond which no working accelerometer
/// reads (1 g, and the BMA250's offset and gain errors many times over).
const MAGNITUDE_G: std::ops::RangeInclusive<f64> = 0.7..=1.3;

/// A sensor of a cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Sensor {
    /// The three-axis accelerometer.
    Accelerometer,
    /// The proximity sensor.
    Proximity,
    /// A force channel (0, 1, 2).
    Force(u8),
}

/// What is wrong with it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Symptom {
    /// Every axis at the end of its range on every sample.
    Saturated,
    /// The same reading on every sample, while other cells show noise.
    Stuck,
    /// One axis reads 0 on every sample, while other cells show noise on it.
    AxisSilent(u8),
    /// The mean acceleration at rest, g, far from 1 g.
    Magnitude(f64),
    /// The top of its range on every sample.
    AtRail,
}

/// A cell's sensor that reads what no working one can.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SensorFault {
    /// The cell.
    pub cell: u16,
    /// Which sensor.
    pub sensor: Sensor,
    /// What is wrong.
    pub symptom: Symptom,
    /// The same for people.
    pub description: String,
    /// Whether the cell is left out of the exploration and the map (a
    /// broken accelerometer).
    pub left_out: bool,
}

impl std::fmt::Display for SensorFault {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.description)
    }
}

/// One cell's readings over the window.
#[derive(Clone, Debug)]
struct Readings {
    n: usize,
    accel_min: [i16; 3],
    accel_max: [i16; 3],
    accel_sum: [f64; 3],
    /// Samples with every axis at the end of its range.
    at_full_scale: usize,
    proximity_at_rail: usize,
    force_at_rail: [usize; 3],
}

impl Readings {
    fn new() -> Readings {
        Readings {
            n: 0,
            accel_min: [i16::MAX; 3],
            accel_max: [i16::MIN; 3],
            accel_sum: [0.0; 3],
            at_full_scale: 0,
            proximity_at_rail: 0,
            force_at_rail: [0; 3],
        }
    }

    fn add(&mut self, s: &Sample) {
        let a = s.accel();
        self.n += 1;
        for (k, &c) in a.iter().enumerate() {
            self.accel_min[k] = self.accel_min[k].min(c);
            self.accel_max[k] = self.accel_max[k].max(c);
            self.accel_sum[k] += f64::from(c);
        }
        self.at_full_scale += usize::from(a.iter().all(|&c| c == ACCEL_MAX || c == ACCEL_MIN));
        self.proximity_at_rail += usize::from(s.proximity() == PROXIMITY_MAX);
        for (k, &force) in s.force().iter().enumerate() {
            self.force_at_rail[k] += usize::from(force == FORCE_MAX);
        }
    }

    fn span(&self, axis: usize) -> i32 {
        i32::from(self.accel_max[axis]) - i32::from(self.accel_min[axis])
    }
}

/// Judges every cell heard in `samples` (a window at rest), accelerations
/// in counts of `range`; the faults found, by cell.
pub fn screen(samples: &[(Address, Sample)], range: AccelRange) -> Vec<SensorFault> {
    let mut cells: BTreeMap<Address, Readings> = BTreeMap::new();
    for (cell, s) in samples {
        cells.entry(*cell).or_insert_with(Readings::new).add(s);
    }
    cells.retain(|_, r| r.n >= MIN_SAMPLES);
    // The skin's noise per axis: the median cell's span. Zero on a skin
    // without noise, where a constant reading says nothing.
    let noisy: [bool; 3] = std::array::from_fn(|k| {
        let mut spans: Vec<i32> = cells.values().map(|r| r.span(k)).collect();
        spans.sort_unstable();
        spans.get(spans.len() / 2).is_some_and(|&s| s > 0)
    });
    let full_scale_g = f64::from(range.full_scale_g());
    let mut faults = Vec::new();
    for (cell, r) in &cells {
        let id = cell.0;
        let fault = |sensor, symptom, description: String| SensorFault {
            cell: id,
            sensor,
            symptom,
            description: format!("cell {id}: {description}"),
            left_out: sensor == Sensor::Accelerometer,
        };
        let mean: [f64; 3] = std::array::from_fn(|k| r.accel_sum[k] / r.n as f64);
        let magnitude_g = mean.iter().map(|c| c * c).sum::<f64>().sqrt() / range.counts_per_g();
        let accel = if r.at_full_scale == r.n {
            let signs: Vec<String> =
                mean.iter().map(|c| format!("{}{full_scale_g} g", if *c > 0.0 { '+' } else { '-' })).collect();
            let at = if signs.iter().all(|s| *s == signs[0]) {
                format!("{} on all axes", signs[0])
            } else {
                format!("({}) on its axes", signs.join(", "))
            };
            Some((Symptom::Saturated, format!("accelerometer saturated at {at} since organizing")))
        } else if (0..3).all(|k| r.span(k) == 0) && noisy.iter().any(|&n| n) {
            let counts = r.accel_min;
            Some((
                Symptom::Stuck,
                format!(
                    "accelerometer stuck at ({}, {}, {}) counts on all axes since organizing, while the other cells show noise",
                    counts[0], counts[1], counts[2]
                ),
            ))
        } else if let Some(k) = (0..3).find(|&k| noisy[k] && r.span(k) == 0 && r.accel_min[k] == 0) {
            Some((
                Symptom::AxisSilent(k as u8),
                format!("accelerometer axis {} reads 0 without noise since organizing", ["x", "y", "z"][k]),
            ))
        } else if !MAGNITUDE_G.contains(&magnitude_g) {
            Some((
                Symptom::Magnitude(magnitude_g),
                format!(
                    "accelerometer reads {magnitude_g:.2} g at rest, far from 1 g (a broken chip or a wrong range)"
                ),
            ))
        } else {
            None
        };
        if let Some((symptom, description)) = accel {
            faults.push(fault(Sensor::Accelerometer, symptom, description));
        }
        if r.proximity_at_rail == r.n {
            let what = format!("proximity stuck at the top of its range ({PROXIMITY_MAX} counts) since organizing");
            faults.push(fault(Sensor::Proximity, Symptom::AtRail, what));
        }
        for k in (0..3).filter(|&k| r.force_at_rail[k] == r.n) {
            let what = format!("force channel {k} stuck at the top of its range ({FORCE_MAX} counts) since organizing");
            faults.push(fault(Sensor::Force(k as u8), Symptom::AtRail, what));
        }
    }
    faults
}

/// Collects every sample of `rig` for [`SCREEN_S`] of robot time while it
/// holds still, and judges them with [`screen`].
pub fn listen<R: Robot + SampleSource>(rig: &mut R, range: AccelRange) -> Result<Vec<SensorFault>, RobotError> {
    rig.command_velocities(&vec![0.0; rig.dof_count()])?;
    let ticks = (SCREEN_S / rig.tick_s()).ceil() as usize;
    let mut samples = Vec::new();
    for _ in 0..ticks {
        rig.next_tick(&mut samples)?;
    }
    Ok(screen(&samples, range))
}

/// A rig whose samples from the left-out cells never reach the caller:
/// the exploration sees the rest of the skin only. It also tells the robot
/// time it has run, tick by tick, for a progress line.
pub struct Screened<'r, R> {
    rig: &'r mut R,
    left_out: BTreeSet<Address>,
    robot_s: f64,
    on_tick: Option<&'r mut dyn FnMut(f64)>,
}

impl<'r, R> Screened<'r, R> {
    /// `rig` without the cells `faults` leave out.
    pub fn new(rig: &'r mut R, faults: &[SensorFault]) -> Screened<'r, R> {
        Screened::leaving_out(rig, faults.iter().filter(|f| f.left_out).map(|f| f.cell))
    }

    /// `rig` without the cells numbered `cells`.
    pub fn leaving_out(rig: &'r mut R, cells: impl IntoIterator<Item = u16>) -> Screened<'r, R> {
        Screened { rig, left_out: cells.into_iter().map(Address).collect(), robot_s: 0.0, on_tick: None }
    }

    /// The same rig, calling `on_tick` after every tick with the robot
    /// time it has run, s.
    pub fn on_tick(self, on_tick: &'r mut dyn FnMut(f64)) -> Screened<'r, R> {
        Screened { on_tick: Some(on_tick), ..self }
    }
}

impl<R: Robot> Robot for Screened<'_, R> {
    fn dof_names(&self) -> Vec<String> {
        self.rig.dof_names()
    }

    fn dof_kinds(&self) -> Vec<DofKind> {
        self.rig.dof_kinds()
    }

    fn velocity_limits(&self) -> Vec<Option<f64>> {
        self.rig.velocity_limits()
    }

    fn command_velocities(&mut self, omega_rad_s: &[f64]) -> Result<(), RobotError> {
        self.rig.command_velocities(omega_rad_s)
    }

    fn positions(&self) -> Vec<f64> {
        self.rig.positions()
    }
}

impl<R: SampleSource> SampleSource for Screened<'_, R> {
    fn tick_s(&self) -> f64 {
        self.rig.tick_s()
    }

    fn next_tick(&mut self, out: &mut Vec<(Address, Sample)>) -> Result<(), RobotError> {
        let from = out.len();
        self.rig.next_tick(out)?;
        self.robot_s += self.rig.tick_s();
        if let Some(on_tick) = &mut self.on_tick {
            on_tick(self.robot_s);
        }
        if !self.left_out.is_empty() {
            let mut k = from;
            for i in from..out.len() {
                if !self.left_out.contains(&out[i].0) {
                    out.swap(k, i);
                    k += 1;
                }
            }
            out.truncate(k);
        }
        Ok(())
    }

    fn robot_time_s(&self) -> Option<f64> {
        self.rig.robot_time_s()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 125 samples of 20 cells at rest reading about 1 g on z with noise of
    /// `noise` counts, cell `broken` read through `read`.
    fn window(noise: i16, broken: u16, read: impl Fn(usize, Sample) -> Sample) -> Vec<(Address, Sample)> {
        let mut out = Vec::new();
        for t in 0..125usize {
            for c in 1..=20u16 {
                let wobble = if noise == 0 { 0 } else { ((t * 7 + usize::from(c) * 3) % 5) as i16 - 2 };
                let s = Sample::saturating(100, [10, 10, 10], [3 + wobble, -5 - wobble, 256 + wobble], 0, t as u8);
                out.push((Address(c), if c == broken { read(t, s) } else { s }));
            }
        }
        out
    }

    fn with_accel(s: Sample, accel: [i16; 3]) -> Sample {
        Sample::saturating(s.proximity(), s.force(), accel, s.temperature(), s.seq())
    }

    #[test]
    fn a_healthy_skin_has_no_faults() {
        assert_eq!(screen(&window(2, 0, |_, s| s), AccelRange::G2), vec![]);
    }

    #[test]
    fn each_broken_accelerometer_is_named_and_left_out() {
        type Read<'a> = &'a dyn Fn(usize, Sample) -> Sample;
        let cases: [(Read, Symptom, &str); 4] = [
            (&|_, s| with_accel(s, [511; 3]), Symptom::Saturated, "cell 17: accelerometer saturated at +2 g on all axes since organizing"),
            (&|_, s| with_accel(s, [3, -5, 256]), Symptom::Stuck, "cell 17: accelerometer stuck at (3, -5, 256) counts on all axes since organizing, while the other cells show noise"),
            (&|_, s| with_accel(s, [s.accel()[0], s.accel()[1], 0]), Symptom::AxisSilent(2), "cell 17: accelerometer axis z reads 0 without noise since organizing"),
            (&|_, s| with_accel(s, s.accel().map(|c| c / 4)), Symptom::Magnitude(0.25), ""),
        ];
        for (read, symptom, says) in cases {
            let faults = screen(&window(2, 17, read), AccelRange::G2);
            assert_eq!(faults.len(), 1, "{faults:?}");
            let f = &faults[0];
            assert_eq!((f.cell, f.sensor, f.left_out), (17, Sensor::Accelerometer, true));
            match (symptom, f.symptom) {
                (Symptom::Magnitude(_), Symptom::Magnitude(g)) => {
                    assert!((0.2..0.3).contains(&g), "{f:?}");
                    assert!(f.description.starts_with("cell 17: accelerometer reads 0.2"), "{f}");
                }
                _ => assert_eq!((f.symptom, f.description.as_str()), (symptom, says)),
            }
        }
    }

    #[test]
    fn a_constant_reading_on_a_skin_without_noise_is_not_called_stuck() {
        // Cell 17 is stuck at its first reading, which is every cell's.
        let first = window(0, 0, |_, s| s)[0].1;
        assert_eq!(screen(&window(0, 17, |_, _| first), AccelRange::G2), vec![]);
    }

    #[test]
    fn proximity_and_force_at_their_rail_are_named_but_the_cell_explores() {
        let faults = screen(
            &window(2, 5, |_, s| Sample::saturating(PROXIMITY_MAX, [10, FORCE_MAX, 10], s.accel(), 0, s.seq())),
            AccelRange::G2,
        );
        let said: Vec<(&str, bool)> = faults.iter().map(|f| (f.description.as_str(), f.left_out)).collect();
        assert_eq!(
            said,
            [
                ("cell 5: proximity stuck at the top of its range (65535 counts) since organizing", false),
                ("cell 5: force channel 1 stuck at the top of its range (4095 counts) since organizing", false),
            ]
        );
    }
}
