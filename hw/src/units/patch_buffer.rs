//! The patch buffer: a cluster's bounded store of patch records delivered by the global
//! memory, handed one per cycle, in arrival order, to the CTU that asked for each.

use crate::link::{Link, UnitId};
use crate::msg::PatchArrival;

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
    pub fn tick(&mut self, to_ctus: &mut [Link<PatchArrival>]) {
        let me = UnitId::PatchBuffer(self.cluster);
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

    /// The clock edge of the store.
    pub fn commit(&mut self) {
        self.store.commit();
    }
}
