//! Faults injected into a run at chosen times.
//!
//! Written on the command line as `KIND:TARGET@SECONDS`:
//! `cut:CELL.PORT@T` cuts the link on that port, `dead:CELL@T` kills a cell
//! for good, `reboot:CELL@T` power-cycles a cell (down for 100 ms; it keeps
//! its stored ID), `interface:K@T` kills interface port `K`, and `ber:RATE`
//! flips wire bits at that rate for the whole run.

use skin_protocol::message::Port;

use super::scenario::MAX_TIME_S;
use super::topology::PortRef;
use super::NetworkError;

/// How long a rebooting cell is without power.
pub const REBOOT_DOWN_NS: u64 = 100_000_000;

/// What goes wrong.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FaultKind {
    /// The link on this port is cut (both directions).
    Cut(PortRef),
    /// The cell dies: its queues are lost and it never talks again.
    Dead(usize),
    /// The cell loses power and boots again with the ID in its store.
    Reboot(usize),
    /// The interface port stops: what it held is lost.
    InterfaceDown(u8),
}

impl std::fmt::Display for FaultKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FaultKind::Cut(p) => write!(f, "cut:{}.{}", p.cell, p.port.index()),
            FaultKind::Dead(c) => write!(f, "dead:{c}"),
            FaultKind::Reboot(c) => write!(f, "reboot:{c}"),
            FaultKind::InterfaceDown(k) => write!(f, "interface:{k}"),
        }
    }
}

/// A fault at a time of the run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fault {
    /// When, in seconds of virtual time after the skin organized.
    pub at_s: f64,
    /// What.
    pub kind: FaultKind,
}

/// A parsed `--fault` flag.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FaultSpec {
    /// A fault at a time.
    At(Fault),
    /// Bit errors on every link for the whole run.
    BitErrorRate(f64),
}

impl std::str::FromStr for FaultSpec {
    type Err = NetworkError;
    fn from_str(s: &str) -> Result<FaultSpec, NetworkError> {
        let bad = |why: &str| {
            NetworkError::Flag(format!(
                "fault `{s}`: {why}; write cut:CELL.PORT@S, dead:CELL@S, reboot:CELL@S, interface:K@S or ber:RATE"
            ))
        };
        let (kind, rest) = s.split_once(':').ok_or_else(|| bad("no `:`"))?;
        if kind == "ber" {
            let rate: f64 = rest.parse().map_err(|_| bad("the rate is not a number"))?;
            return if (0.0..=0.5).contains(&rate) {
                Ok(FaultSpec::BitErrorRate(rate))
            } else {
                Err(bad("the rate must be in [0, 0.5]"))
            };
        }
        let (target, at) = rest.split_once('@').ok_or_else(|| bad("no `@SECONDS`"))?;
        let at_s: f64 = at.parse().map_err(|_| bad("the time is not a number"))?;
        if !(0.0..=MAX_TIME_S).contains(&at_s) {
            return Err(bad("the time must be in [0, 1e9] s"));
        }
        let cell = |t: &str| t.parse::<usize>().map_err(|_| bad("the cell is not a number"));
        let kind = match kind {
            "cut" => {
                let (c, p) = target.split_once('.').ok_or_else(|| bad("write the port as CELL.PORT"))?;
                let port = p.parse().ok().and_then(Port::from_index).ok_or_else(|| bad("ports are 0..=3"))?;
                FaultKind::Cut(PortRef::new(cell(c)?, port))
            }
            "dead" => FaultKind::Dead(cell(target)?),
            "reboot" => FaultKind::Reboot(cell(target)?),
            "interface" => FaultKind::InterfaceDown(target.parse().map_err(|_| bad("interface ports are 0..=253"))?),
            _ => return Err(bad("unknown kind")),
        };
        Ok(FaultSpec::At(Fault { at_s, kind }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn every_kind_parses() {
        let at = |kind| FaultSpec::At(Fault { at_s: 0.5, kind });
        assert_eq!("cut:3.1@0.5".parse::<FaultSpec>().unwrap(), at(FaultKind::Cut(PortRef::new(3, Port::P1))));
        assert_eq!("dead:7@0.5".parse::<FaultSpec>().unwrap(), at(FaultKind::Dead(7)));
        assert_eq!("reboot:0@0.5".parse::<FaultSpec>().unwrap(), at(FaultKind::Reboot(0)));
        assert_eq!("interface:1@0.5".parse::<FaultSpec>().unwrap(), at(FaultKind::InterfaceDown(1)));
        assert_eq!("ber:1e-5".parse::<FaultSpec>().unwrap(), FaultSpec::BitErrorRate(1e-5));
        for bad in ["cut:3.4@1", "cut:3@1", "dead:x@1", "ber:2", "melt:1@1", "dead:1@-1", "dead:1@nan", "dead:1"] {
            assert!(bad.parse::<FaultSpec>().is_err(), "{bad}");
        }
    }

    proptest! {
        #[test]
        fn any_text_parses_or_is_refused(s in "\\PC{0,24}") {
            let _ = s.parse::<FaultSpec>();
        }
    }
}
