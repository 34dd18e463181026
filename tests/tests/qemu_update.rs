//! Firmware updates of QEMU patches over the skin network: every cell runs
//! `cell-qemu` under `boot-qemu` with its flash file (store, boot record,
//! slots), so a killed QEMU is a power cut. They need the thumb build and
//! `qemu-system-arm`, so they are ignored by a plain `cargo test`:
//!
//! ```text
//! cargo build -p skin-firmware --profile firmware --target thumbv7em-none-eabihf --features qemu --bins
//! cargo test -p skin-tests --test qemu_update -- --ignored --skip twenty
//! cargo test -p skin-tests --test qemu_update -- --ignored twenty --nocapture   # the heavy run
//! ```
//!
//! One patch runs at a time (they share the machine's cores with nothing
//! else to spare).

use std::sync::{Mutex, MutexGuard};
use std::time::{Duration, Instant};

use skin_firmware::boot::{BootRecord, SlotId};
use skin_protocol::image::Board;
use skin_protocol::message::Refusal;
use skin_protocol::update::{Distributor, Outcome};
use skin_tests::qemu::default_elf_dir;
use skin_tests::qemu::flash::DEVELOPMENT_SEED;
use skin_tests::qemu::hang::{hanging_trial, HANGING_VERSION};
use skin_tests::qemu::update::{partly_written, Feed, Patch, Truncated, Unconfirmed};

static ONE_PATCH: Mutex<()> = Mutex::new(());

fn one_patch() -> MutexGuard<'static, ()> {
    ONE_PATCH.lock().unwrap_or_else(|e| e.into_inner())
}

fn start(n: usize) -> Patch {
    let patch = Patch::start(n, &default_elf_dir().join("cell-qemu")).unwrap_or_else(|e| panic!("{e}"));
    println!("{n} QEMU cells organized in {:.2} s, run directory {}", patch.organize_s, patch.dir().display());
    patch
}

/// The record of a cell that never took an update.
const UNTOUCHED: BootRecord = BootRecord { confirmed: SlotId::A, trial: None, failed: None };

fn all(feed: &dyn Feed, outcome: Outcome) {
    let outcomes = feed.outcomes();
    assert!(outcomes.iter().all(|(_, o)| *o == outcome), "want {outcome:?} everywhere: {outcomes:?}");
}

/// The patch updated to `image` (version 2): every record confirms slot B,
/// which holds the image byte for byte.
fn updated(patch: &Patch, image: &[u8]) {
    for i in 0..patch.len() {
        let record = patch.record(i).unwrap();
        assert_eq!(record, BootRecord { confirmed: SlotId::B, trial: None, failed: None }, "cell {i}");
        assert_eq!(&patch.slot(i, 1).unwrap()[..image.len()], image, "cell {i}'s slot B");
    }
}

#[test]
#[ignore]
fn seven_cells_are_updated_over_the_network_and_confirmed() {
    let _one = one_patch();
    let mut patch = start(7);
    let image = patch.programs().genuine(2);
    let mut dist = Distributor::new(&image, patch.ids.clone()).unwrap();
    let secs = patch.update(&mut dist, Duration::from_secs(900), &mut |_| Ok(())).unwrap_or_else(|e| panic!("{e}"));
    println!(
        "7 QEMU cells: version 2 ({} bytes, {} chunks) sent, booted on trial and confirmed in {secs:.2} s",
        image.len(),
        dist.chunk_count()
    );
    all(&dist, Outcome::Updated);
    updated(&patch, &image);
    patch.finish();
}

/// Where the kill test is.
#[derive(Clone, Copy)]
enum Kill {
    Waiting,
    Killed(Instant),
    Restarted(Instant),
    Heard,
}

#[test]
#[ignore]
fn a_cell_killed_while_writing_its_slot_boots_the_old_image_and_catches_up() {
    let _one = one_patch();
    let mut patch = start(7);
    let image = patch.programs().genuine(2);
    let victim = patch.len() - 1;
    let mut dist = Distributor::new(&image, patch.ids.clone()).unwrap();
    let mut kill = Kill::Waiting;
    let secs = patch
        .update(&mut dist, Duration::from_secs(900), &mut |p| {
            kill = match kill {
                Kill::Waiting if partly_written(&p.slot(victim, 1)?, &image, image.len() / 2) => {
                    p.kill(victim);
                    println!("cell {victim} killed with half its slot written");
                    Kill::Killed(Instant::now())
                }
                Kill::Killed(t) if t.elapsed() > Duration::from_millis(500) => {
                    assert_eq!(p.record(victim)?, UNTOUCHED, "a cut mid-write changes no boot record");
                    assert!(partly_written(&p.slot(victim, 1)?, &image, 0), "the slot was left half written");
                    p.restart(victim)?;
                    Kill::Restarted(Instant::now())
                }
                // Heard while its slot still lacks the image's end: it runs
                // the old image, the only one it has whole.
                Kill::Restarted(t) if p.heard_from(victim, t) => {
                    assert_eq!(p.record(victim)?, UNTOUCHED);
                    assert!(partly_written(&p.slot(victim, 1)?, &image, 0) || p.slot(victim, 1)?[0] == 0xFF);
                    println!("cell {victim} back on the old image after {:.2} s", t.elapsed().as_secs_f64());
                    Kill::Heard
                }
                other => other,
            };
            Ok(())
        })
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(matches!(kill, Kill::Heard), "the victim was killed, restarted and heard from");
    println!("7 QEMU cells, one killed mid-write: all on version 2 in {secs:.2} s");
    all(&dist, Outcome::Updated);
    updated(&patch, &image);
    patch.finish();
}

#[test]
#[ignore]
fn forged_foreign_and_truncated_images_are_refused_by_every_cell_and_nothing_changes() {
    let _one = one_patch();
    let mut patch = start(7);
    let factory = patch.programs().genuine(1);
    let forged = patch.programs().image(2, Board::Mps2An386, &[0x42; 32]);
    let foreign = patch.programs().image(3, Board::Stm32f405, &DEVELOPMENT_SEED);
    let genuine = patch.programs().genuine(4);
    let cases: Vec<(&str, Box<dyn Feed>, Refusal)> = vec![
        ("bad signature", Box::new(Distributor::new(&forged, patch.ids.clone()).unwrap()), Refusal::BadSignature),
        ("wrong board", Box::new(Distributor::new(&foreign, patch.ids.clone()).unwrap()), Refusal::WrongBoard),
        ("truncated body", Box::new(Truncated::new(&genuine, genuine.len() / 2, 4, &patch.ids)), Refusal::BadHeader),
    ];
    for (what, mut feed, refusal) in cases {
        let secs = patch
            .update(feed.as_mut(), Duration::from_secs(60), &mut |_| Ok(()))
            .unwrap_or_else(|e| panic!("{what}: {e}"));
        println!("{what}: refused ({refusal:?}) by all 7 cells in {secs:.2} s");
        all(feed.as_ref(), Outcome::Refused(refusal));
    }
    // Every cell still runs, organized with its ID; its boot record and
    // running image are as they were.
    patch.reorganized(Duration::from_secs(10)).unwrap_or_else(|e| panic!("{e}"));
    for i in 0..patch.len() {
        assert_eq!(patch.record(i).unwrap(), UNTOUCHED, "cell {i}");
        assert_eq!(&patch.slot(i, 0).unwrap()[..factory.len()], &factory[..], "cell {i}'s slot A");
    }
    patch.finish();
}

/// On 3 cells, one of them relaying the others' reports: a rollback is
/// each cell's own, and 7 took CI 86 s against 38.
#[test]
#[ignore]
fn an_image_never_confirmed_is_rolled_back_on_every_cell() {
    let _one = one_patch();
    let mut patch = start(3);
    let image = patch.programs().genuine(5);
    let mut feed = Unconfirmed(Distributor::new(&image, patch.ids.clone()).unwrap());
    let secs = patch.update(&mut feed, Duration::from_secs(900), &mut |_| Ok(())).unwrap_or_else(|e| panic!("{e}"));
    println!("3 QEMU cells: version 5 never confirmed, all back on version 1 in {secs:.2} s");
    all(&feed, Outcome::RolledBack);
    for i in 0..patch.len() {
        assert_eq!(patch.record(i).unwrap(), BootRecord { failed: Some(5), ..UNTOUCHED }, "cell {i}");
    }
    patch.finish();
}

/// A signed image that hangs at once (no crash, no exit) booted on trial:
/// the watchdog armed by the bootloader resets the cell, the bootloader
/// goes back to version 1 and refuses version 2, and version 1 runs on
/// (it feeds the watchdog: no further reset in 6 s, longer than the
/// watchdog's 4 s).
#[test]
#[ignore]
fn a_trial_image_that_hangs_is_reset_by_the_watchdog_and_rolled_back() {
    let _one = one_patch();
    let elf = default_elf_dir().join("cell-qemu");
    let report = hanging_trial(&elf, Duration::from_secs(60), Duration::from_secs(6)).unwrap_or_else(|e| panic!("{e}"));
    println!("hanging trial image rolled back after {:.2} s of wall time: {report:?}", report.rollback_s);
    assert_eq!(report.record, BootRecord { failed: Some(HANGING_VERSION), ..UNTOUCHED });
    assert_eq!(report.boots, 2, "the trial boot, the watchdog's reset, and no reset after: {report:?}");
    assert!(report.program_reports > 0, "version 1 ran its main loop after the rollback: {report:?}");
}

/// A small deterministic generator for the heavy run's choices.
struct Lcg(u64);

impl Lcg {
    fn below(&mut self, n: usize) -> usize {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((self.0 >> 33) % n as u64) as usize
    }
}

/// The heavy run: 20 cells, cells killed again and again while they write
/// their slots, each at a random byte, and restarted; every cell must end
/// on the new version.
#[test]
#[ignore]
fn twenty_cells_are_updated_through_repeated_kills_at_random_bytes() {
    let _one = one_patch();
    let mut patch = start(20);
    let image = patch.programs().genuine(2);
    let mut dist = Distributor::new(&image, patch.ids.clone()).unwrap();
    let mut rng = Lcg(18);
    let mut kills = 0;
    // The cell to kill next and the byte its slot must have reached; the
    // cell down and since when.
    let mut next = (1 + rng.below(19), rng.below(image.len()));
    let mut down: Option<(usize, Instant)> = None;
    let secs = patch
        .update(&mut dist, Duration::from_secs(1800), &mut |p| {
            match down {
                Some((i, t)) if t.elapsed() > Duration::from_millis(300 + 100 * rng.below(8) as u64) => {
                    assert_eq!(p.record(i)?.confirmed, SlotId::A, "cell {i}: a cut mid-write keeps the old image");
                    p.restart(i)?;
                    down = None;
                }
                None if kills < 8 && partly_written(&p.slot(next.0, 1)?, &image, next.1) => {
                    p.kill(next.0);
                    println!("kill {}: cell {} at byte {} of its slot", kills + 1, next.0, next.1);
                    kills += 1;
                    down = Some((next.0, Instant::now()));
                    next = (1 + rng.below(19), rng.below(image.len()));
                }
                _ => {}
            }
            Ok(())
        })
        .unwrap_or_else(|e| panic!("{e}"));
    println!("20 QEMU cells, {kills} kills mid-write: all on version 2 in {secs:.2} s");
    all(&dist, Outcome::Updated);
    updated(&patch, &image);
    patch.finish();
}
