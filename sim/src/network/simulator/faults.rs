//! Fault injection: cut links, dead and rebooting cells, dead interface ports.

use super::super::fault::{FaultKind, REBOOT_DOWN_NS};
use super::super::ledger::DropReason;
use super::wires::End;
use super::{Event, Network, Power};
use crate::network::NetworkError;

impl Network {
    /// Schedules a fault at virtual time `at_ns`.
    pub fn schedule_fault(&mut self, at_ns: u64, fault: FaultKind) -> Result<(), NetworkError> {
        let ok = match fault {
            FaultKind::Cut(p) => self.peers.get(p.cell).is_some_and(|ps| ps[p.port.index()].is_some()),
            FaultKind::Dead(c) | FaultKind::Reboot(c) => c < self.pulses.len(),
            FaultKind::InterfaceDown(k) => usize::from(k) < self.interfaces.len(),
        };
        if !ok {
            return Err(NetworkError::Flag(format!(
                "fault {fault}: this skin has no such link, cell or interface port (cells 0..{}, interface ports 0..{})",
                self.pulses.len(),
                self.interfaces.len()
            )));
        }
        self.events.at(at_ns, Event::Fault(fault));
        Ok(())
    }

    pub(super) fn fault(&mut self, fault: FaultKind) {
        match fault {
            FaultKind::Cut(a) => {
                if let Some(b) = self.peers[a.cell][a.port.index()].take() {
                    match b {
                        End::Cell(j, q) => self.peers[j as usize][q.index()] = None,
                        End::Interface(k) => self.interfaces[usize::from(k)].at = None,
                    }
                }
            }
            FaultKind::Dead(c) => self.power_off(c, Power::Dead),
            FaultKind::Reboot(c) => {
                if self.pulses[c].power == Power::On {
                    self.power_off(c, Power::Off);
                    self.events.at(self.events.now_ns() + REBOOT_DOWN_NS, Event::PowerOn(c));
                }
            }
            FaultKind::InterfaceDown(k) => {
                let i = &mut self.interfaces[usize::from(k)];
                i.alive = false;
                let followed = i.up.iter().filter_map(|(_, f)| *f);
                let (n, sensors) = followed.fold((0, 0), |(n, s), f| (n + 1, s + u64::from(f.sensor)));
                i.up.clear();
                self.m.ledger.drop_upstream(DropReason::DeadInterface, n, sensors);
            }
        }
    }

    pub(super) fn power_off(&mut self, c: usize, power: Power) {
        // The samples it skipped so far were taken (their noise drawn).
        if let Some(r) = self.rests[c] {
            self.end_rest(c, r, self.taken_through(c, &r));
        }
        self.pulses[c].power = power;
        self.pulses[c].poll_ns = u64::MAX;
        self.pulses[c].sample_ns = u64::MAX;
        let Some(app) = self.stacks[c].power_off() else { return };
        let router = app.cell().router();
        self.m.ledger.lost_at_power_off += router.queued() as u64;
        let traces = router.upstream_metas();
        let (lost, sensors) = traces.fold((0, 0), |(n, s), t| (n + 1, s + u64::from(t.frame.sensor)));
        self.m.ledger.drop_upstream(DropReason::DeadCell, lost, sensors);
    }
}
