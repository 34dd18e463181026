//! A skin cell's application, the one piece firmware, simulator and load
//! generator all run: it applies the settings the host writes, keeps them
//! and acknowledges them, replays the kept ones at boot, calibrates the
//! offsets when it has none, and turns raw samples into messages, telling
//! the processing when the network refused a sample.
//!
//! - [`App`]: the application on any [`Uplink`] (the load generator sends
//!   straight to its interface port).
//! - [`CellApp`]: the application on a cell's network stack, bytes and
//!   time in, frames out: the firmware's and the simulator's cell.
//! - [`store`]: what the application keeps across power cycles.

mod cell_app;
pub mod store;

pub use cell_app::{CellApp, Delivered, UpdateInput};
pub use store::{MemoryStore, SettingsStore, StoreFailed};

use crate::cell::SendError;
use crate::message::{ConfigAck, ConfigWrite, Message, Setting};
use crate::processing::Processor;
use crate::Sample;

/// Where the application's messages go.
pub trait Uplink {
    /// Sends one message toward the host.
    fn send(&mut self, message: &Message) -> Result<(), SendError>;
}

/// Counts of what the application had to give up, for the logs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Losses {
    /// Own messages the network refused (no ID yet, or queue full).
    pub unsent: u32,
    /// Writes to the store that failed.
    pub store_failed: u32,
}

/// A cell's processing and its kept settings.
#[derive(Debug)]
pub struct App<S> {
    processor: Processor,
    store: S,
    losses: Losses,
}

impl<S: SettingsStore> App<S> {
    /// Boots with what `store` keeps: the settings are applied again, and
    /// without offsets the first samples calibrate them
    /// (see [`Processor::calibrate`]).
    pub fn new(store: S) -> App<S> {
        let mut processor = Processor::new();
        for setting in store.settings() {
            processor.apply(&setting);
        }
        match store.offsets() {
            Some(offsets) => processor.set_offsets(offsets),
            None => processor.calibrate(),
        }
        App { processor, store, losses: Losses::default() }
    }

    /// The local processing.
    pub fn processor(&self) -> &Processor {
        &self.processor
    }

    /// The store.
    pub fn store(&self) -> &S {
        &self.store
    }

    /// The store, for the network stack's ID.
    pub fn store_mut(&mut self) -> &mut S {
        &mut self.store
    }

    /// The store, to keep across a reboot.
    pub fn into_store(self) -> S {
        self.store
    }

    /// What was given up so far.
    pub fn losses(&self) -> Losses {
        self.losses
    }

    /// Applies a setting the host wrote, keeps it when accepted and
    /// acknowledges it on `net`. Returns the setting when accepted, for the
    /// board to apply to its hardware.
    pub fn configure(&mut self, write: &ConfigWrite, net: &mut impl Uplink) -> Option<Setting> {
        let accepted = self.processor.apply(&write.setting);
        if accepted && self.store.keep_setting(write.setting).is_err() {
            self.losses.store_failed += 1;
        }
        self.send(&Message::ConfigAck(ConfigAck { tag: write.tag, accepted }), net);
        accepted.then_some(write.setting)
    }

    /// Takes one raw sample: filters it and sends what the processing
    /// decides, or adds it to a running calibration and keeps the offsets.
    pub fn sample(&mut self, raw: &Sample, net: &mut impl Uplink) {
        for message in self.processor.process(raw) {
            if !self.send(&message, net) && matches!(message, Message::Sample(_)) {
                // Not the host's reference then: send the next sample.
                self.processor.refused();
            }
        }
        if let Some(offsets) = self.processor.take_calibrated() {
            if self.store.keep_offsets(offsets).is_err() {
                self.losses.store_failed += 1;
            }
            #[cfg(feature = "defmt")]
            defmt::info!("calibrated offsets {}", offsets);
        }
    }

    /// Sends one of the cell's reports (an update report); a refused one
    /// is counted, and the report is made again when next due.
    pub fn report(&mut self, message: &Message, net: &mut impl Uplink) {
        self.send(message, net);
    }

    /// Sends one message; false (and counted) when the network refused it.
    fn send(&mut self, message: &Message, net: &mut impl Uplink) -> bool {
        let sent = net.send(message).is_ok();
        if !sent {
            self.losses.unsent += 1;
        }
        sent
    }
}
