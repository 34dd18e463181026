//! Rate limiting of log lines, so a flood of bad datagrams costs a few
//! lines a second, not a line each; the counters keep the exact numbers.

/// Lines allowed per reason in each window.
pub const LINES_PER_WINDOW: u32 = 5;
/// Length of a window.
pub const WINDOW_US: u64 = 1_000_000;

/// The log budget of one reason.
#[derive(Clone, Copy, Debug, Default)]
pub struct RateLimit {
    window_start_us: u64,
    lines: u32,
    suppressed: u64,
}

impl RateLimit {
    /// `Some(n)` when a line may be written at `now_us`, with the number of
    /// lines suppressed since the last one written; `None` to stay quiet.
    pub fn allow(&mut self, now_us: u64) -> Option<u64> {
        if now_us >= self.window_start_us.saturating_add(WINDOW_US) {
            self.window_start_us = now_us;
            self.lines = 0;
        }
        if self.lines < LINES_PER_WINDOW {
            self.lines += 1;
            Some(std::mem::take(&mut self.suppressed))
        } else {
            self.suppressed += 1;
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_flood_is_cut_to_a_few_lines_and_the_rest_is_counted() {
        let mut r = RateLimit::default();
        let allowed: Vec<_> = (0..1000).filter_map(|i| r.allow(i)).collect();
        assert_eq!(allowed, vec![0; LINES_PER_WINDOW as usize]);
        assert_eq!(r.allow(WINDOW_US + 5), Some(1000 - u64::from(LINES_PER_WINDOW)));
        assert_eq!(r.allow(WINDOW_US + 6), Some(0));
    }
}
