//! The event queue on the virtual clock: fixed-delay lanes in front of a
//! calendar queue.
//!
//! Most events of a skin network are due a fixed time after they are
//! scheduled: a frame arrives a frame time (plus processing) after it left,
//! a cell samples again one period after it sampled. Scheduled with
//! [`Scheduler::after`], such events go into a FIFO lane per delay: since
//! the clock never runs back, each lane is already in time order, and
//! adding or taking one touches only the lane's ends. Every other event
//! goes into a ring of buckets of 262 us each, found through a bitmap; the
//! rare later ones wait in a heap until the ring reaches them. The next event is the earliest of the lanes' heads and the
//! ring's. Events due at the same time come out in the order they were
//! scheduled, so a run depends on nothing but its inputs and its seed; an
//! event may instead be given a rank, which puts it first among those
//! scheduled at the same time (see [`Order`]), so that its place does not
//! depend on what else was scheduled before it. An event can also be
//! scheduled as if it had been scheduled earlier: its place is then the
//! one it would have had, so a caller may skip events and schedule only the
//! last of a chain without changing the order of anything else.

use std::cmp::Reverse;
use std::collections::{BinaryHeap, VecDeque};

/// A bucket spans 2^18 ns (262 us). Few wide buckets beat many narrow
/// ones: the ring's 256 bucket headers stay in cache, where 16,384 buckets
/// of 4 us cost a cache miss on every event placed or taken (most events
/// placed are wake-ups 10-35 ms ahead); a bucket is sorted once, when the
/// clock reaches it (HRP-2 clock-driven 0.97-0.99 against 1.08-1.14 CPU s
/// for 100 virtual s; 10,000 cells not slower).
const SHIFT: u32 = 18;
/// The ring holds 2^8 buckets: 67 ms ahead, past the 15-35 ms wave, route
/// and link timeouts that every cell of a settled skin keeps re-arming (in
/// the heap, they cost a fifth of a 10,000-cell run's time).
const RING: usize = 1 << 8;
const MASK: u64 = RING as u64 - 1;
/// Fixed delays with a lane of their own; further delays share the ring.
const LANES: usize = 8;

/// Where an event stands in the queue: by the time it is due; among
/// events due at the same time, by the time it was scheduled; among those
/// scheduled at the same time too, events with a rank first, by rank, and
/// then the others in the order they were scheduled.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Order {
    /// When the event is due.
    pub at_ns: u64,
    /// When it was (or is taken to have been) scheduled.
    pub scheduled_ns: u64,
    /// Its rank, or [`UNRANKED`] plus its sequence number.
    tie: u64,
}

/// Ties of unranked events start here; ranks stay below.
const UNRANKED: u64 = 1 << 63;

impl Order {
    /// The place of an event due at `at_ns`, scheduled at `scheduled_ns`
    /// with rank `rank` (below 2^63).
    pub fn ranked(at_ns: u64, scheduled_ns: u64, rank: u64) -> Order {
        debug_assert!(rank < UNRANKED);
        Order { at_ns, scheduled_ns, tie: rank }
    }

    /// After every event due at or before `t_ns`.
    fn end_of(t_ns: u64) -> Order {
        Order { at_ns: t_ns, scheduled_ns: u64::MAX, tie: u64::MAX }
    }
}

/// An event with its place.
#[derive(Debug)]
struct Item<E> {
    order: Order,
    event: E,
}

impl<E> Item<E> {
    fn key(&self) -> Order {
        self.order
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

/// The ring of buckets and the heap behind it: events in any order.
#[derive(Debug)]
struct Calendar<E> {
    ring: Vec<Vec<Item<E>>>,
    /// One bit per non-empty bucket.
    full: Vec<u64>,
    /// The absolute bucket number the ring starts at; no event is earlier.
    base: u64,
    /// The bucket kept sorted, latest first, while it is being drained.
    sorted: Option<u64>,
    later: BinaryHeap<Reverse<Later<E>>>,
    /// The key of the earliest event, when known: `Some(None)` when empty.
    first: Option<Option<Order>>,
}

impl<E> Default for Calendar<E> {
    fn default() -> Self {
        Calendar {
            ring: (0..RING).map(|_| Vec::new()).collect(),
            full: vec![0; RING / 64],
            base: 0,
            sorted: None,
            later: BinaryHeap::new(),
            first: Some(None),
        }
    }
}

impl<E> Calendar<E> {
    fn place(&mut self, item: Item<E>) {
        if let Some(first) = self.first {
            if first.is_none_or(|k| item.key() < k) {
                self.first = Some(Some(item.key()));
            }
        }
        let bucket = item.order.at_ns >> SHIFT;
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

    /// Moves the ring to start at `bucket` (no event may be earlier) and
    /// takes in the later events that now fall within it.
    fn move_to(&mut self, bucket: u64) {
        if bucket == self.base {
            return;
        }
        self.base = bucket;
        while let Some(Reverse(Later(first))) = self.later.peek() {
            if first.order.at_ns >> SHIFT >= self.base + RING as u64 {
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

    /// The place of the earliest event.
    fn first_key(&mut self) -> Option<Order> {
        if let Some(first) = self.first {
            return first;
        }
        let first = match self.first_sorted() {
            Some(b) => self.ring[(b & MASK) as usize].last().map(Item::key),
            None => self.later.peek().map(|x| x.0 .0.key()),
        };
        self.first = Some(first);
        first
    }

    /// Takes the earliest event.
    fn pop(&mut self) -> Option<Item<E>> {
        self.first = None;
        let Some(bucket) = self.first_sorted() else {
            return self.later.pop().map(|x| x.0 .0);
        };
        let slot = (bucket & MASK) as usize;
        let item = self.ring[slot].pop()?;
        if self.ring[slot].is_empty() {
            self.full[slot / 64] &= !(1 << (slot % 64));
        }
        Some(item)
    }
}

/// The key of an empty lane's head: later than any event.
const NONE: Order = Order { at_ns: u64::MAX, scheduled_ns: u64::MAX, tie: u64::MAX };

/// A queue of events of type `E`, ordered by virtual time in nanoseconds.
#[derive(Debug)]
pub struct Scheduler<E> {
    /// Events due a fixed delay after they were scheduled, in time order:
    /// the delays, the events, and the key of each lane's first event.
    delays: Vec<u64>,
    lanes: Vec<VecDeque<Item<E>>>,
    heads: [Order; LANES],
    calendar: Calendar<E>,
    len: usize,
    seq: u64,
    now_ns: u64,
    /// Every event up to this place has been taken.
    done: Order,
}

impl<E> Default for Scheduler<E> {
    fn default() -> Self {
        Scheduler {
            delays: Vec::new(),
            lanes: Vec::new(),
            heads: [NONE; LANES],
            calendar: Calendar::default(),
            len: 0,
            seq: 0,
            now_ns: 0,
            done: Order { at_ns: 0, scheduled_ns: 0, tie: 0 },
        }
    }
}

impl<E> Scheduler<E> {
    /// The time of the event taken last.
    pub fn now_ns(&self) -> u64 {
        self.now_ns
    }

    /// An unranked event due at `at_ns` (the past means now), scheduled now.
    fn item(&mut self, at_ns: u64, event: E) -> Item<E> {
        let tie = UNRANKED + self.seq;
        self.seq += 1;
        self.len += 1;
        Item { order: Order { at_ns: at_ns.max(self.now_ns), scheduled_ns: self.now_ns, tie }, event }
    }

    /// Schedules `event` at `at_ns`; a time in the past means now.
    pub fn at(&mut self, at_ns: u64, event: E) {
        let item = self.item(at_ns, event);
        self.calendar.place(item);
    }

    /// Schedules `event` at the place `order`, which must be later than the
    /// event taken last: an event with a rank, and perhaps taken to have
    /// been scheduled at another time than now.
    pub fn at_order(&mut self, order: Order, event: E) {
        debug_assert!(order > self.done && order.at_ns >= self.now_ns, "{order:?} is past");
        self.len += 1;
        self.calendar.place(Item { order, event });
    }

    /// Schedules `event` `delay_ns` from now. Use it for the delays that
    /// recur (the first few get a lane); it orders events as [`Scheduler::at`].
    pub fn after(&mut self, delay_ns: u64, event: E) {
        let item = self.item(self.now_ns.saturating_add(delay_ns), event);
        self.place_in_lane(delay_ns, item);
    }

    /// [`Scheduler::after`] for an event with rank `rank`.
    pub fn after_ranked(&mut self, delay_ns: u64, rank: u64, event: E) {
        let at_ns = self.now_ns.saturating_add(delay_ns);
        self.len += 1;
        self.place_in_lane(delay_ns, Item { order: Order::ranked(at_ns, self.now_ns, rank), event });
    }

    /// Puts `item` in the lane of `delay_ns`, or in the calendar when that
    /// delay has none. Inlined into its callers: an item is nearly always
    /// the lane's latest, and built in place it is not copied through the
    /// stack (which stalled on reading it back).
    #[inline]
    fn place_in_lane(&mut self, delay_ns: u64, item: Item<E>) {
        let Some(k) = self.lane(delay_ns) else { return self.calendar.place(item) };
        let lane = &mut self.lanes[k];
        match lane.back() {
            None => self.heads[k] = item.key(),
            Some(last) if last.key() < item.key() => {}
            Some(_) => return self.insert_in_lane(k, item),
        }
        lane.push_back(item);
    }

    /// The lane of `delay_ns`: its own, or a new one while there is room.
    #[inline]
    fn lane(&mut self, delay_ns: u64) -> Option<usize> {
        if let Some(k) = self.delays.iter().position(|d| *d == delay_ns) {
            return Some(k);
        }
        if self.lanes.len() == LANES {
            return None;
        }
        self.delays.push(delay_ns);
        self.lanes.push(VecDeque::new());
        Some(self.lanes.len() - 1)
    }

    /// Puts `item` into lane `k` before later ones: a ranked event may go
    /// before others scheduled at this same time.
    #[cold]
    fn insert_in_lane(&mut self, k: usize, item: Item<E>) {
        let lane = &mut self.lanes[k];
        let at = lane.iter().rposition(|x| x.key() < item.key()).map_or(0, |p| p + 1);
        lane.insert(at, item);
        self.heads[k] = lane[0].key();
    }

    /// Where the next event is: `Some(lane)` or `None` for the calendar,
    /// and its time.
    #[inline]
    fn next(&mut self) -> Option<(Option<usize>, u64)> {
        let mut best = (None, self.calendar.first_key().unwrap_or(NONE));
        for (k, head) in self.heads[..self.lanes.len()].iter().enumerate() {
            if *head < best.1 {
                best = (Some(k), *head);
            }
        }
        (best.1 != NONE).then_some((best.0, best.1.at_ns))
    }

    /// The time of the next event.
    pub fn next_ns(&mut self) -> Option<u64> {
        self.next().map(|(_, t)| t)
    }

    /// Takes the next event if it is due at or before `until_ns`, and
    /// moves the clock to it.
    #[inline]
    pub fn pop_until(&mut self, until_ns: u64) -> Option<E> {
        let (at, t) = self.next()?;
        if t > until_ns {
            return None;
        }
        let item = match at {
            Some(k) => {
                let item = self.lanes[k].pop_front()?;
                self.heads[k] = self.lanes[k].front().map_or(NONE, Item::key);
                item
            }
            None => self.calendar.pop()?,
        };
        self.len -= 1;
        self.pass(item.order);
        Some(item.event)
    }

    /// The place of an unranked event due at `at_ns` (the past means now),
    /// scheduled now, that the caller keeps outside the queue: events of
    /// one kind that come due in the order they are made need no queue of
    /// their own, only their place among the others.
    pub fn stamp(&mut self, at_ns: u64) -> Order {
        let tie = UNRANKED + self.seq;
        self.seq += 1;
        Order { at_ns: at_ns.max(self.now_ns), scheduled_ns: self.now_ns, tie }
    }

    /// The place of the next event in the queue.
    #[inline]
    pub fn next_order(&mut self) -> Option<Order> {
        let first = self.calendar.first_key().unwrap_or(NONE);
        let best =
            self.heads[..self.lanes.len()].iter().fold(first, |best, head| if *head < best { *head } else { best });
        (best != NONE).then_some(best)
    }

    /// Moves the clock to an event at `order` that the caller kept outside
    /// the queue ([`Scheduler::stamp`]) and takes now: it must come before
    /// every event in the queue.
    #[inline]
    pub fn pass(&mut self, order: Order) {
        debug_assert!(self.next_order().is_none_or(|n| order <= n), "{order:?} is not next");
        self.now_ns = order.at_ns;
        // Compared field by field and written only when later: a copy of
        // the whole key through the stack stalled every pop.
        if order > self.done {
            self.done = order;
        }
        self.calendar.move_to(self.now_ns >> SHIFT);
    }

    /// Moves the clock to `t_ns` when no event comes before it.
    pub fn advance(&mut self, t_ns: u64) {
        let next = self.next_ns();
        if next.is_none_or(|n| n >= t_ns) {
            self.now_ns = self.now_ns.max(t_ns);
        }
        if next.is_none_or(|n| n > t_ns) {
            self.done = self.done.max(Order::end_of(t_ns));
        }
    }

    /// The place of the event taken last (or of the end of the time the
    /// clock was advanced to): every event up to it has been taken.
    pub fn done(&self) -> Order {
        self.done
    }

    /// True when an event at place `order` would have been taken by now:
    /// it comes no later than the event taken last (or than every event
    /// due by the time the clock was advanced to).
    pub fn is_done(&self, order: Order) -> bool {
        order <= self.done
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
        s.after(0, 'f');
        assert_eq!(s.next_ns(), Some(30), "the past is now");
        s.advance(50);
        assert_eq!(s.now_ns(), 30, "the clock does not skip a due event");
        s.pop_until(100);
        assert_eq!(s.pop_until(100), Some('f'));
        s.advance(50);
        assert_eq!(s.now_ns(), 50);
        assert!(s.is_empty());
    }

    #[test]
    fn ranked_events_keep_their_place_whatever_was_scheduled_before() {
        let mut s = Scheduler::default();
        s.at(1_000, 'x');
        s.pop_until(1_000);
        // Scheduled at the same time: ranked ones first, by rank.
        s.after(500, 'c');
        s.after_ranked(500, 7, 'b');
        s.after_ranked(500, 2, 'a');
        // Due at the same time but taken to have been scheduled earlier.
        s.at_order(Order::ranked(1_500, 900, 9), 'e');
        s.at(1_500, 'd');
        assert!(s.is_done(Order::ranked(1_000, 0, 0)) && !s.is_done(Order::ranked(1_500, 1_000, 0)));
        let order: Vec<char> = std::iter::from_fn(|| s.pop_until(2_000)).collect();
        assert_eq!(order, ['e', 'a', 'b', 'c', 'd']);
        assert!(s.is_done(Order::ranked(1_500, 1_000, 8)), "after 'b'");
        s.advance(1_700);
        assert!(s.is_done(Order::ranked(1_700, 1_600, 1)), "everything due by 1700 is done");
        assert!(!s.is_done(Order::ranked(1_701, 1_600, 1)));
    }

    proptest! {
        /// Lanes and calendar give the events of a plain sorted list, in
        /// the same order, for delays from nanoseconds to many ring turns,
        /// recurring delays (lanes) and more distinct delays than lanes.
        #[test]
        fn same_order_as_a_sorted_list(
            ops in proptest::collection::vec((0u64..6, 0u64..60_000_000, 0u64..3_000_000), 1..400)
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
                    let delay = match op {
                        1 => delay,
                        4 => [0, 50_000, 75_000, 4_000_000][(delay % 4) as usize],
                        _ => delay % 5_000,
                    };
                    let at = s.now_ns() + delay;
                    if op >= 4 {
                        s.after(delay, seq);
                    } else {
                        s.at(at, seq);
                    }
                    model.push((at, seq));
                    seq += 1;
                }
                prop_assert_eq!(s.len(), model.len());
            }
        }
    }
}
