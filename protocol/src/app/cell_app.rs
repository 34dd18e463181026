//! The application on a cell's network stack: what the firmware's main
//! loop and the simulator's cells drive.

use super::{App, Losses, SettingsStore, Uplink};
use crate::address::Address;
use crate::cell::{Arrived, Cell, Received, SendError};
use crate::frame::Frame;
use crate::message::{ConfigWrite, Message, Port, Setting};
use crate::organize::Config;
use crate::processing::Processor;
use crate::router::{Discard, Meta, Stamp};
use crate::Sample;

/// One skin cell: network stack ([`Cell`]) and application ([`App`]),
/// with metadata `M` on its upstream frames (`()` in the firmware).
///
/// A configuration write comes out of [`CellApp::receive`] and goes back
/// in through [`CellApp::configure`], so the caller can bring the
/// processing up to date in between (the simulator's resting cells).
#[derive(Debug)]
pub struct CellApp<S, M = ()> {
    cell: Cell<M>,
    app: App<S>,
}

/// The cell's network stack as the application's uplink, telling the
/// caller what became of every message.
struct Net<'a, M, T, F> {
    cell: &'a mut Cell<M>,
    stamp: &'a mut T,
    sent: F,
}

impl<M: Meta, T: Stamp<M>, F: FnMut(&Message, Result<(), SendError>)> Uplink for Net<'_, M, T, F> {
    fn send(&mut self, message: &Message) -> Result<(), SendError> {
        let result = self.cell.send(message, self.stamp);
        (self.sent)(message, result);
        result
    }
}

impl<S: SettingsStore, M: Meta> CellApp<S, M> {
    /// Boots at `now_us` with what `store` keeps: ID, offsets, settings.
    pub fn new(config: Config, store: S, now_us: u64) -> CellApp<S, M> {
        let app = App::new(store);
        CellApp { cell: Cell::new(config, app.store(), now_us), app }
    }

    /// This cell's address.
    pub fn id(&self) -> Address {
        self.cell.id()
    }

    /// The network stack.
    pub fn cell(&self) -> &Cell<M> {
        &self.cell
    }

    /// The local processing.
    pub fn processor(&self) -> &Processor {
        self.app.processor()
    }

    /// The store.
    pub fn store(&self) -> &S {
        self.app.store()
    }

    /// The store, to boot the cell again from it.
    pub fn into_store(self) -> S {
        self.app.into_store()
    }

    /// What the application gave up so far.
    pub fn losses(&self) -> Losses {
        self.app.losses()
    }

    /// Takes the bytes of one frame received; see [`Cell::receive`].
    /// Returns a configuration write for [`CellApp::configure`].
    pub fn receive(&mut self, rx: Received<'_, M>, now_us: u64, stamp: &mut impl Stamp<M>) -> Option<ConfigWrite> {
        let delivered = self.cell.receive(rx, now_us, self.app.store_mut(), stamp);
        Self::write(delivered)
    }

    /// Takes a checked frame; see [`Cell::receive_frame`].
    pub fn receive_frame(&mut self, rx: Arrived<M>, now_us: u64, stamp: &mut impl Stamp<M>) -> Option<ConfigWrite> {
        let delivered = self.cell.receive_frame(rx, now_us, self.app.store_mut(), stamp);
        Self::write(delivered)
    }

    fn write(delivered: Option<(crate::frame::Header, Message)>) -> Option<ConfigWrite> {
        match delivered {
            Some((_, Message::ConfigWrite(write))) => Some(write),
            _ => None,
        }
    }

    /// Applies, keeps and acknowledges a configuration write (see
    /// [`App::configure`]); `sent` learns what became of the acknowledgement.
    pub fn configure(
        &mut self,
        write: &ConfigWrite,
        stamp: &mut impl Stamp<M>,
        sent: impl FnMut(&Message, Result<(), SendError>),
    ) -> Option<Setting> {
        self.app.configure(write, &mut Net { cell: &mut self.cell, stamp, sent })
    }

    /// Takes one raw sample (see [`App::sample`]); `sent` learns what
    /// became of every message it made.
    pub fn sample(
        &mut self,
        raw: &Sample,
        stamp: &mut impl Stamp<M>,
        sent: impl FnMut(&Message, Result<(), SendError>),
    ) {
        self.app.sample(raw, &mut Net { cell: &mut self.cell, stamp, sent });
    }

    /// The next time [`CellApp::poll`] has work.
    pub fn poll_at(&self) -> u64 {
        self.cell.poll_at()
    }

    /// Lets time pass for the network stack.
    pub fn poll(&mut self, now_us: u64, stamp: &mut impl Stamp<M>) {
        self.cell.poll(now_us, stamp);
    }

    /// True when `port` has frames to transmit.
    pub fn has_pending(&self, port: Port) -> bool {
        self.cell.has_pending(port)
    }

    /// The next frame for `port`, whose transmitter has room for it.
    pub fn transmit(&mut self, port: Port) -> Option<Frame> {
        self.cell.transmit(port)
    }

    /// [`CellApp::transmit`], with the metadata of an upstream frame.
    pub fn transmit_meta(&mut self, port: Port) -> Option<(Frame, Option<M>)> {
        self.cell.transmit_meta(port)
    }

    /// The next upstream frame given up, with its metadata.
    pub fn take_discarded(&mut self) -> Option<(M, Discard)> {
        self.cell.take_discarded()
    }
}
