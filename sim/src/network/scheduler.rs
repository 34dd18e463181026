//! The event queue on the virtual clock.
//!
//! Events at the same time come out in the order they were scheduled, so a
//! run depends on nothing but its inputs and its seed.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// Bits of a heap key's second word that hold the slot index.
const SLOT_BITS: u32 = 24;

/// A queue of events of type `E`, ordered by virtual time in nanoseconds.
///
/// The heap holds only 16-byte keys (time, then sequence number and slot);
/// the events wait in a slab, so sifting moves no event.
#[derive(Debug)]
pub struct Scheduler<E> {
    heap: BinaryHeap<Reverse<(u64, u64)>>,
    slots: Vec<Option<E>>,
    free: Vec<u32>,
    seq: u64,
    now_ns: u64,
}

impl<E> Default for Scheduler<E> {
    fn default() -> Self {
        Scheduler { heap: BinaryHeap::new(), slots: Vec::new(), free: Vec::new(), seq: 0, now_ns: 0 }
    }
}

impl<E> Scheduler<E> {
    /// The time of the event taken last.
    pub fn now_ns(&self) -> u64 {
        self.now_ns
    }

    /// Schedules `event` at `at_ns`; a time in the past means now.
    pub fn at(&mut self, at_ns: u64, event: E) {
        let slot = match self.free.pop() {
            Some(s) => {
                self.slots[s as usize] = Some(event);
                s
            }
            None => {
                self.slots.push(Some(event));
                (self.slots.len() - 1) as u32
            }
        };
        assert!(slot < 1 << SLOT_BITS, "more than 16 million events pending");
        self.heap.push(Reverse((at_ns.max(self.now_ns), self.seq << SLOT_BITS | u64::from(slot))));
        self.seq += 1;
    }

    /// The time of the next event.
    pub fn next_ns(&self) -> Option<u64> {
        self.heap.peek().map(|Reverse((t, _))| *t)
    }

    /// Takes the next event if it is due at or before `until_ns`, and
    /// moves the clock to it.
    pub fn pop_until(&mut self, until_ns: u64) -> Option<E> {
        if self.next_ns()? > until_ns {
            return None;
        }
        let Reverse((t, key)) = self.heap.pop()?;
        self.now_ns = t;
        let slot = (key & ((1 << SLOT_BITS) - 1)) as u32;
        self.free.push(slot);
        self.slots[slot as usize].take()
    }

    /// Moves the clock to `t_ns` when no event comes before it.
    pub fn advance(&mut self, t_ns: u64) {
        if self.next_ns().is_none_or(|n| n >= t_ns) {
            self.now_ns = self.now_ns.max(t_ns);
        }
    }

    /// Events waiting.
    pub fn len(&self) -> usize {
        self.heap.len()
    }

    /// True when nothing is scheduled.
    pub fn is_empty(&self) -> bool {
        self.heap.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
    }
}
