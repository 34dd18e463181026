//! A cell taking an update through its node: the image from the host's
//! distributor, byte by byte through the port, into a flash slot, then
//! the boot record the board keeps for each boot action.

use super::*;
use crate::boot::{boot, BootRecord, SlotId};
use crate::flash_slot::FlashSlot;
use skin_protocol::image::{self, Board, PUBLIC_KEY_LEN};
use skin_protocol::message::{Refusal, UpdateState};
use skin_protocol::update::{BootState, Distributor, Outcome};

/// Record in sectors 0-1, slot A in 2-5, slot B in 6-9.
type Image = RamFlash<1024, 10>;
type Spare = FlashSlot<Image>;
const SEED: [u8; 32] = [3; 32];
const SLOT_LEN: u32 = 4096;

fn key() -> [u8; PUBLIC_KEY_LEN] {
    salty::Keypair::from(&SEED).public.to_bytes()
}

fn signed(version: u32, seed: &[u8; 32], board: Board) -> Vec<u8> {
    let body: Vec<u8> = (0..2000u32).map(|i| (i * 13 + version) as u8).collect();
    image::sign(&body, board, version, seed).unwrap()
}

fn base(slot: SlotId) -> u32 {
    2048 + slot as u32 * SLOT_LEN
}

/// The cell's image flash at reset: the bootloader's choice, then the
/// node on it with the spare slot, joined as cell 17.
fn power_on(flash: Image, store: Flash, sink: &mut Sink, t: &mut u64) -> (Node<Flash, Spare>, BootRecord) {
    let slots = [SlotId::A, SlotId::B].map(|s| FlashSlot::new(flash.clone(), base(s), SLOT_LEN).unwrap());
    let mut records = Store::<_, BootRecord>::open(flash, 0, 2048).unwrap();
    let running = boot(&mut records, [&slots[0], &slots[1]], Board::Mps2An386, &key(), u32::MAX).unwrap();
    let record = *records.state();
    let version = image::ImageHeader::parse(&read(&slots[running as usize], 128)).unwrap().version;
    let spare = FlashSlot::new(records.release(), base(record.spare()), SLOT_LEN).unwrap();
    let mut n = node(store, *t);
    n.take_updates(Updater::new(Board::Mps2An386, key(), version, record.state()), spare);
    let mut down = Vec::new();
    if n.id() == Address::UNASSIGNED {
        join(&mut n, sink, &mut down, t);
        exchange(&mut n, sink, &mut down, t, *t + 50_000);
    }
    (n, record)
}

fn read(slot: &impl Slot, len: usize) -> Vec<u8> {
    let mut buf = vec![0; len];
    slot.read(0, &mut buf).unwrap();
    buf
}

/// The distributor and the node until the node asks its bootloader for
/// something or `until`; returns the action and the distributor's view.
fn run(
    n: &mut Node<Flash, Spare>,
    dist: &mut Distributor,
    sink: &mut Sink,
    t: &mut u64,
    until: u64,
) -> (Option<BootAction>, Outcome) {
    let mut down = Vec::new();
    while *t < until {
        // Four frames a step: about what a port carries in 100 us at 4 Mbit/s.
        for _ in 0..4 {
            match dist.next(*t) {
                // One cell on one interface port: every frame goes down it.
                Some(o) => down.push(Frame::new(Address::HOST, o.to, &o.message)),
                None => break,
            }
        }
        let step = *t + 100;
        for f in exchange(n, sink, &mut down, t, step) {
            if let Ok(Message::UpdateReport(r)) = f.message() {
                dist.handle(f.src(), 0, r);
            }
        }
        if let Some(action) = n.take_boot_action() {
            return (Some(action), dist.outcomes().next().unwrap().1);
        }
    }
    (None, dist.outcomes().next().unwrap().1)
}

fn factory() -> Image {
    let mut flash = Image::default();
    flash.write(base(SlotId::A), &signed(1, &SEED, Board::Mps2An386)).unwrap();
    flash
}

#[test]
fn an_image_arrives_boots_on_trial_and_is_confirmed() {
    let (mut t, mut sink) = (0, Sink::new(0, Config::default(), 0).unwrap());
    let (mut n, record) = power_on(factory(), Flash::default(), &mut sink, &mut t);
    assert_eq!(n.id(), Address(17));
    let new = signed(2, &SEED, Board::Mps2An386);
    let mut dist = Distributor::new(&new, [Address(17)]).unwrap();
    let (action, _) = run(&mut n, &mut dist, &mut sink, &mut t, 5_000_000);
    assert_eq!(action, Some(BootAction::BootTrial));
    let (updater, spare) = n.updates().unwrap();
    assert_eq!(read(spare, new.len()), new, "the slot holds the image byte for byte");
    // The board keeps the trial request and restarts.
    let version = updater.report().version;
    let (_, spare) = n.update.take().unwrap();
    let mut records = Store::<_, BootRecord>::open(spare.release(), 0, 2048).unwrap();
    records.set(record.request_trial(version)).unwrap();
    let store = n.into_store().release();
    let (mut n, record) = power_on(records.release(), store, &mut sink, &mut t);
    assert_eq!((record.running(), record.state()), (SlotId::B, BootState::Trial));
    let until = t + 2_000_000;
    let (action, _) = run(&mut n, &mut dist, &mut sink, &mut t, until);
    assert_eq!(action, Some(BootAction::Confirm));
    let (_, spare) = n.update.take().unwrap();
    let mut records = Store::<_, BootRecord>::open(spare.release(), 0, 2048).unwrap();
    records.set(record.confirm()).unwrap();
    // The host hears it running the new version.
    let until = t + 1_000_000;
    let (action, outcome) = run(&mut n, &mut dist, &mut sink, &mut t, until);
    assert_eq!((action, outcome), (None, Outcome::Updated));
    assert_eq!(records.state().running(), SlotId::B);
}

#[test]
fn forged_and_foreign_images_are_refused_and_nothing_boots() {
    for (bad, refusal) in [
        (signed(2, &[9; 32], Board::Mps2An386), Refusal::BadSignature),
        (signed(2, &SEED, Board::Stm32f405), Refusal::WrongBoard),
    ] {
        let (mut t, mut sink) = (0, Sink::new(0, Config::default(), 0).unwrap());
        let (mut n, _) = power_on(factory(), Flash::default(), &mut sink, &mut t);
        let mut dist = Distributor::new(&bad, [Address(17)]).unwrap();
        let (action, outcome) = run(&mut n, &mut dist, &mut sink, &mut t, 2_000_000);
        assert_eq!((action, outcome), (None, Outcome::Refused(refusal)));
        assert_eq!(n.updates().unwrap().0.report().state, UpdateState::Refused(refusal));
    }
}
