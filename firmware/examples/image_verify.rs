//! A signed image checked on the cell's CPU, as a cell checks its slot
//! before booting it: the genuine image passes; one changed body bit, a
//! missing last byte and the wrong board are refused. The image was signed
//! with RFC 8032's TEST 1 key (`skin sign`), whose public key is below.
//!
//! Run under QEMU with `-icount shift=0` (one instruction per ns; SysTick at
//! 25 MHz counts one tick per 40 instructions), it prints the instructions
//! one verification of the 1 KiB body takes, and exits 0 when every verdict
//! is right. Its size beside the `panic` example is the verifier's flash cost.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use skin_firmware::boards::qemu::{exit, Ticks, INSTRUCTIONS_PER_TICK};
use skin_protocol::image::{Board, ImageError, ImageHeader, Verifier, HEADER_LEN};

static IMAGE: &[u8] = include_bytes!("data/rfc8032-test1.skfw");
/// RFC 8032 section 7.1, TEST 1: the public key.
const KEY: [u8; 32] = [
    0xd7, 0x5a, 0x98, 0x01, 0x82, 0xb1, 0x0a, 0xb7, 0xd5, 0x4b, 0xfe, 0xd3, 0xc9, 0x64, 0x07, 0x3a, 0x0e, 0xe1, 0x72,
    0xf3, 0xda, 0xa6, 0x23, 0x25, 0xaf, 0x02, 0x1a, 0x68, 0xf7, 0x07, 0x51, 0x1a,
];

/// Verifies the image's body as `pieces` give it, for a cell of `board`.
fn check<'a>(board: Board, pieces: impl IntoIterator<Item = &'a [u8]>) -> Result<ImageHeader, ImageError> {
    let header = ImageHeader::parse(IMAGE)?;
    let mut verifier = Verifier::new(&header, board, 60 * 1024, &KEY)?;
    for piece in pieces {
        verifier.absorb(piece)?;
    }
    verifier.finish()
}

#[entry]
fn main() -> ! {
    let Some(mut core) = cortex_m::Peripherals::take() else { exit(2) };
    let ticks = Ticks::start(&mut core.SYST);
    let body = &IMAGE[HEADER_LEN..];
    let (genuine, took) = ticks.count(|| check(Board::Mps2An386, body.chunks(256)));
    let instructions = took * INSTRUCTIONS_PER_TICK;

    let flipped = [body[100] ^ 0x08];
    let changed = check(Board::Mps2An386, [&body[..100], &flipped[..], &body[101..]]);
    let truncated = check(Board::Mps2An386, [&body[..body.len() - 1]]);
    let wrong_board = check(Board::Stm32f405, [body]);

    let right = genuine.is_ok_and(|h| h.version == 2 && h.body_len == 1024)
        && changed == Err(ImageError::BadDigest)
        && truncated == Err(ImageError::LengthMismatch { expected: 1024, found: 1023 })
        && wrong_board == Err(ImageError::WrongBoard { expected: Board::Stm32f405, found: Board::Mps2An386 });
    semihosting::println!(
        "image-verify: {}-byte body verified in {} instructions; verdicts {:?} {:?} {:?} {:?}",
        body.len(),
        instructions,
        genuine.map(|h| h.version),
        changed,
        truncated,
        wrong_board
    );
    exit(if right { 0 } else { 1 })
}
