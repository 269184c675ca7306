//! The patch buffer: a cluster's bounded store of patch records delivered by the global
//! memory, handed one per cycle, in arrival order, to the CTU that asked for each.

use crate::link::{Link, UnitCode, UnitId};
use crate::msg::PatchArrival;
use crate::units::{Around, Unit};

/// Patch-buffer counters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct PatchBufferStats {
    pub patches_in: u64,
    pub occupancy_sum: u64,
    pub max_occupancy: u64,
}

/// The patch buffer. It owns its store: a registered FIFO of `capacity` records whose write
/// port is the memory's (the memory pushes into it, the buffer pops; rule 7 of `link`).
#[derive(Clone, Debug)]
pub struct PatchBuffer {
    cluster: usize,
    /// The store, written by the memory.
    pub store: Link<PatchArrival>,
    pub stats: PatchBufferStats,
}

impl PatchBuffer {
    /// Cluster `cluster`'s patch buffer of `capacity` records.
    pub fn new(cluster: usize, capacity: u32) -> Self {
        PatchBuffer {
            cluster,
            store: Link::new(capacity as usize).wired(UnitId::Memory, UnitId::PatchBuffer(cluster)),
            stats: PatchBufferStats::default(),
        }
    }

    /// One clock cycle: hand the oldest patch in the store to its CTU if that CTU's link is
    /// ready.
    #[inline(always)]
    pub fn tick(&mut self, to_ctus: &mut [Link<PatchArrival>]) {
        // An empty store adds nothing to the occupancy counters and hands nothing on.
        if !self.store.is_empty() {
            self.tick_active(to_ctus);
        }
    }

    /// A cycle with a record in the store.
    #[inline(always)]
    fn tick_active(&mut self, to_ctus: &mut [Link<PatchArrival>]) {
        let me = UnitCode::from(UnitId::PatchBuffer(self.cluster));
        let occ = self.store.len() as u64;
        self.stats.occupancy_sum += occ;
        self.stats.max_occupancy = self.stats.max_occupancy.max(occ);
        if let Some(a) = self.store.peek() {
            let out = &mut to_ctus[a.ctu as usize];
            if out.can_push() {
                let a = self.store.pop(me);
                out.push(me, a);
                self.stats.patches_in += 1;
            }
        }
    }

    /// The clock edge of the store, outside a stamping clock ([`Link::commit`]).
    #[inline(always)]
    pub fn commit(&mut self) {
        self.commit_at(u64::MAX);
    }

    /// The clock edge of the store at the end of cycle `now` ([`Link::commit_at`]).
    #[inline(always)]
    pub fn commit_at(&mut self, now: u64) {
        self.store.commit_at(now);
    }
}

/// The patch buffer's cold paths: quiet and done when its store is empty; its progress is
/// the store's transfers.
impl Unit for PatchBuffer {
    fn quiet(&self, _now: u64, _: &Around) -> bool {
        self.store.is_empty()
    }

    fn activity(&self) -> u64 {
        self.store.transfers
    }

    fn done(&self) -> bool {
        self.store.is_empty()
    }

    fn report(&self, _now: u64) -> String {
        format!("{} patches", self.store.len())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn arrival(patch: u32, ctu: u16) -> PatchArrival {
        PatchArrival { patch, ctu }
    }

    #[test]
    fn the_store_holds_capacity_records_and_then_refuses() {
        let mut b = PatchBuffer::new(0, 2);
        b.store.push(UnitId::Memory, arrival(1, 0));
        b.commit();
        b.store.push(UnitId::Memory, arrival(2, 0));
        assert!(
            !b.store.can_push(),
            "full at capacity, counting this cycle's push"
        );
        b.commit();
        assert!(!b.store.can_push());
        assert_eq!(b.store.len(), 2);
    }

    #[test]
    fn a_full_ctu_link_holds_the_store_back_in_order() {
        let mut b = PatchBuffer::new(0, 4);
        let mut to: Vec<Link<PatchArrival>> = (0..2).map(|_| Link::new(1)).collect();
        for (p, c) in [(1, 0), (2, 0), (3, 1)] {
            b.store.push(UnitId::Memory, arrival(p, c));
            b.commit();
        }
        let mut got = vec![];
        for cycle in 0..20 {
            b.tick(&mut to);
            b.commit();
            // CTU 0 does not take anything for the first 10 cycles (back-pressure).
            for (j, l) in to.iter_mut().enumerate() {
                if l.peek().is_some() && (j == 1 || cycle >= 10) {
                    got.push((cycle, l.pop(UnitId::Ctu(0, j)).patch));
                }
                l.commit();
            }
        }
        // Patch 1 waits in CTU 0's link; patch 2 holds the store's front, so patch 3 (for the
        // free CTU 1) waits behind it: arrival order, never reordered.
        let order: Vec<u32> = got.iter().map(|g| g.1).collect();
        assert_eq!(order, vec![1, 2, 3]);
        assert!(got[0].0 >= 10);
        assert_eq!(b.stats.patches_in, 3);
        assert_eq!(b.stats.max_occupancy, 3);
    }
}
