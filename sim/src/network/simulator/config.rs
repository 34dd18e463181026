//! What a network is made of, besides its wiring.

use skin_protocol::message::TrafficMode;
use skin_protocol::organize::Config;

use super::super::link::LinkTiming;
use super::super::stimulus::StimulusKind;
use super::super::NetworkError;

/// What a network is made of, besides its wiring.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NetworkConfig {
    /// Link timing.
    pub timing: LinkTiming,
    /// Self-organization timing of cells and interface ports.
    pub organize: Config,
    /// Sampling rate of every cell.
    pub rate_hz: f32,
    /// Clock- or event-driven sending.
    pub traffic: TrafficMode,
    /// What the skin feels.
    pub stimulus: StimulusKind,
    /// Send-on-delta thresholds the host sets, per sample channel (the
    /// order of `Sample::channels`), in counts; `None` keeps the firmware's
    /// default (about twice the sensor noise).
    pub delta_counts: [Option<u16>; 8],
    /// Bit-error rate of every cell-2-cell wire.
    pub bit_error_rate: f64,
    /// Seed of boot order, sampling phases, sensor noise and bit errors.
    pub seed: u64,
    /// Cells the stimulus leaves at rest skip their samples while they
    /// provably send nothing (the same run, faster); off only to check that.
    pub skip_resting_cells: bool,
    /// The cells' update key and factory version, when they take firmware
    /// updates (each cell then has a 66 KiB slot).
    pub update: Option<super::UpdateSetup>,
}

impl Default for NetworkConfig {
    fn default() -> Self {
        NetworkConfig {
            timing: LinkTiming::default(),
            organize: Config::default(),
            rate_hz: 250.0,
            traffic: TrafficMode::Clock,
            stimulus: StimulusKind::Quiet,
            delta_counts: [None; 8],
            bit_error_rate: 0.0,
            seed: 0,
            skip_resting_cells: true,
            update: None,
        }
    }
}

/// Shortest and longest keep-alive or beacon period the simulator takes.
const PERIOD_RANGE_US: std::ops::RangeInclusive<u64> = 1_000..=10_000_000;

impl NetworkConfig {
    /// The same network with a keep-alive on settled links every
    /// `keepalive_us` and beacon waves every `beacon_us`; a link is given
    /// up after 3.5 keep-alive periods without a frame, a route and the link
    /// to the parent after 3.5 beacon periods without a wave (the cell asks
    /// its neighbours for waves after 1.5), as with the defaults (100 ms,
    /// 10 ms). Longer periods cost a large skin less control traffic (a
    /// settled skin carries about one wave relay per cell per beacon
    /// period) and detect a broken link or route later.
    pub fn with_periods(mut self, keepalive_us: u64, beacon_us: u64) -> Result<NetworkConfig, NetworkError> {
        for (what, us) in [("keep-alive", keepalive_us), ("beacon", beacon_us)] {
            if !PERIOD_RANGE_US.contains(&us) {
                return Err(NetworkError::Flag(format!(
                    "{what} period {} ms: use {} ms to {} ms",
                    us as f64 / 1e3,
                    *PERIOD_RANGE_US.start() as f64 / 1e3,
                    *PERIOD_RANGE_US.end() as f64 / 1e3
                )));
            }
        }
        self.organize.keepalive_period_us = keepalive_us;
        self.organize.keepalive_timeout_us = keepalive_us * 7 / 2;
        self.organize.link_timeout_us = beacon_us * 7 / 2;
        self.organize.beacon_period_us = beacon_us;
        self.organize.wave_timeout_us = beacon_us * 3 / 2;
        self.organize.route_timeout_us = beacon_us * 7 / 2;
        Ok(self)
    }
}
