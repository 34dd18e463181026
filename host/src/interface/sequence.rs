//! Loss, duplication and reordering of one interface port's datagrams,
//! seen through the datagram sequence number.
//!
//! A sliding window over the last [`WINDOW`] sequence numbers, as in IPsec
//! replay protection: a number ahead of the highest one seen moves the window
//! (the numbers it skips are missing until they turn up late), a number in
//! the window is either late (first time) or a duplicate (seen), and a number
//! behind the window cannot be told from a duplicate, so it is dropped as
//! stale. An interface port that restarts begins again at a small number:
//! a run of stale datagrams, or a jump far outside the window, restarts the
//! window instead of dropping the port's traffic for good.

/// Sequence numbers remembered behind the highest one seen.
pub const WINDOW: u32 = 64;
/// A jump farther than this, either way, is a restart of the sender.
pub const RESTART_JUMP: u32 = 1 << 16;
/// This many stale datagrams in a row are a restart of the sender.
pub const RESTART_STALE_RUN: u32 = 8;

/// What one sequence number means.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// New, and the next one or ahead of it; `skipped` numbers in between
    /// are now missing.
    Ahead {
        /// Numbers jumped over.
        skipped: u32,
    },
    /// New but behind the highest: it fills a gap counted as missing.
    Late,
    /// Seen before: drop it.
    Duplicate,
    /// Too far behind to tell: drop it.
    Stale,
    /// The sender started over (first datagram, or a restart): the window
    /// begins at this number and nothing is counted missing.
    Restart,
}

impl Verdict {
    /// True when the datagram is to be processed.
    pub fn accepts(self) -> bool {
        !matches!(self, Verdict::Duplicate | Verdict::Stale)
    }
}

/// The receive window of one port.
#[derive(Clone, Copy, Debug, Default)]
pub struct SeqWindow {
    /// Highest number accepted, once one was.
    top: Option<u32>,
    /// Bit `i` set: number `top - i` was seen.
    seen: u64,
    stale_run: u32,
}

impl SeqWindow {
    /// Classifies `seq` and remembers it when accepted.
    pub fn observe(&mut self, seq: u32) -> Verdict {
        let Some(top) = self.top else { return self.restart(seq) };
        let ahead = seq.wrapping_sub(top);
        let behind = top.wrapping_sub(seq);
        if ahead != 0 && ahead <= RESTART_JUMP {
            self.stale_run = 0;
            self.seen = if ahead >= 64 { 0 } else { self.seen << ahead };
            self.seen |= 1;
            self.top = Some(seq);
            return Verdict::Ahead { skipped: ahead - 1 };
        }
        if behind < WINDOW {
            self.stale_run = 0;
            let bit = 1u64 << behind;
            if self.seen & bit != 0 {
                return Verdict::Duplicate;
            }
            self.seen |= bit;
            return Verdict::Late;
        }
        if behind <= RESTART_JUMP {
            self.stale_run += 1;
            if self.stale_run < RESTART_STALE_RUN {
                return Verdict::Stale;
            }
        }
        self.restart(seq)
    }

    fn restart(&mut self, seq: u32) -> Verdict {
        *self = SeqWindow { top: Some(seq), seen: 1, stale_run: 0 };
        Verdict::Restart
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn run(seqs: &[u32]) -> Vec<Verdict> {
        let mut w = SeqWindow::default();
        seqs.iter().map(|s| w.observe(*s)).collect()
    }

    #[test]
    fn in_order_loss_duplicates_and_late_arrivals() {
        use Verdict::*;
        assert_eq!(
            run(&[10, 11, 13, 11, 12, 12, 14]),
            [Restart, Ahead { skipped: 0 }, Ahead { skipped: 1 }, Duplicate, Late, Duplicate, Ahead { skipped: 0 }]
        );
    }

    #[test]
    fn wraps_around_u32() {
        use Verdict::*;
        assert_eq!(
            run(&[u32::MAX - 1, u32::MAX, 0, 1]),
            [Restart, Ahead { skipped: 0 }, Ahead { skipped: 0 }, Ahead { skipped: 0 }]
        );
    }

    #[test]
    fn a_sender_restart_is_followed() {
        let mut w = SeqWindow::default();
        for s in 0..5000 {
            w.observe(s);
        }
        // Restarted at 0: stale until the run proves it is a restart.
        let verdicts: Vec<_> = (0..RESTART_STALE_RUN + 2).map(|s| w.observe(s)).collect();
        assert!(verdicts[..RESTART_STALE_RUN as usize - 1].iter().all(|v| *v == Verdict::Stale));
        assert_eq!(verdicts[RESTART_STALE_RUN as usize - 1], Verdict::Restart);
        assert_eq!(verdicts[RESTART_STALE_RUN as usize], Verdict::Ahead { skipped: 0 });
        // A jump far away is a restart at once.
        assert_eq!(w.observe(3_000_000_000), Verdict::Restart);
    }

    proptest! {
        /// Any permutation with duplicates of a window-sized stretch: every
        /// number is accepted exactly once, and what is missing at the end is
        /// exactly what never came.
        #[test]
        fn each_number_is_accepted_once(
            start in any::<u32>(),
            picks in proptest::collection::vec(0u32..48, 1..200),
        ) {
            let mut w = SeqWindow::default();
            let first = w.observe(start);
            prop_assert_eq!(first, Verdict::Restart);
            let mut accepted = std::collections::BTreeSet::from([0u32]);
            let mut missing: i64 = 0;
            for p in &picks {
                match w.observe(start.wrapping_add(*p)) {
                    Verdict::Ahead { skipped } => { missing += i64::from(skipped); prop_assert!(accepted.insert(*p)); }
                    Verdict::Late => { missing -= 1; prop_assert!(accepted.insert(*p)); }
                    Verdict::Duplicate => prop_assert!(accepted.contains(p)),
                    v => prop_assert!(false, "unexpected {:?}", v),
                }
            }
            let top = *accepted.iter().max().unwrap();
            prop_assert_eq!(missing, i64::from(top + 1) - accepted.len() as i64);
        }
    }
}
