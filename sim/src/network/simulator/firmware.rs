//! A simulated cell's firmware update side: its spare slot and the state
//! its bootloader keeps (running, previous and trial versions), which
//! survive power cycles as flash does; the cell's [`Updater`] runs in the
//! real protocol code, driven by the network like the rest of the cell.

use skin_protocol::app::UpdateInput;
use skin_protocol::image::{Board, PUBLIC_KEY_LEN};
use skin_protocol::update::{BootAction, BootState, MemorySlot, Updater};

use super::super::fault::REBOOT_DOWN_NS;
use super::cells::book_sent;
use super::{Event, Network, Power};

/// Bytes of a simulated slot: a 64 KiB body, its header and the last chunk's padding.
const SLOT: usize = 66 * 1024;
/// The bootloader's trial limit ([`skin_protocol::update::TRIAL_US`]) in ns.
pub const TRIAL_NS: u64 = skin_protocol::update::TRIAL_US * 1_000;

/// What a simulated skin's cells run and trust.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct UpdateSetup {
    /// The public key built into every cell.
    pub key: [u8; PUBLIC_KEY_LEN],
    /// The version every cell runs at power-up.
    pub version: u32,
}

/// One cell's bootloader state, spare slot and updater.
#[derive(Debug)]
pub struct Firmware {
    key: [u8; PUBLIC_KEY_LEN],
    updater: Updater,
    slot: MemorySlot<SLOT>,
    previous: u32,
    trial_until_ns: Option<u64>,
}

impl Firmware {
    /// Factory state: `setup.version` confirmed, an empty slot.
    pub fn new(setup: UpdateSetup) -> Firmware {
        Firmware {
            key: setup.key,
            updater: Updater::new(Board::Mps2An386, setup.key, setup.version, BootState::Confirmed),
            slot: MemorySlot::default(),
            previous: setup.version,
            trial_until_ns: None,
        }
    }

    /// The version running.
    pub fn running(&self) -> u32 {
        self.updater.running()
    }

    /// What the bootloader does at the next boot: a new updater for the image it starts.
    fn boot(&mut self, action: BootAction, now_ns: u64) {
        let running = self.updater.running();
        let (version, state) = match action {
            BootAction::BootTrial => {
                // The updater only asks for this with a verified image ready.
                let new = self.updater.report().version;
                self.previous = running;
                self.trial_until_ns = Some(now_ns + TRIAL_NS);
                (new, BootState::Trial)
            }
            BootAction::Rollback => {
                self.trial_until_ns = None;
                (self.previous, BootState::RolledBack { from: running })
            }
            BootAction::Confirm => {
                self.trial_until_ns = None;
                return;
            }
        };
        self.updater = Updater::new(Board::Mps2An386, self.key, version, state);
    }
}

impl Network {
    /// The update side of cell `i`, when the skin runs updates.
    pub fn firmware(&self, i: usize) -> Option<&Firmware> {
        self.stacks.get(i)?.firmware.as_deref()
    }

    /// Cell `i` takes an update message; a boot or rollback restarts it.
    pub(super) fn update(&mut self, i: usize, input: &UpdateInput) {
        let now_ns = self.events.now_ns();
        let mut stamp = self.stamper();
        let cell = &mut self.stacks[i];
        let (Some(app), Some(fw)) = (cell.app.as_mut(), cell.firmware.as_deref_mut()) else { return };
        let (m, window, w) = (&mut self.m, &mut self.window, now_ns / self.period_ns);
        let action = app.update(input, &mut fw.updater, &mut fw.slot, now_ns / 1000, &mut stamp, |message, result| {
            book_sent(m, window, w, message, result, false)
        });
        self.book(i, stamp);
        match action {
            Some(BootAction::Confirm) => {
                if let Some(fw) = self.stacks[i].firmware.as_deref_mut() {
                    fw.boot(BootAction::Confirm, now_ns);
                }
            }
            Some(a) => self.restart(i, a),
            None => {}
        }
    }

    /// Cell `i`'s periodic update work, at its sampling pulse: a due report,
    /// and the bootloader's trial limit.
    pub(super) fn update_pulse(&mut self, i: usize) {
        let now_ns = self.events.now_ns();
        let expired = self.stacks[i].firmware.as_deref().and_then(|f| f.trial_until_ns).is_some_and(|t| now_ns >= t);
        if expired {
            return self.restart(i, BootAction::Rollback);
        }
        let mut stamp = self.stamper();
        let cell = &mut self.stacks[i];
        let (Some(app), Some(fw)) = (cell.app.as_mut(), cell.firmware.as_deref_mut()) else { return };
        let (m, window, w) = (&mut self.m, &mut self.window, now_ns / self.period_ns);
        app.poll_update(&mut fw.updater, now_ns / 1000, &mut stamp, |message, result| {
            book_sent(m, window, w, message, result, false)
        });
        self.book(i, stamp);
        self.settle(i, self.master_port(i));
    }

    /// Restarts cell `i` into the image `action` names, as its bootloader would.
    fn restart(&mut self, i: usize, action: BootAction) {
        let now_ns = self.events.now_ns();
        if let Some(fw) = self.stacks[i].firmware.as_deref_mut() {
            fw.boot(action, now_ns);
        }
        if self.pulses[i].power == Power::On {
            self.power_off(i, Power::Off);
            self.events.at(now_ns + REBOOT_DOWN_NS, Event::PowerOn(i));
        }
    }
}
