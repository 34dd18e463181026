//! Resting cells: a cell that the stimulus leaves at rest, and whose
//! processing provably sends nothing, skips its samples and takes them in
//! one go when it wakes (see the module above).

use skin_protocol::processing::Processor;

use super::super::scheduler::Order;
use super::{Event, Network};

/// A cell rests only when it can skip at least this many samples.
const MIN_REST_SAMPLES: u64 = 2;

/// A cell skipping its samples at rest, until its sample event.
#[derive(Clone, Copy, Debug)]
pub(super) struct Rest {
    /// The first sample its processor has not taken.
    pub(super) next_ns: u64,
    /// The first sample not yet counted in [`Measurements::samples`].
    pub(super) count_ns: u64,
    /// The sampling period.
    pub(super) period_ns: u64,
}

impl Rest {
    /// How many skipped samples fall from `from_ns` through `through_ns`
    /// (and before the sample event at `end_ns`), and the first one after.
    pub(super) fn span(&self, from_ns: u64, through_ns: u64, end_ns: u64) -> (u64, u64) {
        let last = through_ns.min(end_ns.saturating_sub(1));
        if from_ns > last {
            return (0, from_ns);
        }
        let n = (last - from_ns) / self.period_ns + 1;
        (n, from_ns + n * self.period_ns)
    }
}

impl Network {
    /// Cell `i`'s processing, while it is powered.
    fn processor(&self, i: usize) -> &Processor {
        self.stacks[i].app.as_ref().expect("only powered cells sample").processor()
    }

    /// Schedules cell `i`'s next sample, one period after the one it just
    /// took; or, when it can rest, the sample that ends its rest (none when
    /// the stimulus never reaches it).
    pub(super) fn schedule_sample(&mut self, i: usize) {
        let now_ns = self.events.now_ns();
        let period_ns = self.processor(i).period_us() * 1000;
        let next_ns = now_ns + period_ns;
        let epoch = self.pulses[i].epoch;
        let Some(end_ns) = self.rest_end(i, next_ns, period_ns) else {
            self.pulses[i].sample_ns = next_ns;
            self.events.after_ranked(period_ns, i as u64, Event::Sample(i, epoch));
            return;
        };
        self.rests[i] = Some(Rest { next_ns, count_ns: next_ns, period_ns });
        self.resting += 1;
        self.pulses[i].sample_ns = end_ns;
        if end_ns < u64::MAX {
            // Where it would have been in a run without rests.
            let order = Order::ranked(end_ns, end_ns - period_ns, i as u64);
            self.events.at_order(order, Event::Sample(i, epoch));
        }
    }

    /// The sample at which cell `i` would wake when it rested from its
    /// sample at `next_ns` on (`u64::MAX`: never), or `None` when it cannot
    /// rest: its stimulus reaches it within a few samples, or its
    /// processor might send something at rest.
    pub(super) fn rest_end(&self, i: usize, next_ns: u64, period_ns: u64) -> Option<u64> {
        if !self.config.skip_resting_cells || !self.processor(i).may_be_silent() {
            return None;
        }
        let until_s = self.stimulus.rest_until(i, next_ns as f64 * 1e-9);
        // Rounding down: the rest ends no later than the stimulus says.
        let until_ns = if until_s.is_finite() { (until_s * 1e9) as u64 } else { u64::MAX };
        if until_ns < next_ns.saturating_add(MIN_REST_SAMPLES * period_ns) {
            return None;
        }
        let (lo, hi) = self.stimulus.rest_bounds(i);
        if !self.processor(i).silent_within(lo, hi) {
            return None;
        }
        let samples = (until_ns - next_ns).div_ceil(period_ns);
        Some(samples.checked_mul(period_ns).and_then(|d| d.checked_add(next_ns)).unwrap_or(u64::MAX))
    }

    /// The last time at which cell `i`'s skipped samples have been taken by
    /// now, as events in a run without rests would have been: a sample due
    /// in this very nanosecond only when it comes before the event taken last.
    pub(super) fn taken_through(&self, i: usize, r: &Rest) -> u64 {
        let now_ns = self.events.now_ns();
        let at_now = Order::ranked(now_ns, now_ns.saturating_sub(r.period_ns), i as u64);
        if self.events.is_done(at_now) {
            now_ns
        } else {
            now_ns.saturating_sub(1)
        }
    }

    /// How many of cell `i`'s skipped samples not counted yet, through
    /// `through_ns`, count in [`Measurements::samples`] (those of a cell
    /// with an ID that come after measuring began), and the first sample
    /// after them.
    pub(super) fn skipped_measured(&self, i: usize, r: &Rest, through_ns: u64) -> (u64, u64) {
        let end_ns = self.pulses[i].sample_ns;
        let (_, after) = r.span(r.count_ns, through_ns, end_ns);
        if !self.pulses[i].has_id {
            return (0, after);
        }
        let m = self.measure_from;
        let first = if r.count_ns > m.at_ns {
            r.count_ns
        } else {
            let t = r.count_ns + (m.at_ns - r.count_ns) / r.period_ns * r.period_ns;
            let later = Order::ranked(t, t.saturating_sub(r.period_ns), i as u64) > m;
            if t == m.at_ns && later {
                t
            } else {
                t + r.period_ns
            }
        };
        (r.span(first, through_ns, end_ns).0, after)
    }

    /// Counts the samples cell `i` skipped so far, if it rests.
    pub(super) fn count_skipped(&mut self, i: usize) {
        let Some(mut r) = self.rests[i] else { return };
        let (n, count_ns) = self.skipped_measured(i, &r, self.taken_through(i, &r));
        self.m.samples += n;
        r.count_ns = count_ns;
        self.rests[i] = Some(r);
    }

    /// Ends cell `i`'s rest: its processor takes the samples it skipped
    /// through `through_ns`, which provably send nothing; they are counted.
    pub(super) fn end_rest(&mut self, i: usize, r: Rest, through_ns: u64) -> u64 {
        let (measured, _) = self.skipped_measured(i, &r, through_ns);
        self.m.samples += measured;
        let (n, next_ns) = r.span(r.next_ns, through_ns, self.pulses[i].sample_ns);
        let mut stamp = self.stamper();
        let app = self.stacks[i].app.as_mut().expect("only powered cells rest");
        for _ in 0..n {
            let raw = self.stimulus.rest(i);
            app.sample(&raw, &mut stamp, |message, _| panic!("cell {i} sent {message:?} at rest"));
        }
        self.rests[i] = None;
        self.resting -= 1;
        next_ns
    }

    /// Wakes cell `i` if it rests, now: it takes the samples it skipped
    /// so far, and samples on from the next one.
    pub(super) fn wake(&mut self, i: usize) {
        let Some(r) = self.rests[i] else { return };
        let next_ns = self.end_rest(i, r, self.taken_through(i, &r));
        self.pulses[i].sample_ns = next_ns;
        let order = Order::ranked(next_ns, next_ns - r.period_ns, i as u64);
        self.events.at_order(order, Event::Sample(i, self.pulses[i].epoch));
    }
}
