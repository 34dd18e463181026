//! Firmware updates of a QEMU patch: the host's [`Distributor`] (or a
//! deliberately broken sender) feeds an image down the interface port while
//! the cells run `cell-qemu` under `boot-qemu`, each with its flash file;
//! the tests read the cells' boot records and slots back from those files.

use std::collections::{BTreeMap, VecDeque};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use skin_firmware::boot::BootRecord;
use skin_protocol::frame::Frame;
use skin_protocol::message::{
    ImageChunk, Message, Setting, TrafficMode, UpdateAction, UpdateCommand, UpdateOffer, UpdateReport, UpdateState,
    CHUNK_LEN,
};
use skin_protocol::update::{Distributor, Outcome};
use skin_protocol::Address;

use super::flash::{self, Programs};
use super::hex::{End, Wiring};
use super::net::{baseline, organized, run_dir, World};
use super::QemuError;

/// What sends an image to the cells and hears their reports.
pub trait Feed {
    /// The next frame to send at `now_us`: destination and message.
    fn next(&mut self, now_us: u64) -> Option<(Address, Message)>;
    /// A cell's report.
    fn handle(&mut self, from: Address, report: UpdateReport);
    /// Each cell's outcome so far.
    fn outcomes(&self) -> Vec<(Address, Outcome)>;
}

/// A patch hangs on one interface port (number 0): every frame goes down it.
impl Feed for Distributor {
    fn next(&mut self, now_us: u64) -> Option<(Address, Message)> {
        Distributor::next(self, now_us).map(|o| (o.to, o.message))
    }

    fn handle(&mut self, from: Address, report: UpdateReport) {
        Distributor::handle(self, from, 0, report)
    }

    fn outcomes(&self) -> Vec<(Address, Outcome)> {
        Distributor::outcomes(self).collect()
    }
}

/// A distributor that never confirms: it asks cells on trial where they
/// are instead, so its image must roll back (and the cells say so).
#[derive(Debug)]
pub struct Unconfirmed(pub Distributor);

impl Feed for Unconfirmed {
    fn next(&mut self, now_us: u64) -> Option<(Address, Message)> {
        match Feed::next(&mut self.0, now_us)? {
            (dst, Message::UpdateCommand(UpdateCommand { version, action: UpdateAction::Confirm })) => {
                Some((dst, Message::UpdateCommand(UpdateCommand { version, action: UpdateAction::Status })))
            }
            other => Some(other),
        }
    }

    fn handle(&mut self, from: Address, report: UpdateReport) {
        Feed::handle(&mut self.0, from, report)
    }

    fn outcomes(&self) -> Vec<(Address, Outcome)> {
        self.0.outcomes().collect()
    }
}

/// The first bytes of an image offered as if they were all of it (a
/// transfer cut short): the offer, again every 0.5 s, each chunk once,
/// and to each cell the chunks it reports missing. The [`Distributor`]
/// refuses to send such an image.
#[derive(Debug)]
pub struct Truncated {
    offer: UpdateOffer,
    chunks: Vec<ImageChunk>,
    next: usize,
    last_offer_us: Option<u64>,
    repairs: VecDeque<(Address, u16)>,
    cells: BTreeMap<Address, Option<UpdateReport>>,
}

impl Truncated {
    /// `image` cut to `len` bytes, for `cells`.
    pub fn new(image: &[u8], len: usize, version: u32, cells: &[Address]) -> Truncated {
        let chunks: Vec<ImageChunk> = skin_protocol::update::chunks(&image[..len.min(image.len())]).collect();
        let offer = UpdateOffer { version, chunks: chunks.len() as u16 };
        let cells = cells.iter().map(|c| (*c, None)).collect();
        Truncated { offer, chunks, next: 0, last_offer_us: None, repairs: VecDeque::new(), cells }
    }
}

impl Feed for Truncated {
    fn next(&mut self, now_us: u64) -> Option<(Address, Message)> {
        if self.last_offer_us.is_none_or(|t| now_us.saturating_sub(t) >= 500_000) {
            self.last_offer_us = Some(now_us);
            return Some((Address::BROADCAST, Message::UpdateOffer(self.offer)));
        }
        if let Some((cell, i)) = self.repairs.pop_front() {
            return Some((cell, Message::ImageChunk(self.chunks[usize::from(i)])));
        }
        let chunk = self.chunks.get(self.next)?;
        self.next += 1;
        Some((Address::BROADCAST, Message::ImageChunk(*chunk)))
    }

    fn handle(&mut self, from: Address, report: UpdateReport) {
        self.cells.insert(from, Some(report));
        if report.state == UpdateState::Receiving && report.version == self.offer.version {
            let end = report.first_missing.saturating_add(report.missing).min(self.next as u16);
            for i in report.first_missing..end {
                if !self.repairs.contains(&(from, i)) {
                    self.repairs.push_back((from, i));
                }
            }
        }
    }

    fn outcomes(&self) -> Vec<(Address, Outcome)> {
        let outcome = |r: &Option<UpdateReport>| match r {
            None => Outcome::NotHeard,
            Some(r) => match r.state {
                UpdateState::Refused(why) if r.version == self.offer.version => Outcome::Refused(why),
                state => Outcome::Unfinished(state),
            },
        };
        self.cells.iter().map(|(a, r)| (*a, outcome(r))).collect()
    }
}

/// A running, organized QEMU patch whose cells take updates.
pub struct Patch {
    world: World,
    wiring: Wiring,
    interface: End,
    dir: PathBuf,
    /// The ID of each cell, in patch order.
    pub ids: Vec<Address>,
    /// Wall time from the start of QEMU to a patch organized.
    pub organize_s: f64,
}

/// Frames the host sends per second at most. A QEMU UART holds one byte
/// and interrupts for each, so a QEMU patch takes a few dozen to a few
/// hundred frames a second, as its size and the machine's load allow; the
/// [`Distributor`] keeps to that pace itself (its rounds wait for the
/// cells' answers), this only spreads a round over a few tens of
/// milliseconds.
pub const FRAMES_PER_S: u64 = 500;

impl Patch {
    /// Starts `n` cells of the `cell-qemu` program `elf` (version 1 in slot
    /// A of every flash file) and waits until they are organized.
    pub fn start(n: usize, elf: &Path) -> Result<Patch, QemuError> {
        if !(2..=40).contains(&n) {
            return Err(QemuError::BadSize(n));
        }
        let dir = run_dir()?;
        let wiring = Wiring::patch(n);
        let interface = *wiring.free_ports().first().ok_or(QemuError::BadSize(n))?;
        let mut world = World::new(elf, &wiring, interface, &dir)?;
        for i in 0..n {
            world.cells.start(i)?;
        }
        let everyone: Vec<usize> = (0..n).collect();
        let limit = Duration::from_secs(20 + n as u64);
        let (ids, organize_s) =
            world.wait("self-organization", limit, |w| organized(w, &wiring, interface, &everyone, None))?;
        // Still sensors and event traffic: the cells sample (a cell without
        // stimulus logs every skipped sample) but send nothing, so the
        // update has the links to itself.
        world.configure(&ids, &[(1, Setting::Traffic(TrafficMode::Event))])?;
        for i in 0..n {
            world.set_stimulus(i, baseline());
        }
        let ids = ids.into_iter().map(|a| a.unwrap_or(Address::UNASSIGNED)).collect();
        Ok(Patch { world, wiring, interface, dir, ids, organize_s })
    }

    /// The programs the cells run.
    pub fn programs(&self) -> &Programs {
        &self.world.programs
    }

    /// Cells in the patch.
    pub fn len(&self) -> usize {
        self.ids.len()
    }

    /// True for a patch of no cells (never: [`Patch::start`] refuses it).
    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }

    /// The run directory (flash files, logs), kept after a failure.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Feeds `feed` [`FRAMES_PER_S`] frames a second until every cell's
    /// outcome is final or `limit` passes; `during` runs every millisecond
    /// (to kill and restart cells). Returns the wall time.
    pub fn update(
        &mut self,
        feed: &mut dyn Feed,
        limit: Duration,
        during: &mut dyn FnMut(&mut Patch) -> Result<(), QemuError>,
    ) -> Result<f64, QemuError> {
        let start = Instant::now();
        let mut seen = self.world.host.updates.len();
        let mut sent = 0u64;
        loop {
            self.world.pump(Duration::from_millis(1))?;
            for a in &self.world.host.updates[seen..] {
                feed.handle(a.src, a.value);
            }
            seen = self.world.host.updates.len();
            let now_us = start.elapsed().as_micros() as u64;
            let due = (now_us * FRAMES_PER_S / 1_000_000).saturating_sub(sent);
            let frames: Vec<Frame> = std::iter::from_fn(|| feed.next(now_us))
                .take(due as usize)
                .map(|(dst, m)| Frame::new(Address::HOST, dst, &m))
                .collect();
            self.world.host.send_all(&frames)?;
            // Time without frames to send is not saved up for a burst.
            sent = if frames.len() < due as usize { now_us * FRAMES_PER_S / 1_000_000 } else { sent + due };
            let outcomes = feed.outcomes();
            if outcomes.iter().all(|(_, o)| o.is_final()) {
                return Ok(start.elapsed().as_secs_f64());
            }
            if start.elapsed() > limit {
                let detail = format!("outcomes {outcomes:?}");
                return Err(QemuError::Timeout { stage: "update", seconds: limit.as_secs_f64(), detail });
            }
            during(self)?;
        }
    }

    /// Serves the patch for `wait` (cells run, reports are taken).
    pub fn idle(&mut self, wait: Duration) -> Result<(), QemuError> {
        let end = Instant::now() + wait;
        while Instant::now() < end {
            self.world.pump(Duration::from_millis(20))?;
        }
        Ok(())
    }

    /// Waits until every cell is organized again with its old ID.
    pub fn reorganized(&mut self, limit: Duration) -> Result<f64, QemuError> {
        let everyone: Vec<usize> = (0..self.len()).collect();
        let expect: Vec<Option<Address>> = self.ids.iter().map(|a| Some(*a)).collect();
        let (wiring, interface) = (self.wiring.clone(), self.interface);
        self.world.host.reports.clear();
        let ((), s) = self
            .world
            .wait("re-organization", limit, |w| organized(w, &wiring, interface, &everyone, Some(&expect)).map(drop))?;
        Ok(s)
    }

    /// True when cell `i` sent an update report after `since`.
    pub fn heard_from(&self, i: usize, since: Instant) -> bool {
        self.world.host.updates.iter().any(|a| a.src == self.ids[i] && a.at > since)
    }

    /// Kills cell `i` (a power cut).
    pub fn kill(&mut self, i: usize) {
        self.world.cells.kill(i);
    }

    /// Starts cell `i` again with its flash file.
    pub fn restart(&mut self, i: usize) -> Result<(), QemuError> {
        self.world.cells.start(i)
    }

    /// Cell `i`'s boot record, read from its flash file.
    pub fn record(&self, i: usize) -> Result<BootRecord, QemuError> {
        flash::record(&self.world.flashes[i])
    }

    /// Slot `slot` (0: A, 1: B) of cell `i`, from its flash file.
    pub fn slot(&self, i: usize, slot: usize) -> Result<Vec<u8>, QemuError> {
        flash::slot(&self.world.flashes[i], slot)
    }

    /// Stops the cells and removes the run directory.
    pub fn finish(self) {
        let dir = self.dir.clone();
        drop(self.world);
        let _ = std::fs::remove_dir_all(dir);
    }
}

/// True when `slot` holds part of `image` but not all: its first chunk
/// and the byte at `at` are written, the image's last chunk is not.
pub fn partly_written(slot: &[u8], image: &[u8], at: usize) -> bool {
    let at = at.min(image.len().saturating_sub(1));
    let last = image.len().saturating_sub(1) / CHUNK_LEN * CHUNK_LEN;
    slot.get(..CHUNK_LEN) == image.get(..CHUNK_LEN)
        && slot.get(at) == image.get(at)
        && slot.get(last..image.len()).is_some_and(|tail| tail.iter().all(|b| *b == 0xFF))
        && image.get(last..).is_some_and(|tail| tail.iter().any(|b| *b != 0xFF))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_slot_is_partly_written_between_its_first_and_last_chunk() {
        let image: Vec<u8> = (0..95u8).collect();
        let mut slot = vec![0xFF; 200];
        assert!(!partly_written(&slot, &image, 40));
        slot[..50].copy_from_slice(&image[..50]);
        assert!(partly_written(&slot, &image, 40));
        assert!(!partly_written(&slot, &image, 60), "byte 60 not yet written");
        slot[..95].copy_from_slice(&image);
        assert!(!partly_written(&slot, &image, 40), "whole");
    }

    #[test]
    fn a_truncated_image_is_offered_with_its_own_length_and_refusals_are_final() {
        let image = vec![7u8; 1000];
        let mut t = Truncated::new(&image, 555, 3, &[Address(1)]);
        assert_eq!(t.next(0), Some((Address::BROADCAST, Message::UpdateOffer(UpdateOffer { version: 3, chunks: 56 }))));
        assert_eq!(std::iter::from_fn(|| t.next(1)).count(), 56);
        assert_eq!(t.outcomes(), vec![(Address(1), Outcome::NotHeard)]);
        let refused = skin_protocol::message::Refusal::BadHeader;
        t.handle(
            Address(1),
            UpdateReport { version: 3, state: UpdateState::Refused(refused), first_missing: 0, missing: 0 },
        );
        assert_eq!(t.outcomes(), vec![(Address(1), Outcome::Refused(refused))]);
    }
}
