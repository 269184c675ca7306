//! A cluster: one ICU, K CTUs, a ray buffer and a patch buffer (one per section of the
//! partition). The links between them are the machine's (`machine::links`); the buffers'
//! stores are the buffers' own. The cluster builds its units but the CTUs from the
//! configuration, estimates their stores' memory, and lists them, in tick order, for the
//! machine's cold paths ([`Cluster::each_unit`]): a unit added to a cluster is built, held,
//! estimated and listed here.

use crate::config::{DescriptorOrder, JobSource, MachineConfig};
use crate::link::{Link, UnitId};
use crate::msg::PatchArrival;
use crate::units::ctu::Ctu;
use crate::units::icu::Icu;
use crate::units::memory::Stores;
use crate::units::patch_buffer::PatchBuffer;
use crate::units::ray_buffer::RayBuffer;
use crate::units::Unit;
use std::ops::ControlFlow;

/// One cluster.
#[derive(Clone, Debug)]
pub struct Cluster {
    pub ctus: Vec<Ctu>,
    pub icu: Icu,
    pub ray_buffer: RayBuffer,
    pub patch_buffer: PatchBuffer,
}

impl Cluster {
    /// Cluster `c` of the machine `cfg` around its CTUs `ctus`.
    pub fn new(cfg: &MachineConfig, c: usize, ctus: Vec<Ctu>) -> Self {
        let m = &cfg.machine;
        let ray_buffer = if m.job_source == JobSource::Bundle {
            RayBuffer::bundle(
                m.ray_buffer_capacity,
                m.descriptor_order == DescriptorOrder::LargestFirst,
            )
        } else {
            RayBuffer::new(m.ray_buffer_capacity, m.ctus_per_cluster as usize + 1)
        };
        Cluster {
            ctus,
            icu: Icu::new(cfg.divider_stages()),
            ray_buffer,
            patch_buffer: PatchBuffer::new(c, m.patch_buffer_capacity),
        }
    }

    /// Bytes a cluster's units' own stores take for `cfg` before it runs (the ray buffer's
    /// queue or descriptor store, the patch buffer's store), for `Machine::memory_estimate`.
    pub fn memory_estimate(cfg: &MachineConfig) -> u64 {
        use crate::msg::{Descriptor, Job};
        use std::mem::size_of;
        let m = &cfg.machine;
        let slots = |n: u64, bytes: usize| (n + 1) * bytes as u64;
        let k = m.ctus_per_cluster as u64;
        let descs = if m.job_source == JobSource::Bundle {
            slots(m.ray_buffer_capacity as u64, size_of::<Descriptor>())
        } else {
            0
        };
        slots(m.ray_buffer_capacity as u64 + k + 1, size_of::<Job>())
            + slots(m.patch_buffer_capacity as u64, size_of::<PatchArrival>())
            + descs
            + 4096
    }

    /// Visits the cluster's units, as cluster `c`, in tick order — its patch buffer, its
    /// CTUs, its ray buffer, its ICU — until `f` breaks.
    #[inline]
    pub fn each_unit<B>(
        &self,
        c: usize,
        mut f: impl FnMut(UnitId, &dyn Unit) -> ControlFlow<B>,
    ) -> ControlFlow<B> {
        f(UnitId::PatchBuffer(c), &self.patch_buffer)?;
        for (j, ctu) in self.ctus.iter().enumerate() {
            f(UnitId::Ctu(c, j), ctu)?;
        }
        f(UnitId::RayBuffer(c), &self.ray_buffer)?;
        f(UnitId::Icu(c), &self.icu)
    }

    /// [`Cluster::each_unit`], each unit mutable, all of them.
    #[inline]
    pub fn each_unit_mut(&mut self, c: usize, mut f: impl FnMut(UnitId, &mut dyn Unit)) {
        f(UnitId::PatchBuffer(c), &mut self.patch_buffer);
        for (j, ctu) in self.ctus.iter_mut().enumerate() {
            f(UnitId::Ctu(c, j), ctu);
        }
        f(UnitId::RayBuffer(c), &mut self.ray_buffer);
        f(UnitId::Icu(c), &mut self.icu);
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
