//! The endpoint's core without sockets: the robot link's answers, the
//! control period that moves world and skin network together, and the
//! person of an experiment. The endpoint (`mod.rs`) only moves bytes
//! between this core and its sockets.

use std::net::SocketAddr;
use std::sync::mpsc;
use std::time::{Duration, Instant};

use skin_protocol::interface::Datagram;
use skin_protocol::robot_link::{FromRobot, Refusal, ToRobot, MAX_NAME};
use skin_protocol::{Address, Sample};

use super::batch::{Batcher, Batching};
use super::{Pacing, Served, Truth};
use crate::network::{Network, NetworkError};
use crate::scene::operator::{Note, Operator, Order};
use crate::world::World;

/// A real-time robot stops when no command came for this long (a host
/// that died must not leave the arms moving).
const WATCHDOG: Duration = Duration::from_millis(200);

/// The simulated robot and skin, bytes in and out.
pub struct Rig {
    pub(super) world: World,
    pub(super) network: Network,
    /// `world_cell[n]`: the world's skin index of network cell `n`.
    pub(super) world_cell: Vec<usize>,
    pub(super) pacing: Pacing,
    /// The interface ports' frames on their way into datagrams.
    batcher: Batcher,
    command: Vec<f64>,
    /// When the last command came.
    commanded_at: Option<Instant>,
    /// Who sent the last command, its `seq` and the answer, for retries.
    last: Option<(SocketAddr, u32, FromRobot)>,
    samples: Vec<(Address, Sample)>,
    raw: Vec<Sample>,
    pub(super) served: Served,
    /// The person of an experiment.
    pub(super) operator: Option<Operator>,
    /// The experimenter's side channel, when served by [`super::Running`].
    pub(super) side: Option<Side>,
}

/// The endpoint's end of the experimenter's side channel.
pub(super) struct Side {
    pub(super) orders: mpsc::Receiver<Order>,
    pub(super) notes: mpsc::Sender<Note>,
}

impl Rig {
    /// `world` and the skin `network` of its cells (network cell `n` is
    /// the world's skin cell `world_cell[n]`), paced and batched as asked.
    pub(super) fn new(
        world: World,
        network: Network,
        world_cell: Vec<usize>,
        pacing: Pacing,
        batching: Batching,
    ) -> Rig {
        Rig {
            batcher: Batcher::new(network.interfaces(), batching),
            command: vec![0.0; world.robot().dofs().len()],
            raw: vec![Sample::default(); world_cell.len()],
            world,
            network,
            world_cell,
            pacing,
            commanded_at: None,
            last: None,
            samples: Vec::new(),
            served: Served::default(),
            operator: None,
            side: None,
        }
    }

    /// The ID each of the world's skin cells has in the network now
    /// ([`Address::UNASSIGNED`] before it got one), in the world's skin order.
    pub(super) fn assigned_ids(&self) -> Vec<Address> {
        let mut ids = vec![Address::UNASSIGNED; self.world_cell.len()];
        for (n, &w) in self.world_cell.iter().enumerate() {
            ids[w] = self.network.cell(n).map_or(Address::UNASSIGNED, |c| c.id());
        }
        ids
    }

    /// What only the simulator knows, now.
    pub fn truth(&self) -> Truth {
        let m = self.network.measurements();
        Truth {
            served: self.served,
            ids: self.assigned_ids(),
            neighbours: (0..self.network.cells())
                .filter_map(|n| Some((self.network.cell(n)?.id(), self.network.true_neighbours(n))))
                .filter(|(id, _)| id.is_cell())
                .collect(),
            latency_us: m.latency.counts().collect(),
            sensor_frames_lost: m.ledger.sensor_dropped,
        }
    }

    /// A datagram the host sent to the skin's interface port `k`; counted
    /// when it is not one for that port or the network refuses it.
    pub fn from_host(&mut self, k: usize, bytes: &[u8]) {
        let for_port = Datagram::parse(bytes).is_ok_and(|d| usize::from(d.header().interface) == k);
        if !for_port || self.network.inject(bytes).is_err() {
            self.served.datagrams_refused += 1;
        }
    }

    /// Counts a request on the robot link that was not one.
    pub fn rejected(&mut self) {
        self.served.rejected += 1;
    }

    /// Counts a request from a host other than the one served.
    pub fn other_host(&mut self, from: SocketAddr) {
        if self.served.other_hosts == 0 {
            tracing::warn!(%from, "a second host asks the robot; it is refused: the endpoint serves the first host only");
        }
        self.served.other_hosts += 1;
    }

    /// Answers a robot-link request from `from` at wall time `now`; a
    /// command in lockstep first runs a control period, whose datagrams for
    /// the host go to `up`.
    pub fn answer(
        &mut self,
        request: ToRobot,
        from: SocketAddr,
        now: Instant,
        up: &mut Vec<(usize, Vec<u8>)>,
    ) -> Result<FromRobot, NetworkError> {
        let dofs = self.world.robot().dofs();
        Ok(match request {
            ToRobot::Hello => FromRobot::Info {
                dofs: dofs.len() as u16,
                period_us: (self.world.config().tick_s * 1e6).round() as u32,
                lockstep: self.pacing == Pacing::Lockstep,
            },
            ToRobot::DofName { index } => match dofs.get(usize::from(index)) {
                Some(d) => {
                    let name = d.name.char_indices().take_while(|(i, c)| i + c.len_utf8() <= MAX_NAME);
                    FromRobot::DofName { index, name: name.map(|(_, c)| c).collect() }
                }
                None => FromRobot::Refused { seq: 0, reason: Refusal::NoSuchDof },
            },
            ToRobot::DofKind { index } => match dofs.get(usize::from(index)) {
                Some(d) => FromRobot::DofKind { index, kind: d.kind },
                None => FromRobot::Refused { seq: 0, reason: Refusal::NoSuchDof },
            },
            ToRobot::Command { seq, velocities } => {
                if let Some((asker, last, answer)) = &self.last {
                    if *asker == from && *last == seq {
                        return Ok(answer.clone());
                    }
                }
                if let Some(reason) = Refusal::of_command(&velocities, dofs.len()) {
                    self.served.refused += 1;
                    return Ok(FromRobot::Refused { seq, reason });
                }
                self.command.clear();
                self.command.extend_from_slice(&velocities);
                self.commanded_at = Some(now);
                if self.pacing == Pacing::Lockstep {
                    self.advance(now, up)?;
                }
                let answer = FromRobot::State {
                    seq,
                    time_us: (self.world.time_s() * 1e6).round() as u64,
                    positions: self.world.positions().iter().copied().collect(),
                };
                self.last = Some((from, seq, answer.clone()));
                answer
            }
        })
    }

    /// One control period: what the host sent down goes into the skin, the
    /// world moves under the held command, and the network runs to the
    /// period's end, every frame it delivers going up to the host.
    /// The host's datagrams for the skin are taken before (see
    /// [`Rig::from_host`]); the datagrams for the host, batched per
    /// interface port, go to `up` with the number of the port that sends them.
    pub fn advance(&mut self, now: Instant, up: &mut Vec<(usize, Vec<u8>)>) -> Result<(), NetworkError> {
        if self.pacing == Pacing::RealTime && self.commanded_at.is_none_or(|t| now.duration_since(t) > WATCHDOG) {
            self.command.iter_mut().for_each(|w| *w = 0.0);
        }
        // Checked when it arrived: the right length, finite.
        self.world.command(&self.command)?;
        self.take_orders();
        self.samples.clear();
        self.world.step(&mut self.samples);
        let stepped = Instant::now();
        self.served.world_time = self.world.step_time();
        self.served.engine_time = self.world.engine_time();
        if let (Some(op), Some(side)) = (&self.operator, &self.side) {
            if let Some(note) = op.watch(&self.world) {
                // The experimenter may have gone; the robot serves on.
                let _ = side.notes.send(note);
            }
        }
        for (n, &w) in self.world_cell.iter().enumerate() {
            self.raw[n] = self.samples[w].1;
        }
        self.network.feed(&self.raw)?;
        let until_ns = (self.world.time_s() * 1e9).round() as u64;
        let before = up.len();
        while let Some(d) = self.network.step(until_ns) {
            self.batcher.take(d.at_ns, &d.bytes, up)?;
            self.network.recycle(d);
        }
        // The next chance to send is the next period's end.
        let tick_ns = (self.world.config().tick_s * 1e9).round() as u64;
        self.batcher.due(until_ns + tick_ns, up);
        self.served.network_time += stepped.elapsed();
        self.served.datagrams_up += (up.len() - before) as u64;
        self.served.ticks += 1;
        Ok(())
    }

    /// Carries out the experimenter's orders, then lets the person act once.
    fn take_orders(&mut self) {
        let Some(side) = &self.side else { return };
        let orders: Vec<Order> = side.orders.try_iter().collect();
        let ids = if orders.is_empty() { Vec::new() } else { self.assigned_ids() };
        let mut notes = Vec::new();
        match &mut self.operator {
            Some(op) => {
                notes.extend(orders.into_iter().filter_map(|o| op.order(o, &self.world, &ids)));
                notes.extend(op.act(&self.world));
            }
            None => notes.extend(orders.iter().map(|o| Note::Refused(format!("{o:?}: nobody is at this robot")))),
        }
        for note in notes {
            let _ = side.notes.send(note);
        }
    }
}
