//! A bounded FIFO whose bookkeeping is kept apart from its slots.
//!
//! A `heapless::Deque` keeps its indices behind its slots, so a router that
//! only asks its thirteen queues whether they hold anything reads thirteen
//! cache lines spread over kilobytes. A [`Ring`] is the two bytes of one
//! queue's bookkeeping: the router keeps all of them together, in front of
//! the slots, and a slot is touched only where a frame is.

/// The head and length of one queue over `N` slots held by the caller.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) struct Ring {
    head: u8,
    len: u8,
}

impl Ring {
    /// Items queued.
    pub(super) fn len(self) -> usize {
        usize::from(self.len)
    }

    /// True when nothing is queued.
    pub(super) fn is_empty(self) -> bool {
        self.len == 0
    }

    /// True when all `N` slots are taken.
    pub(super) fn is_full<T, const N: usize>(self, _: &[Option<T>; N]) -> bool {
        self.len() == N
    }

    /// Puts `item` at the back, or gives it back when the queue is full.
    pub(super) fn push_back<T, const N: usize>(&mut self, slots: &mut [Option<T>; N], item: T) -> Result<(), T> {
        const { assert!(N <= u8::MAX as usize, "a ring counts in bytes") };
        if self.len() == N {
            return Err(item);
        }
        slots[(usize::from(self.head) + self.len()) % N] = Some(item);
        self.len += 1;
        Ok(())
    }

    /// Takes the item at the front. Its slot keeps a copy, which the ring
    /// no longer reads (a later push overwrites it): no store to clear it.
    pub(super) fn pop_front<T: Copy, const N: usize>(&mut self, slots: &[Option<T>; N]) -> Option<T> {
        if self.len == 0 {
            return None;
        }
        let item = slots[usize::from(self.head)];
        // Below N, which fits a byte.
        self.head = ((usize::from(self.head) + 1) % N) as u8;
        self.len -= 1;
        item
    }

    /// Forgets every item (their slots are overwritten by later pushes).
    pub(super) fn clear(&mut self) {
        *self = Ring::default();
    }

    /// The items, front first.
    pub(super) fn iter<T, const N: usize>(self, slots: &[Option<T>; N]) -> impl Iterator<Item = &T> {
        (0..self.len()).filter_map(move |k| slots[(usize::from(self.head) + k) % N].as_ref())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// A ring over its slots is a FIFO of capacity N: the same items
        /// come out as from an unbounded queue that refuses past N.
        #[test]
        fn same_as_a_bounded_queue(ops in proptest::collection::vec(0u8..4, 1..300)) {
            let mut ring = Ring::default();
            let mut slots: [Option<u32>; 5] = Default::default();
            let mut model = std::collections::VecDeque::new();
            for (k, op) in (0u32..).zip(ops) {
                match op {
                    0 | 1 => {
                        let pushed = ring.push_back(&mut slots, k);
                        prop_assert_eq!(pushed.is_ok(), model.len() < 5);
                        if pushed.is_ok() {
                            model.push_back(k);
                        }
                    }
                    2 => prop_assert_eq!(ring.pop_front(&slots), model.pop_front()),
                    _ if k % 7 == 0 => {
                        ring.clear();
                        model.clear();
                    }
                    _ => {}
                }
                prop_assert_eq!(ring.len(), model.len());
                prop_assert_eq!(ring.is_full(&slots), model.len() == 5);
                prop_assert!(ring.iter(&slots).eq(model.iter()));
            }
        }
    }
}
