//! What the skin feels: raw sensor samples of every cell over time, for a
//! quiet skin, a moving fingertip, or a whole-arm grasp.
//!
//! Each cell has its own baselines (proximity cross-talk, force-cell
//! offset, gravity direction, temperature) and its own stream of white
//! sensor noise, Gaussian but bounded at three standard deviations (a draw
//! beyond is drawn again); contact adds force at the three force cells
//! (Figure 3: 120 degrees apart, 7 mm off centre) and proximity that falls
//! off with distance, up to the proximity sensor's range.
//!
//! A stimulus knows where and when it acts: [`Stimulus::rest_until`] says
//! how long a cell reads nothing but its baseline and noise, and
//! [`Stimulus::rest_bounds`] what it can read meanwhile, so the network
//! can skip the cells the stimulus leaves at rest.

use rand::{Rng, RngCore, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use skin_protocol::sample::{Sample, FORCE_MAX, PROXIMITY_MAX};

use super::NetworkError;

/// Force cell full scale (Table 1: 0-10 N over 12 bits).
pub const FORCE_FULL_SCALE_N: f64 = 10.0;
/// Accelerometer counts per g at the +-2 g range (10 bits).
const COUNTS_PER_G: f64 = 256.0;
/// LM71 counts per degree Celsius.
const COUNTS_PER_C: f64 = 32.0;
/// White noise, one standard deviation in counts: proximity (VCNL4010),
/// force (capacitive), acceleration (BMA250: about 4 mg rms), temperature.
pub const NOISE_COUNTS: [f64; 4] = [3.0, 2.0, 1.0, 1.0];
/// Noise never exceeds this many standard deviations (0.27% of Gaussian
/// draws would), so a cell's readings at rest have known bounds.
pub const NOISE_BOUND_SD: f64 = 3.0;
/// Distance over which proximity falls to 1/e.
const PROXIMITY_DECAY_M: f64 = 0.015;
/// Range of the proximity sensor (Table 1: 1-200 mm); beyond it, nothing.
pub const PROXIMITY_RANGE_M: f64 = 0.2;
/// Normalized proximity at touch (Table 3: close contact from 0.8).
const PROXIMITY_AT_TOUCH: f64 = 0.85;
/// Where the force cells sit: on a circle of 7 mm radius around the cell
/// centre, 120 degrees apart.
const FORCE_CELLS_M: [[f64; 2]; 3] = [[0.007, 0.0], [-0.0035, 0.006_062], [-0.0035, -0.006_062]];
/// Radius of the circle the force cells sit on.
const FORCE_CELL_RADIUS_M: f64 = 0.007;
/// Contact radius of the fingertip.
const FINGER_RADIUS_M: f64 = 0.012;
/// Speed of the fingertip.
const FINGER_SPEED_M_S: f64 = 0.1;
/// Half the width of the band a grasped object presses.
const HALF_BAND_M: f64 = 0.03;
/// One grasp: approach, press, hold, let go, withdraw.
const GRASP_CYCLE_S: f64 = 7.0;
/// The grasped object approaches (and withdraws) at this speed for 2 s.
const GRASP_SPEED_M_S: f64 = 0.025;
/// When the grasped object is pressed in, and when it is taken back, in the cycle.
const GRASP_CONTACT_S: std::ops::Range<f64> = 2.0..5.0;
/// [`Stimulus::rest_until`] keeps this far from the stimulus's reach, so
/// that rounding never decides.
const REST_MARGIN_M: f64 = 0.001;
// No force without proximity: the proximity range bounds where a stimulus acts.
const _: () = assert!(FINGER_RADIUS_M + FORCE_CELL_RADIUS_M < PROXIMITY_RANGE_M);

/// A stimulus the skin is exposed to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StimulusKind {
    /// Nothing touches the skin.
    Quiet,
    /// A fingertip (2 N, 12 mm contact radius) slides across the skin at
    /// 0.1 m/s, back and forth through its middle.
    Touch,
    /// A large object is grasped with the whole arm, every 7 s: it
    /// approaches at 25 mm/s (2 s), is pressed in to 3 N per force cell
    /// along a 60 mm wide band across the middle of the skin (1 s), held
    /// while it slips slightly (1 s), let go (1 s) and taken back at
    /// 25 mm/s (2 s).
    Grasp,
}

impl std::str::FromStr for StimulusKind {
    type Err = NetworkError;
    fn from_str(s: &str) -> Result<Self, NetworkError> {
        match s {
            "quiet" => Ok(StimulusKind::Quiet),
            "touch" => Ok(StimulusKind::Touch),
            "grasp" => Ok(StimulusKind::Grasp),
            _ => Err(NetworkError::Flag(format!("stimulus `{s}`: use quiet, touch or grasp"))),
        }
    }
}

/// The resting state of one cell.
#[derive(Clone, Copy, Debug)]
struct Baseline {
    proximity: f64,
    force: [f64; 3],
    gravity: [f64; 3],
    temperature: f64,
}

/// Raw samples of every cell of a skin under one stimulus.
#[derive(Clone, Debug)]
pub struct Stimulus {
    kind: StimulusKind,
    positions_m: Vec<[f64; 2]>,
    baselines: Vec<Baseline>,
    lo: [f64; 2],
    hi: [f64; 2],
    /// Each cell's noise, so that what one cell reads does not depend on
    /// when the others read.
    noise: Vec<Noise>,
    /// Readings fed from outside (a world model), one per cell, replacing
    /// the stimulus once given.
    fed: Option<Vec<Sample>>,
}

impl Stimulus {
    /// The stimulus `kind` on cells at `positions_m`, with baselines and
    /// noise drawn from `seed`.
    pub fn new(kind: StimulusKind, positions_m: &[[f64; 2]], seed: u64) -> Stimulus {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let baselines = positions_m
            .iter()
            .map(|_| {
                // A cell glued on at some tilt: gravity within 45 degrees of -z.
                let (tilt, turn) = (rng.random::<f64>() * std::f64::consts::FRAC_PI_4, rng.random::<f64>() * 6.3);
                Baseline {
                    proximity: 1_000.0 + 500.0 * rng.random::<f64>(),
                    force: std::array::from_fn(|_| 40.0 + 30.0 * rng.random::<f64>()),
                    gravity: [
                        COUNTS_PER_G * tilt.sin() * turn.cos(),
                        COUNTS_PER_G * tilt.sin() * turn.sin(),
                        COUNTS_PER_G * tilt.cos(),
                    ],
                    temperature: COUNTS_PER_C * (30.0 + 4.0 * rng.random::<f64>()),
                }
            })
            .collect();
        let fold = |f: fn(f64, f64) -> f64, init: f64, k: usize| positions_m.iter().map(|p| p[k]).fold(init, f);
        Stimulus {
            kind,
            positions_m: positions_m.to_vec(),
            baselines,
            lo: [fold(f64::min, f64::MAX, 0), fold(f64::min, f64::MAX, 1)],
            hi: [fold(f64::max, f64::MIN, 0), fold(f64::max, f64::MIN, 1)],
            noise: (0..positions_m.len()).map(|_| Noise(rng.next_u64())).collect(),
            fed: None,
        }
    }

    /// The stimulus kind.
    pub fn kind(&self) -> StimulusKind {
        self.kind
    }

    fn mid(&self) -> [f64; 2] {
        [(self.lo[0] + self.hi[0]) / 2.0, (self.lo[1] + self.hi[1]) / 2.0]
    }

    /// The width of skin the fingertip travels.
    fn span_m(&self) -> f64 {
        (self.hi[0] - self.lo[0]).max(0.01)
    }

    /// Where the fingertip is in its back and forth at `t_s`, in `[0, 2)`:
    /// a fraction of the span on the way out, two less it on the way back.
    fn finger_phase(&self, t_s: f64) -> f64 {
        let x = t_s * FINGER_SPEED_M_S / self.span_m();
        // `x % 2.0` without the call into libm: `x - 2k` is exact for
        // `2k <= x < 2k + 2` (Sterbenz), as the remainder is.
        x - 2.0 * crate::round::trunc(x * 0.5)
    }

    /// Where the object is at time `t_s`: worked out once per reading, as
    /// a cell's centre and its three force cells read the same object.
    fn object(&self, t_s: f64) -> Object {
        let mid = self.mid();
        match self.kind {
            StimulusKind::Quiet => Object::None,
            StimulusKind::Touch => {
                // A triangle wave over the width of the skin.
                let phase = self.finger_phase(t_s);
                let x = self.lo[0] + self.span_m() * if phase < 1.0 { phase } else { 2.0 - phase };
                Object::Finger([x, mid[1]])
            }
            StimulusKind::Grasp => {
                let t = t_s % GRASP_CYCLE_S;
                let (start, end) = (GRASP_CONTACT_S.start, GRASP_CONTACT_S.end);
                let (gap_m, press) = match t {
                    t if t < start => (GRASP_SPEED_M_S * (start - t), 0.0),
                    t if t < start + 1.0 => (0.0, t - start),
                    t if t < start + 2.0 => (0.0, 1.0 - 0.1 * (std::f64::consts::PI * (t - start - 1.0)).sin()),
                    t if t < end => (0.0, 0.9 * (end - t)),
                    t => (GRASP_SPEED_M_S * (t - end), 0.0),
                };
                Object::Band { y: mid[1], gap_m, press }
            }
        }
    }

    /// The first time from `t_s` on at which cell `cell` may read more than
    /// its rest (baseline and noise): `t_s` itself when the stimulus
    /// reaches it now or readings are fed from outside, infinity when it
    /// never will. Its proximity sensor reaches farthest, so the cell is at
    /// rest while the object stays beyond that range.
    pub fn rest_until(&self, cell: usize, t_s: f64) -> f64 {
        if self.fed.is_some() {
            return t_s;
        }
        let p = self.positions_m[cell];
        let mid = self.mid();
        let reach_m = PROXIMITY_RANGE_M + REST_MARGIN_M;
        match self.kind {
            StimulusKind::Quiet => f64::INFINITY,
            StimulusKind::Touch => {
                // The fingertip passes within reach while its x is within
                // `w` of the cell's: fractions `a..=b` of the span, which it
                // enters at phase `a` on the way out and `2 - b` on the way back.
                let dy = (p[1] - mid[1]).abs();
                if dy > reach_m {
                    return f64::INFINITY;
                }
                let w = (reach_m * reach_m - dy * dy).sqrt();
                let span = self.span_m();
                let (a, b) = (((p[0] - w - self.lo[0]) / span).max(0.0), ((p[0] + w - self.lo[0]) / span).min(1.0));
                let phase = self.finger_phase(t_s);
                let at = if phase < 1.0 { phase } else { 2.0 - phase };
                if (a..=b).contains(&at) {
                    return t_s;
                }
                let ahead = [a, 2.0 - b].map(|entry| (entry - phase).rem_euclid(2.0));
                t_s + ahead[0].min(ahead[1]) * span / FINGER_SPEED_M_S
            }
            StimulusKind::Grasp => {
                // The object is `gap + off` away; `gap` shrinks to 0 on
                // approach and grows again on withdrawal.
                let off = ((p[1] - mid[1]).abs() - HALF_BAND_M).max(0.0);
                let gap = reach_m - off;
                if gap < 0.0 {
                    return f64::INFINITY;
                }
                let (near, far) =
                    (GRASP_CONTACT_S.start - gap / GRASP_SPEED_M_S, GRASP_CONTACT_S.end + gap / GRASP_SPEED_M_S);
                let t = t_s % GRASP_CYCLE_S;
                match t {
                    t if t < near => t_s + (near - t),
                    t if t > far => t_s + (GRASP_CYCLE_S - t) + near,
                    _ => t_s,
                }
            }
        }
    }

    /// Per channel (in [`Sample::channels`] order), the lowest and the
    /// highest reading of cell `cell` at rest: its baselines with the
    /// noise at its bounds.
    pub fn rest_bounds(&self, cell: usize) -> ([i32; 8], [i32; 8]) {
        let bound = |sign: f64| {
            let [np, nf, na, nt] = NOISE_COUNTS.map(|sd| sign * NOISE_BOUND_SD * sd);
            reading(&self.baselines[cell], 0.0, [0.0; 3], [np, nf, nf, nf, na, na, na, nt]).channels()
        };
        (bound(-1.0), bound(1.0))
    }

    /// The raw sample of cell `cell` at rest: what it reads whenever
    /// [`Stimulus::rest_until`] says it is at rest, as [`Stimulus::raw`]
    /// would read it.
    pub fn rest(&mut self, cell: usize) -> Sample {
        let noise = self.noise[cell].draw();
        reading(&self.baselines[cell], 0.0, [0.0; 3], noise)
    }

    /// True when a cell whose centre is `distance_m` from the object (as
    /// [`Object::contact`] measures it) cannot feel force at any of its
    /// force cells.
    fn out_of_reach(&self, distance_m: f64) -> bool {
        // A margin keeps rounding from deciding.
        let reach_m = match self.kind {
            StimulusKind::Quiet => return true,
            StimulusKind::Touch => FINGER_RADIUS_M + FORCE_CELL_RADIUS_M,
            StimulusKind::Grasp => FORCE_CELL_RADIUS_M,
        };
        distance_m > reach_m + 1e-6
    }

    /// From now on every cell reads `raw[cell]` (until the next call)
    /// instead of the stimulus: the readings of a simulated world, so the
    /// network carries what the robot feels.
    pub fn feed(&mut self, raw: &[Sample]) -> Result<(), NetworkError> {
        if raw.len() != self.positions_m.len() {
            return Err(NetworkError::Flag(format!(
                "{} readings fed to a skin of {} cells",
                raw.len(),
                self.positions_m.len()
            )));
        }
        match &mut self.fed {
            Some(fed) => fed.copy_from_slice(raw),
            None => self.fed = Some(raw.to_vec()),
        }
        Ok(())
    }

    /// The raw sample of cell `cell` at time `t_s`.
    pub fn raw(&mut self, cell: usize, t_s: f64) -> Sample {
        if let Some(fed) = &self.fed {
            return fed[cell];
        }
        let p = self.positions_m[cell];
        let object = self.object(t_s);
        let (_, distance_m) = object.contact(p);
        let proximity = if distance_m <= PROXIMITY_RANGE_M {
            PROXIMITY_AT_TOUCH * f64::from(PROXIMITY_MAX) * (-distance_m / PROXIMITY_DECAY_M).exp()
        } else {
            0.0
        };
        let force: [f64; 3] = if self.out_of_reach(distance_m) {
            [0.0; 3]
        } else {
            FORCE_CELLS_M
                .map(|o| object.contact([p[0] + o[0], p[1] + o[1]]).0 / FORCE_FULL_SCALE_N * f64::from(FORCE_MAX))
        };
        let noise = self.noise[cell].draw();
        reading(&self.baselines[cell], proximity, force, noise)
    }
}

/// Where the stimulus's object is at one moment.
#[derive(Clone, Copy, Debug)]
enum Object {
    None,
    /// The fingertip's centre.
    Finger([f64; 2]),
    /// The grasped object's band, along x through `y`: how far it is from
    /// the skin, and how hard it presses (1: 3 N per force cell).
    Band {
        y: f64,
        gap_m: f64,
        press: f64,
    },
}

impl Object {
    /// Contact at a point of the skin: force in newtons and distance of
    /// the object in metres.
    fn contact(&self, p: [f64; 2]) -> (f64, f64) {
        match *self {
            Object::None => (0.0, f64::INFINITY),
            Object::Finger([x, y]) => {
                let d = ((p[0] - x).powi(2) + (p[1] - y).powi(2)).sqrt();
                let force = 2.0 * (1.0 - (d / FINGER_RADIUS_M).powi(2)).max(0.0);
                (force, d)
            }
            Object::Band { y, gap_m, press } => {
                let across = (p[1] - y).abs();
                let force = 3.0 * press * (1.0 - (across / HALF_BAND_M).powi(2)).max(0.0);
                (force, gap_m + (across - HALF_BAND_M).max(0.0))
            }
        }
    }
}

/// A cell's reading: baseline, what the stimulus adds (in counts), and
/// noise per channel (in counts, [`Sample::channels`] order), rounded to
/// counts and saturated as the ADCs do. Monotonic in every input.
fn reading(b: &Baseline, proximity: f64, force: [f64; 3], noise: [f64; 8]) -> Sample {
    let count = crate::round::round;
    Sample::saturating(
        count(b.proximity + proximity + noise[0]).clamp(0.0, f64::from(PROXIMITY_MAX)) as u16,
        std::array::from_fn(|k| count(b.force[k] + force[k] + noise[1 + k]).max(0.0) as u16),
        std::array::from_fn(|k| count(b.gravity[k] + noise[4 + k]) as i16),
        count(b.temperature + noise[7]) as i16,
        0,
    )
}

/// One cell's sensor noise: SplitMix64 (Steele, Lea and Flood, 2014), a
/// generator of eight bytes of state, seeded from the skin's seed.
#[derive(Clone, Copy, Debug)]
struct Noise(u64);

impl RngCore for Noise {
    fn next_u32(&mut self) -> u32 {
        (self.next_u64() >> 32) as u32
    }

    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    fn fill_bytes(&mut self, dst: &mut [u8]) {
        rand::rand_core::impls::fill_bytes_via_next(self, dst)
    }
}

impl Noise {
    /// One reading's noise in counts, per channel in [`Sample::channels`]
    /// order: Gaussian, drawn again beyond [`NOISE_BOUND_SD`].
    fn draw(&mut self) -> [f64; 8] {
        let [np, nf, na, nt] = NOISE_COUNTS;
        let sds = [np, nf, nf, nf, na, na, na, nt];
        sds.map(|sd| loop {
            let z: f64 = self.sample(StandardNormal);
            if z.abs() <= NOISE_BOUND_SD {
                break sd * z;
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(n: usize) -> Vec<[f64; 2]> {
        (0..n).map(|i| [(i / 10) as f64 * 0.0277, (i % 10) as f64 * 0.024]).collect()
    }

    #[test]
    fn quiet_skin_is_noise_around_its_baseline() {
        let mut s = Stimulus::new(StimulusKind::Quiet, &line(10), 3);
        let a: Vec<Sample> = (0..200).map(|k| s.raw(4, k as f64 * 0.004)).collect();
        let force: Vec<f64> = a.iter().map(|x| f64::from(x.force()[0])).collect();
        let mean = force.iter().sum::<f64>() / force.len() as f64;
        let sd = (force.iter().map(|f| (f - mean).powi(2)).sum::<f64>() / force.len() as f64).sqrt();
        assert!((sd - NOISE_COUNTS[1]).abs() < 0.5, "force noise {sd}");
        let g = a[0].accel().map(f64::from);
        let norm = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
        assert!((norm - COUNTS_PER_G).abs() < 6.0, "gravity {norm}");
    }

    #[test]
    fn grasp_presses_the_middle_band_only_while_holding() {
        let cells = line(30);
        let mut s = Stimulus::new(StimulusKind::Grasp, &cells, 1);
        let pressed = |s: &mut Stimulus, t: f64| (0..30).filter(|&c| s.raw(c, t).force_norm()[0] > 0.1).count();
        assert_eq!(pressed(&mut s, 1.0), 0, "approaching");
        let holding = pressed(&mut s, 3.5);
        assert!(holding > 3 && holding < 20, "{holding} cells pressed");
        assert_eq!(pressed(&mut s, 5.5), 0, "let go");
        // The object moves, it never jumps: proximity is continuous over a cycle.
        let proximity = |s: &mut Stimulus, t: f64| f64::from(s.raw(14, t).proximity());
        for k in 0..700 {
            let t = f64::from(k) * 0.01;
            let step = (proximity(&mut s, t + 0.004) - proximity(&mut s, t)).abs();
            assert!(step < 5_000.0, "proximity jumps by {step} at {t} s");
        }
        let row: Vec<[f64; 2]> = (0..30).map(|i| [i as f64 * 0.0277, 0.0]).collect();
        let mut t = Stimulus::new(StimulusKind::Touch, &row, 1);
        let touched = |t: &mut Stimulus, s: f64| (0..30).filter(|&c| t.raw(c, s).force_norm()[0] > 0.05).count();
        let mut times = (0..20).map(|k| f64::from(k) * 0.1);
        assert!(times.all(|s| touched(&mut t, s) <= 3), "a fingertip presses a few cells at most");
        assert!((0..20).any(|k| touched(&mut t, f64::from(k) * 0.1) > 0), "the finger touches somewhere");
        assert!("poke".parse::<StimulusKind>().is_err());
    }

    #[test]
    fn the_finger_phase_is_the_remainder() {
        let s = Stimulus::new(StimulusKind::Touch, &line(30), 1);
        for k in 0..100_000 {
            let t = f64::from(k) * 0.000_731;
            let x = t * FINGER_SPEED_M_S / s.span_m();
            assert_eq!(s.finger_phase(t).to_bits(), (x % 2.0).to_bits(), "{t}");
        }
    }

    #[test]
    fn fed_readings_replace_the_stimulus() {
        let mut s = Stimulus::new(StimulusKind::Touch, &line(3), 1);
        let fed: Vec<Sample> = (0..3).map(|k| Sample::saturating(k, [k; 3], [0, 0, 256], 800, 0)).collect();
        assert!(s.feed(&fed[..2]).is_err(), "one reading per cell");
        s.feed(&fed).unwrap();
        assert_eq!((0..3).map(|c| s.raw(c, 1.0)).collect::<Vec<_>>(), fed);
    }
}
