//! The digital low-pass of section 4.3.2: a second-order Butterworth run
//! forward and backward, so the filtered signal keeps its timing (equation
//! (11) compares the times of its extremes).

use std::f64::consts::{PI, SQRT_2};

/// A second-order Butterworth low-pass section.
#[derive(Clone, Copy, Debug)]
pub struct Butterworth {
    b: [f64; 3],
    a: [f64; 2],
}

impl Butterworth {
    /// Cut-off `cutoff_hz` at sampling rate `sample_hz` (bilinear transform);
    /// `None` unless `0 < cutoff_hz < sample_hz / 2`.
    pub fn new(cutoff_hz: f64, sample_hz: f64) -> Option<Butterworth> {
        if !(cutoff_hz > 0.0 && cutoff_hz < sample_hz / 2.0) {
            return None;
        }
        let k = (PI * cutoff_hz / sample_hz).tan();
        let norm = 1.0 / (1.0 + SQRT_2 * k + k * k);
        let b0 = k * k * norm;
        Some(Butterworth { b: [b0, 2.0 * b0, b0], a: [2.0 * (k * k - 1.0) * norm, (1.0 - SQRT_2 * k + k * k) * norm] })
    }

    /// Filters `x` in place forward then backward, starting each pass at
    /// rest on the first value it sees.
    pub fn filtfilt(&self, x: &mut [f64]) {
        self.pass(x.iter_mut());
        self.pass(x.iter_mut().rev());
    }

    fn pass<'a>(&self, xs: impl Iterator<Item = &'a mut f64>) {
        let mut state: Option<([f64; 2], [f64; 2])> = None;
        for x in xs {
            let (xin, yout) = state.get_or_insert(([*x; 2], [*x; 2]));
            let y =
                self.b[0] * *x + self.b[1] * xin[0] + self.b[2] * xin[1] - self.a[0] * yout[0] - self.a[1] * yout[1];
            *xin = [*x, xin[0]];
            *yout = [y, yout[0]];
            *x = y;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Gain of the filter for a sine of `f_hz`, from RMS values away from the ends.
    fn amplitude_after(f_hz: f64) -> f64 {
        let lp = Butterworth::new(25.0, 250.0).unwrap();
        let x: Vec<f64> = (0..2500).map(|k| (std::f64::consts::TAU * f_hz * k as f64 / 250.0).sin()).collect();
        let mut y = x.clone();
        lp.filtfilt(&mut y);
        let rms = |v: &[f64]| (v.iter().map(|a| a * a).sum::<f64>() / v.len() as f64).sqrt();
        rms(&y[500..2000]) / rms(&x[500..2000])
    }

    #[test]
    fn passes_the_pattern_and_stops_vibration() {
        // Forward-backward squares the magnitude: -6 dB at the cut-off.
        assert!((amplitude_after(2.0) - 1.0).abs() < 1e-3);
        assert!((amplitude_after(25.0) - 0.5).abs() < 0.02);
        assert!(amplitude_after(100.0) < 0.01);
    }

    #[test]
    fn constants_pass_unchanged_and_bad_cutoffs_are_refused() {
        let mut x = vec![3.5; 50];
        Butterworth::new(10.0, 250.0).unwrap().filtfilt(&mut x);
        assert!(x.iter().all(|v| (v - 3.5).abs() < 1e-12));
        assert!(Butterworth::new(125.0, 250.0).is_none());
        assert!(Butterworth::new(0.0, 250.0).is_none());
        assert!(Butterworth::new(f64::NAN, 250.0).is_none());
    }
}
