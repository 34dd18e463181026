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

    /// An empty set over `0..len`, or `None` if `len` exceeds the capacity.
    pub fn new(len: u16) -> Option<Self> {
        (usize::from(len) <= Self::CAPACITY).then_some(Bitmap { words: [0; WORDS], len })
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
