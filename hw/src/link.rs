//! Registered valid/ready links: bounded FIFOs whose reads see only the state committed at
//! the last clock edge and whose writes are staged until the next one (two-phase commit).
//!
//! Handshake rules:
//! 1. A producer may push at most one item per cycle (a multi-port link: `ports` items), and
//!    only when `can_push()` — the link held fewer than `capacity` items at the last edge,
//!    counting those pushed this cycle (its registered `ready`).
//! 2. A producer never waits for `ready` before raising `valid`: it decides from registered
//!    state alone, so no combinational path runs from consumer to producer.
//! 3. A consumer may pop at most one item per cycle, and only the item `peek()` shows — the
//!    front at the last edge (its registered `valid`).
//! 4. Pushes and pops take effect together at `commit()`. A transfer is counted when an
//!    item is popped.
//! 5. With capacity 2 (a skid buffer) a producer and a consumer that act every cycle move
//!    one item per cycle: full throughput with no combinational path.
//! 6. A splitter (dynamic balancing) may take up to `len − 1` items from the back at once:
//!    never the front item, which the consumer may be popping in the same cycle.
//!
//! 7. A link has one producer and one consumer. Every push and pop names the unit doing it
//!    ([`UnitId`]); a link wired with [`Link::wired`] checks it against its two ends, an
//!    unwired one records the first pusher and popper and checks every later one. A second
//!    producer (or consumer) is a model bug and panics, in release builds too.
//!
//! Because every read sees committed state and every write is staged, the order in which
//! producer and consumer are ticked within a cycle cannot change any result.

use crate::machine::sink::Sink;
use std::cell::Cell;
use std::rc::Rc;

/// A unit of the machine: one end of a link, and what the machine ticks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UnitId {
    Memory,
    Balancer,
    /// (cluster, CTU within it).
    Ctu(usize, usize),
    Icu(usize),
    RayBuffer(usize),
    PatchBuffer(usize),
}

/// Bits of a unit's code: the kind (3 bits), the cluster, the CTU.
const KIND_BITS: u32 = 3;
const INDEX_BITS: u32 = 30;

impl UnitId {
    /// The unit as one nonzero integer (rule 7 compares a link's end in one instruction):
    /// the kind in the low bits, then the cluster, then the CTU — distinct for every
    /// cluster and CTU index below 2^30 (the configuration allows 256 and 64; indices are
    /// not masked, so the code costs a shift and an or).
    #[inline(always)]
    pub fn code(self) -> u64 {
        let (kind, c, j) = match self {
            UnitId::Memory => (1, 0, 0),
            UnitId::Balancer => (2, 0, 0),
            UnitId::Ctu(c, j) => (3, c, j),
            UnitId::Icu(c) => (4, c, 0),
            UnitId::RayBuffer(c) => (5, c, 0),
            UnitId::PatchBuffer(c) => (6, c, 0),
        };
        kind | (c as u64) << KIND_BITS | (j as u64) << (KIND_BITS + INDEX_BITS)
    }

    /// The unit whose [`UnitId::code`] is `code`; `None` for 0 (no unit) or a code no unit
    /// has.
    pub fn from_code(code: u64) -> Option<UnitId> {
        let c = (code >> KIND_BITS) as usize & ((1 << INDEX_BITS) - 1);
        let j = (code >> (KIND_BITS + INDEX_BITS)) as usize;
        let u = match code & ((1 << KIND_BITS) - 1) {
            1 => UnitId::Memory,
            2 => UnitId::Balancer,
            3 => UnitId::Ctu(c, j),
            4 => UnitId::Icu(c),
            5 => UnitId::RayBuffer(c),
            6 => UnitId::PatchBuffer(c),
            _ => return None,
        };
        (u.code() == code).then_some(u)
    }
}

/// The unit as the watchdog's report names it: `memory`, `cluster 1 ctu 0`, ….
impl std::fmt::Display for UnitId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            UnitId::Memory => write!(f, "memory"),
            UnitId::Balancer => write!(f, "balancer"),
            UnitId::Ctu(c, j) => write!(f, "cluster {c} ctu {j}"),
            UnitId::Icu(c) => write!(f, "cluster {c} icu"),
            UnitId::RayBuffer(c) => write!(f, "cluster {c} ray buffer"),
            UnitId::PatchBuffer(c) => write!(f, "cluster {c} patch buffer"),
        }
    }
}

/// A unit's [`UnitId::code`], computed once: what a push or pop names (rule 7). A unit on
/// the hot path keeps its own, so the check is one compare with a value in a register (the
/// code of a `UnitId` read from memory is a jump table on its kind, which cost more than the
/// handshake it guards). Any `UnitId` converts to it, so tests name ends as `UnitId`s.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct UnitCode(u64);

impl From<UnitId> for UnitCode {
    #[inline(always)]
    fn from(u: UnitId) -> Self {
        UnitCode(u.code())
    }
}

impl UnitCode {
    /// The unit it stands for.
    pub fn unit(self) -> UnitId {
        UnitId::from_code(self.0).expect("a code made from a unit")
    }
}

/// A word of touch bits shared by up to 64 links: each link raises its own bit whenever a
/// push, pop or take-back stages something, so the word's owner (the machine's link table)
/// commits only the links whose bits are up ([`TouchWord::take`]) instead of testing every
/// link every cycle. A link not given a word has a private one nobody reads; its `commit`
/// tests its own flag, so a spurious bit costs one test and never changes a result.
#[derive(Clone, Debug, Default)]
pub struct TouchWord(Rc<Cell<u64>>);

impl TouchWord {
    /// The bits raised since the last call, cleared.
    #[inline(always)]
    pub fn take(&self) -> u64 {
        self.0.replace(0)
    }

    #[inline(always)]
    fn raise(&self, bits: u64) {
        self.0.set(self.0.get() | bits);
    }
}

/// A registered FIFO link carrying `T`.
///
/// The items live in a ring of `capacity` slots (a link never holds more: a push needs room
/// counting this cycle's pushes, and a staged pop frees none). `head` is the registered
/// front's slot, `tail` the slot the next push writes; the registered state the units read
/// (`peekable`, `room`, `len`) is computed once at the edge, so each handshake call is a
/// load and a test.
#[derive(Clone, Debug)]
pub struct Link<T> {
    slots: Box<[T]>,
    head: usize,
    tail: usize,
    /// Items held at the last edge (those staged for a take-back or a pop included).
    len: usize,
    /// Pushes the producer may still make this cycle: room at the last edge, at most
    /// `ports`, less this cycle's pushes (rule 1).
    room: usize,
    /// The registered front is there and not popped this cycle (rule 3).
    peekable: bool,
    staged_pop: bool,
    /// Something was staged this cycle: `commit` has work.
    touched: bool,
    capacity: usize,
    ports: usize,
    /// Items pushed this cycle (not yet registered).
    staged_push: usize,
    staged_take_back: usize,
    /// The one unit that pushes, as its [`UnitId::code`] (rule 7); 0 until the first push
    /// of an unwired link.
    producer: u64,
    /// The one unit that pops (rule 7).
    consumer: u64,
    /// Where a touch is recorded, and this link's bit in it.
    touch: TouchWord,
    touch_bit: u64,
    /// Items transferred (popped) since the start.
    pub transfers: u64,
    /// The clock's stamp of the last touched edge ([`Link::commit_at`]): the registered
    /// state changes only at a touched edge, so the waveform's sampler reads a link only when
    /// this is past its last sample ([`Link::stamp`]).
    stamp: u64,
}

/// Rule 7: records `by` as the link's `end` on first use, else checks it is the same unit.
#[inline(always)]
fn one_end(end: &mut u64, by: UnitCode, side: &'static str) {
    if *end != by.0 {
        first_or_wrong_end(end, by, side);
    }
}

/// The rare side of rule 7: the first use of an unwired end, or a second unit (a panic, in
/// release builds too).
#[cold]
#[inline(never)]
fn first_or_wrong_end(end: &mut u64, by: UnitCode, side: &'static str) {
    let by = by.unit();
    match UnitId::from_code(*end) {
        Some(u) => panic!("rule 7: {by:?} acts as the {side} of a link whose {side} is {u:?}"),
        None => *end = by.code(),
    }
}

impl<T: Clone + Default> Link<T> {
    /// A link holding at most `capacity` items (at least 1).
    pub fn new(capacity: usize) -> Self {
        Self::with_ports(capacity, 1)
    }

    /// Bytes a link of `capacity` takes (as [`Link::with_ports`] builds it): the link and
    /// its ring's slots. What the machine's memory estimate counts per link.
    pub fn bytes(capacity: usize) -> u64 {
        (std::mem::size_of::<Self>() + capacity.max(1) * std::mem::size_of::<T>()) as u64
    }

    /// Bytes this link takes as built: the link and the slots allocated (what
    /// [`Link::bytes`] estimates).
    #[cfg(test)]
    pub(crate) fn allocated_bytes(&self) -> u64 {
        (std::mem::size_of::<Self>() + std::mem::size_of_val(&*self.slots)) as u64
    }

    /// A link whose producer side takes up to `ports` items per cycle (a ray buffer fed by
    /// several CTUs at once).
    pub fn with_ports(capacity: usize, ports: usize) -> Self {
        let capacity = capacity.max(1);
        let ports = ports.max(1);
        Link {
            slots: vec![T::default(); capacity].into_boxed_slice(),
            head: 0,
            tail: 0,
            len: 0,
            room: capacity.min(ports),
            peekable: false,
            staged_pop: false,
            touched: false,
            capacity,
            ports,
            staged_push: 0,
            staged_take_back: 0,
            producer: 0,
            consumer: 0,
            touch: TouchWord::default(),
            touch_bit: 1,
            transfers: 0,
            stamp: 0,
        }
    }
}

impl<T: Clone> Link<T> {
    /// The same link with its two ends fixed (the machine's wiring): a push by any unit but
    /// `producer`, or a pop by any but `consumer`, panics (rule 7).
    pub fn wired(mut self, producer: UnitId, consumer: UnitId) -> Self {
        self.producer = producer.code();
        self.consumer = consumer.code();
        self
    }

    /// Records this link's touches as bit `bit` (below 64) of `word` from now on.
    pub fn log_touches(&mut self, word: &TouchWord, bit: u32) {
        assert!(bit < 64, "a touch word has 64 bits");
        self.touch = word.clone();
        self.touch_bit = 1 << bit;
        if self.touched {
            self.touch.raise(self.touch_bit);
        }
    }

    /// The producer (rule 7), once known.
    pub fn producer(&self) -> Option<UnitId> {
        UnitId::from_code(self.producer)
    }

    /// The consumer (rule 7), once known.
    pub fn consumer(&self) -> Option<UnitId> {
        UnitId::from_code(self.consumer)
    }

    /// Marks the link as having work at the edge.
    #[inline(always)]
    fn touch(&mut self) {
        self.touched = true;
        self.touch.raise(self.touch_bit);
    }

    /// The slot `n` places after slot `i` (`n` ≤ capacity).
    #[inline(always)]
    fn wrap(&self, i: usize, n: usize) -> usize {
        let j = i + n;
        if j >= self.capacity {
            j - self.capacity
        } else {
            j
        }
    }

    /// Registered ready: room at the last edge (rule 1).
    #[inline(always)]
    pub fn can_push(&self) -> bool {
        self.room > 0
    }

    /// Stages a push by `by` (rules 1 and 7). Panics if the rules were broken — a model bug.
    #[inline(always)]
    pub fn push(&mut self, by: impl Into<UnitCode>, x: T) {
        one_end(&mut self.producer, by.into(), "producer");
        assert!(
            self.can_push(),
            "push without ready or more pushes than ports in a cycle"
        );
        self.slots[self.tail] = x;
        self.tail = self.wrap(self.tail, 1);
        self.room -= 1;
        self.staged_push += 1;
        self.touch();
    }

    /// Registered valid and data: the front at the last edge (rule 3).
    #[inline(always)]
    pub fn peek(&self) -> Option<&T> {
        if self.peekable {
            self.slots.get(self.head)
        } else {
            None
        }
    }

    /// Stages popping the front by `by` (rules 3 and 7).
    #[inline(always)]
    pub fn pop(&mut self, by: impl Into<UnitCode>) -> T {
        one_end(&mut self.consumer, by.into(), "consumer");
        assert!(self.peekable, "pop without valid or two pops in a cycle");
        self.peekable = false;
        self.staged_pop = true;
        self.touch();
        self.slots[self.head].clone()
    }

    /// Stages taking `k` items from the back (rule 6) and returns them, oldest first. The
    /// splitter is the link's producer (it takes back what it queued; rule 7).
    pub fn take_back(&mut self, by: impl Into<UnitCode>, k: usize) -> Vec<T> {
        one_end(&mut self.producer, by.into(), "producer");
        let len = self.len;
        assert!(self.staged_take_back == 0 && k < len.max(1), "rule 6");
        self.staged_take_back = k;
        self.touch();
        (len - k..len)
            .map(|i| self.slots[self.wrap(self.head, i)].clone())
            .collect()
    }

    /// The clock edge (rule 4) outside a clock that stamps it: a sampler takes the link as
    /// changed ever after ([`Link::commit_at`]). An untouched link has nothing to do.
    #[inline(always)]
    pub fn commit(&mut self) {
        self.commit_at(u64::MAX);
    }

    /// The clock edge (rule 4) at the end of cycle `stamp`: a touched link commits and
    /// records the stamp ([`Link::stamp`]); an untouched link has nothing to do.
    #[inline(always)]
    pub fn commit_at(&mut self, stamp: u64) {
        if self.touched {
            self.commit_staged();
            self.stamp = stamp;
        }
    }

    /// The edge of a touched link: take-back, pop, then the staged pushes become registered.
    fn commit_staged(&mut self) {
        if self.staged_take_back > 0 {
            self.drop_taken_back();
        }
        // Without a branch on the pop: whether a link was popped is anyone's guess.
        let popped = self.staged_pop as usize;
        self.head = self.wrap(self.head, popped);
        self.len = self.len - popped + self.staged_push;
        self.transfers += popped as u64;
        self.staged_pop = false;
        self.staged_push = 0;
        self.room = (self.capacity - self.len).min(self.ports);
        self.peekable = self.len > 0;
        self.touched = false;
    }

    /// Removes the `staged_take_back` registered items before this cycle's pushes: the
    /// pushes move down into their slots.
    #[cold]
    fn drop_taken_back(&mut self) {
        let k = self.staged_take_back;
        let first = self.wrap(self.head, self.len - k);
        for i in 0..self.staged_push {
            let (to, from) = (self.wrap(first, i), self.wrap(first, k + i));
            self.slots.swap(to, from);
        }
        self.tail = self.wrap(first, self.staged_push);
        self.len -= k;
        self.staged_take_back = 0;
    }

    /// Signals a link shows in the waveform: [`Link::signals`] reports exactly these.
    pub const SIGNALS: usize = 4;

    /// Reports the link's registered valid, ready, occupancy and transfer count to `s` under
    /// `scope` ([`Link::SIGNALS`] of them). A link's waveform signals: add one here.
    #[inline(always)]
    pub(crate) fn signals(&self, s: &mut impl Sink, scope: &str) {
        s.bits(scope, "valid", 1, self.valid() as u64);
        s.bits(scope, "ready", 1, self.ready() as u64);
        s.bits(scope, "occupancy", 16, self.len() as u64);
        s.bits(scope, "transfers", 32, self.transfers);
    }

    /// The stamp of the last touched edge (0 before any): the registered state (valid,
    /// ready, occupancy, transfers) changes only at a touched edge, so the waveform reads a
    /// link's signals only when this is past its last sample ([`Sink::link_moved`]; the
    /// link keeps no flag for it).
    #[inline(always)]
    pub fn stamp(&self) -> u64 {
        self.stamp
    }

    /// Items held at the last edge.
    #[inline(always)]
    pub fn len(&self) -> usize {
        self.len
    }

    /// True when empty at the last edge.
    #[inline(always)]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Registered valid (an item is at the front).
    #[inline(always)]
    pub fn valid(&self) -> bool {
        !self.is_empty()
    }

    /// Registered ready (room for one more).
    #[inline(always)]
    pub fn ready(&self) -> bool {
        self.len < self.capacity
    }

    /// The capacity.
    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// True when nothing is staged (between cycles).
    pub fn is_settled(&self) -> bool {
        !self.touched
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const P: UnitId = UnitId::Ctu(0, 0);
    const C: UnitId = UnitId::RayBuffer(0);

    /// The naive model a skid buffer must match: one item per cycle end to end.
    #[test]
    fn a_skid_buffer_moves_one_item_per_cycle_in_either_tick_order() {
        for producer_first in [true, false] {
            let mut l: Link<u32> = Link::new(2);
            let mut sent = 0;
            let mut got = vec![];
            for _cycle in 0..100 {
                let mut produce = |l: &mut Link<u32>| {
                    if l.can_push() {
                        l.push(P, sent);
                        sent += 1;
                    }
                };
                let consume = |l: &mut Link<u32>, got: &mut Vec<u32>| {
                    if l.peek().is_some() {
                        got.push(l.pop(C));
                    }
                };
                if producer_first {
                    produce(&mut l);
                    consume(&mut l, &mut got);
                } else {
                    consume(&mut l, &mut got);
                    produce(&mut l);
                }
                l.commit();
            }
            assert_eq!(got, (0..got.len() as u32).collect::<Vec<_>>());
            assert!(got.len() >= 98, "throughput {}", got.len());
            assert_eq!(l.transfers, got.len() as u64);
        }
    }

    #[test]
    fn reads_see_only_the_last_edge() {
        let mut l: Link<u8> = Link::new(1);
        l.push(P, 7);
        assert!(l.peek().is_none(), "a staged push is not visible");
        assert!(!l.can_push());
        l.commit();
        assert_eq!(l.peek(), Some(&7));
        assert!(!l.can_push(), "full at capacity 1");
        assert_eq!(l.pop(C), 7);
        assert!(!l.can_push(), "a staged pop does not free room this cycle");
        l.commit();
        assert!(l.can_push());
    }

    #[test]
    #[should_panic(expected = "rule 7")]
    fn a_second_producer_panics() {
        let mut l: Link<u8> = Link::new(4);
        l.push(P, 1);
        l.commit();
        l.push(UnitId::Ctu(0, 1), 2);
    }

    #[test]
    #[should_panic(expected = "rule 7")]
    fn a_wired_link_refuses_another_producer_on_the_first_push() {
        let mut l: Link<u8> = Link::new(4).wired(P, C);
        l.push(UnitId::Memory, 1);
    }

    #[test]
    #[should_panic(expected = "rule 7")]
    fn a_second_consumer_panics() {
        let mut l: Link<u8> = Link::new(4).wired(P, C);
        l.push(P, 1);
        l.commit();
        l.push(P, 2);
        l.commit();
        l.pop(C);
        l.commit();
        l.pop(UnitId::Icu(0));
    }

    #[test]
    fn take_back_never_takes_the_front() {
        let mut l: Link<u8> = Link::with_ports(8, 4).wired(P, C);
        for x in 0..4 {
            l.push(P, x);
        }
        l.commit();
        assert_eq!(l.pop(C), 0);
        assert_eq!(l.take_back(P, 3), vec![1, 2, 3]);
        l.commit();
        assert!(l.is_empty());
    }

    #[test]
    fn the_stamp_moves_at_a_touched_edge_only() {
        let mut l: Link<u32> = Link::new(2);
        assert_eq!(l.stamp(), 0);
        l.commit_at(3);
        assert_eq!(l.stamp(), 0, "an untouched edge changes nothing");
        l.push(UnitId::Memory, 7);
        assert_eq!(l.stamp(), 0, "a staged push is not registered yet");
        let before = (l.valid(), l.ready(), l.len(), l.transfers);
        l.commit_at(4);
        assert_eq!(l.stamp(), 4);
        assert_ne!((l.valid(), l.ready(), l.len(), l.transfers), before);
        l.pop(UnitId::Balancer);
        l.commit();
        assert_eq!(l.stamp(), u64::MAX, "an unclocked edge: always changed");
    }

    /// The two-phase FIFO the ring must behave as: a queue of registered items followed by
    /// this cycle's pushes, with the pop and the take-back applied at the edge.
    struct Model {
        q: std::collections::VecDeque<u32>,
        capacity: usize,
        ports: usize,
        pushed: usize,
        popped: bool,
        taken: usize,
        transfers: u64,
    }

    impl Model {
        fn len(&self) -> usize {
            self.q.len() - self.pushed
        }
        fn can_push(&self) -> bool {
            self.q.len() < self.capacity && self.pushed < self.ports
        }
        fn peek(&self) -> Option<u32> {
            (!self.popped && self.len() > 0).then(|| self.q[0])
        }
        fn commit(&mut self) {
            let len = self.len();
            self.q.drain(len - self.taken..len);
            if self.popped {
                self.q.pop_front();
                self.transfers += 1;
            }
            (self.pushed, self.popped, self.taken) = (0, false, 0);
        }
    }

    /// Random pushes (up to the ports), pops and take-backs against the model, through many
    /// wraps of the ring: every registered read agrees every cycle.
    #[test]
    fn the_ring_matches_a_two_phase_queue_through_wraps_pushes_pops_and_take_backs() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut rand = |n: u64| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed % n
        };
        let mut wraps = 0;
        for (capacity, ports) in [(1, 1), (2, 1), (3, 1), (3, 2), (5, 3), (8, 4), (7, 7)] {
            let mut l: Link<u32> = Link::with_ports(capacity, ports).wired(P, C);
            let mut m = Model {
                q: Default::default(),
                capacity,
                ports,
                pushed: 0,
                popped: false,
                taken: 0,
                transfers: 0,
            };
            let mut next = 0;
            for _cycle in 0..3000 {
                let (take, take_first) = (rand(8) == 0 && m.len() > 1, rand(2) == 0);
                let take_back = |l: &mut Link<u32>, m: &mut Model, k: u64| {
                    let k = k as usize % m.len();
                    let want: Vec<u32> = m.q.range(m.len() - k..m.len()).copied().collect();
                    assert_eq!(l.take_back(P, k), want);
                    m.taken = k;
                };
                let k = rand(1 << 20);
                if take && take_first {
                    take_back(&mut l, &mut m, k);
                }
                if rand(3) > 0 && m.peek().is_some() {
                    assert_eq!(Some(l.pop(C)), m.peek());
                    m.popped = true;
                }
                for _ in 0..rand(ports as u64 + 2) {
                    assert_eq!(l.can_push(), m.can_push());
                    if m.can_push() {
                        l.push(P, next);
                        m.q.push_back(next);
                        m.pushed += 1;
                        next += 1;
                    }
                }
                if take && !take_first {
                    take_back(&mut l, &mut m, k);
                }
                assert_eq!(l.peek().copied(), m.peek());
                let head = l.head;
                l.commit();
                m.commit();
                wraps += (l.head < head) as usize;
                assert_eq!(l.peek().copied(), m.peek());
                assert_eq!((l.len(), l.can_push()), (m.len(), m.can_push()));
                assert_eq!((l.valid(), l.ready()), (m.len() > 0, m.len() < capacity));
                assert_eq!(l.transfers, m.transfers);
            }
        }
        assert!(wraps > 100, "the ring wrapped {wraps} times");
    }

    #[test]
    fn a_take_back_with_pushes_in_the_same_cycle_keeps_the_pushes_behind_the_rest() {
        let mut l: Link<u8> = Link::with_ports(6, 3).wired(P, C);
        for x in 0..4 {
            l.push(P, x);
            if x == 2 {
                l.commit();
            }
        }
        l.commit();
        // Registered 0 1 2 3 (the ring's head at 0); take 2 and 3, push 4 and 5, pop 0.
        assert_eq!(l.take_back(P, 2), vec![2, 3]);
        l.push(P, 4);
        l.push(P, 5);
        assert_eq!(l.pop(C), 0);
        l.commit();
        let mut got = vec![];
        while let Some(&x) = l.peek() {
            got.push(x);
            l.pop(C);
            l.commit();
        }
        assert_eq!(got, vec![1, 4, 5]);
    }

    #[test]
    fn every_unit_has_its_own_code_and_the_code_names_it() {
        let mut units = vec![UnitId::Memory, UnitId::Balancer];
        for c in [0, 1, 7, 255] {
            units.extend([UnitId::Icu(c), UnitId::RayBuffer(c), UnitId::PatchBuffer(c)]);
            units.extend([0, 1, 63].map(|j| UnitId::Ctu(c, j)));
        }
        let mut codes: Vec<u64> = units.iter().map(|u| u.code()).collect();
        for (u, &code) in units.iter().zip(&codes) {
            assert_ne!(code, 0, "0 means no unit");
            assert_eq!(UnitId::from_code(code), Some(*u));
        }
        codes.sort_unstable();
        codes.dedup();
        assert_eq!(codes.len(), units.len());
        assert_eq!(UnitId::from_code(0), None);
        assert_eq!(UnitId::from_code(7), None);
    }

    #[test]
    fn a_touch_raises_the_links_bit_in_its_word_and_nothing_else() {
        let w = TouchWord::default();
        let mut a: Link<u8> = Link::new(2);
        let mut b: Link<u8> = Link::new(2);
        a.log_touches(&w, 3);
        b.log_touches(&w, 40);
        assert_eq!(w.take(), 0);
        a.push(P, 1);
        assert_eq!(w.take(), 1 << 3);
        a.commit();
        a.pop(C);
        b.push(P, 2);
        assert_eq!(w.take(), 1 << 3 | 1 << 40);
        assert_eq!(w.take(), 0, "taking clears");
        // A link touched before it is given a word raises its bit at once.
        let mut c: Link<u8> = Link::new(2);
        c.push(P, 3);
        c.log_touches(&w, 63);
        assert_eq!(w.take(), 1 << 63);
    }

    #[test]
    fn a_link_reports_its_signal_count() {
        let mut c = crate::machine::sink::Count::default();
        Link::<u32>::new(2).signals(&mut c, "");
        assert_eq!(c.0, Link::<u32>::SIGNALS);
    }
}
