//! The host's side of an update, as a pure state machine: it offers the
//! image, broadcasts every chunk once, resends the runs cells report
//! missing (selective repeat: only what a cell asked for, each chunk once
//! however many cells asked for it), tells the ready cells to boot the
//! image on trial once none is still receiving and confirms each one heard
//! running it, and keeps every cell's outcome for the result table. Chunks
//! go in [`Rounds`], each once the cells answered the last, so the update
//! goes at the pace of the slowest tree. Time in, frames out: the caller
//! sends what [`Distributor::next`] gives as fast as its links take it.
//!
//! A resent chunk goes as a broadcast down only the interface ports whose
//! trees hold a cell that asked for it, once per port: a cell's router
//! copies whatever comes down its master port to all its children (it does
//! not know where an address lives), so a chunk sent to one cell crosses
//! its whole tree anyway, and broadcast there it serves every cell of that
//! tree that missed it at once, while the other trees are spared.

use std::collections::{BTreeMap, BTreeSet, VecDeque};

use super::rounds::{Rounds, Via};
use super::REPAIR_WINDOW;
use crate::address::Address;
use crate::image::{ImageError, ImageHeader};
use crate::message::{
    ImageChunk, Message, Refusal, UpdateAction, UpdateCommand, UpdateOffer, UpdateReport, UpdateState, CHUNK_LEN,
};

/// How often the offer, and the boot command to ready cells, are repeated:
/// a cell that was off, or lost a command, catches up within this.
pub const REPEAT_US: u64 = 500_000;

/// What became of the update on one cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Outcome {
    /// Runs the new version, confirmed.
    Updated,
    /// Went back to its old image: the trial was not confirmed in time.
    RolledBack,
    /// Refused the image; nothing changed.
    Refused(Refusal),
    /// Never answered.
    NotHeard,
    /// Answered, but had not finished when the update stopped.
    Unfinished(UpdateState),
}

impl Outcome {
    /// True when the cell ended on the requested version.
    pub fn is_updated(self) -> bool {
        self == Outcome::Updated
    }

    /// True when nothing more will happen for this cell.
    pub fn is_final(self) -> bool {
        matches!(self, Outcome::Updated | Outcome::RolledBack | Outcome::Refused(_))
    }
}

/// One frame of the update to send: down `via`, to `to`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Outgoing {
    /// The interface ports it goes down.
    pub via: Via,
    /// Its destination (a cell, or [`Address::BROADCAST`]).
    pub to: Address,
    /// The message.
    pub message: Message,
}

/// The host's update of every cell it knows to one image.
#[derive(Clone, Debug)]
pub struct Distributor {
    version: u32,
    chunks: Vec<ImageChunk>,
    cells: BTreeMap<Address, Option<UpdateReport>>,
    next_chunk: usize,
    /// Chunks some cell asked for again, with the interface port its report
    /// came up, sent lowest first, each once per port.
    repairs: BTreeSet<(u16, u8)>,
    rounds: Rounds,
    confirms: VecDeque<Address>,
    last_offer_us: Option<u64>,
    last_boot_us: Option<u64>,
    last_confirm_us: Option<u64>,
}

impl Distributor {
    /// An update of `cells` to `image` (checked for form, not signature:
    /// the cells check that).
    pub fn new(image: &[u8], cells: impl IntoIterator<Item = Address>) -> Result<Distributor, ImageError> {
        let header = ImageHeader::parse(image)?;
        let len = usize::try_from(header.image_len()).unwrap_or(usize::MAX);
        if image.len() != len {
            return Err(ImageError::LengthMismatch {
                expected: header.body_len,
                found: u32::try_from(image.len().saturating_sub(crate::image::HEADER_LEN)).unwrap_or(u32::MAX),
            });
        }
        let max = usize::from(u16::MAX) * CHUNK_LEN;
        if image.len() > max {
            return Err(ImageError::TooLong { len: header.body_len, max: max as u32 });
        }
        let chunks = super::chunks(image).collect();
        Ok(Distributor {
            version: header.version,
            chunks,
            cells: cells.into_iter().map(|c| (c, None)).collect(),
            next_chunk: 0,
            repairs: BTreeSet::new(),
            rounds: Rounds::default(),
            confirms: VecDeque::new(),
            last_offer_us: None,
            last_boot_us: None,
            last_confirm_us: None,
        })
    }

    /// The version being installed.
    pub fn version(&self) -> u32 {
        self.version
    }

    /// Chunks in the image.
    pub fn chunk_count(&self) -> usize {
        self.chunks.len()
    }

    /// Chunks of the broadcast pass sent so far.
    pub fn broadcast_sent(&self) -> usize {
        self.next_chunk
    }

    /// The offer this update makes.
    pub fn offer(&self) -> UpdateOffer {
        UpdateOffer { version: self.version, chunks: self.chunks.len() as u16 }
    }

    /// A report from a cell that came up interface port `port`; a cell not
    /// in the list is added.
    pub fn handle(&mut self, from: Address, port: u8, report: UpdateReport) {
        self.cells.insert(from, Some(report));
        self.rounds.heard(from);
        match report.state {
            UpdateState::Receiving if report.version == self.version => {
                // Only what the broadcast pass has already sent, and not
                // in this round, is missed.
                let end = report.first_missing.saturating_add(report.missing.min(REPAIR_WINDOW));
                let missed = (report.first_missing..end.min(self.next_chunk as u16))
                    .filter(|i| !self.rounds.in_flight(*i, port))
                    .map(|i| (i, port));
                self.repairs.extend(missed);
            }
            // Every trial report is confirmed: the confirm itself may be lost.
            UpdateState::Trial if report.version == self.version && !self.confirms.contains(&from) => {
                self.confirms.push_back(from);
            }
            _ => {}
        }
    }

    fn outcome_of(&self, report: Option<UpdateReport>) -> Outcome {
        match report {
            None => Outcome::NotHeard,
            Some(r) => match r.state {
                UpdateState::Running if r.version == self.version => Outcome::Updated,
                UpdateState::RolledBack => Outcome::RolledBack,
                UpdateState::Refused(why) if r.version == self.version => Outcome::Refused(why),
                state => Outcome::Unfinished(state),
            },
        }
    }

    /// Each cell's outcome so far.
    pub fn outcomes(&self) -> impl Iterator<Item = (Address, Outcome)> + '_ {
        self.cells.iter().map(|(a, r)| (*a, self.outcome_of(*r)))
    }

    /// True when every cell's outcome is final.
    pub fn finished(&self) -> bool {
        self.outcomes().all(|(_, o)| o.is_final())
    }

    fn due(last: Option<u64>, now_us: u64) -> bool {
        last.is_none_or(|t| now_us.saturating_sub(t) >= REPEAT_US)
    }

    /// The next frame to send at `now_us`. `None` when there is nothing to
    /// send now.
    pub fn next(&mut self, now_us: u64) -> Option<Outgoing> {
        let command = |action| Message::UpdateCommand(UpdateCommand { version: self.version, action });
        let every = |to, message| Some(Outgoing { via: Via::Every, to, message });
        if self.confirms.is_empty() && Self::due(self.last_confirm_us, now_us) {
            // Confirmed again until heard running: the answer may be lost.
            let trial = Outcome::Unfinished(UpdateState::Trial);
            let on_trial: Vec<Address> = self.outcomes().filter(|(_, o)| *o == trial).map(|(a, _)| a).collect();
            if !on_trial.is_empty() {
                self.last_confirm_us = Some(now_us);
                self.confirms.extend(on_trial);
            }
        }
        if let Some(cell) = self.confirms.pop_front() {
            return every(cell, command(UpdateAction::Confirm));
        }
        // Offered again while a cell has not got it yet: unheard, still
        // receiving, or running something else (it was off).
        let behind = self.cells.values().any(|r| match self.outcome_of(*r) {
            Outcome::NotHeard => true,
            Outcome::Unfinished(state) => !matches!(state, UpdateState::Ready | UpdateState::Trial),
            _ => false,
        });
        if behind && Self::due(self.last_offer_us, now_us) {
            self.last_offer_us = Some(now_us);
            return every(Address::BROADCAST, Message::UpdateOffer(self.offer()));
        }
        // Boot once no cell is still receiving: a cell that restarts
        // cuts its subtree off the image for a while.
        let any = |s| self.cells.values().any(|r| r.is_some_and(|r| r.version == self.version && r.state == s));
        if any(UpdateState::Ready) && !any(UpdateState::Receiving) && Self::due(self.last_boot_us, now_us) {
            self.last_boot_us = Some(now_us);
            return every(Address::BROADCAST, command(UpdateAction::Boot));
        }
        let receiving = self.cells.iter().filter_map(|(a, r)| {
            r.is_some_and(|r| r.version == self.version && r.state == UpdateState::Receiving).then_some(*a)
        });
        if !self.rounds.open(now_us, receiving) {
            return None;
        }
        let (index, via) = match self.repairs.pop_first() {
            Some((i, port)) => (usize::from(i), Via::Port(port)),
            None if self.next_chunk < self.chunks.len() => {
                self.next_chunk += 1;
                (self.next_chunk - 1, Via::Every)
            }
            None => return None,
        };
        let chunk = self.chunks[index];
        self.rounds.sent(chunk.index, via, now_us);
        Some(Outgoing { via, to: Address::BROADCAST, message: Message::ImageChunk(chunk) })
    }
}
