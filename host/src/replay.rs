//! A recorded run played back as a robot and its skin: the recorded
//! interface datagrams go through the same checks ([`Ingest`]) as live
//! ones, and the recorded robot states answer the commands. The host's
//! code is deterministic, so given the same samples it sends the same
//! commands; a command that differs from the recorded one means the
//! replay no longer matches the run and stops it with an error instead
//! of answering with states that belong to another motion.

use std::collections::VecDeque;

use skin_protocol::{Address, Sample};

use crate::config::InterfaceConfig;
use crate::interface::{Event, EventKind, Ingest};
use crate::recording::{ExploreStart, Record, RecordError, Recording, EXPLORE_START};
use crate::robot::{DofKind, Robot, RobotError, SampleSource};

/// A recording from the start of its exploration, as a robot and skin.
#[derive(Debug)]
pub struct Replay {
    start: ExploreStart,
    records: VecDeque<Record>,
    ingest: Ingest,
    commanded: Vec<f64>,
    positions: Vec<f64>,
    /// The robot's clock at the last recorded state, microseconds.
    time_us: u64,
    events: Vec<Event>,
    ticks: u64,
}

impl Replay {
    /// Takes every datagram recorded before the exploration (the cells'
    /// registry and the ports' sequence numbers are then as they were
    /// live) and stands at the exploration's start.
    pub fn explore(recording: Recording) -> Result<Replay, RecordError> {
        let mut records: VecDeque<Record> = recording.records.into();
        let start = records
            .iter()
            .find_map(|r| if let Record::ExploreStart(s) = r { Some(s.clone()) } else { None })
            .ok_or_else(|| RecordError::NoExploration { path: recording.path.clone() })?;
        let ports = InterfaceConfig { ports: start.ports.clone(), ..InterfaceConfig::default() };
        let why = match ports.validate() {
            Err(e) => Some(e.to_string()),
            Ok(()) if !(start.period_s.is_finite() && start.period_s > 0.0) => {
                Some(format!("a control period of {} s", start.period_s))
            }
            Ok(()) => None,
        };
        if let Some(why) = why {
            let (path, topic) = (recording.path.clone(), EXPLORE_START.to_owned());
            return Err(RecordError::BadMessage { path, topic, sequence: 0, why });
        }
        let mut replay = Replay {
            ingest: Ingest::new(&start.ports),
            commanded: vec![0.0; start.dof_names.len()],
            positions: vec![0.0; start.dof_names.len()],
            time_us: 0,
            start,
            records: VecDeque::new(),
            events: Vec::new(),
            ticks: 0,
        };
        while let Some(record) = records.pop_front() {
            match record {
                Record::ExploreStart(_) => break,
                Record::State { positions, time_us } => {
                    replay.positions = positions;
                    replay.time_us = time_us;
                }
                Record::Datagram { from, now_us, bytes } => {
                    replay.ingest.datagram(from, &bytes, now_us, &mut replay.events);
                    replay.events.clear();
                    replay.ingest.take_replies();
                }
                _ => {}
            }
        }
        replay.records = records;
        Ok(replay)
    }

    /// What the exploration started with.
    pub fn start(&self) -> &ExploreStart {
        &self.start
    }

    /// The checks of the replayed datagrams.
    pub fn ingest(&self) -> &Ingest {
        &self.ingest
    }

    fn diverged(&self, why: String) -> RobotError {
        RobotError::Disconnected(format!("replay of tick {}: {why}", self.ticks))
    }
}

impl Robot for Replay {
    fn dof_names(&self) -> Vec<String> {
        self.start.dof_names.clone()
    }

    fn dof_kinds(&self) -> Vec<DofKind> {
        self.start.dof_kinds.clone()
    }

    fn command_velocities(&mut self, omega_rad_s: &[f64]) -> Result<(), RobotError> {
        if omega_rad_s.len() != self.commanded.len() {
            return Err(RobotError::WrongLength { expected: self.commanded.len(), got: omega_rad_s.len() });
        }
        self.commanded.copy_from_slice(omega_rad_s);
        Ok(())
    }

    fn positions(&self) -> Vec<f64> {
        self.positions.clone()
    }
}

impl SampleSource for Replay {
    fn tick_s(&self) -> f64 {
        self.start.period_s
    }

    /// The next recorded tick: its command must be the one given, its
    /// state gives the positions, its datagrams the samples.
    fn next_tick(&mut self, out: &mut Vec<(Address, Sample)>) -> Result<(), RobotError> {
        self.ticks += 1;
        match self.records.pop_front() {
            Some(Record::Command(velocities)) if velocities == self.commanded => {}
            Some(Record::Command(velocities)) => {
                return Err(self.diverged(format!(
                    "the host commands {:?}, the recorded run commanded {velocities:?}",
                    self.commanded
                )))
            }
            Some(other) => return Err(self.diverged(format!("a command was recorded here, not {other:?}"))),
            None => return Err(self.diverged("the recording ends".to_owned())),
        }
        match self.records.pop_front() {
            Some(Record::State { positions, time_us }) if positions.len() == self.positions.len() => {
                self.positions = positions;
                self.time_us = time_us;
            }
            other => return Err(self.diverged(format!("the command's answer was recorded as {other:?}"))),
        }
        while let Some(Record::Datagram { .. }) = self.records.front() {
            if let Some(Record::Datagram { from, now_us, bytes }) = self.records.pop_front() {
                self.ingest.datagram(from, &bytes, now_us, &mut self.events);
            }
        }
        self.ingest.take_replies();
        out.extend(self.events.drain(..).filter_map(|e| match e.kind {
            EventKind::Sample(s) => Some((e.cell, s)),
            _ => None,
        }));
        Ok(())
    }

    /// The recorded clock, so a replay leaves out the ticks the run did.
    fn robot_time_s(&self) -> Option<f64> {
        Some(self.time_us as f64 / 1e6)
    }
}

#[cfg(test)]
mod tests {
    use std::path::PathBuf;

    use super::*;

    fn recording(records: Vec<Record>) -> Recording {
        Recording { path: PathBuf::from("t.mcap"), records }
    }

    fn tick(velocity: f64, position: f64) -> [Record; 2] {
        [Record::Command(vec![velocity]), Record::State { positions: vec![position], time_us: 0 }]
    }

    fn replay() -> Replay {
        let mut records = tick(0.0, 0.5).to_vec();
        records.push(Record::ExploreStart(ExploreStart::one_dof()));
        records.extend(tick(0.1, 0.6));
        records.extend(tick(0.2, 0.7));
        Replay::explore(recording(records)).unwrap()
    }

    #[test]
    fn a_recorded_start_that_cannot_be_is_refused() {
        for bad in [
            ExploreStart { ports: Vec::new(), ..ExploreStart::one_dof() },
            ExploreStart { period_s: f64::NAN, ..ExploreStart::one_dof() },
        ] {
            let e = Replay::explore(recording(vec![Record::ExploreStart(bad)])).unwrap_err();
            assert!(matches!(e, RecordError::BadMessage { .. }), "{e}");
        }
    }

    #[test]
    fn the_recorded_states_answer_the_recorded_commands() {
        let mut r = replay();
        assert_eq!(r.positions(), vec![0.5], "the last state before the exploration");
        r.command_velocities(&[0.1]).unwrap();
        r.next_tick(&mut Vec::new()).unwrap();
        assert_eq!(r.positions(), vec![0.6]);
    }

    #[test]
    fn another_command_than_recorded_stops_the_replay() {
        let mut r = replay();
        r.command_velocities(&[0.1]).unwrap();
        r.next_tick(&mut Vec::new()).unwrap();
        r.command_velocities(&[0.3]).unwrap();
        let e = r.next_tick(&mut Vec::new()).unwrap_err().to_string();
        assert!(e.contains("replay of tick 2: the host commands [0.3], the recorded run commanded [0.2]"), "{e}");
    }

    #[test]
    fn a_replay_past_the_recording_says_it_ended() {
        let mut r = replay();
        for v in [0.1, 0.2] {
            r.command_velocities(&[v]).unwrap();
            r.next_tick(&mut Vec::new()).unwrap();
        }
        let e = r.next_tick(&mut Vec::new()).unwrap_err().to_string();
        assert!(e.contains("replay of tick 3: the recording ends"), "{e}");
    }

    #[test]
    fn a_recording_without_exploration_says_so() {
        let e = Replay::explore(recording(tick(0.0, 0.0).to_vec())).unwrap_err();
        assert!(matches!(e, RecordError::NoExploration { .. }), "{e}");
    }
}
