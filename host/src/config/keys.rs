//! What each configuration key means, its unit and the values it accepts:
//! the source of the configuration reference in the book. The ranges are
//! written from the same constants [`Config::validate`](super::Config::validate)
//! checks against, and a test holds this list to the keys `skin config
//! --default` writes, so a new key cannot go undocumented.

use skin_protocol::interface::MAX_DATAGRAM;
use skin_protocol::Address;

use super::{BATCH, FORCE_GAIN, RATE_HZ};

/// One key of the configuration file.
#[derive(Clone, Debug, PartialEq)]
pub struct KeyDoc {
    /// The dotted key, `[]` standing for any element of an array of tables
    /// (`interface.ports[].number`).
    pub key: &'static str,
    /// The unit of its value, or `-` for none.
    pub unit: &'static str,
    /// The values it accepts.
    pub range: String,
    /// What it does.
    pub meaning: &'static str,
}

fn doc(key: &'static str, unit: &'static str, range: String, meaning: &'static str) -> KeyDoc {
    KeyDoc { key, unit, range, meaning }
}

/// Every key, in the order `skin config --default` writes them.
pub fn keys() -> Vec<KeyDoc> {
    let (rate, gain, batch) = (RATE_HZ, FORCE_GAIN, BATCH);
    let normalized = "4 rising values in [0, 1]".to_owned();
    vec![
        doc(
            "interface.listen",
            "IP:port",
            "a socket address".into(),
            "The host's UDP socket; every interface port of the skin sends here.",
        ),
        doc(
            "interface.recv_buffer_bytes",
            "bytes",
            format!(">= {MAX_DATAGRAM} (one datagram)"),
            "Receive buffer asked of the OS; absorbs bursts while the host is busy. Linux caps it at \
             `net.core.rmem_max` unless the process has `CAP_NET_ADMIN`.",
        ),
        doc(
            "interface.batch",
            "datagrams",
            format!("{} to {}", batch.start(), batch.end()),
            "Most datagrams taken per receive call.",
        ),
        doc(
            "interface.ports[].number",
            "-",
            format!("0 to {}, each once", Address::MAX_INTERFACES - 1),
            "An interface port: the number its datagrams carry. A datagram claiming an unlisted port is dropped \
             (and counted).",
        ),
        doc(
            "interface.ports[].address",
            "IP:port",
            "optional; each address once".into(),
            "Where the port sends from and receives at; without one the port is bound to the first source that \
             claims it.",
        ),
        doc(
            "cells.sample_rate_hz",
            "Hz",
            format!("{} to {}", rate.start(), rate.end()),
            "Sensor sampling rate of every cell.",
        ),
        doc(
            "cells.traffic",
            "-",
            "`clock` or `event`".into(),
            "`clock`: every sample at the sampling rate; `event`: samples that moved by more than the deltas, \
             and level events.",
        ),
        doc(
            "cells.filter_cutoff_hz",
            "Hz",
            "above 0, at most half `sample_rate_hz`".into(),
            "Cut-off of each cell's local low-pass filter.",
        ),
        doc("cells.accel_range_g", "g", "2, 8 or 16".into(), "Accelerometer range."),
        doc(
            "cells.force_levels",
            "normalized",
            normalized.clone(),
            "Lower bounds of the force levels low, medium, high, pain (Table 3).",
        ),
        doc(
            "cells.proximity_levels",
            "normalized",
            normalized,
            "Lower bounds of the proximity levels high, medium, low, close contact (Table 3).",
        ),
        doc("cells.hysteresis", "normalized", "0 to 1".into(), "A level is left only below its bound minus this."),
        doc(
            "cells.force_gains",
            "factor",
            format!("3 values, each {} to {}", gain.start(), gain.end()),
            "Calibration gains of the three force cells.",
        ),
        doc(
            "cells.delta_counts",
            "raw counts",
            "8 values, 0 to 65535".into(),
            "Send-on-delta thresholds: proximity, forces 0..3, acceleration x, y, z, temperature.",
        ),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Config;

    /// The dotted keys of a TOML table, `[]` for arrays of tables.
    fn dotted(prefix: &str, table: &toml::Table, out: &mut Vec<String>) {
        for (name, value) in table {
            let key = if prefix.is_empty() { name.clone() } else { format!("{prefix}.{name}") };
            match value {
                toml::Value::Table(t) => dotted(&key, t, out),
                toml::Value::Array(items) if items.iter().all(toml::Value::is_table) && !items.is_empty() => {
                    let mut inner = Vec::new();
                    for item in items.iter().filter_map(toml::Value::as_table) {
                        dotted(&format!("{key}[]"), item, &mut inner);
                    }
                    for k in inner {
                        if !out.contains(&k) {
                            out.push(k);
                        }
                    }
                }
                _ => out.push(key),
            }
        }
    }

    #[test]
    fn every_written_key_is_documented_and_nothing_else() {
        let mut written = Vec::new();
        let table: toml::Table = toml::from_str(&Config::default().to_toml()).unwrap();
        dotted("", &table, &mut written);
        // `address` is optional and absent from the defaults.
        written.push("interface.ports[].address".into());
        let mut documented: Vec<String> = keys().iter().map(|k| k.key.to_owned()).collect();
        written.sort();
        documented.sort();
        assert_eq!(documented, written);
    }
}
