//! The main job on a robot and its skin reached over UDP ([`Remote`]):
//! wait until the skin has organized itself, write the cell settings, then
//! explore the body (section 4). The same steps run against the built-in
//! simulated robot (`skin demo`) and a real one (`skin run`).
//!
//! While the skin organizes, the host holds the robot still: it commands
//! zero velocities every period, which is also what lets a lockstep
//! simulator's clock run.

use std::time::Instant;

use serde::Serialize;
use skin_protocol::message::{Setting, TrafficMode};
use skin_protocol::Address;

use crate::explore::ExploreError;
use crate::interface::{silence_bound_s, EventKind};
use crate::remote::Remote;
use crate::robot::{Robot, RobotError};

/// Why the main job stopped.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PipelineError {
    /// The robot or the skin interface failed.
    #[error(transparent)]
    Robot(#[from] RobotError),
    /// The skin did not organize in time.
    #[error(
        "the skin did not organize within {timeout_s} s of {clock}: {cells} cells heard, {with_tables} with a neighbour table{expected}{suspect} (check the cables and interface ports; `skin monitor` shows what arrives)"
    )]
    NotOrganized {
        /// The limit, s.
        timeout_s: f64,
        /// The clock that reached it: robot time, or wall-clock time when
        /// the robot's clock runs slower.
        clock: &'static str,
        /// Cells heard.
        cells: usize,
        /// Cells that reported their neighbours and tree.
        with_tables: usize,
        /// ", N expected" when a count was given.
        expected: String,
        /// What points at another sender than the skin, if anything.
        suspect: String,
    },
    /// The cell settings could not be sent.
    #[error("writing the cell settings: {0}")]
    Settings(#[from] crate::interface::Error),
    /// The self-exploration failed.
    #[error(transparent)]
    Explore(#[from] ExploreError),
}

/// When the skin counts as organized.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrganizeConfig {
    /// Cells the skin has, when known; otherwise whatever reported counts.
    pub expected_cells: Option<usize>,
    /// Robot time the set of cells and their tables must stay unchanged, s.
    pub settle_s: f64,
    /// Longest time to wait, s, in robot time and in wall-clock time
    /// (whichever ends first: a robot clock that crawls cannot hang it).
    pub timeout_s: f64,
}

impl Default for OrganizeConfig {
    fn default() -> Self {
        OrganizeConfig { expected_cells: None, settle_s: 0.5, timeout_s: 30.0 }
    }
}

/// The organized skin, as the host learned it.
#[derive(Clone, Debug, Serialize)]
pub struct Organized {
    /// Robot time from the first command until the last change of the
    /// cells or their tables, s: how long self-organization took.
    pub time_s: f64,
    /// Robot time waited in all, including the quiet `settle_s` after it, s.
    pub waited_s: f64,
    /// Cells, by ID.
    pub cells: Vec<CellView>,
    /// Configuration writes sent to every cell.
    pub settings_written: usize,
    /// Acknowledgements of them received.
    pub settings_acknowledged: usize,
}

/// One cell as the registry holds it.
#[derive(Clone, Debug, Serialize)]
pub struct CellView {
    /// Its ID.
    pub id: u16,
    /// The interface port whose tree it is in.
    pub interface: u8,
    /// Its parent in that tree: a cell ID, or `None` when the parent is the interface port.
    pub parent: Option<u16>,
    /// Hops to the interface port along reported links.
    pub hops: Option<u16>,
    /// Who is on each of its four ports: `[id, port]` of a cell, or
    /// `[0xFF00 + k, 0]` for interface port k; `None` where free.
    pub neighbours: [Option<[u16; 2]>; 4],
}

/// Runs the robot's control period with zero velocities until the skin
/// has organized: every cell heard has reported a neighbour table with a
/// master port, none changed for `settle_s`, and the expected number of
/// cells (if given) is there. `progress` gets, every control period, the
/// cells with a table and the robot time spent, s.
pub fn organize(
    remote: &mut Remote,
    cfg: &OrganizeConfig,
    progress: &mut dyn FnMut(usize, f64),
) -> Result<Organized, PipelineError> {
    let zero = vec![0.0; remote.dof_count()];
    remote.command_velocities(&zero)?;
    let start_s = remote.link().time_s();
    let wall = Instant::now();
    let mut last_change_s = start_s;
    let mut seen = (0, 0);
    loop {
        remote.tick()?;
        let now_s = remote.link().time_s();
        let registry = remote.interface().registry();
        let with_tables = registry.cells().filter(|c| c.neighbours().is_some_and(|r| r.master.is_some())).count();
        let state = (registry.len(), registry.topology_version());
        if state != seen {
            seen = state;
            last_change_s = now_s;
        }
        progress(with_tables, now_s - start_s);
        let complete = with_tables == registry.len()
            && !registry.is_empty()
            && cfg.expected_cells.is_none_or(|n| registry.len() >= n);
        if complete && now_s - last_change_s >= cfg.settle_s {
            break;
        }
        let clock = if now_s - start_s > cfg.timeout_s {
            "robot time"
        } else if wall.elapsed().as_secs_f64() > cfg.timeout_s {
            "wall-clock time"
        } else {
            continue;
        };
        return Err(PipelineError::NotOrganized {
            timeout_s: cfg.timeout_s,
            clock,
            cells: registry.len(),
            with_tables,
            expected: cfg.expected_cells.map_or(String::new(), |n| format!(", {n} expected")),
            suspect: suspect(remote.interface().counters()),
        });
    }
    Ok(Organized {
        time_s: last_change_s - start_s,
        waited_s: remote.link().time_s() - start_s,
        cells: cell_views(remote),
        settings_written: 0,
        settings_acknowledged: 0,
    })
}

/// ", and ..." naming the signs of a sender other than the skin: datagrams
/// dropped as spoofed, a flood of ID requests; empty when there were none.
fn suspect(counters: &crate::interface::InterfaceCounters) -> String {
    let spoofed = counters.datagrams.rejected(crate::interface::DatagramReject::Spoofed);
    let flooded = counters.ids_flooded;
    if spoofed == 0 && flooded == 0 {
        return String::new();
    }
    format!(
        "; {spoofed} datagrams dropped as spoofed and {flooded} ID requests refused as a flood: another sender may be using the interface ports (pin each port's address in the configuration)"
    )
}

/// How long an interface port may fall silent once `settings` are written
/// ([`Remote::watch_silence`]): [`silence_bound_s`] of their sample rate
/// when every cell sends every sample; `None` for event-driven traffic,
/// where a resting skin is quiet.
pub fn silence_bound(settings: &[Setting]) -> Option<f64> {
    let mut rate_hz = skin_protocol::processing::DEFAULT_RATE_HZ;
    for s in settings {
        match *s {
            Setting::Traffic(TrafficMode::Event) => return None,
            Setting::SampleRateHz(r) => rate_hz = r,
            _ => {}
        }
    }
    Some(silence_bound_s(f64::from(rate_hz)))
}

/// Rounds of writing the settings a cell has not acknowledged yet.
const SETTING_ROUNDS: usize = 20;
/// Configuration writes sent down one interface port per round: every
/// downstream frame is copied to the whole tree, and a cell queues only
/// this many per child port, so a larger burst is partly dropped.
const WRITES_PER_PORT: usize = skin_protocol::router::DOWN_QUEUE;

/// Writes `settings` into every cell: to all cells at once, a queue's worth
/// per round, then again to each cell that did not acknowledge some of them
/// within `wait_s` of robot time (a busy network drops frames), a queue's
/// worth per interface port and round; the robot is held still meanwhile.
/// Returns how many (cell, setting) pairs were acknowledged.
pub fn write_settings(remote: &mut Remote, settings: &[Setting], wait_s: f64) -> Result<usize, PipelineError> {
    let cells: Vec<Address> = remote.interface().registry().cells().map(|c| c.id()).collect();
    // Per cell, which settings are still unacknowledged.
    let mut missing: std::collections::BTreeMap<Address, Vec<bool>> =
        cells.iter().map(|c| (*c, vec![true; settings.len()])).collect();
    for round in 0..SETTING_ROUNDS {
        // Tag -> setting index, for this round's writes.
        let mut sent: std::collections::HashMap<(Address, u8), usize> = std::collections::HashMap::new();
        let first = round * WRITES_PER_PORT;
        if first < settings.len() {
            let chunk = &settings[first..(first + WRITES_PER_PORT).min(settings.len())];
            let tags = remote.interface_mut().send_config(Address::BROADCAST, chunk)?;
            for c in &cells {
                sent.extend(tags.iter().enumerate().map(|(k, t)| ((*c, *t), first + k)));
            }
        } else {
            let mut budget: std::collections::HashMap<u8, usize> = std::collections::HashMap::new();
            for (c, left) in &missing {
                let port = remote.interface().registry().get(*c).map_or(0, |r| r.interface());
                let room = budget.entry(port).or_insert(WRITES_PER_PORT);
                let which: Vec<usize> = (0..settings.len()).filter(|k| left[*k]).take(*room).collect();
                *room -= which.len();
                if which.is_empty() {
                    continue;
                }
                let again: Vec<Setting> = which.iter().map(|&k| settings[k]).collect();
                let tags = remote.interface_mut().send_config(*c, &again)?;
                sent.extend(tags.iter().zip(&which).map(|(t, k)| ((*c, *t), *k)));
            }
        }
        if sent.is_empty() {
            break;
        }
        let start_s = remote.link().time_s();
        while remote.link().time_s() - start_s < wait_s {
            remote.tick()?;
            for e in remote.events() {
                let EventKind::ConfigAck(a) = e.kind else { continue };
                if let (Some(&k), Some(left)) = (sent.get(&(e.cell, a.tag)), missing.get_mut(&e.cell)) {
                    left[k] &= !a.accepted;
                }
            }
        }
    }
    let unacknowledged: usize = missing.values().map(|l| l.iter().filter(|m| **m).count()).sum();
    Ok(cells.len() * settings.len() - unacknowledged)
}

/// The registry's cells with their trees and neighbours.
fn cell_views(remote: &Remote) -> Vec<CellView> {
    let registry = remote.interface().registry();
    let hops: std::collections::HashMap<Address, u16> = registry.topology().hops.into_iter().collect();
    registry
        .cells()
        .map(|c| {
            let report = c.neighbours().copied().unwrap_or_default();
            let parent = report.master.and_then(|p| report.neighbours[p.index()]).map(|n| n.id);
            CellView {
                id: c.id().0,
                interface: c.interface(),
                parent: parent.filter(|a| a.is_cell()).map(|a| a.0),
                hops: hops.get(&c.id()).copied(),
                neighbours: report.neighbours.map(|n| n.map(|n| [n.id.0, n.port.index() as u16])),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::interface::InterfaceCounters;

    #[test]
    fn ports_are_watched_for_silence_only_when_every_sample_is_sent() {
        use crate::config::{CellSettings, Traffic};
        assert_eq!(silence_bound(&CellSettings::default().settings()), Some(0.05));
        assert_eq!(silence_bound(&[]), Some(0.05), "the cells' default rate");
        let slow = CellSettings { sample_rate_hz: 2.0, filter_cutoff_hz: 1.0, ..CellSettings::default() };
        assert_eq!(silence_bound(&slow.settings()), Some(5.0));
        let event = CellSettings { traffic: Traffic::Event, ..CellSettings::default() };
        assert_eq!(silence_bound(&event.settings()), None);
    }

    #[test]
    fn a_skin_that_did_not_organize_names_signs_of_another_sender() {
        assert_eq!(suspect(&InterfaceCounters::default()), "");
        let flooded = InterfaceCounters { ids_flooded: 3, ..InterfaceCounters::default() };
        let said = suspect(&flooded);
        assert!(
            said.contains("3 ID requests refused as a flood") && said.contains("pin each port's address"),
            "{said}"
        );
    }
}
