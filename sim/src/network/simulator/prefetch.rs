//! Asking the memory for a cell's state ahead of the frame that reads it.
//!
//! A 10,000-cell skin keeps 73 MB of cell state, far beyond the caches, and
//! every frame that reached a cell waited for that state from memory, line
//! after line: the cell's [`Pulse`], the organizer and the router's
//! bookkeeping (the first lines of its [`SimCell`]), and the first line of
//! its application, where `Option<CellApp>` keeps its niche (read by every
//! access to the application). Those misses were most of the run's time.
//! A frame goes on its wire 75 us before it arrives, so the simulator asks
//! for those lines then, and they wait in cache for it: 10,000 cells ran
//! 3.2-3.3 times real time per CPU second against 1.9-2.4 without. A skin
//! whose state fits in cache gains nothing and pays for the hints (HRP-2's
//! 74 cells, 0.5 MB: 1.02-1.04 CPU s for 100 virtual s against 0.96-1.00),
//! so only a larger one gets them ([`worth_it`]).
//!
//! A prefetch is a hint: it reads nothing and cannot fault, whatever the
//! address, so a layout that moves on only costs speed.

use std::mem::size_of;

use skin_protocol::cell::Cell;

use super::{Pulse, SimCell, Trace};

/// Lines from the start of a cell: the organizer (200 bytes), then the
/// router's bookkeeping, in front of its slots (see `Cell`). 8 measured as
/// fast as 12, 5 slower.
const CELL_LINES: usize = 8;

/// Where the application starts in a cell (`SimCell`, `CellApp` and `Cell`
/// are `repr(C)`, network stack first): its first field holds the niche.
const APP_AT: usize = size_of::<Cell<Trace>>();

/// Skins with more cell state than this get the hints: beyond the 1-2 MB
/// of a core's own cache.
const ABOVE_BYTES: usize = 2 << 20;

/// True when a skin of `cells` cells should get the hints.
pub(super) fn worth_it(cells: usize) -> bool {
    cells * (size_of::<SimCell>() + size_of::<Pulse>()) > ABOVE_BYTES
}

/// Asks for the lines of cell state that a frame reaching the cell reads.
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
pub(super) fn cell(pulse: &Pulse, cell: &SimCell) {
    use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
    let pulse = std::ptr::from_ref(pulse).cast::<i8>();
    let cell = std::ptr::from_ref(cell).cast::<i8>();
    let lines = (0..CELL_LINES).map(|k| cell.wrapping_add(64 * k));
    let pulse_lines = [pulse, pulse.wrapping_add(size_of::<Pulse>() - 1)];
    for at in lines.chain(pulse_lines).chain([cell.wrapping_add(APP_AT)]) {
        // SAFETY: a prefetch neither reads nor writes memory and does not
        // fault on any address; SSE is part of every x86-64.
        unsafe { _mm_prefetch::<_MM_HINT_T0>(at) };
    }
}

/// Elsewhere, nothing: the caches get no hint.
#[cfg(not(target_arch = "x86_64"))]
pub(super) fn cell(_: &Pulse, _: &SimCell) {}
