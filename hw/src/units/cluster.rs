//! A cluster: one ICU, K CTUs, a ray buffer and a patch buffer (one per section of the
//! partition). The links between them are the machine's (`machine::links`); the buffers'
//! stores are the buffers' own.

use crate::link::Link;
use crate::msg::PatchArrival;
use crate::units::ctu::Ctu;
use crate::units::icu::Icu;
use crate::units::memory::Stores;
use crate::units::patch_buffer::PatchBuffer;
use crate::units::ray_buffer::RayBuffer;

/// One cluster.
#[derive(Clone, Debug)]
pub struct Cluster {
    pub ctus: Vec<Ctu>,
    pub icu: Icu,
    pub ray_buffer: RayBuffer,
    pub patch_buffer: PatchBuffer,
}

impl Cluster {
    /// A cluster of the given units.
    pub fn new(ctus: Vec<Ctu>, icu: Icu, ray_buffer: RayBuffer, patch_buffer: PatchBuffer) -> Self {
        Cluster {
            ctus,
            icu,
            ray_buffer,
            patch_buffer,
        }
    }

    /// True when the cluster has finished and holds nothing (its links aside).
    pub fn drained(&self) -> bool {
        self.ctus.iter().all(Ctu::done) && self.is_empty()
    }

    /// True when the ICU and both buffers' stores are empty.
    pub fn is_empty(&self) -> bool {
        self.icu.is_empty() && self.ray_buffer.is_empty() && self.patch_buffer.store.is_empty()
    }

    /// The clock edge of the units' own stores (the ray buffer's queue, the patch buffer's
    /// store); the links commit in `machine::links`. Inlined: it runs every cycle for every
    /// cluster, and each store's edge is one test when untouched. `now`: the cycle whose
    /// edge this is (the stores' stamp, [`Link::commit_at`]).
    #[inline(always)]
    pub fn commit(&mut self, now: u64) {
        self.ray_buffer.commit_at(now);
        self.patch_buffer.commit_at(now);
    }
}

/// The memory reaches each cluster's patch-buffer store, and nothing else of the cluster.
impl Stores for [Cluster] {
    fn store(&mut self, cluster: usize) -> &mut Link<PatchArrival> {
        &mut self[cluster].patch_buffer.store
    }
}
