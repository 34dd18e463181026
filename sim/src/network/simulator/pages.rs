//! The cell state of a large skin on 2 MiB pages.
//!
//! A 10,000-cell skin keeps 73 MB of cell state: on 4 KiB pages that is
//! 18,000 pages, far more than a core's TLB maps, so a frame reaching a
//! cell also walked the page tables for it. On transparent huge pages the
//! same state is 37 pages. Linux gives them to a range that asks
//! (`madvise(MADV_HUGEPAGE)`, honoured when
//! `/sys/kernel/mm/transparent_hugepage/enabled` says `always` or
//! `madvise`): the 10,000-cell bench ran 3.33-3.79 times real time against
//! 2.84-3.66 without (eight runs each, in turn), and varies less.
//! Elsewhere, or when the kernel declines, only speed changes.

/// A huge page.
#[cfg(target_os = "linux")]
const HUGE: usize = 2 << 20;

/// Asks for huge pages under `v`'s buffer, best before anything is written
/// to it: the kernel then backs each whole 2 MiB of it with one page as it
/// is first touched. A buffer smaller than that is left as it is.
#[cfg(target_os = "linux")]
#[allow(unsafe_code)]
pub(super) fn huge<T>(v: &Vec<T>) {
    let start = v.as_ptr() as usize;
    let end = start + v.capacity() * size_of::<T>();
    let (first, last) = (start.next_multiple_of(HUGE), end / HUGE * HUGE);
    if last > first {
        // SAFETY: advice on whole pages inside our own allocation; it
        // changes neither their contents nor whether they may be accessed.
        // A kernel that declines returns an error, which changes nothing.
        unsafe { libc::madvise(first as *mut libc::c_void, last - first, libc::MADV_HUGEPAGE) };
    }
}

/// Elsewhere, nothing.
#[cfg(not(target_os = "linux"))]
pub(super) fn huge<T>(_: &Vec<T>) {}
