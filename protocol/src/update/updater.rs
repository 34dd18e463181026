//! The cell's update state machine: messages and time in, reports and boot
//! actions out, the image into a [`Slot`].

use super::{verify_body, Bitmap, Slot, SlotImageError};
use crate::image::{Board, ImageError, ImageHeader, Verifier, HEADER_LEN, PUBLIC_KEY_LEN};
use crate::message::{
    ImageChunk, Refusal, UpdateAction, UpdateCommand, UpdateOffer, UpdateReport, UpdateState, CHUNK_LEN,
};

/// Quiet time after the last chunk before a receiving cell reports what it
/// misses, and the least time between two of its reports.
pub const QUIET_US: u64 = 20_000;
/// Doublings of the time between the reports of a receiving cell that hears
/// no chunk at all: 20 ms, 40 ms, ... up to 640 ms. Every report crosses
/// every cell between it and the host, so a patch of cells waiting (the
/// host waits for a cell that is off, or for its own pace) would otherwise
/// spend its links on reports, 50 a second from each cell.
const MAX_BACKOFF: u8 = 5;
/// Chunks a report's missing span covers at most: what the host resends for it.
pub const REPAIR_WINDOW: u16 = 64;
/// How often a cell on trial reports until the host confirms it.
pub const TRIAL_REPORT_US: u64 = 200_000;
/// The time a new image has to be confirmed once booted on trial: the
/// bootloader goes back to the old image at the next boot if it was not
/// (the firmware of a real cell and the simulator keep this limit; QEMU
/// cells, which take seconds to organize again, have their own).
pub const TRIAL_US: u64 = 3_000_000;
/// Chunks a cell can take: a 64 KiB image and its header.
const WORDS: usize = (64 * 1024 + HEADER_LEN).div_ceil(CHUNK_LEN).div_ceil(32);
/// Chunks of the header.
const HEADER_CHUNKS: u16 = HEADER_LEN.div_ceil(CHUNK_LEN) as u16;

/// How the running image was booted, as the bootloader tells the firmware.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BootState {
    /// A confirmed image.
    Confirmed,
    /// A new image on trial: unless confirmed, the next boot goes back.
    Trial,
    /// The old image again, after a trial of version `from` that was not
    /// confirmed: that version is not taken again.
    RolledBack {
        /// The version that failed its trial.
        from: u32,
    },
}

/// What the board (and its bootloader) must do for the updater.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BootAction {
    /// Mark the spare slot for a trial boot and restart.
    BootTrial,
    /// Keep the running trial image for good.
    Confirm,
    /// Mark the previous image and restart.
    Rollback,
}

/// Where the offered image is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Progress {
    Receiving,
    Ready,
    Refused(Refusal),
}

/// One cell's side of an update.
#[derive(Clone, Debug)]
pub struct Updater {
    board: Board,
    key: [u8; PUBLIC_KEY_LEN],
    running: u32,
    boot: BootState,
    offer: Option<(UpdateOffer, Progress)>,
    have: Bitmap<WORDS>,
    header_checked: bool,
    /// The slot's chunks were kept from before a restart ([`Updater::offer`]).
    resumed: bool,
    last_chunk_us: u64,
    last_report_us: Option<u64>,
    /// Reports since the last chunk: each one waits twice as long.
    quiet_reports: u8,
}

impl Updater {
    /// A cell of `board` trusting `key`, running `version` booted as `boot`.
    pub fn new(board: Board, key: [u8; PUBLIC_KEY_LEN], version: u32, boot: BootState) -> Updater {
        Updater {
            board,
            key,
            running: version,
            boot,
            offer: None,
            have: Bitmap::EMPTY,
            header_checked: false,
            resumed: false,
            last_chunk_us: 0,
            last_report_us: None,
            quiet_reports: 0,
        }
    }

    /// The version running.
    pub fn running(&self) -> u32 {
        self.running
    }

    /// Chunks of the offered image in the slot.
    pub fn received(&self) -> u32 {
        self.have.count()
    }

    /// What the cell would report now.
    pub fn report(&self) -> UpdateReport {
        let (version, state, first_missing, missing) = match self.offer {
            Some((offer, progress)) if offer.version != self.running => match progress {
                Progress::Receiving => {
                    let (first, count) = self.have.first_missing(0, REPAIR_WINDOW).unwrap_or((offer.chunks, 0));
                    (offer.version, UpdateState::Receiving, first, count)
                }
                Progress::Ready => (offer.version, UpdateState::Ready, 0, 0),
                Progress::Refused(r) => (offer.version, UpdateState::Refused(r), 0, 0),
            },
            _ => {
                let state = match self.boot {
                    BootState::Confirmed => UpdateState::Running,
                    BootState::Trial => UpdateState::Trial,
                    BootState::RolledBack { .. } => UpdateState::RolledBack,
                };
                (self.running, state, 0, 0)
            }
        };
        UpdateReport { version, state, first_missing, missing }
    }

    fn reported(&mut self, now_us: u64) -> Option<UpdateReport> {
        self.last_report_us = Some(now_us);
        Some(self.report())
    }

    /// An offer: a new version clears the slot for it, unless the slot
    /// already holds part of this very image (see `resume`); every
    /// offer is answered. On trial the running image is the spare slot's
    /// own, so nothing is taken until the trial is confirmed or rolled back.
    pub fn offer(&mut self, offer: UpdateOffer, slot: &mut impl Slot, now_us: u64) -> Option<UpdateReport> {
        if self.boot == BootState::Trial {
            return self.reported(now_us);
        }
        let current = self.offer.is_some_and(|(o, _)| o == offer);
        let failed = self.boot == BootState::RolledBack { from: offer.version };
        if offer.version != self.running && !current && !failed {
            let fits = usize::from(offer.chunks) * CHUNK_LEN <= slot.capacity() as usize
                && usize::from(offer.chunks) >= usize::from(HEADER_CHUNKS);
            let room = fits && self.have.reset(offer.chunks);
            self.resumed = room && self.resume(offer, slot);
            let progress = if !room {
                Progress::Refused(Refusal::TooLong)
            } else if self.resumed {
                Progress::Receiving
            } else if slot.erase().is_err() {
                Progress::Refused(Refusal::SlotFailed)
            } else {
                Progress::Receiving
            };
            self.offer = Some((offer, progress));
            self.header_checked = self.resumed;
            self.heard_chunk(now_us);
            if let Some(progress) = self.resumed.then(|| self.completed(slot)).flatten() {
                self.offer = Some((offer, progress));
            }
        }
        self.reported(now_us)
    }

    /// Takes up the image a restart (a power cut) interrupted: when the
    /// slot holds this offer's header, genuine under the key, every chunk
    /// written before (any chunk not blank) is kept rather than asked for
    /// again. A chunk the cut tore shows when the whole image is checked,
    /// and the slot is then received again from nothing. False (and no
    /// chunk kept) when the slot holds no such header.
    fn resume(&mut self, offer: UpdateOffer, slot: &impl Slot) -> bool {
        if self.verifier(offer, slot).is_err() {
            return false;
        }
        let mut bytes = [0u8; CHUNK_LEN];
        for i in 0..offer.chunks {
            if slot.read(u32::from(i) * CHUNK_LEN as u32, &mut bytes).is_err() {
                self.have.reset(offer.chunks);
                return false;
            }
            if bytes.iter().any(|b| *b != 0xFF) {
                self.have.insert(i);
            }
        }
        let header = (0..HEADER_CHUNKS).all(|i| self.have.has(i));
        if !header {
            self.have.reset(offer.chunks);
        }
        header
    }

    /// Once every chunk is in: the image checked whole. A resumed slot
    /// that fails is blanked and received again (a chunk torn by a power
    /// cut); any other failure refuses the image.
    fn completed(&mut self, slot: &mut impl Slot) -> Option<Progress> {
        if !self.have.is_full() {
            return None;
        }
        match self.check_image(slot) {
            Ok(_) => Some(Progress::Ready),
            Err(Refusal::BadBody) if self.resumed => {
                self.resumed = false;
                self.header_checked = false;
                self.have.reset(self.have.len());
                Some(if slot.erase().is_ok() { Progress::Receiving } else { Progress::Refused(Refusal::SlotFailed) })
            }
            Err(refusal) => Some(Progress::Refused(refusal)),
        }
    }

    /// A chunk of the offered image; reports when the image is complete or refused.
    pub fn chunk(&mut self, chunk: &ImageChunk, slot: &mut impl Slot, now_us: u64) -> Option<UpdateReport> {
        let Some((offer, Progress::Receiving)) = self.offer else { return None };
        // A chunk this cell has is still news: the host is sending, and
        // the cell answers once it stops (the host paces itself on that).
        self.heard_chunk(now_us);
        if !self.have.insert(chunk.index) {
            return None;
        }
        let offset = u32::from(chunk.index) * CHUNK_LEN as u32;
        let progress = if slot.write(offset, &chunk.data).is_err() {
            Some(Progress::Refused(Refusal::SlotFailed))
        } else if !self.header_checked && (0..HEADER_CHUNKS).all(|i| self.have.has(i)) {
            self.header_checked = true;
            self.verifier(offer, slot).err().map(Progress::Refused)
        } else {
            None
        };
        let progress = progress.or_else(|| self.completed(slot))?;
        self.offer = Some((offer, progress));
        self.reported(now_us)
    }

    /// The host is sending: the next report comes after [`QUIET_US`] without.
    fn heard_chunk(&mut self, now_us: u64) {
        self.last_chunk_us = now_us;
        self.quiet_reports = 0;
    }

    /// The header in the slot, checked against the offer, the board and the key.
    fn verifier(&self, offer: UpdateOffer, slot: &impl Slot) -> Result<Verifier, Refusal> {
        let mut bytes = [0u8; HEADER_LEN];
        slot.read(0, &mut bytes).map_err(|_| Refusal::SlotFailed)?;
        let header = ImageHeader::parse(&bytes).map_err(refusal)?;
        let chunks = header.image_len().div_ceil(CHUNK_LEN as u64);
        if header.version != offer.version || chunks != u64::from(offer.chunks) {
            return Err(Refusal::BadHeader);
        }
        let room = (u64::from(offer.chunks) * CHUNK_LEN as u64).saturating_sub(HEADER_LEN as u64);
        Verifier::new(&header, self.board, u32::try_from(room).unwrap_or(u32::MAX), &self.key).map_err(refusal)
    }

    /// The whole image read back from the slot and verified.
    fn check_image(&self, slot: &impl Slot) -> Result<ImageHeader, Refusal> {
        let Some((offer, _)) = self.offer else { return Err(Refusal::BadHeader) };
        let verifier = self.verifier(offer, slot)?;
        verify_body(slot, verifier).map_err(|e| match e {
            SlotImageError::Slot(_) => Refusal::SlotFailed,
            SlotImageError::Image(e) => refusal(e),
        })
    }

    /// Lets time pass: a receiving cell that heard no chunk for
    /// [`QUIET_US`] reports the first run it misses, and again while it
    /// hears none, each time twice as late (up to 32 times); a cell on
    /// trial reports every [`TRIAL_REPORT_US`] until it is confirmed.
    pub fn poll(&mut self, now_us: u64) -> Option<UpdateReport> {
        let since = |t: Option<u64>, period: u64| t.is_none_or(|t| now_us.saturating_sub(t) >= period);
        match self.offer {
            Some((_, Progress::Receiving)) => {
                let wait = QUIET_US << self.quiet_reports.min(MAX_BACKOFF);
                let due = now_us.saturating_sub(self.last_chunk_us) >= QUIET_US && since(self.last_report_us, wait);
                if !due {
                    return None;
                }
                self.quiet_reports = self.quiet_reports.saturating_add(1);
                self.reported(now_us)
            }
            _ if self.boot == BootState::Trial && since(self.last_report_us, TRIAL_REPORT_US) => self.reported(now_us),
            _ => None,
        }
    }

    /// A command from the host: the report to send and what the board must do.
    pub fn command(&mut self, command: &UpdateCommand, now_us: u64) -> (Option<UpdateReport>, Option<BootAction>) {
        let ready = matches!(self.offer, Some((o, Progress::Ready)) if o.version == command.version);
        let trial = self.boot == BootState::Trial && self.running == command.version;
        let action = match command.action {
            UpdateAction::Boot if ready => Some(BootAction::BootTrial),
            UpdateAction::Confirm if trial => {
                self.boot = BootState::Confirmed;
                Some(BootAction::Confirm)
            }
            UpdateAction::Rollback if trial => Some(BootAction::Rollback),
            _ => None,
        };
        (self.reported(now_us), action)
    }
}

/// The refusal a cell reports for an image error.
fn refusal(e: ImageError) -> Refusal {
    match e {
        ImageError::BadSignature | ImageError::BadKey => Refusal::BadSignature,
        ImageError::WrongBoard { .. } => Refusal::WrongBoard,
        ImageError::TooLong { .. } => Refusal::TooLong,
        ImageError::BadDigest | ImageError::LengthMismatch { .. } => Refusal::BadBody,
        _ => Refusal::BadHeader,
    }
}
