//! Where every frame went.
//!
//! Two books are kept. The upstream book follows each frame a cell sends
//! toward the host from the moment it enters the cell's own queue: it is
//! delivered, dropped with a reason, or still in the network (queued or on
//! a wire), and the three always add up. The wire book counts every frame
//! put on any wire: received, rejected as corrupt, accepted although
//! corrupted, lost, or still on the wire.

use serde::Serialize;

/// Why a frame on its way to the host was lost.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum DropReason {
    /// A router queue was full.
    QueueFull,
    /// The tree changed under it (it met a master port, or its queue was
    /// cleared when its input became the master port).
    Reroute,
    /// Sent on a port whose link is cut.
    NoLink,
    /// Its cell died or rebooted, or it was sent to a dead cell.
    DeadCell,
    /// Its interface port died.
    DeadInterface,
    /// Bit errors on a wire; the receiver's CRC rejected it.
    Corrupt,
}

impl DropReason {
    /// Every reason, in report order.
    pub const ALL: [DropReason; 6] = [
        DropReason::QueueFull,
        DropReason::Reroute,
        DropReason::NoLink,
        DropReason::DeadCell,
        DropReason::DeadInterface,
        DropReason::Corrupt,
    ];
}

/// Drops by reason, as reported.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Drops {
    /// A router queue was full.
    pub queue_full: u64,
    /// The tree changed under the frame.
    pub reroute: u64,
    /// The link was cut.
    pub no_link: u64,
    /// A cell died or rebooted.
    pub dead_cell: u64,
    /// An interface port died.
    pub dead_interface: u64,
    /// Rejected by a CRC.
    pub corrupt: u64,
}

impl Drops {
    fn slot(&mut self, reason: DropReason) -> &mut u64 {
        match reason {
            DropReason::QueueFull => &mut self.queue_full,
            DropReason::Reroute => &mut self.reroute,
            DropReason::NoLink => &mut self.no_link,
            DropReason::DeadCell => &mut self.dead_cell,
            DropReason::DeadInterface => &mut self.dead_interface,
            DropReason::Corrupt => &mut self.corrupt,
        }
    }

    /// All drops.
    pub fn total(&self) -> u64 {
        self.queue_full + self.reroute + self.no_link + self.dead_cell + self.dead_interface + self.corrupt
    }
}

/// Counts of the two books.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Ledger {
    /// Upstream frames that entered a cell's own queue.
    pub entered: u64,
    /// Upstream frames that reached the host.
    pub delivered: u64,
    /// Upstream frames lost, by reason.
    pub dropped: Drops,
    /// Of those, sensor frames (samples and tactile events).
    pub sensor_dropped: u64,
    /// Own messages a cell could not queue at all (its own queue was full).
    pub refused_at_source: u64,
    /// Frames put on any wire by cells and interface ports.
    pub transmitted: u64,
    /// Frames that arrived at a live receiver on a connected wire.
    pub received: u64,
    /// Frames sent into a free or cut port.
    pub lost_no_link: u64,
    /// Frames sent to a dead cell or interface port.
    pub lost_dead_receiver: u64,
    /// Received frames the CRC (or payload check) rejected.
    pub corrupt_rejected: u64,
    /// Received frames with flipped bits that were nevertheless accepted.
    pub corrupt_accepted: u64,
    /// Frames of any kind in a cell's queues when it died or rebooted.
    pub lost_at_power_off: u64,
    /// Frames from the host that an interface port had no room for, or
    /// that were corrupt or sent to a dead port.
    pub host_frames_refused: u64,
}

impl Ledger {
    /// Books `n` upstream frames as lost, `sensor` of them sensor frames.
    pub fn drop_upstream(&mut self, reason: DropReason, n: u64, sensor: u64) {
        *self.dropped.slot(reason) += n;
        self.sensor_dropped += sensor;
    }

    /// True when the upstream book adds up, given the upstream frames still
    /// in the network and the wire book adds up, given the frames still on
    /// wires.
    pub fn balanced(&self, upstream_in_network: u64, on_wires: u64) -> bool {
        self.entered == self.delivered + self.dropped.total() + upstream_in_network
            && self.transmitted == self.received + self.lost_no_link + self.lost_dead_receiver + on_wires
    }
}

/// Latencies in microseconds: exact below 100 ms, the maximum exact always.
#[derive(Clone, Debug)]
pub struct Histogram {
    counts: Vec<u64>,
    n: u64,
    max_us: u64,
}

impl Default for Histogram {
    fn default() -> Self {
        Histogram { counts: vec![0; Self::EXACT_US], n: 0, max_us: 0 }
    }
}

/// Quantiles of a [`Histogram`], in microseconds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Quantiles {
    /// Median.
    pub p50: u64,
    /// 99th percentile.
    pub p99: u64,
    /// Largest.
    pub max: u64,
    /// How many values.
    pub count: u64,
}

/// The smallest value with at least fraction `q` of all `total` values at
/// or below it, from (value, count) pairs, smallest value first; `None`
/// when they hold fewer values than that.
pub fn quantile(counts: impl IntoIterator<Item = (u64, u64)>, total: u64, q: f64) -> Option<u64> {
    let rank = ((q * total as f64).ceil() as u64).max(1);
    let mut seen = 0;
    counts
        .into_iter()
        .find(|(_, n)| {
            seen += n;
            seen >= rank
        })
        .map(|(value, _)| value)
}

impl Histogram {
    const EXACT_US: usize = 100_000;

    /// Adds one value.
    pub fn record(&mut self, us: u64) {
        self.counts[(us as usize).min(Self::EXACT_US - 1)] += 1;
        self.n += 1;
        self.max_us = self.max_us.max(us);
    }

    /// The smallest value with at least fraction `q` of all values at or
    /// below it (values of 100 ms and more count as 100 ms).
    fn quantile(&self, q: f64) -> u64 {
        quantile(self.counts(), self.n, q).map_or(self.max_us, |us| us.min(self.max_us))
    }

    /// Every latency recorded and how often, in microseconds, smallest
    /// first, leaving out those never seen (values of 100 ms and more
    /// count as 100 ms less 1 us).
    pub fn counts(&self) -> impl Iterator<Item = (u64, u64)> + '_ {
        (0u64..).zip(self.counts.iter().copied()).filter(|(_, c)| *c > 0)
    }

    /// Median, 99th percentile, maximum and count (all 0 when empty).
    pub fn quantiles(&self) -> Quantiles {
        if self.n == 0 {
            return Quantiles::default();
        }
        Quantiles { p50: self.quantile(0.5), p99: self.quantile(0.99), max: self.max_us, count: self.n }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_of_known_values() {
        let mut h = Histogram::default();
        assert_eq!(h.quantiles(), Quantiles::default());
        for us in 1..=100 {
            h.record(us);
        }
        h.record(250_000);
        let q = h.quantiles();
        assert_eq!((q.p50, q.p99, q.max, q.count), (51, 100, 250_000, 101));
        let counts: Vec<(u64, u64)> = h.counts().collect();
        assert_eq!((counts.len(), counts[0], counts[100]), (101, (1, 1), (99_999, 1)));
    }

    #[test]
    fn books_balance_only_when_every_frame_is_accounted() {
        let mut l =
            Ledger { entered: 10, delivered: 6, transmitted: 20, received: 17, lost_no_link: 2, ..Ledger::default() };
        l.drop_upstream(DropReason::Reroute, 3, 1);
        assert!(l.balanced(1, 1));
        assert!(!l.balanced(0, 1), "one upstream frame vanished");
        assert!(!l.balanced(1, 0), "one frame vanished from a wire");
    }
}
