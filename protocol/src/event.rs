//! Tactile events (section 5.2, Table 3) and send-on-delta filtering.
//!
//! A [`Quantizer`] maps a normalized sensor value to one of five levels and
//! reports only changes of level, with a hysteresis so that a value
//! trembling at a threshold does not trigger again and again. A
//! [`SendOnDelta`] filter passes a sample only when some channel moved by
//! more than its threshold since the last sample it passed. Thresholds are
//! configuration; the defaults are the paper's.

use crate::sample::Sample;

/// Table 3, force cells: lower bounds of low, medium, high and pain force,
/// normalized to the force sensor's full scale.
pub const FORCE_LEVELS: [f32; 4] = [0.04, 0.10, 0.30, 0.45];
/// Table 3, pre-contact sensor: lower bounds of high, medium and low
/// proximity and of close contact, normalized intensity.
pub const PROXIMITY_LEVELS: [f32; 4] = [0.01, 0.02, 0.10, 0.80];
/// Default hysteresis: a level is left only below its bound minus this.
pub const HYSTERESIS: f32 = 0.005;
/// Names of the force levels 0..=4.
pub const FORCE_NAMES: [&str; 5] = ["no force", "low force", "medium force", "high force", "pain force"];
/// Names of the proximity levels 0..=4.
pub const PROXIMITY_NAMES: [&str; 5] =
    ["no proximity", "high proximity", "medium proximity", "low proximity", "close contact"];

/// Level quantizer with hysteresis for one channel.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Quantizer {
    bounds: [f32; 4],
    hysteresis: f32,
    level: u8,
}

impl Quantizer {
    /// A quantizer with ascending lower bounds of levels 1..=4, starting at level 0.
    pub fn new(bounds: [f32; 4], hysteresis: f32) -> Quantizer {
        let mut q = Quantizer { bounds: FORCE_LEVELS, hysteresis: 0.0, level: 0 };
        q.set_hysteresis(hysteresis);
        for (i, b) in bounds.into_iter().enumerate() {
            q.set_bound(i as u8 + 1, b);
        }
        q
    }

    /// The force quantizer of Table 3.
    pub fn force() -> Quantizer {
        Quantizer::new(FORCE_LEVELS, HYSTERESIS)
    }

    /// The proximity quantizer of Table 3.
    pub fn proximity() -> Quantizer {
        Quantizer::new(PROXIMITY_LEVELS, HYSTERESIS)
    }

    /// The current level, 0..=4.
    pub fn level(&self) -> u8 {
        self.level
    }

    /// Sets the lower bound of `level` (1..=4); bounds stay ascending by
    /// pushing neighbours along. Returns false (and changes nothing) for a
    /// level out of range or a bound outside `[0, 1]`.
    pub fn set_bound(&mut self, level: u8, bound: f32) -> bool {
        if !(1..=4).contains(&level) || !(0.0..=1.0).contains(&bound) {
            return false;
        }
        let i = usize::from(level - 1);
        self.bounds[i] = bound;
        for j in 0..4 {
            if j < i {
                self.bounds[j] = self.bounds[j].min(bound);
            } else if j > i {
                self.bounds[j] = self.bounds[j].max(bound);
            }
        }
        true
    }

    /// Sets the hysteresis; false (no change) outside `[0, 1]` or NaN.
    pub fn set_hysteresis(&mut self, hysteresis: f32) -> bool {
        let ok = (0.0..=1.0).contains(&hysteresis);
        if ok {
            self.hysteresis = hysteresis;
        }
        ok
    }

    /// Feeds one normalized value; returns the new level when it changed.
    /// A level is entered at its bound and left below its bound minus the
    /// hysteresis. NaN is ignored.
    pub fn update(&mut self, value: f32) -> Option<u8> {
        if value.is_nan() {
            return None;
        }
        let above = self.bounds.iter().take_while(|b| value >= **b).count() as u8;
        let level = if above >= self.level {
            above
        } else {
            // Falling: stay in each level until clearly below its bound.
            let held =
                self.bounds[..usize::from(self.level)].iter().take_while(|b| value >= **b - self.hysteresis).count()
                    as u8;
            held.max(above)
        };
        (level != self.level).then(|| {
            self.level = level;
            level
        })
    }

    /// True when no value in `lo..=hi` changes the level. The level a value
    /// leads to never falls as the value grows (entering is at a bound,
    /// falling is held below it), so the two ends decide.
    pub fn holds(&self, lo: f32, hi: f32) -> bool {
        let stays = |v: f32| {
            let mut q = *self;
            v.is_finite() && q.update(v).is_none()
        };
        lo <= hi && stays(lo) && stays(hi)
    }
}

/// Send-on-delta filter over the eight channels of a [`Sample`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SendOnDelta {
    deltas: [u16; 8],
    last: Option<[i32; 8]>,
}

/// Default send-on-delta thresholds in counts: proximity and forces at 1%
/// of full scale, the finest step of Table 3's levels that the host acts
/// on; acceleration and temperature at about twice their sensors' noise.
/// A quiet cell is silent.
pub const DEFAULT_DELTAS: [u16; 8] = [655, 41, 41, 41, 6, 6, 6, 16];

impl Default for SendOnDelta {
    fn default() -> Self {
        SendOnDelta::new(DEFAULT_DELTAS)
    }
}

impl SendOnDelta {
    /// A filter with per-channel thresholds in counts; `0` on a channel
    /// sends on any change of it.
    pub fn new(deltas: [u16; 8]) -> SendOnDelta {
        SendOnDelta { deltas, last: None }
    }

    /// Changes one channel's threshold (`channel < 8`, else false).
    pub fn set_delta(&mut self, channel: u8, counts: u16) -> bool {
        match self.deltas.get_mut(usize::from(channel)) {
            Some(d) => {
                *d = counts;
                true
            }
            None => false,
        }
    }

    /// True when the sample should be sent; it then becomes the reference.
    pub fn update(&mut self, sample: &Sample) -> bool {
        let now = sample.channels();
        let send = match self.last {
            None => true,
            Some(last) => now
                .iter()
                .zip(last)
                .zip(self.deltas)
                .any(|((n, l), d)| (n - l).unsigned_abs() > u32::from(d) || (d == 0 && *n != l)),
        };
        if send {
            self.last = Some(now);
        }
        send
    }

    /// Forgets the reference: the next sample is sent.
    pub fn reset(&mut self) {
        self.last = None;
    }

    /// True when no sample whose channels each lie within `lo..=hi` would
    /// be sent: there is a reference, and both ends of every channel's
    /// range are within its threshold of it.
    pub fn holds(&self, lo: [i32; 8], hi: [i32; 8]) -> bool {
        let Some(last) = self.last else { return false };
        (0..8).all(|c| {
            let near = |v: i32| (i64::from(v) - i64::from(last[c])).unsigned_abs() <= u64::from(self.deltas[c]);
            lo[c] <= hi[c] && near(lo[c]) && near(hi[c])
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn table_3_force_levels() {
        let mut q = Quantizer::force();
        assert_eq!(q.update(0.03), None);
        assert_eq!(q.update(0.04), Some(1));
        assert_eq!(q.update(0.2), Some(2));
        assert_eq!(q.update(0.46), Some(4));
        // Within the hysteresis below the pain bound: still pain.
        assert_eq!(q.update(0.447), None);
        assert_eq!(q.update(0.44), Some(3));
        assert_eq!(q.update(0.0), Some(0));
        assert_eq!(q.update(f32::NAN), None);
    }

    #[test]
    fn bounds_stay_ascending_and_bad_settings_are_refused() {
        let mut q = Quantizer::proximity();
        assert!(q.set_bound(2, 0.5));
        assert_eq!(q.bounds, [0.01, 0.5, 0.5, 0.8]);
        assert!(!q.set_bound(0, 0.1));
        assert!(!q.set_bound(3, f32::NAN));
        assert!(!q.set_hysteresis(-0.1));
    }

    proptest! {
        /// An event is emitted exactly when the level changes, and a value
        /// trembling by less than the hysteresis around a bound emits at
        /// most one event.
        #[test]
        fn events_only_on_level_changes(values in proptest::collection::vec(0.0f32..1.0, 1..200)) {
            let mut q = Quantizer::force();
            let mut level = 0;
            for v in values {
                let before = q.level();
                match q.update(v) {
                    Some(l) => { prop_assert_ne!(l, before); level = l; }
                    None => prop_assert_eq!(q.level(), before),
                }
                prop_assert_eq!(q.level(), level);
            }
        }

        #[test]
        fn trembling_at_a_bound_gives_one_event(bound in 0usize..4, jitter in proptest::collection::vec(-0.0049f32..0.0049, 1..100)) {
            let mut q = Quantizer::force();
            let b = FORCE_LEVELS[bound];
            q.update(b);
            let events = jitter.iter().filter(|j| q.update(b + **j).is_some()).count();
            prop_assert!(events <= 1, "{} events", events);
        }

        /// Whatever holds for a range holds for every value in it.
        #[test]
        fn a_range_that_holds_changes_no_level(
            history in proptest::collection::vec(0.0f32..1.0, 0..20),
            a in 0.0f32..1.0,
            b in 0.0f32..1.0,
            inside in proptest::collection::vec(0.0f32..=1.0, 1..50),
        ) {
            let mut q = Quantizer::force();
            history.into_iter().for_each(|v| { q.update(v); });
            let (lo, hi) = (a.min(b), a.max(b));
            if q.holds(lo, hi) {
                for t in inside {
                    prop_assert_eq!(q.update(lo + t * (hi - lo)), None);
                }
            }
        }

        #[test]
        fn a_range_within_the_thresholds_sends_nothing(
            reference in proptest::collection::vec(50i32..450, 8),
            spread in proptest::collection::vec((0i32..50, 0i32..50), 8),
            inside in proptest::collection::vec(proptest::collection::vec(0.0f64..=1.0, 8), 1..30),
        ) {
            let sample = |v: [i32; 8]| {
                Sample::new(v[0] as u16, [1, 2, 3].map(|c| v[c] as u16), [4, 5, 6].map(|c| v[c] as i16), v[7] as i16, 0)
                    .unwrap()
            };
            let mut f = SendOnDelta::new([40, 40, 40, 40, 6, 6, 6, 0]);
            let r: [i32; 8] = core::array::from_fn(|c| reference[c]);
            let lo: [i32; 8] = core::array::from_fn(|c| r[c] - spread[c].0);
            let hi: [i32; 8] = core::array::from_fn(|c| r[c] + spread[c].1);
            prop_assert!(!f.holds(lo, hi), "no reference yet: the next sample goes out");
            prop_assert!(f.update(&sample(r)));
            let fits = (0..8).all(|c| spread[c].0.max(spread[c].1) <= i32::from(f.deltas[c]));
            prop_assert_eq!(f.holds(lo, hi), fits);
            if lo != hi {
                prop_assert!(!f.holds(hi, lo), "an empty range is refused");
            }
            if fits {
                for t in inside {
                    let v = core::array::from_fn(|c| lo[c] + (t[c] * f64::from(hi[c] - lo[c])).round() as i32);
                    prop_assert!(!f.update(&sample(v)));
                }
            }
        }

        #[test]
        fn send_on_delta_passes_big_moves_only(a in 0u16..4000, step in 0u16..40) {
            let mut f = SendOnDelta::default();
            let s = |force| Sample::new(0, [force, 0, 0], [0; 3], 0, 0).unwrap();
            prop_assert!(f.update(&s(a)));
            let moved = f.update(&s(a.saturating_add(step).min(4095)));
            prop_assert_eq!(moved, a.saturating_add(step).min(4095) - a > DEFAULT_DELTAS[1]);
        }
    }
}
