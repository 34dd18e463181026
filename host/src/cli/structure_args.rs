//! The structural exploration's flags that `skin explore`, `skin calibrate`
//! and `skin run` share: the mounting clearance (declared, the default, or
//! none with `--strict`) and the robot-time budget, checked in one place.

use skin_host::explore::StructureConfig;

use super::seconds;

/// Flags of the structural exploration.
#[derive(clap::Args)]
pub struct StructureArgs {
    /// Declare that in the start posture no skin cell lies closer than this
    /// to the axis line of a joint that moves it (and none moves less than
    /// this per radian of a DoF that drives mimic joints), m. Settles cells
    /// that show no lever to a vertical axis no posture can tilt (a yaw
    /// joint on the fixed base) or to a coupled DoF (mimic fingers) [default:
    /// 1/25 of the cell pitch, assumed and reported as such].
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    axis_clearance: Option<f64>,
    /// Assume no mounting clearance: the entries only one settles are
    /// reported as undecided (exit 1) instead.
    #[arg(long, conflicts_with = "axis_clearance")]
    strict: bool,
    /// Robot time the structural exploration may spend on undecided entries, s.
    #[arg(long, value_name = "S", default_value_t = StructureConfig::default().budget_s, allow_negative_numbers = true)]
    time_budget: f64,
}

/// A flag of the structural exploration out of range.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A clearance no skin has.
    #[error("--axis-clearance must be a finite length > 0 m, not {0} (--strict assumes none)")]
    AxisClearance(f64),
    /// The budget.
    #[error(transparent)]
    Seconds(#[from] seconds::Error),
}

impl StructureArgs {
    /// `base` with the flags applied.
    pub fn apply(&self, base: StructureConfig) -> Result<StructureConfig, Error> {
        let axis_clearance_m = match self.axis_clearance {
            Some(m) if !(m.is_finite() && m > 0.0) => return Err(Error::AxisClearance(m)),
            Some(m) => m,
            None => 0.0,
        };
        let budget_s = seconds::positive("--time-budget", self.time_budget)?;
        Ok(StructureConfig { axis_clearance_m, strict: self.strict, budget_s, ..base })
    }

    /// The declared clearance, m (0: none).
    #[cfg(feature = "sim")]
    pub fn declared_m(&self) -> f64 {
        self.axis_clearance.unwrap_or(0.0)
    }
}
