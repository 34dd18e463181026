//! The configuration file of the `skin` program (TOML).
//!
//! Every key has a default, so an empty file (or none) is a valid
//! configuration, and `skin config --default` writes them all out. Unknown
//! keys are errors, so a typo does not silently keep a default. A bad file
//! gives an error that names the key and says what is expected.
//!
//! Extension point: a later part of the program adds its own section (the
//! touch `areas`, the `grasp` parameters) as one more field of [`Config`]
//! with a `Default`, plus its checks in [`Config::validate`]; nothing else
//! here changes.

use std::net::SocketAddr;
use std::ops::RangeInclusive;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use skin_model::file::{read_text_capped, MIB};
use skin_protocol::event::{DEFAULT_DELTAS, FORCE_LEVELS, HYSTERESIS, PROXIMITY_LEVELS};
use skin_protocol::interface::MAX_DATAGRAM;
use skin_protocol::message::{AccelRange, Setting, TrafficMode};
use skin_protocol::processing::{DEFAULT_CUTOFF_HZ, DEFAULT_RATE_HZ};
use skin_protocol::Address;

mod keys;
pub use keys::{keys, KeyDoc};

/// Why a configuration could not be used.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The file could not be read.
    #[error("cannot read the configuration {path}: {source} (write one with `skin config --default --output FILE`)")]
    Read {
        /// The file.
        path: PathBuf,
        /// What the OS said.
        source: std::io::Error,
    },
    /// The file is not TOML, has an unknown key, or a value of the wrong type.
    #[error("{origin}: {source}")]
    Parse {
        /// The file (or other origin) of the text.
        origin: String,
        /// The parser's error, with line, column and the offending key.
        #[source]
        source: toml::de::Error,
    },
    /// A value has the right type but is out of range.
    #[error("{}`{key}` {message}", prefix(origin))]
    Invalid {
        /// The file (or other origin) of the text; empty for a configuration
        /// built in code.
        origin: String,
        /// The dotted key, e.g. `cells.sample_rate_hz`.
        key: String,
        /// What is wrong and what is expected.
        message: String,
    },
}

fn prefix(origin: &str) -> String {
    if origin.is_empty() {
        String::new()
    } else {
        format!("{origin}: ")
    }
}

/// Everything the `skin` program can be configured with.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Config {
    /// How the host reaches the skin.
    pub interface: InterfaceConfig,
    /// What the host writes into every cell.
    pub cells: CellSettings,
}

/// The UDP side of the host.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct InterfaceConfig {
    /// The host's socket; every interface port sends here.
    pub listen: SocketAddr,
    /// Receive buffer asked of the OS, in bytes. It absorbs bursts while the
    /// host is busy elsewhere (the interface benchmark prints how long a
    /// burst the default holds). Linux caps it at
    /// `net.core.rmem_max` unless the process has `CAP_NET_ADMIN` (and
    /// reports twice the granted size).
    pub recv_buffer_bytes: usize,
    /// Most datagrams taken per receive call.
    pub batch: usize,
    /// The interface ports; a datagram claiming any other is dropped.
    pub ports: Vec<PortConfig>,
}

/// One interface port.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PortConfig {
    /// The number its datagrams carry.
    pub number: u8,
    /// Where it sends from and receives at. Without one, the port is bound
    /// to the first source that claims it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub address: Option<SocketAddr>,
}

impl Default for InterfaceConfig {
    fn default() -> Self {
        InterfaceConfig {
            listen: SocketAddr::from(([127, 0, 0, 1], 7700)),
            recv_buffer_bytes: 32 << 20,
            batch: 64,
            // The five ports of the HRP-2 skin interface.
            ports: (0..5).map(|number| PortConfig { number, address: None }).collect(),
        }
    }
}

/// How cells send their samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Traffic {
    /// Every sample at the sampling rate.
    Clock,
    /// Samples that moved by more than the deltas, and level events.
    Event,
}

/// Sampling rates a configuration may ask for, Hz: below 1 Hz the
/// exploration's averages starve; the cells' sensors give at most 10 kHz.
const RATE_HZ: RangeInclusive<f32> = 1.0..=10_000.0;
/// Force-cell calibration gains a configuration may ask for: a factor of
/// 100 either way is calibration, beyond it a typo that saturates every
/// force level.
const FORCE_GAIN: RangeInclusive<f32> = 0.01..=100.0;
/// Datagrams per receive call: at least one, and no more than the batched
/// receive takes at once (its `MAX_BATCH`).
const BATCH: RangeInclusive<usize> = 1..=1024;

/// The settings written into every cell (section 2.1.4, Table 3).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CellSettings {
    /// Sensor sampling rate.
    pub sample_rate_hz: f32,
    /// `clock` or `event`.
    pub traffic: Traffic,
    /// Cut-off of each cell's local low-pass filter.
    pub filter_cutoff_hz: f32,
    /// Accelerometer range: 2, 8 or 16 g.
    pub accel_range_g: u8,
    /// Lower bounds of the force levels low, medium, high, pain, normalized.
    pub force_levels: [f32; 4],
    /// Lower bounds of the proximity levels high, medium, low, close contact.
    pub proximity_levels: [f32; 4],
    /// A level is left only below its bound minus this, normalized.
    pub hysteresis: f32,
    /// Calibration gains of the three force cells.
    pub force_gains: [f32; 3],
    /// Send-on-delta thresholds in raw counts: proximity, forces 0..3,
    /// acceleration x, y, z, temperature.
    pub delta_counts: [u16; 8],
}

impl Default for CellSettings {
    fn default() -> Self {
        CellSettings {
            sample_rate_hz: DEFAULT_RATE_HZ,
            traffic: Traffic::Clock,
            filter_cutoff_hz: DEFAULT_CUTOFF_HZ,
            accel_range_g: 2,
            force_levels: FORCE_LEVELS,
            proximity_levels: PROXIMITY_LEVELS,
            hysteresis: HYSTERESIS,
            force_gains: [1.0; 3],
            delta_counts: DEFAULT_DELTAS,
        }
    }
}

impl CellSettings {
    /// Each setting with the key it comes from.
    fn keyed(&self) -> Vec<(String, Setting)> {
        let accel = match self.accel_range_g {
            2 => Some(AccelRange::G2),
            8 => Some(AccelRange::G8),
            16 => Some(AccelRange::G16),
            _ => None,
        };
        let mut out = vec![
            ("sample_rate_hz".to_owned(), Setting::SampleRateHz(self.sample_rate_hz)),
            (
                "traffic".to_owned(),
                Setting::Traffic(match self.traffic {
                    Traffic::Clock => TrafficMode::Clock,
                    Traffic::Event => TrafficMode::Event,
                }),
            ),
            ("filter_cutoff_hz".to_owned(), Setting::FilterCutoffHz(self.filter_cutoff_hz)),
        ];
        out.extend(accel.map(|a| ("accel_range_g".to_owned(), Setting::AccelRange(a))));
        for (i, v) in self.force_levels.iter().enumerate() {
            out.push((format!("force_levels[{i}]"), Setting::ForceLevel { level: i as u8 + 1, value: *v }));
        }
        for (i, v) in self.proximity_levels.iter().enumerate() {
            out.push((format!("proximity_levels[{i}]"), Setting::ProximityLevel { level: i as u8 + 1, value: *v }));
        }
        out.push(("hysteresis".to_owned(), Setting::Hysteresis(self.hysteresis)));
        for (i, g) in self.force_gains.iter().enumerate() {
            out.push((format!("force_gains[{i}]"), Setting::ForceGain { cell: i as u8, gain: *g }));
        }
        for (i, c) in self.delta_counts.iter().enumerate() {
            out.push((format!("delta_counts[{i}]"), Setting::Delta { channel: i as u8, counts: *c }));
        }
        out
    }

    /// The configuration writes that bring a cell to these settings.
    pub fn settings(&self) -> Vec<Setting> {
        self.keyed().into_iter().map(|(_, s)| s).collect()
    }

    /// Checks every value; the error names the first bad key.
    pub fn validate(&self) -> Result<(), Error> {
        self.check().map_err(|(key, message)| invalid("cells", key, message))
    }

    fn check(&self) -> Result<(), (String, String)> {
        if ![2, 8, 16].contains(&self.accel_range_g) {
            return Err(("accel_range_g".into(), format!("= {}: must be 2, 8 or 16", self.accel_range_g)));
        }
        let rate = self.sample_rate_hz;
        if !RATE_HZ.contains(&rate) {
            return Err(("sample_rate_hz".into(), format!("= {rate:?}: must be in [1, 10000] Hz")));
        }
        let (cutoff, nyquist) = (self.filter_cutoff_hz, rate / 2.0);
        if !(cutoff > 0.0 && cutoff <= nyquist) {
            return Err((
                "filter_cutoff_hz".into(),
                format!("= {cutoff:?}: must be in (0, {nyquist}] Hz, at most half the sample rate (Nyquist)"),
            ));
        }
        for (i, gain) in self.force_gains.iter().enumerate() {
            if !FORCE_GAIN.contains(gain) {
                return Err((format!("force_gains[{i}]"), format!("= {gain:?}: must be in [0.01, 100]")));
            }
        }
        // What is left: the normalized levels and hysteresis.
        for (key, setting) in self.keyed() {
            if !setting.is_valid() {
                return Err((key, "is out of range: expected a normalized value in [0, 1]".into()));
            }
        }
        for (key, levels) in [("force_levels", self.force_levels), ("proximity_levels", self.proximity_levels)] {
            if levels.windows(2).any(|w| w[0] >= w[1]) {
                return Err((key.into(), format!("= {levels:?}: the four bounds must rise strictly")));
            }
        }
        Ok(())
    }
}

impl InterfaceConfig {
    /// Checks every value; the error names the first bad key.
    pub fn validate(&self) -> Result<(), Error> {
        self.check().map_err(|(key, message)| invalid("interface", key, message))
    }

    fn check(&self) -> Result<(), (String, String)> {
        if self.recv_buffer_bytes < MAX_DATAGRAM {
            return Err(("recv_buffer_bytes".into(), format!("must be at least {MAX_DATAGRAM} (one datagram)")));
        }
        if !BATCH.contains(&self.batch) {
            return Err(("batch".into(), format!("must be in {}..={}", BATCH.start(), BATCH.end())));
        }
        if self.ports.is_empty() {
            return Err(("ports".into(), "is empty: configure at least one interface port".into()));
        }
        for (i, p) in self.ports.iter().enumerate() {
            if Address::interface(p.number).is_none() {
                let max = Address::MAX_INTERFACES - 1;
                return Err((format!("ports[{i}].number"), format!("= {}: must be at most {max}", p.number)));
            }
            if self.ports[..i].iter().any(|q| q.number == p.number) {
                return Err((format!("ports[{i}].number"), format!("= {}: used twice", p.number)));
            }
            if p.address.is_some() && self.ports[..i].iter().any(|q| q.address == p.address) {
                return Err((format!("ports[{i}].address"), "is used by another port".into()));
            }
        }
        Ok(())
    }
}

fn invalid(section: &str, key: String, message: String) -> Error {
    Error::Invalid { origin: String::new(), key: format!("{section}.{key}"), message }
}

/// Section comments of the written-out defaults.
const SECTION_NOTES: [(&str, &str); 3] = [
    ("[interface]", "# The host's UDP socket; every interface port of the skin sends to `listen`."),
    (
        "[[interface.ports]]",
        "# An interface port: the number its datagrams carry, and optionally `address`, where it\n\
         # sends from (\"192.168.1.20:7700\"); without one it is bound to the first source that claims it.",
    ),
    ("[cells]", "# Written into every cell at start (paper section 2.1.4, Table 3); levels are normalized."),
];

/// The largest configuration file read: the defaults take 2 KiB.
pub const MAX_FILE_BYTES: usize = MIB;

impl Config {
    /// Reads and checks a configuration file.
    pub fn load(path: &Path) -> Result<Config, Error> {
        let text =
            read_text_capped(path, MAX_FILE_BYTES).map_err(|source| Error::Read { path: path.to_owned(), source })?;
        Config::from_toml(&text, &path.display().to_string())
    }

    /// Parses and checks configuration text; `origin` names it in errors.
    pub fn from_toml(text: &str, origin: &str) -> Result<Config, Error> {
        let config: Config =
            toml::from_str(text).map_err(|source| Error::Parse { origin: origin.to_owned(), source })?;
        config.validate().map_err(|e| match e {
            Error::Invalid { key, message, .. } => Error::Invalid { origin: origin.to_owned(), key, message },
            e => e,
        })?;
        Ok(config)
    }

    /// Checks every value; the error names the first bad key.
    pub fn validate(&self) -> Result<(), Error> {
        self.interface.validate()?;
        self.cells.validate()
    }

    /// The configuration as commented TOML.
    pub fn to_toml(&self) -> String {
        // Serializing plain structs of numbers, strings and arrays cannot fail.
        let body = toml::to_string(self).unwrap_or_default();
        let mut out =
            String::from("# Configuration of the `skin` program. Every key is optional; these are the defaults.\n");
        let mut noted = [false; SECTION_NOTES.len()];
        for line in body.lines() {
            if let Some(i) = SECTION_NOTES.iter().position(|(header, _)| *header == line) {
                if !noted[i] {
                    noted[i] = true;
                    if !out.ends_with("\n\n") {
                        out.push('\n');
                    }
                    out.push_str(SECTION_NOTES[i].1);
                    out.push('\n');
                }
            }
            out.push_str(line);
            out.push('\n');
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_defaults_round_trip_through_their_written_form() {
        let text = Config::default().to_toml();
        assert_eq!(Config::from_toml(&text, "defaults").unwrap(), Config::default());
        assert!(text.contains("force_levels = [0.04, 0.1, 0.3, 0.45]"), "{text}");
        assert_eq!(Config::from_toml("", "empty").unwrap(), Config::default());
    }

    #[test]
    fn bad_files_name_the_key() {
        let cases = [
            ("[cells]\nsample_rate_hz = \"fast\"\n", "sample_rate_hz"),
            ("[cells]\nsampel_rate_hz = 100\n", "sampel_rate_hz"),
            ("[cells]\nsample_rate_hz = -5.0\n", "cells.sample_rate_hz"),
            ("[cells]\nforce_levels = [0.1, 0.05, 0.3, 0.45]\n", "cells.force_levels"),
            ("[cells]\nforce_gains = [1.0, 0.0, 1.0]\n", "cells.force_gains[1]"),
            ("[cells]\nforce_gains = [1e38, 1.0, 1.0]\n", "`cells.force_gains[0]` = 1e38: must be in [0.01, 100]"),
            ("[cells]\nsample_rate_hz = 0.001\n", "`cells.sample_rate_hz` = 0.001: must be in [1, 10000] Hz"),
            ("[cells]\nfilter_cutoff_hz = 1e30\n", "`cells.filter_cutoff_hz` = 1e30: must be in (0, 125] Hz"),
            ("[cells]\nsample_rate_hz = 100\nfilter_cutoff_hz = 60\n", "(0, 50] Hz, at most half the sample rate"),
            (
                "[cells]\nhysteresis = 2.0\n",
                "`cells.hysteresis` is out of range: expected a normalized value in [0, 1]",
            ),
            ("[cells]\naccel_range_g = 4\n", "cells.accel_range_g"),
            ("[interface]\nlisten = \"nowhere\"\n", "listen"),
            ("[[interface.ports]]\nnumber = 1\n[[interface.ports]]\nnumber = 1\n", "interface.ports[1].number"),
            ("[[interface.ports]]\nnumber = 254\n", "interface.ports[0].number"),
            ("[interface]\nports = []\n", "interface.ports"),
            ("[interface]\nbatch = 0\n", "interface.batch"),
        ];
        for (text, key) in cases {
            let e = Config::from_toml(text, "test.toml").unwrap_err().to_string();
            assert!(e.starts_with("test.toml: ") && e.contains(key), "{text:?} gave {e}");
        }
    }

    #[test]
    fn settings_cover_every_key() {
        let s = CellSettings::default().settings();
        assert_eq!(s.len(), 3 + 1 + 4 + 4 + 1 + 3 + 8);
        assert!(s.iter().all(Setting::is_valid));
    }
}
