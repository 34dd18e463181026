use proptest::prelude::*;

use super::*;
use crate::address::Address;
use crate::image::{Board, HEADER_LEN};
use crate::message::{
    ImageChunk, Refusal, UpdateAction, UpdateCommand, UpdateOffer, UpdateReport, UpdateState, CHUNK_LEN,
};

const SLOT: usize = 4096;
type TestSlot = MemorySlot<SLOT>;

fn key_pair(seed: u8) -> salty::Keypair {
    salty::Keypair::from(&[seed; 32])
}

/// A signed image of `len` body bytes, and its chunks.
fn image(board: Board, version: u32, len: usize, seed: u8) -> (Vec<u8>, Vec<ImageChunk>) {
    let body: Vec<u8> = (0..len).map(|i| (i * 31 + 7) as u8).collect();
    let bytes = crate::image::sign(&body, board, version, &[seed; 32]).unwrap();
    let chunks = chunks(&bytes);
    (bytes, chunks)
}

fn chunks(bytes: &[u8]) -> Vec<ImageChunk> {
    super::chunks(bytes).collect()
}

fn offer_of(version: u32, chunks: &[ImageChunk]) -> UpdateOffer {
    UpdateOffer { version, chunks: chunks.len() as u16 }
}

fn cell() -> Updater {
    Updater::new(Board::Mps2An386, key_pair(1).public.to_bytes(), 1, BootState::Confirmed)
}

fn state(r: Option<UpdateReport>) -> Option<UpdateState> {
    r.map(|r| r.state)
}

#[test]
fn an_image_in_order_becomes_ready_then_boots_on_trial() {
    let (bytes, chunks) = image(Board::Mps2An386, 2, 1000, 1);
    let (mut u, mut slot) = (cell(), TestSlot::default());
    let first = u.offer(offer_of(2, &chunks), &mut slot, 0).unwrap();
    assert_eq!(
        first,
        UpdateReport { version: 2, state: UpdateState::Receiving, first_missing: 0, missing: REPAIR_WINDOW }
    );
    let mut reports = Vec::new();
    for (t, c) in chunks.iter().enumerate() {
        reports.extend(u.chunk(c, &mut slot, t as u64));
    }
    assert_eq!(reports.iter().map(|r| r.state).collect::<Vec<_>>(), [UpdateState::Ready]);
    assert_eq!(&slot.bytes()[..bytes.len()], &bytes[..]);
    let boot = UpdateCommand { version: 2, action: UpdateAction::Boot };
    assert_eq!(u.command(&boot, 1).1, Some(BootAction::BootTrial));
    // A command for another version does nothing.
    assert_eq!(u.command(&UpdateCommand { version: 3, action: UpdateAction::Boot }, 2).1, None);
}

#[test]
fn a_cell_asks_for_the_runs_it_missed_and_only_after_a_quiet_time() {
    let (bytes, chunks) = image(Board::Mps2An386, 2, 1000, 1);
    let (mut u, mut slot) = (cell(), TestSlot::default());
    u.offer(offer_of(2, &chunks), &mut slot, 0);
    for c in chunks.iter().filter(|c| !(20..25).contains(&c.index) && c.index != 40) {
        assert_eq!(u.chunk(c, &mut slot, 1_000), None);
    }
    assert_eq!(u.poll(1_000 + QUIET_US - 1), None, "not quiet long enough");
    let nack = u.poll(1_000 + QUIET_US).unwrap();
    // The span from the first gap to the last within the window: 20..=40.
    assert_eq!((nack.state, nack.first_missing, nack.missing), (UpdateState::Receiving, 20, 21));
    assert_eq!(u.poll(1_000 + QUIET_US + 1), None, "one report per quiet time");
    for c in &chunks[20..25] {
        u.chunk(c, &mut slot, 200_000);
    }
    let nack = u.poll(200_000 + QUIET_US).unwrap();
    assert_eq!((nack.first_missing, nack.missing), (40, 1));
    assert_eq!(state(u.chunk(&chunks[40], &mut slot, 300_000)), Some(UpdateState::Ready));
    assert_eq!(&slot.bytes()[..bytes.len()], &bytes[..]);
    assert_eq!(u.poll(10_000_000), None, "a ready cell asks for nothing");
}

#[test]
fn a_cell_that_hears_no_chunk_reports_ever_later_and_any_chunk_restarts_the_quiet_time() {
    let (_, chunks) = image(Board::Mps2An386, 2, 1000, 1);
    let (mut u, mut slot) = (cell(), TestSlot::default());
    u.offer(offer_of(2, &chunks), &mut slot, 0);
    u.chunk(&chunks[0], &mut slot, 0);
    let mut at = Vec::new();
    for t in (0..2_000_000).step_by(1_000) {
        if u.poll(t).is_some() {
            at.push(t / 1_000);
        }
    }
    assert_eq!(at, [20, 60, 140, 300, 620, 1260, 1900], "ms: twice as long each time, up to 640 ms");
    // A chunk the cell has is news too: the host is sending again.
    u.chunk(&chunks[0], &mut slot, 2_000_000);
    assert_eq!(u.poll(2_000_000 + QUIET_US - 1), None);
    assert!(u.poll(2_000_000 + QUIET_US).is_some());
}

#[test]
fn a_forged_header_is_refused_before_the_body_arrives() {
    let (_, chunks) = image(Board::Mps2An386, 2, 1000, 9);
    let (mut u, mut slot) = (cell(), TestSlot::default());
    u.offer(offer_of(2, &chunks), &mut slot, 0);
    let header_chunks = HEADER_LEN.div_ceil(CHUNK_LEN);
    let mut reports = Vec::new();
    for c in &chunks[..header_chunks] {
        reports.extend(u.chunk(c, &mut slot, 0));
    }
    assert_eq!(reports.iter().map(|r| r.state).collect::<Vec<_>>(), [UpdateState::Refused(Refusal::BadSignature)]);
    assert_eq!(u.chunk(&chunks[header_chunks], &mut slot, 0), None, "nothing more is written");
    assert_eq!(u.poll(QUIET_US * 10), None);
    assert_eq!(u.command(&UpdateCommand { version: 2, action: UpdateAction::Boot }, 0).1, None);
}

#[test]
fn wrong_board_truncated_and_corrupted_images_are_refused() {
    let refused = |chunks: &[ImageChunk], offer: UpdateOffer| {
        let (mut u, mut slot) = (cell(), TestSlot::default());
        u.offer(offer, &mut slot, 0);
        chunks.iter().filter_map(|c| u.chunk(c, &mut slot, 0)).map(|r| r.state).collect::<Vec<_>>()
    };
    let (_, other) = image(Board::Stm32f405, 2, 500, 1);
    assert_eq!(refused(&other, offer_of(2, &other)), [UpdateState::Refused(Refusal::WrongBoard)]);

    let (bytes, good) = image(Board::Mps2An386, 2, 500, 1);
    let short = chunks(&bytes[..bytes.len() - 11]);
    assert_eq!(
        refused(&short, offer_of(2, &short)),
        [UpdateState::Refused(Refusal::BadHeader)],
        "offer and header disagree"
    );

    let mut corrupt = good.clone();
    corrupt[30].data[3] ^= 1;
    assert_eq!(refused(&corrupt, offer_of(2, &corrupt)), [UpdateState::Refused(Refusal::BadBody)]);

    assert_eq!(
        refused(&good, offer_of(3, &good)),
        [UpdateState::Refused(Refusal::BadHeader)],
        "offered as another version"
    );
    let (mut u, mut slot) = (cell(), TestSlot::default());
    let too_long = UpdateOffer { version: 2, chunks: (SLOT / CHUNK_LEN + 1) as u16 };
    assert_eq!(state(u.offer(too_long, &mut slot, 0)), Some(UpdateState::Refused(Refusal::TooLong)));
}

#[test]
fn the_running_version_is_not_taken_again_and_a_trial_confirms() {
    let (_, chunks) = image(Board::Mps2An386, 2, 300, 1);
    let mut u = Updater::new(Board::Mps2An386, key_pair(1).public.to_bytes(), 2, BootState::Trial);
    let mut slot = TestSlot::default();
    assert_eq!(state(u.offer(offer_of(2, &chunks), &mut slot, 0)), Some(UpdateState::Trial));
    assert_eq!(u.chunk(&chunks[0], &mut slot, 0), None);
    let (report, action) = u.command(&UpdateCommand { version: 2, action: UpdateAction::Confirm }, 0);
    assert_eq!((state(report), action), (Some(UpdateState::Running), Some(BootAction::Confirm)));
    let (_, action) = u.command(&UpdateCommand { version: 2, action: UpdateAction::Rollback }, 0);
    assert_eq!(action, None, "a confirmed image is not rolled back");

    let mut trial = Updater::new(Board::Mps2An386, key_pair(1).public.to_bytes(), 2, BootState::Trial);
    let (_, action) = trial.command(&UpdateCommand { version: 2, action: UpdateAction::Rollback }, 0);
    assert_eq!(action, Some(BootAction::Rollback));
    let mut back = Updater::new(Board::Mps2An386, key_pair(1).public.to_bytes(), 1, BootState::RolledBack { from: 2 });
    let rolled_back = UpdateReport { version: 1, state: UpdateState::RolledBack, first_missing: 0, missing: 0 };
    assert_eq!(back.report(), rolled_back);
    assert_eq!(
        back.offer(offer_of(2, &chunks), &mut slot, 0),
        Some(rolled_back),
        "the failed version is not taken again"
    );
}

#[test]
fn an_offer_during_a_trial_leaves_the_running_image_alone() {
    // The trial image runs from the spare slot: erasing it for another
    // offer would leave the confirm pointing at nothing.
    let (_, running) = image(Board::Mps2An386, 2, 300, 1);
    let (_, next) = image(Board::Mps2An386, 3, 300, 1);
    let mut slot = TestSlot::default();
    for c in &running {
        slot.write(u32::from(c.index) * CHUNK_LEN as u32, &c.data).unwrap();
    }
    let before = *slot.bytes();
    let mut u = Updater::new(Board::Mps2An386, key_pair(1).public.to_bytes(), 2, BootState::Trial);
    assert_eq!(state(u.offer(offer_of(3, &next), &mut slot, 0)), Some(UpdateState::Trial));
    assert_eq!(u.chunk(&next[0], &mut slot, 0), None);
    assert_eq!(slot.bytes(), &before);
    // Once confirmed, the next version is taken.
    u.command(&UpdateCommand { version: 2, action: UpdateAction::Confirm }, 0);
    assert_eq!(state(u.offer(offer_of(3, &next), &mut slot, 0)), Some(UpdateState::Receiving));
}

/// Chunks sent to a fresh cell (the restarted one: a new updater on the
/// same slot) after the offer, until ready; returns how many it wrote.
fn finish(
    u: &mut Updater,
    slot: &mut TestSlot,
    chunks: &[ImageChunk],
    offer: UpdateOffer,
) -> (usize, Option<UpdateState>) {
    let mut last = state(u.offer(offer, slot, 0));
    let before = u.received();
    for c in chunks {
        if last == Some(UpdateState::Ready) {
            break;
        }
        last = state(u.chunk(c, slot, 1)).or(last);
    }
    (u.received().saturating_sub(before) as usize, last)
}

/// An image of version 2 offered, its first 60 chunks written, and the
/// power cut: the slot as the cut left it.
fn cut_after_60_chunks() -> (Vec<u8>, Vec<ImageChunk>, UpdateOffer, TestSlot) {
    let (bytes, chunks) = image(Board::Mps2An386, 2, 1000, 1);
    let offer = offer_of(2, &chunks);
    let (mut u, mut slot) = (cell(), TestSlot::default());
    u.offer(offer, &mut slot, 0);
    for c in &chunks[..60] {
        u.chunk(c, &mut slot, 1);
    }
    (bytes, chunks, offer, slot)
}

#[test]
fn a_cell_restarted_mid_image_keeps_the_chunks_its_slot_holds() {
    let (bytes, chunks, offer, mut slot) = cut_after_60_chunks();
    // The power comes back: a new updater, the same slot.
    let mut again = cell();
    let report = again.offer(offer, &mut slot, 2).unwrap();
    assert_eq!((report.state, report.first_missing), (UpdateState::Receiving, 60), "{report:?}");
    assert_eq!(again.received(), 60);
    assert_eq!(finish(&mut again, &mut slot, &chunks[60..], offer), (chunks.len() - 60, Some(UpdateState::Ready)));
    assert_eq!(&slot.bytes()[..bytes.len()], &bytes[..]);
    // Ready before the cut: ready again at the offer, nothing asked for.
    let mut third = cell();
    assert_eq!(state(third.offer(offer, &mut slot, 3)), Some(UpdateState::Ready));
}

#[test]
fn a_chunk_torn_by_the_cut_costs_the_slot_not_the_image() {
    let (bytes, chunks, offer, mut slot) = cut_after_60_chunks();
    // Chunk 60 cut after 4 of its 10 bytes.
    slot.write(60 * CHUNK_LEN as u32, &chunks[60].data[..4]).unwrap();
    let mut again = cell();
    assert_eq!(again.offer(offer, &mut slot, 2).unwrap().first_missing, 61);
    // The whole image fails its digest: the slot is blanked and received anew.
    let (_, last) = finish(&mut again, &mut slot, &chunks[61..], offer);
    let report = again.report();
    assert_eq!((last, report.first_missing, again.received()), (Some(UpdateState::Receiving), 0, 0));
    let (written, last) = finish(&mut again, &mut slot, &chunks, offer);
    assert_eq!((written, last), (chunks.len(), Some(UpdateState::Ready)));
    assert_eq!(&slot.bytes()[..bytes.len()], &bytes[..]);
}

#[test]
fn a_slot_holding_another_image_is_blanked_for_the_offer() {
    // An older version, and this version signed with another key.
    let (old, _) = image(Board::Mps2An386, 2, 1000, 1);
    let (forged, _) = image(Board::Mps2An386, 3, 1000, 9);
    let (bytes, new) = image(Board::Mps2An386, 3, 1000, 1);
    for before in [old, forged] {
        let mut slot = TestSlot::default();
        slot.write(0, &before).unwrap();
        let mut u = cell();
        assert_eq!(u.offer(offer_of(3, &new), &mut slot, 0).unwrap().first_missing, 0);
        assert_eq!(u.received(), 0);
        assert_eq!(finish(&mut u, &mut slot, &new, offer_of(3, &new)), (new.len(), Some(UpdateState::Ready)));
        assert_eq!(&slot.bytes()[..bytes.len()], &bytes[..]);
    }
}

fn any_message() -> impl Strategy<Value = (u8, u16, [u8; CHUNK_LEN], u32)> {
    (0u8..4, any::<u16>(), any::<[u8; CHUNK_LEN]>(), 0u32..4)
}

proptest! {
    /// Lossy, reordered, duplicated delivery with selective repeat always
    /// ends with the image verified and in the slot, byte for byte.
    #[test]
    fn any_loss_and_order_ends_ready_with_the_image_in_the_slot(
        len in 1usize..1500,
        order in any::<u64>(),
        loss_per_mille in 0u32..900,
    ) {
        let (bytes, chunks) = image(Board::Mps2An386, 5, len, 1);
        let (mut u, mut slot) = (cell(), TestSlot::default());
        u.offer(offer_of(5, &chunks), &mut slot, 0);
        let mut rng = order | 1;
        let mut next = || { rng ^= rng << 13; rng ^= rng >> 7; rng ^= rng << 17; rng };
        let mut now = 0;
        let mut last = None;
        // The broadcast pass, lossy and with some duplicates.
        for c in &chunks {
            for _ in 0..1 + next() % 2 {
                if (next() % 1000) as u32 >= loss_per_mille {
                    last = u.chunk(c, &mut slot, now).or(last);
                }
                now += 10;
            }
        }
        // Selective repeat: resend what the cell reports missing, lossy too.
        for _ in 0..10_000 {
            if state(last) == Some(UpdateState::Ready) { break; }
            now += QUIET_US;
            if let Some(r) = u.poll(now) {
                prop_assert_eq!(r.state, UpdateState::Receiving);
                prop_assert!(r.missing > 0);
                for c in &chunks[usize::from(r.first_missing)..usize::from(r.first_missing + r.missing)] {
                    if (next() % 1000) as u32 >= loss_per_mille {
                        last = u.chunk(c, &mut slot, now).or(last);
                    }
                }
            }
        }
        prop_assert_eq!(state(last), Some(UpdateState::Ready));
        prop_assert_eq!(&slot.bytes()[..bytes.len()], &bytes[..]);
    }

    /// Power cuts at any chunk, each tearing the chunk being written or
    /// not, with the chunks in any order: the cell always ends ready with
    /// the image in its slot, byte for byte.
    #[test]
    fn cuts_at_any_chunk_end_ready_with_the_image_in_the_slot(
        len in 1usize..1500,
        order in any::<u64>(),
        cuts in proptest::collection::vec((0usize..200, 0usize..CHUNK_LEN), 0..6),
    ) {
        let (bytes, chunks) = image(Board::Mps2An386, 5, len, 1);
        let offer = offer_of(5, &chunks);
        let mut rng = order | 1;
        let mut next = || { rng ^= rng << 13; rng ^= rng >> 7; rng ^= rng << 17; rng as usize };
        let mut slot = TestSlot::default();
        let mut u = cell();
        let mut last = state(u.offer(offer, &mut slot, 0));
        let mut cuts = cuts.into_iter();
        let mut cut = cuts.next();
        let mut sent = 0;
        for round in 0..50 {
            if last == Some(UpdateState::Ready) { break; }
            // The host sends every chunk again, in any order (the cell
            // takes what it misses).
            let mut all: Vec<&ImageChunk> = chunks.iter().collect();
            for i in (1..all.len()).rev() {
                all.swap(i, next() % (i + 1));
            }
            for c in all {
                let offset = usize::from(c.index) * CHUNK_LEN;
                let blank = slot.bytes()[offset..offset + CHUNK_LEN].iter().all(|b| *b == 0xFF);
                if let Some((at, torn)) = cut.filter(|(at, _)| sent >= *at && blank) {
                    // The cut while this chunk is written: part of it in
                    // the slot, then a new updater on the same slot.
                    let _ = slot.write(u32::from(c.index) * CHUNK_LEN as u32, &c.data[..torn]);
                    u = cell();
                    last = state(u.offer(offer, &mut slot, round));
                    cut = cuts.next().map(|(k, t)| (at + 1 + k, t));
                    break;
                }
                sent += 1;
                last = state(u.chunk(c, &mut slot, round)).or(last);
            }
        }
        prop_assert_eq!(last, Some(UpdateState::Ready));
        prop_assert_eq!(&slot.bytes()[..bytes.len()], &bytes[..]);
    }

    /// Any messages in any order never panic, and the cell is only ever
    /// ready with the genuine image in its slot.
    #[test]
    fn any_messages_never_panic_and_ready_means_genuine(script in proptest::collection::vec(any_message(), 0..300)) {
        let (bytes, chunks) = image(Board::Mps2An386, 2, 200, 1);
        let (mut u, mut slot) = (cell(), TestSlot::default());
        for (t, (what, index, data, version)) in script.into_iter().enumerate() {
            let now = t as u64 * 1000;
            let report = match what {
                0 => u.offer(UpdateOffer { version, chunks: index % 600 }, &mut slot, now),
                1 => u.chunk(&ImageChunk { index: index % 40, data }, &mut slot, now),
                2 => u.chunk(&chunks[usize::from(index) % chunks.len()], &mut slot, now),
                _ => u.poll(now * 100),
            };
            if let Some(r) = report {
                if r.state == UpdateState::Ready {
                    prop_assert_eq!(r.version, 2);
                    prop_assert_eq!(&slot.bytes()[..bytes.len()], &bytes[..]);
                }
            }
        }
    }

    /// However many cells ask for a run, each of its chunks goes once down
    /// each interface port whose tree asked for it, and down no other; and
    /// with nobody answering, at most one round of chunk frames goes per
    /// round timeout, whenever the host asks.
    #[test]
    fn resends_go_once_per_asking_port_and_rounds_wait_for_answers(
        asking in proptest::collection::btree_map(1u16..40, 0u8..4, 1..20),
        first in 0u16..60,
        missing in 1u16..80,
        calls in proptest::collection::vec(0u64..200_000, 1..400),
    ) {
        use super::rounds::Via;
        let (bytes, chunks) = image(Board::Mps2An386, 2, 1000, 1);
        // Cell 100, on port 7, has every chunk and never asks.
        let quiet = (Address(100), 7u8);
        let cells: Vec<(Address, u8)> =
            asking.iter().map(|(a, p)| (Address(*a), *p)).chain(core::iter::once(quiet)).collect();
        let mut d = Distributor::new(&bytes, cells.iter().map(|c| c.0)).unwrap();
        let sent_chunk = |m: Option<super::distributor::Outgoing>| match m {
            Some(o) => match o.message {
                crate::message::Message::ImageChunk(c) => Some((o.via, o.to, c.index)),
                _ => None,
            },
            None => None,
        };
        // The whole broadcast pass, every round answered by every cell.
        let mut now = 0;
        let mut pass = Vec::new();
        while pass.len() < chunks.len() {
            match sent_chunk(d.next(now)) {
                Some((via, to, i)) => {
                    prop_assert_eq!((via, to), (Via::Every, Address::BROADCAST));
                    pass.push(i)
                }
                None => {
                    for (c, port) in &cells {
                        let r = UpdateReport { version: 2, state: UpdateState::Receiving, first_missing: 200, missing: 0 };
                        d.handle(*c, *port, r);
                    }
                }
            }
            now += 1;
        }
        prop_assert_eq!(pass, (0..chunks.len() as u16).collect::<Vec<_>>());
        let asked = UpdateReport { version: 2, state: UpdateState::Receiving, first_missing: first, missing };
        for (c, port) in &cells[..cells.len() - 1] {
            d.handle(*c, *port, asked);
        }
        let has_all = UpdateReport { version: 2, state: UpdateState::Receiving, first_missing: 200, missing: 0 };
        d.handle(quiet.0, quiet.1, has_all);
        let end = (first + missing.min(REPAIR_WINDOW)).min(chunks.len() as u16);
        let mut resent = Vec::new();
        let mut at = now + 1;
        let mut times = Vec::new();
        for dt in calls {
            at += dt;
            while let Some((via, to, i)) = sent_chunk(d.next(at)) {
                prop_assert_eq!(to, Address::BROADCAST);
                resent.push((i, via));
                times.push(at);
            }
        }
        let ports: std::collections::BTreeSet<u8> = asking.values().copied().collect();
        let want: Vec<(u16, Via)> = (first..end).flat_map(|i| ports.iter().map(move |p| (i, Via::Port(*p)))).collect();
        let n = resent.len().min(want.len());
        prop_assert_eq!(&resent[..n], &want[..n]);
        prop_assert!(resent.len() <= want.len(), "nothing beyond what was asked, once per asking port");
        // Nobody answers the resends: each round after the first waits out its timeout.
        for k in (ROUND_FRAMES..times.len()).step_by(ROUND_FRAMES) {
            prop_assert!(times[k] - times[k - 1] >= ROUND_TIMEOUT_US, "round at {} after {}", times[k], times[k - 1]);
        }
    }
}
