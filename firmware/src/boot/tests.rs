use super::*;
use crate::flash_slot::FlashSlot;
use crate::store::RamFlash;

/// One flash: the record in sectors 0-1, slot A in 2-3, slot B in 4-5.
type Flash = RamFlash<1024, 6>;
const SEED: [u8; 32] = [1; 32];

fn key() -> [u8; PUBLIC_KEY_LEN] {
    salty::Keypair::from(&SEED).public.to_bytes()
}

fn image(board: Board, version: u32, seed: &[u8; 32]) -> Vec<u8> {
    let body: Vec<u8> = (0..700u32).map(|i| (i * 7 + version) as u8).collect();
    skin_protocol::image::sign(&body, board, version, seed).unwrap()
}

/// A cell's flash with `a` in slot A and `b` (if any) in slot B.
fn flash(a: &[u8], b: Option<&[u8]>) -> Flash {
    let mut f = Flash::default();
    f.write(2048, a).unwrap();
    if let Some(b) = b {
        f.write(4096, b).unwrap();
    }
    f
}

/// The bootloader at reset: record, slots and the slot it boots; the flash back.
fn reset(f: Flash) -> (Result<SlotId, BootError>, BootRecord, Flash) {
    // The three regions are views of one flash: read the slots from a copy
    // (the bootloader only reads them) and keep the record's writes.
    let slots = [FlashSlot::new(f.clone(), 2048, 2048).unwrap(), FlashSlot::new(f.clone(), 4096, 2048).unwrap()];
    let mut store = Store::<_, BootRecord>::open(f, 0, 2048).unwrap();
    let chosen = boot(&mut store, [&slots[0], &slots[1]], Board::Mps2An386, &key(), u32::MAX);
    let record = *store.state();
    (chosen, record, store.release())
}

/// The firmware keeping `record` (as on `BootAction`).
fn keep(f: Flash, record: BootRecord) -> Flash {
    let mut store = Store::<_, BootRecord>::open(f, 0, 2048).unwrap();
    store.set(record).unwrap();
    store.release()
}

#[test]
fn a_new_image_runs_on_trial_once_and_stays_when_confirmed() {
    let (chosen, record, f) = reset(flash(&image(Board::Mps2An386, 1, &SEED), None));
    assert_eq!((chosen, record.state()), (Ok(SlotId::A), BootState::Confirmed));
    // The update wrote version 2 to the spare slot; the firmware asks for a trial.
    assert_eq!(record.spare(), SlotId::B);
    let mut f = f;
    f.write(4096, &image(Board::Mps2An386, 2, &SEED)).unwrap();
    let (chosen, record, f) = reset(keep(f, record.request_trial(2)));
    assert_eq!((chosen, record.state(), record.running()), (Ok(SlotId::B), BootState::Trial, SlotId::B));
    let (chosen, record, _) = reset(keep(f, record.confirm()));
    assert_eq!(
        (chosen, record.state(), record.confirmed, record.spare()),
        (Ok(SlotId::B), BootState::Confirmed, SlotId::B, SlotId::A)
    );
}

#[test]
fn a_trial_not_confirmed_before_the_next_boot_is_rolled_back_for_good() {
    let f = flash(&image(Board::Mps2An386, 1, &SEED), Some(&image(Board::Mps2An386, 2, &SEED)));
    let (_, record, f) = reset(f);
    let (chosen, _, f) = reset(keep(f, record.request_trial(2)));
    assert_eq!(chosen, Ok(SlotId::B));
    // The trial image never confirms (crash, hang, timeout, rollback command).
    let (chosen, record, f) = reset(f);
    assert_eq!((chosen, record.state()), (Ok(SlotId::A), BootState::RolledBack { from: 2 }));
    let (chosen, again, _) = reset(f);
    assert_eq!((chosen, again), (Ok(SlotId::A), record), "stays on the old image");
}

#[test]
fn forged_foreign_truncated_or_other_version_images_are_never_booted() {
    let good = image(Board::Mps2An386, 1, &SEED);
    let mut truncated = image(Board::Mps2An386, 2, &SEED);
    truncated.truncate(500);
    let mut flipped = image(Board::Mps2An386, 2, &SEED);
    flipped[600] ^= 1;
    let bad = [
        image(Board::Mps2An386, 2, &[2; 32]),
        image(Board::Stm32f405, 2, &SEED),
        truncated,
        flipped,
        image(Board::Mps2An386, 3, &SEED),
    ];
    for spare in &bad {
        let (_, record, f) = reset(flash(&good, Some(spare)));
        let (chosen, after, _) = reset(keep(f, record.request_trial(2)));
        assert_eq!((chosen, after), (Ok(SlotId::A), record));
    }
}

#[test]
fn a_damaged_confirmed_image_falls_back_to_the_other_and_none_boots_nothing() {
    let good = image(Board::Mps2An386, 1, &SEED);
    let mut broken = good.clone();
    broken[300] ^= 0x80;
    let (chosen, record, _) = reset(flash(&broken, Some(&good)));
    assert_eq!((chosen, record.confirmed), (Ok(SlotId::B), SlotId::B));
    assert_eq!(reset(flash(&broken, None)).0, Err(BootError::NoImage));
}

#[test]
fn a_power_cut_at_any_step_of_the_boot_leaves_a_genuine_image_booted() {
    let f = flash(&image(Board::Mps2An386, 1, &SEED), Some(&image(Board::Mps2An386, 2, &SEED)));
    let (_, record, f) = reset(f);
    let asked = keep(f, record.request_trial(2));
    let mut cut_at = 0;
    loop {
        let mut f = asked.clone();
        f.cut_after(cut_at, 0x5A5A_5A5A ^ cut_at);
        let (chosen, _, mut f) = reset(f);
        let cut = !f.powered();
        f.power_on();
        let (next, record, _) = reset(f);
        assert!(chosen.is_ok() && next.is_ok(), "cut at step {cut_at}");
        // Either the trial began (its second boot rolls back) or it is asked again.
        match chosen {
            Ok(SlotId::B) => assert_eq!((next, record.state()), (Ok(SlotId::A), BootState::RolledBack { from: 2 })),
            _ => assert_eq!((next, record.state()), (Ok(SlotId::B), BootState::Trial), "cut at step {cut_at}"),
        }
        if !cut {
            break;
        }
        cut_at += 1;
    }
    assert!(cut_at > 10, "the record write was cut at each of its steps");
}
