//! Which chunks of an image a cell has, one bit each.

/// A set of chunk indices below `WORDS * 32`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Bitmap<const WORDS: usize> {
    words: [u32; WORDS],
    len: u16,
}

impl<const WORDS: usize> Bitmap<WORDS> {
    /// Most indices a bitmap holds.
    pub const CAPACITY: usize = WORDS * 32;

    /// The set over nothing.
    pub const EMPTY: Self = Bitmap { words: [0; WORDS], len: 0 };

    /// Empties the set and makes it range over `0..len`, in place (a
    /// bitmap is most of a cell's update state: no copy on the stack);
    /// false, and unchanged, if `len` exceeds the capacity.
    pub fn reset(&mut self, len: u16) -> bool {
        if usize::from(len) > Self::CAPACITY {
            return false;
        }
        self.words = [0; WORDS];
        self.len = len;
        true
    }

    /// The indices the set ranges over.
    pub fn len(&self) -> u16 {
        self.len
    }

    /// True when the set ranges over nothing.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// True when `i` is in the set.
    pub fn has(&self, i: u16) -> bool {
        i < self.len && self.words[usize::from(i / 32)] & (1 << (i % 32)) != 0
    }

    /// Adds `i` (below `len`); returns true if it was new.
    pub fn insert(&mut self, i: u16) -> bool {
        if i >= self.len || self.has(i) {
            return false;
        }
        self.words[usize::from(i / 32)] |= 1 << (i % 32);
        true
    }

    /// The first missing index at or after `from`, and the span from it
    /// to the last missing index within `window` indices of it:
    /// `(start, span)`. Resending the span fills every gap in it, however
    /// scattered, for the price of the ones already there.
    pub fn first_missing(&self, from: u16, window: u16) -> Option<(u16, u16)> {
        let start = (from..self.len).find(|i| !self.has(*i))?;
        let end = start.saturating_add(window).min(self.len);
        let last = (start..end).rev().find(|i| !self.has(*i)).unwrap_or(start);
        Some((start, last - start + 1))
    }

    /// True when every index below `len` is in.
    pub fn is_full(&self) -> bool {
        self.first_missing(0, 1).is_none()
    }

    /// How many indices are in.
    pub fn count(&self) -> u32 {
        self.words.iter().map(|w| w.count_ones()).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_reset_empties_the_set_in_place_or_refuses_too_many() {
        let mut b = Bitmap::<2>::EMPTY;
        assert!(b.reset(40));
        assert!(b.insert(39) && b.has(39) && !b.insert(40));
        assert!(!b.reset(65), "64 indices at most");
        assert_eq!((b.len(), b.has(39)), (40, true), "unchanged");
        assert!(b.reset(64));
        assert_eq!((b.len(), b.has(39)), (64, false));
    }
}
