//! Seconds flags (`--duration`, `--organize-timeout`, ...): checked in one
//! place, so a value no clock can hold (`1e300`, `NaN`, `-1`) is refused
//! with the flag's name and range instead of panicking in `Duration`.

use std::time::Duration;

/// The longest time any seconds flag takes, s: about 31 years, far past
/// any run and far inside what `Duration` and a microsecond clock hold.
pub const MAX_S: f64 = 1e9;

/// A seconds flag out of its range.
#[derive(Debug, thiserror::Error)]
#[error("{flag} must be a number of seconds in {range}, not {value:?}")]
pub struct Error {
    /// The flag, e.g. `--duration`.
    flag: &'static str,
    /// Its range as written for people.
    range: &'static str,
    /// What was given.
    value: f64,
}

/// `value` if it lies in (0, [`MAX_S`]].
pub fn positive(flag: &'static str, value: f64) -> Result<f64, Error> {
    check(flag, value, value > 0.0, "(0, 1e9]")
}

/// `value` as a `Duration` if it lies in [0, [`MAX_S`]].
pub fn duration(flag: &'static str, value: f64) -> Result<Duration, Error> {
    check(flag, value, value >= 0.0, "[0, 1e9]").map(Duration::from_secs_f64)
}

fn check(flag: &'static str, value: f64, low_ok: bool, range: &'static str) -> Result<f64, Error> {
    if low_ok && value <= MAX_S {
        Ok(value)
    } else {
        Err(Error { flag, range, value })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_no_clock_holds_are_refused_by_name() {
        for bad in [1e300, f64::INFINITY, f64::NAN, -1.0, MAX_S * 2.0] {
            let e = duration("--duration", bad).unwrap_err().to_string();
            assert_eq!(e, format!("--duration must be a number of seconds in [0, 1e9], not {bad:?}"));
        }
        assert_eq!(duration("--duration", 0.0).unwrap(), Duration::ZERO);
        assert_eq!(duration("--duration", MAX_S).unwrap(), Duration::from_secs(1_000_000_000));
        assert!(positive("--organize-timeout", 0.0).unwrap_err().to_string().contains("(0, 1e9]"));
        assert_eq!(positive("--organize-timeout", 30.0).unwrap(), 30.0);
    }
}
