//! Registered valid/ready links: bounded FIFOs whose reads see only the state committed at
//! the last clock edge and whose writes are staged until the next one (two-phase commit).
//!
//! Handshake rules:
//! 1. A producer may push at most one item per cycle, and only when `can_push()` — the link
//!    held fewer than `capacity` items at the last edge (its registered `ready`).
//! 2. A producer never waits for `ready` before raising `valid`: it decides from registered
//!    state alone, so no combinational path runs from consumer to producer.
//! 3. A consumer may pop at most one item per cycle, and only the item `peek()` shows — the
//!    front at the last edge (its registered `valid`).
//! 4. Pushes and pops take effect together at `commit()`. A transfer is counted when an
//!    item is popped.
//! 5. With capacity 2 (a skid buffer) a producer and a consumer that act every cycle move
//!    one item per cycle: full throughput with no combinational path.
//!
//! Because every read sees committed state and every write is staged, the order in which
//! producer and consumer are ticked within a cycle cannot change any result.

use std::collections::VecDeque;

/// A registered FIFO link carrying `T`.
#[derive(Clone, Debug)]
pub struct Link<T> {
    q: VecDeque<T>,
    capacity: usize,
    staged_push: Option<T>,
    staged_pop: bool,
    /// Items transferred (popped) since the start.
    pub transfers: u64,
}

impl<T: Clone> Link<T> {
    /// A link holding at most `capacity` items (at least 1).
    pub fn new(capacity: usize) -> Self {
        let capacity = capacity.max(1);
        Link {
            q: VecDeque::with_capacity(capacity + 1),
            capacity,
            staged_push: None,
            staged_pop: false,
            transfers: 0,
        }
    }

    /// Registered ready: room at the last edge (rule 1).
    #[inline]
    pub fn can_push(&self) -> bool {
        self.q.len() < self.capacity && self.staged_push.is_none()
    }

    /// Stages a push (rule 1). Panics if the rules were broken — a model bug.
    #[inline]
    pub fn push(&mut self, x: T) {
        assert!(self.can_push(), "push without ready or twice in a cycle");
        self.staged_push = Some(x);
    }

    /// Registered valid and data: the front at the last edge (rule 3).
    #[inline]
    pub fn peek(&self) -> Option<&T> {
        if self.staged_pop {
            None
        } else {
            self.q.front()
        }
    }

    /// Stages popping the front (rule 3).
    #[inline]
    pub fn pop(&mut self) -> T {
        assert!(!self.staged_pop, "two pops in a cycle");
        self.staged_pop = true;
        self.q.front().cloned().expect("pop without valid")
    }

    /// The clock edge (rule 4).
    #[inline]
    pub fn commit(&mut self) {
        if self.staged_pop {
            self.q.pop_front();
            self.staged_pop = false;
            self.transfers += 1;
        }
        if let Some(x) = self.staged_push.take() {
            self.q.push_back(x);
        }
    }

    /// Items held at the last edge.
    #[inline]
    pub fn len(&self) -> usize {
        self.q.len()
    }

    /// True when empty at the last edge.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.q.is_empty()
    }

    /// Registered valid (an item is at the front).
    #[inline]
    pub fn valid(&self) -> bool {
        !self.q.is_empty()
    }

    /// Registered ready (room for one more).
    #[inline]
    pub fn ready(&self) -> bool {
        self.q.len() < self.capacity
    }

    /// The capacity.
    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// True when nothing is staged (between cycles).
    pub fn is_settled(&self) -> bool {
        self.staged_push.is_none() && !self.staged_pop
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
                        l.push(sent);
                        sent += 1;
                    }
                };
                let consume = |l: &mut Link<u32>, got: &mut Vec<u32>| {
                    if l.peek().is_some() {
                        got.push(l.pop());
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
        l.push(7);
        assert!(l.peek().is_none(), "a staged push is not visible");
        assert!(!l.can_push());
        l.commit();
        assert_eq!(l.peek(), Some(&7));
        assert!(!l.can_push(), "full at capacity 1");
        assert_eq!(l.pop(), 7);
        assert!(!l.can_push(), "a staged pop does not free room this cycle");
        l.commit();
        assert!(l.can_push());
    }
}
