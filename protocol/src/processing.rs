//! A cell's local signal processing (section 2.1.4), between its sensor
//! drivers and its network stack.
//!
//! Raw samples go in at the sampling rate; out come the messages the cell
//! sends: the filtered, offset-compensated sample (every time when traffic
//! is clock-driven, only when it moved by more than the send-on-delta
//! thresholds when event-driven) and a tactile event for every change of
//! level. The host configures all of it with [`Setting`]s. The firmware and
//! the simulated cells run this same code.

use heapless::Vec;

use crate::event::{Quantizer, SendOnDelta};
use crate::message::{AccelRange, Channel, Message, Setting, TactileEvent, TrafficMode};
use crate::sample::{Sample, FORCE_MAX, PROXIMITY_MAX};

/// Default sampling rate (section 2.2.3).
pub const DEFAULT_RATE_HZ: f32 = 250.0;
/// Default cut-off of the local low-pass filter: well above the 20 Hz that
/// the sensory-motor exploration needs (4.3.2), well below Nyquist.
pub const DEFAULT_CUTOFF_HZ: f32 = 60.0;

/// What one sample produces: at most the sample and four events.
pub type Outputs = Vec<Message, 5>;

/// Samples averaged for the offsets (0.128 s at 250 Hz).
pub const CALIBRATION_SAMPLES: u32 = 32;
/// Channels (in [`Sample::channels`] order) that read zero at rest and so
/// get an offset: proximity (light reflected by the cover) and the three
/// force cells (the unloaded spring). Acceleration and temperature are
/// absolute.
const CALIBRATED: core::ops::Range<usize> = 0..4;

/// Running sums of a calibration.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Calibration {
    sums: [i64; 8],
    n: u32,
}

/// The local processing state of one cell.
#[derive(Clone, Debug, PartialEq)]
pub struct Processor {
    rate_hz: f32,
    cutoff_hz: f32,
    alpha: f32,
    traffic: TrafficMode,
    accel_range: AccelRange,
    force_gain: [f32; 3],
    offsets: [i32; 8],
    calibration: Option<Calibration>,
    calibrated: bool,
    filtered: Option<[f32; 8]>,
    force: [Quantizer; 3],
    proximity: Quantizer,
    delta: SendOnDelta,
    seq: u8,
}

impl Default for Processor {
    fn default() -> Self {
        Processor::new()
    }
}

/// Smoothing factor of a first-order low-pass at `cutoff` sampled at `rate`.
fn alpha(cutoff_hz: f32, rate_hz: f32) -> f32 {
    let x = 2.0 * core::f32::consts::PI * cutoff_hz / rate_hz;
    // 1 - exp(-x), without libm: exact enough for x in (0, ~10].
    let e = if x > 10.0 { 0.0 } else { exp_neg(x) };
    1.0 - e
}

/// `exp(-x)` for `x >= 0` by squaring a short Taylor series.
fn exp_neg(x: f32) -> f32 {
    let y = x / 16.0;
    let mut e = 1.0 - y + y * y / 2.0 - y * y * y / 6.0 + y * y * y * y / 24.0;
    for _ in 0..4 {
        e *= e;
    }
    e
}

/// Filtered values rounded to counts and clamped to the sensors' ranges.
fn counts(y: &[f32; 8], seq: u8) -> Sample {
    let round = |v: f32| if v < 0.0 { (v - 0.5) as i32 } else { (v + 0.5) as i32 };
    let clamp_u16 = |v: f32, max: u16| round(v).clamp(0, i32::from(max)) as u16;
    let clamp_i16 = |v: f32| round(v).clamp(i32::from(i16::MIN), i32::from(i16::MAX)) as i16;
    Sample::saturating(
        clamp_u16(y[0], PROXIMITY_MAX),
        [clamp_u16(y[1], FORCE_MAX), clamp_u16(y[2], FORCE_MAX), clamp_u16(y[3], FORCE_MAX)],
        [clamp_i16(y[4]), clamp_i16(y[5]), clamp_i16(y[6])],
        clamp_i16(y[7]),
        seq,
    )
}

impl Processor {
    /// Clock-driven at 250 Hz, Table 3 levels, no offsets, unit gains.
    pub fn new() -> Processor {
        Processor {
            rate_hz: DEFAULT_RATE_HZ,
            cutoff_hz: DEFAULT_CUTOFF_HZ,
            alpha: alpha(DEFAULT_CUTOFF_HZ, DEFAULT_RATE_HZ),
            traffic: TrafficMode::Clock,
            accel_range: AccelRange::G2,
            force_gain: [1.0; 3],
            offsets: [0; 8],
            calibration: None,
            calibrated: false,
            filtered: None,
            force: [Quantizer::force(); 3],
            proximity: Quantizer::proximity(),
            delta: SendOnDelta::default(),
            seq: 0,
        }
    }

    /// The sampling period in microseconds.
    pub fn period_us(&self) -> u64 {
        (1e6 / self.rate_hz) as u64
    }

    /// How samples are sent.
    pub fn traffic(&self) -> TrafficMode {
        self.traffic
    }

    /// The accelerometer range the host asked for (the driver applies it).
    pub fn accel_range(&self) -> AccelRange {
        self.accel_range
    }

    /// Per-channel offsets (in [`Sample::channels`] order) subtracted from
    /// every raw sample; measured at calibration and kept in persistent
    /// storage.
    pub fn set_offsets(&mut self, offsets: [i32; 8]) {
        self.offsets = offsets;
    }

    /// The offsets in use.
    pub fn offsets(&self) -> [i32; 8] {
        self.offsets
    }

    /// The network refused the last sample (no ID yet, or a full queue):
    /// forget it as the send-on-delta reference, so the next one is sent
    /// and the host is not left with a stale value.
    pub fn refused(&mut self) {
        self.delta.reset();
    }

    /// Starts measuring the offsets: the next [`CALIBRATION_SAMPLES`]
    /// samples are averaged, and nothing is sent meanwhile.
    pub fn calibrate(&mut self) {
        self.calibration = Some(Calibration::default());
    }

    /// True while a calibration runs.
    pub fn calibrating(&self) -> bool {
        self.calibration.is_some()
    }

    /// The offsets a calibration just measured, once, for the persistent store.
    pub fn take_calibrated(&mut self) -> Option<[i32; 8]> {
        core::mem::take(&mut self.calibrated).then_some(self.offsets)
    }

    /// Adds a sample to a running calibration; true while it goes on.
    fn calibration_step(&mut self, raw: &Sample) -> bool {
        let Some(c) = &mut self.calibration else { return false };
        for (sum, v) in c.sums.iter_mut().zip(raw.channels()) {
            *sum += i64::from(v);
        }
        c.n += 1;
        if c.n == CALIBRATION_SAMPLES {
            let n = i64::from(c.n);
            for i in CALIBRATED {
                self.offsets[i] = ((c.sums[i] + n / 2) / n) as i32;
            }
            self.calibration = None;
            self.calibrated = true;
            self.filtered = None;
        }
        true
    }

    /// Applies a setting from the host; false (and no change) when invalid.
    pub fn apply(&mut self, setting: &Setting) -> bool {
        if !setting.is_valid() {
            return false;
        }
        match *setting {
            Setting::SampleRateHz(hz) => {
                self.rate_hz = hz;
                self.alpha = alpha(self.cutoff_hz, hz);
            }
            Setting::FilterCutoffHz(hz) => {
                self.cutoff_hz = hz;
                self.alpha = alpha(hz, self.rate_hz);
            }
            Setting::Traffic(t) => {
                self.traffic = t;
                self.delta.reset();
            }
            Setting::ForceLevel { level, value } => {
                for q in &mut self.force {
                    q.set_bound(level, value);
                }
            }
            Setting::ProximityLevel { level, value } => {
                self.proximity.set_bound(level, value);
            }
            Setting::Hysteresis(h) => {
                for q in self.force.iter_mut().chain(core::iter::once(&mut self.proximity)) {
                    q.set_hysteresis(h);
                }
            }
            Setting::Delta { channel, counts } => {
                self.delta.set_delta(channel, counts);
            }
            Setting::ForceGain { cell, gain } => self.force_gain[usize::from(cell)] = gain,
            Setting::AccelRange(r) => self.accel_range = r,
            Setting::Calibrate => self.calibrate(),
        }
        true
    }

    /// Raw channels less offsets, times the force gains: the filter's input.
    fn inputs(&self, raw: [i32; 8]) -> [f32; 8] {
        core::array::from_fn(|i| {
            let gain = if (1..4).contains(&i) { self.force_gain[i - 1] } else { 1.0 };
            (raw[i] - self.offsets[i]) as f32 * gain
        })
    }

    /// False when no input can keep the processor from sending: traffic is
    /// clock-driven (every sample goes out) or a calibration runs (its end
    /// is a store write). A caller checks this before computing bounds.
    pub fn may_be_silent(&self) -> bool {
        self.traffic == TrafficMode::Event && self.calibration.is_none()
    }

    /// True when, from its present state, this processor sends nothing for
    /// any run of raw samples whose channels stay within `lo..=hi` (in
    /// [`Sample::channels`] order), and such samples change nothing but its
    /// filter and its sequence number. So a caller that knows its inputs
    /// stay so bounded for a while (a simulator's resting cell) may process
    /// them later in one go, with the same outcome.
    ///
    /// It holds when the processor [may be silent](Processor::may_be_silent) and every
    /// value the filter can reach stays within the send-on-delta threshold
    /// of the last sample sent and within each quantizer's present level.
    /// The filter's output is a weighted mean of its present value and the
    /// inputs, so it stays between them; f32 rounding can step past that
    /// range by a few units in the last place (never further: a step from
    /// outside it goes back toward it), which the margin of a quarter count
    /// (or 2^-20 of the value, when larger) covers. Quantization to counts
    /// and the level of a value are monotonic, so the range's ends decide.
    pub fn silent_within(&self, lo: [i32; 8], hi: [i32; 8]) -> bool {
        if !self.may_be_silent() {
            return false;
        }
        let (a, b) = (self.inputs(lo), self.inputs(hi));
        let mut ends = [[0f32; 8]; 2];
        for c in 0..8 {
            let (mut l, mut h) = (a[c].min(b[c]), a[c].max(b[c]));
            if let Some(y) = &self.filtered {
                (l, h) = (l.min(y[c]), h.max(y[c]));
            }
            let margin = (l.abs().max(h.abs()) * 8.0 * f32::EPSILON).max(0.25);
            (ends[0][c], ends[1][c]) = (l - margin, h + margin);
        }
        let (low, high) = (counts(&ends[0], 0), counts(&ends[1], 0));
        let (pl, ph) = (low.proximity_norm(), high.proximity_norm());
        let (fl, fh) = (low.force_norm(), high.force_norm());
        self.delta.holds(low.channels(), high.channels())
            && self.proximity.holds(pl, ph)
            && (0..3).all(|k| self.force[k].holds(fl[k], fh[k]))
    }

    /// Processes one raw sample: offsets, gains, low-pass, events, and the
    /// send decision. During a calibration nothing comes out.
    pub fn process(&mut self, raw: &Sample) -> Outputs {
        if self.calibration_step(raw) {
            return Outputs::new();
        }
        let x = self.inputs(raw.channels());
        let y = match &mut self.filtered {
            Some(y) => {
                for (y, x) in y.iter_mut().zip(x) {
                    *y += self.alpha * (x - *y);
                }
                *y
            }
            slot @ None => *slot.insert(x),
        };
        self.seq = self.seq.wrapping_add(1);
        let sample = counts(&y, self.seq);

        let mut out = Outputs::new();
        let send = match self.traffic {
            TrafficMode::Clock => true,
            TrafficMode::Event => self.delta.update(&sample),
        };
        if send {
            let _ = out.push(Message::Sample(sample));
        }
        let [f0, f1, f2] = &mut self.force;
        let (force, norm) = (sample.force(), sample.force_norm());
        let levels = [
            (Channel::Proximity, &mut self.proximity, sample.proximity(), sample.proximity_norm()),
            (Channel::Force0, f0, force[0], norm[0]),
            (Channel::Force1, f1, force[1], norm[1]),
            (Channel::Force2, f2, force[2], norm[2]),
        ];
        for (channel, q, value, norm) in levels {
            if let Some(level) = q.update(norm) {
                let _ = out.push(Message::Event(TactileEvent { channel, level, value }));
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn force(f: u16) -> Sample {
        Sample::new(0, [f, 0, 0], [0, 0, 256], 800, 0).unwrap()
    }

    #[test]
    fn the_filter_has_its_cutoff() {
        // exp_neg against known values, and a smoothing factor that passes
        // most of a step at once at the default cut-off and rate.
        assert!((exp_neg(1.0) - 0.367_879_4).abs() < 1e-4);
        assert!((exp_neg(6.0) - 0.002_478_75).abs() < 1e-4);
        let a = alpha(DEFAULT_CUTOFF_HZ, DEFAULT_RATE_HZ);
        assert!(a > 0.7 && a < 0.9, "alpha {a}");
    }

    #[test]
    fn clock_traffic_sends_every_sample_and_events_on_changes() {
        let mut p = Processor::new();
        assert!(p.apply(&Setting::FilterCutoffHz(1000.0)));
        let out = p.process(&force(0));
        assert_eq!(out.len(), 1);
        // A press to about 0.2 of full scale: medium force.
        let mut levels = std::vec::Vec::new();
        for _ in 0..20 {
            for m in p.process(&force(820)) {
                if let Message::Event(e) = m {
                    levels.push(e.level);
                }
            }
        }
        assert_eq!(levels.last(), Some(&2));
        assert!(levels.windows(2).all(|w| w[0] < w[1]), "levels rise monotonically: {levels:?}");
    }

    #[test]
    fn event_traffic_is_silent_when_nothing_moves() {
        let mut p = Processor::new();
        assert!(p.apply(&Setting::Traffic(TrafficMode::Event)));
        let sent: usize = (0..100).map(|_| p.process(&force(10)).len()).sum();
        assert_eq!(sent, 1, "only the first sample goes out");
        assert!(!p.process(&force(400)).is_empty());
    }

    #[test]
    fn offsets_gains_and_bad_settings() {
        let mut p = Processor::new();
        p.set_offsets([0, 100, 0, 0, 0, 0, 0, 0]);
        assert!(p.apply(&Setting::ForceGain { cell: 0, gain: 2.0 }));
        assert!(!p.apply(&Setting::ForceGain { cell: 3, gain: 2.0 }));
        assert!(!p.apply(&Setting::SampleRateHz(f32::NAN)));
        let out = p.process(&force(300));
        let Message::Sample(s) = out[0] else { panic!("{out:?}") };
        assert_eq!(s.force()[0], 400);
        assert_eq!(p.period_us(), 4000);
    }

    #[test]
    fn calibration_measures_proximity_and_force_offsets_only() {
        let mut p = Processor::new();
        assert!(p.apply(&Setting::Calibrate));
        let rest = Sample::new(700, [30, 40, 50], [1, 2, 250], 800, 0).unwrap();
        for _ in 0..CALIBRATION_SAMPLES {
            assert!(p.calibrating());
            assert!(p.process(&rest).is_empty());
        }
        assert!(!p.calibrating());
        assert_eq!(p.take_calibrated(), Some([700, 30, 40, 50, 0, 0, 0, 0]));
        assert_eq!(p.take_calibrated(), None);
        let Message::Sample(s) = p.process(&rest)[0] else { panic!() };
        assert_eq!((s.proximity(), s.force(), s.accel()), (0, [0; 3], [1, 2, 250]));
    }

    fn raw(v: [i32; 8]) -> Sample {
        Sample::saturating(
            v[0] as u16,
            [v[1], v[2], v[3]].map(|f| f as u16),
            [v[4], v[5], v[6]].map(|a| a as i16),
            v[7] as i16,
            0,
        )
    }

    /// A cell at rest: baselines, and noise within three counts.
    const REST: [i32; 8] = [1_200, 50, 60, 70, 10, -20, 250, 1_000];

    #[test]
    fn a_settled_resting_cell_is_silent_and_clock_traffic_never() {
        let (lo, hi) = (REST.map(|v| v - 3), REST.map(|v| v + 3));
        let mut p = Processor::new();
        assert!(!p.silent_within(lo, hi), "clock-driven traffic sends every sample");
        assert!(p.apply(&Setting::Traffic(TrafficMode::Event)));
        assert!(!p.silent_within(lo, hi), "the first sample always goes out");
        assert!(!p.process(&raw(REST)).is_empty());
        assert!(p.silent_within(lo, hi));
        // A threshold below the noise, or a reference far from the rest, may send.
        let mut zero = p.clone();
        assert!(zero.apply(&Setting::Delta { channel: 4, counts: 0 }));
        assert!(!zero.silent_within(lo, hi));
        let mut pressed = Processor::new();
        assert!(pressed.apply(&Setting::Traffic(TrafficMode::Event)));
        pressed.process(&raw([1_200, 90, 60, 70, 10, -20, 250, 1_000]));
        assert!(!pressed.silent_within(lo, hi), "40 counts from the reference, 43 with noise");
        // A calibration changes the offsets: not silent while it runs.
        assert!(p.apply(&Setting::Calibrate));
        assert!(!p.silent_within(lo, hi));
    }

    proptest! {
        /// When the processor says it is silent for a range of inputs, any
        /// run of such inputs, extremes included, sends nothing and leaves
        /// the levels and the send-on-delta reference as they were; for
        /// any filter cut-off (down to a tenth of a hertz and up to a
        /// filter that passes the input unchanged) and force gain.
        #[test]
        fn silent_means_silent(
            cutoff_hz in prop_oneof![Just(60.0f32), 0.1f32..1e4, Just(1e6)],
            gain in 0.2f32..5.0,
            history in proptest::collection::vec(proptest::collection::vec(-3i32..=3, 8), 1..40),
            spread in proptest::collection::vec((0i32..5, 0i32..5), 8),
            run in proptest::collection::vec(proptest::collection::vec(prop_oneof![Just(0.0f64), Just(1.0), 0.0f64..1.0], 8), 1..60),
        ) {
            let mut p = Processor::new();
            for s in [Setting::Traffic(TrafficMode::Event), Setting::FilterCutoffHz(cutoff_hz), Setting::ForceGain { cell: 1, gain }] {
                prop_assert!(p.apply(&s));
            }
            for noise in &history {
                p.process(&raw(core::array::from_fn(|c| REST[c] + noise[c])));
            }
            let lo: [i32; 8] = core::array::from_fn(|c| REST[c] - spread[c].0);
            let hi: [i32; 8] = core::array::from_fn(|c| REST[c] + spread[c].1);
            if p.silent_within(lo, hi) {
                let (levels, delta) = ((p.proximity, p.force), p.delta);
                for t in run {
                    let v = core::array::from_fn(|c| lo[c] + (t[c] * f64::from(hi[c] - lo[c])).round() as i32);
                    prop_assert!(p.process(&raw(v)).is_empty(), "sent at {:?}", v);
                }
                prop_assert!((p.proximity, p.force) == levels && p.delta == delta);
            }
        }
    }
}
