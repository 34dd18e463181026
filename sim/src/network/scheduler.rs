//! The event queue on the virtual clock: a calendar queue.
//!
//! Almost every event of a skin network is due within a few milliseconds
//! (a frame time, a sampling period, a probe period), so events go into a
//! ring of buckets of about a microsecond each, found through a bitmap;
//! the rare later ones wait in a heap until the ring reaches them. Taking
//! and adding an event costs the same however many are pending, and
//! events at the same time come out in the order they were scheduled, so
//! a run depends on nothing but its inputs and its seed.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// A bucket spans 2^10 ns.
const SHIFT: u32 = 10;
/// The ring holds 2^14 buckets: 16.8 ms ahead.
const RING: usize = 1 << 14;
const MASK: u64 = RING as u64 - 1;

/// An event with its time and sequence number.
#[derive(Debug)]
struct Item<E> {
    at_ns: u64,
    seq: u64,
    event: E,
}

impl<E> Item<E> {
    fn key(&self) -> (u64, u64) {
        (self.at_ns, self.seq)
    }
}

/// A later event in the heap, ordered by time and sequence only.
#[derive(Debug)]
struct Later<E>(Item<E>);

impl<E> PartialEq for Later<E> {
    fn eq(&self, other: &Self) -> bool {
        self.0.key() == other.0.key()
    }
}
impl<E> Eq for Later<E> {}
impl<E> PartialOrd for Later<E> {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl<E> Ord for Later<E> {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.0.key().cmp(&other.0.key())
    }
}

/// A queue of events of type `E`, ordered by virtual time in nanoseconds.
#[derive(Debug)]
pub struct Scheduler<E> {
    ring: Vec<Vec<Item<E>>>,
    /// One bit per non-empty bucket.
    full: Vec<u64>,
    /// The absolute bucket number the ring starts at.
    base: u64,
    /// The bucket kept sorted, latest first, while it is being drained.
    sorted: Option<u64>,
    later: BinaryHeap<Reverse<Later<E>>>,
    len: usize,
    seq: u64,
    now_ns: u64,
}

impl<E> Default for Scheduler<E> {
    fn default() -> Self {
        Scheduler {
            ring: (0..RING).map(|_| Vec::new()).collect(),
            full: vec![0; RING / 64],
            base: 0,
            sorted: None,
            later: BinaryHeap::new(),
            len: 0,
            seq: 0,
            now_ns: 0,
        }
    }
}

impl<E> Scheduler<E> {
    /// The time of the event taken last.
    pub fn now_ns(&self) -> u64 {
        self.now_ns
    }

    /// Schedules `event` at `at_ns`; a time in the past means now.
    pub fn at(&mut self, at_ns: u64, event: E) {
        let item = Item { at_ns: at_ns.max(self.now_ns), seq: self.seq, event };
        self.seq += 1;
        self.len += 1;
        self.place(item);
    }

    fn place(&mut self, item: Item<E>) {
        let bucket = item.at_ns >> SHIFT;
        if bucket >= self.base + RING as u64 {
            self.later.push(Reverse(Later(item)));
            return;
        }
        let slot = (bucket & MASK) as usize;
        let b = &mut self.ring[slot];
        if self.sorted == Some(bucket) {
            let key = item.key();
            let at = b.partition_point(|x| x.key() > key);
            b.insert(at, item);
        } else {
            b.push(item);
        }
        self.full[slot / 64] |= 1 << (slot % 64);
    }

    /// The first non-empty bucket of the ring, as an absolute number.
    fn first_bucket(&self) -> Option<u64> {
        let start = (self.base & MASK) as usize;
        for k in 0..=RING / 64 {
            let word = (start / 64 + k) % (RING / 64);
            let mut bits = self.full[word];
            if k == 0 {
                bits &= !0u64 << (start % 64);
            } else if k == RING / 64 {
                bits &= !(!0u64 << (start % 64));
            }
            if bits != 0 {
                let slot = word * 64 + bits.trailing_zeros() as usize;
                let ahead = (slot as u64).wrapping_sub(self.base & MASK) & MASK;
                return Some(self.base + ahead);
            }
        }
        None
    }

    /// Moves the ring to start at `bucket` and takes in the later events
    /// that now fall within it.
    fn move_to(&mut self, bucket: u64) {
        self.base = bucket;
        while let Some(Reverse(Later(first))) = self.later.peek() {
            if first.at_ns >> SHIFT >= self.base + RING as u64 {
                break;
            }
            let Some(Reverse(Later(item))) = self.later.pop() else { break };
            self.place(item);
        }
    }

    /// The first non-empty bucket of the ring, sorted latest first.
    fn first_sorted(&mut self) -> Option<u64> {
        let bucket = self.first_bucket()?;
        if self.sorted != Some(bucket) {
            self.ring[(bucket & MASK) as usize].sort_unstable_by_key(|x| Reverse(x.key()));
            self.sorted = Some(bucket);
        }
        Some(bucket)
    }

    /// The time of the next event.
    pub fn next_ns(&mut self) -> Option<u64> {
        match self.first_sorted() {
            Some(b) => self.ring[(b & MASK) as usize].last().map(|x| x.at_ns),
            None => self.later.peek().map(|x| x.0 .0.at_ns),
        }
    }

    /// Takes the next event if it is due at or before `until_ns`, and
    /// moves the clock to it.
    pub fn pop_until(&mut self, until_ns: u64) -> Option<E> {
        let item = match self.first_sorted() {
            Some(bucket) => {
                let slot = (bucket & MASK) as usize;
                if self.ring[slot].last()?.at_ns > until_ns {
                    return None;
                }
                let item = self.ring[slot].pop()?;
                if self.ring[slot].is_empty() {
                    self.full[slot / 64] &= !(1 << (slot % 64));
                }
                item
            }
            // Nothing in the ring: the next event is the heap's first.
            None => {
                if self.later.peek()?.0 .0.at_ns > until_ns {
                    return None;
                }
                self.later.pop()?.0 .0
            }
        };
        self.len -= 1;
        self.now_ns = item.at_ns;
        let bucket = item.at_ns >> SHIFT;
        if bucket != self.base {
            self.move_to(bucket);
        }
        Some(item.event)
    }

    /// Moves the clock to `t_ns` when no event comes before it.
    pub fn advance(&mut self, t_ns: u64) {
        if self.next_ns().is_none_or(|n| n >= t_ns) {
            self.now_ns = self.now_ns.max(t_ns);
        }
    }

    /// Events waiting.
    pub fn len(&self) -> usize {
        self.len
    }

    /// True when nothing is scheduled.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn time_order_then_schedule_order() {
        let mut s = Scheduler::default();
        s.at(30, 'c');
        s.at(10, 'a');
        s.at(30, 'd');
        s.at(10, 'b');
        assert_eq!(s.pop_until(5), None);
        let order: Vec<char> = std::iter::from_fn(|| s.pop_until(100)).collect();
        assert_eq!(order, ['a', 'b', 'c', 'd']);
        assert_eq!(s.now_ns(), 30);
        s.at(0, 'e');
        assert_eq!(s.next_ns(), Some(30), "the past is now");
        s.advance(50);
        assert_eq!(s.now_ns(), 30, "the clock does not skip a due event");
        s.pop_until(100);
        s.advance(50);
        assert_eq!(s.now_ns(), 50);
        assert!(s.is_empty());
    }

    proptest! {
        /// The calendar queue gives the events of a plain sorted list, in
        /// the same order, for delays from nanoseconds to many ring turns.
        #[test]
        fn same_order_as_a_sorted_list(
            ops in proptest::collection::vec((0u64..4, 0u64..60_000_000, 0u64..3_000_000), 1..400)
        ) {
            let mut s = Scheduler::default();
            let mut model: Vec<(u64, u64)> = Vec::new();
            let mut seq = 0;
            for (op, delay, horizon) in ops {
                if op == 0 {
                    let until = s.now_ns() + horizon;
                    model.sort();
                    while let Some(e) = s.pop_until(until) {
                        let (t, q) = model.remove(0);
                        prop_assert_eq!((e, s.now_ns()), (q, t));
                    }
                    prop_assert!(model.first().is_none_or(|(t, _)| *t > until));
                    s.advance(until);
                } else {
                    // Mostly short delays, some long ones.
                    let at = s.now_ns() + if op == 1 { delay } else { delay % 5_000 };
                    s.at(at, seq);
                    model.push((at, seq));
                    seq += 1;
                }
                prop_assert_eq!(s.len(), model.len());
            }
        }
    }
}
