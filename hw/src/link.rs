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

use std::cell::Cell;
use std::collections::VecDeque;

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

/// A registered FIFO link carrying `T`.
#[derive(Clone, Debug)]
pub struct Link<T> {
    /// The registered items, then (at the back) the `staged_push` items pushed this cycle:
    /// a push goes straight into the one queue and becomes visible at the edge.
    q: VecDeque<T>,
    capacity: usize,
    ports: usize,
    /// Items at the back of `q` pushed this cycle (not yet registered).
    staged_push: usize,
    staged_pop: bool,
    staged_take_back: usize,
    /// Something was staged this cycle: `commit` has work (an untouched link's edge is one
    /// test, so the machine's clock edge costs little for the many idle links).
    touched: bool,
    /// The one unit that pushes (rule 7); `None` until the first push of an unwired link.
    producer: Option<UnitId>,
    /// The one unit that pops (rule 7).
    consumer: Option<UnitId>,
    /// Items transferred (popped) since the start.
    pub transfers: u64,
    /// The registered state changed at an edge since the waveform last looked
    /// ([`Link::take_changed`]); true at the start.
    changed: Cell<bool>,
}

/// Rule 7: records `by` as the link's `end` on first use, else checks it is the same unit.
#[inline(always)]
fn one_end(end: &mut Option<UnitId>, by: UnitId, side: &str) {
    match *end {
        Some(u) => assert!(
            u == by,
            "rule 7: {by:?} acts as the {side} of a link whose {side} is {u:?}"
        ),
        None => *end = Some(by),
    }
}

impl<T: Clone> Link<T> {
    /// A link holding at most `capacity` items (at least 1).
    pub fn new(capacity: usize) -> Self {
        Self::with_ports(capacity, 1)
    }

    /// A link whose producer side takes up to `ports` items per cycle (a ray buffer fed by
    /// several CTUs at once).
    pub fn with_ports(capacity: usize, ports: usize) -> Self {
        let capacity = capacity.max(1);
        let ports = ports.max(1);
        Link {
            q: VecDeque::with_capacity(capacity + ports),
            capacity,
            ports,
            staged_push: 0,
            staged_pop: false,
            staged_take_back: 0,
            touched: false,
            producer: None,
            consumer: None,
            transfers: 0,
            changed: Cell::new(true),
        }
    }

    /// The same link with its two ends fixed (the machine's wiring): a push by any unit but
    /// `producer`, or a pop by any but `consumer`, panics (rule 7).
    pub fn wired(mut self, producer: UnitId, consumer: UnitId) -> Self {
        self.producer = Some(producer);
        self.consumer = Some(consumer);
        self
    }

    /// The producer (rule 7), once known.
    pub fn producer(&self) -> Option<UnitId> {
        self.producer
    }

    /// The consumer (rule 7), once known.
    pub fn consumer(&self) -> Option<UnitId> {
        self.consumer
    }

    /// Registered ready: room at the last edge (rule 1).
    #[inline(always)]
    pub fn can_push(&self) -> bool {
        self.q.len() < self.capacity && self.staged_push < self.ports
    }

    /// Stages a push by `by` (rules 1 and 7). Panics if the rules were broken — a model bug.
    #[inline(always)]
    pub fn push(&mut self, by: UnitId, x: T) {
        one_end(&mut self.producer, by, "producer");
        assert!(
            self.can_push(),
            "push without ready or more pushes than ports in a cycle"
        );
        self.q.push_back(x);
        self.staged_push += 1;
        self.touched = true;
    }

    /// Registered valid and data: the front at the last edge (rule 3).
    #[inline(always)]
    pub fn peek(&self) -> Option<&T> {
        if self.staged_pop || self.q.len() == self.staged_push {
            None
        } else {
            self.q.front()
        }
    }

    /// Stages popping the front by `by` (rules 3 and 7).
    #[inline(always)]
    pub fn pop(&mut self, by: UnitId) -> T {
        one_end(&mut self.consumer, by, "consumer");
        assert!(!self.staged_pop, "two pops in a cycle");
        assert!(!self.is_empty(), "pop without valid");
        self.staged_pop = true;
        self.touched = true;
        self.q.front().cloned().expect("pop without valid")
    }

    /// Stages taking `k` items from the back (rule 6) and returns them, oldest first. The
    /// splitter is the link's producer (it takes back what it queued; rule 7).
    pub fn take_back(&mut self, by: UnitId, k: usize) -> Vec<T> {
        one_end(&mut self.producer, by, "producer");
        let len = self.len();
        assert!(self.staged_take_back == 0 && k < len.max(1), "rule 6");
        self.staged_take_back = k;
        self.touched = true;
        self.q.range(len - k..len).cloned().collect()
    }

    /// The clock edge (rule 4). An untouched link has nothing to do.
    #[inline(always)]
    pub fn commit(&mut self) {
        if self.touched {
            self.commit_staged();
        }
    }

    /// The edge of a touched link: take-back, pop, then the staged pushes become registered.
    fn commit_staged(&mut self) {
        if self.staged_take_back > 0 {
            let len = self.len();
            self.q.drain(len - self.staged_take_back..len);
            self.staged_take_back = 0;
        }
        if self.staged_pop {
            self.q.pop_front();
            self.staged_pop = false;
            self.transfers += 1;
        }
        self.staged_push = 0;
        self.touched = false;
        *self.changed.get_mut() = true;
    }

    /// True when the registered state (valid, ready, occupancy, transfers) may have changed
    /// since the last call — a touched edge happened — and clears it: the waveform's walk
    /// reads a link's signals only then. Registered state changes only at a touched edge.
    #[inline(always)]
    pub fn take_changed(&self) -> bool {
        self.changed.replace(false)
    }

    /// Items held at the last edge.
    #[inline(always)]
    pub fn len(&self) -> usize {
        self.q.len() - self.staged_push
    }

    /// True when empty at the last edge.
    #[inline(always)]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Registered valid (an item is at the front).
    #[inline(always)]
    pub fn valid(&self) -> bool {
        !self.is_empty()
    }

    /// Registered ready (room for one more).
    #[inline(always)]
    pub fn ready(&self) -> bool {
        self.len() < self.capacity
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
    fn the_change_flag_is_raised_by_a_touched_edge_only() {
        let mut l: Link<u32> = Link::new(2);
        assert!(l.take_changed(), "a new link has never been looked at");
        assert!(!l.take_changed());
        l.commit();
        assert!(!l.take_changed(), "an untouched edge changes nothing");
        l.push(UnitId::Memory, 7);
        assert!(!l.take_changed(), "a staged push is not registered yet");
        let before = (l.valid(), l.ready(), l.len(), l.transfers);
        l.commit();
        assert!(l.take_changed());
        assert_ne!((l.valid(), l.ready(), l.len(), l.transfers), before);
        l.pop(UnitId::Balancer);
        l.commit();
        assert!(l.take_changed());
        assert!(!l.take_changed());
    }
}
