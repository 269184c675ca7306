//! The patch buffer: a cluster's bounded store of patch records delivered by the global
//! memory, handed one per cycle, in arrival order, to the CTU that asked for each.

use crate::link::Link;
use crate::msg::PatchArrival;

/// Patch-buffer counters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct PatchBufferStats {
    pub patches_in: u64,
    pub occupancy_sum: u64,
    pub max_occupancy: u64,
}

/// The patch buffer. Its store is a link the memory writes (held by the machine, beside the
/// other clusters' stores, so the memory can reach them all).
#[derive(Clone, Debug, Default)]
pub struct PatchBuffer {
    pub stats: PatchBufferStats,
}

impl PatchBuffer {
    /// One clock cycle: hand the oldest patch in `store` to its CTU if that CTU's link is
    /// ready.
    pub fn tick(&mut self, store: &mut Link<PatchArrival>, to_ctus: &mut [Link<PatchArrival>]) {
        let occ = store.len() as u64;
        self.stats.occupancy_sum += occ;
        self.stats.max_occupancy = self.stats.max_occupancy.max(occ);
        if let Some(a) = store.peek() {
            let out = &mut to_ctus[a.ctu as usize];
            if out.can_push() {
                let a = store.pop();
                out.push(a);
                self.stats.patches_in += 1;
            }
        }
    }
}
