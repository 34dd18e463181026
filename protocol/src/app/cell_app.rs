//! The application on a cell's network stack: what the firmware's main
//! loop and the simulator's cells drive.

use core::mem::MaybeUninit;
use core::ptr::{addr_of, addr_of_mut};

use super::{App, Losses, SettingsStore, Uplink};
use crate::address::Address;
use crate::cell::{Arrived, Cell, Received, SendError};
use crate::frame::Frame;
use crate::message::{ConfigWrite, ImageChunk, Message, Port, Setting, UpdateCommand, UpdateOffer};
use crate::organize::Config;
use crate::processing::Processor;
use crate::router::{Discard, Meta, Stamp};
use crate::update::{BootAction, Slot, Updater};
use crate::Sample;

/// A message for the application, out of [`CellApp::receive`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Delivered {
    /// A configuration write, for [`CellApp::configure`].
    Config(ConfigWrite),
    /// A firmware update message, for [`CellApp::update`].
    Update(UpdateInput),
}

/// The update messages a cell takes (see [`crate::update`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UpdateInput {
    /// An image offered.
    Offer(UpdateOffer),
    /// A chunk of it.
    Chunk(ImageChunk),
    /// Boot, confirm, roll back, report.
    Command(UpdateCommand),
}

/// One skin cell: network stack ([`Cell`]) and application ([`App`]),
/// with metadata `M` on its upstream frames (`()` in the firmware).
///
/// A configuration write comes out of [`CellApp::receive`] and goes back
/// in through [`CellApp::configure`], so the caller can bring the
/// processing up to date in between (the simulator's resting cells); an
/// update message goes back in through [`CellApp::update`] with the
/// caller's [`Updater`] and slot, which live as long as the board does.
///
/// The network stack comes first (`repr(C)`), so that what a frame reads
/// of it is at the start of the cell, in the same few cache lines.
#[derive(Debug)]
#[repr(C)]
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
    #[allow(unsafe_code)]
    pub fn new(config: Config, store: S, now_us: u64) -> CellApp<S, M> {
        let mut slot = MaybeUninit::uninit();
        CellApp::new_in(&mut slot, config, store, now_us);
        // SAFETY: `new_in` wrote every field.
        unsafe { slot.assume_init() }
    }

    /// [`CellApp::new`] written in place, into the firmware's static: the
    /// router's slots are kilobytes, and a cell built on the boot stack and
    /// then moved would need that much more stack than the main loop does.
    #[allow(unsafe_code)]
    pub fn new_in(slot: &mut MaybeUninit<CellApp<S, M>>, config: Config, store: S, now_us: u64) -> &mut CellApp<S, M> {
        let cell_app = slot.as_mut_ptr();
        // SAFETY: each field is written once through a pointer into `slot`,
        // `app` before the cell reads its store, and the whole is only
        // referred to once both are written.
        unsafe {
            addr_of_mut!((*cell_app).app).write(App::new(store));
            let store = (*addr_of!((*cell_app).app)).store();
            Cell::<M>::new_in(&mut *addr_of_mut!((*cell_app).cell).cast(), config, store, now_us);
            slot.assume_init_mut()
        }
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
    /// Returns a message for the application.
    pub fn receive(&mut self, rx: Received<'_, M>, now_us: u64, stamp: &mut impl Stamp<M>) -> Option<Delivered> {
        let delivered = self.cell.receive(rx, now_us, self.app.store_mut(), stamp);
        Self::for_app(delivered)
    }

    /// Takes a checked frame; see [`Cell::receive_frame`].
    pub fn receive_frame(&mut self, rx: Arrived<M>, now_us: u64, stamp: &mut impl Stamp<M>) -> Option<Delivered> {
        let delivered = self.cell.receive_frame(rx, now_us, self.app.store_mut(), stamp);
        Self::for_app(delivered)
    }

    fn for_app(delivered: Option<(crate::frame::Header, Message)>) -> Option<Delivered> {
        Some(match delivered?.1 {
            Message::ConfigWrite(write) => Delivered::Config(write),
            Message::UpdateOffer(o) => Delivered::Update(UpdateInput::Offer(o)),
            Message::ImageChunk(c) => Delivered::Update(UpdateInput::Chunk(c)),
            Message::UpdateCommand(c) => Delivered::Update(UpdateInput::Command(c)),
            _ => return None,
        })
    }

    /// Hands an update message to `updater` (writing chunks to `slot`) and
    /// sends its report upstream; returns what the board must do.
    pub fn update(
        &mut self,
        input: &UpdateInput,
        updater: &mut Updater,
        slot: &mut impl Slot,
        now_us: u64,
        stamp: &mut impl Stamp<M>,
        sent: impl FnMut(&Message, Result<(), SendError>),
    ) -> Option<BootAction> {
        let (report, action) = match input {
            UpdateInput::Offer(o) => (updater.offer(*o, slot, now_us), None),
            UpdateInput::Chunk(c) => (updater.chunk(c, slot, now_us), None),
            UpdateInput::Command(c) => updater.command(c, now_us),
        };
        if let Some(report) = report {
            self.app.report(&Message::UpdateReport(report), &mut Net { cell: &mut self.cell, stamp, sent });
        }
        action
    }

    /// Lets time pass for `updater`: its due report goes upstream.
    pub fn poll_update(
        &mut self,
        updater: &mut Updater,
        now_us: u64,
        stamp: &mut impl Stamp<M>,
        sent: impl FnMut(&Message, Result<(), SendError>),
    ) {
        if let Some(report) = updater.poll(now_us) {
            self.app.report(&Message::UpdateReport(report), &mut Net { cell: &mut self.cell, stamp, sent });
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::app::MemoryStore;

    /// A cell written in place boots from its store as one built by value:
    /// its ID and offsets, nothing queued, no master port.
    #[test]
    fn a_cell_written_in_place_boots_from_its_store() {
        let store = MemoryStore { id: Some(Address(7)), offsets: Some([3; 8]), ..MemoryStore::default() };
        let mut slot = MaybeUninit::uninit();
        let app: &mut CellApp<MemoryStore> = CellApp::new_in(&mut slot, Config::default(), store, 0);
        assert_eq!(app.id(), Address(7));
        assert_eq!(app.store(), &store);
        assert!(!app.processor().calibrating());
        assert_eq!(app.cell().router().queued(), 0);
        assert_eq!(app.cell().router().master(), None);
    }
}
