//! One clock cycle: tick every unit once in the chosen order, then the clock edge (every
//! link and every unit's own store commits). No allocation: the order is permuted in a
//! scratch vector of fixed capacity.

use super::links::Links;
use super::{Machine, TickOrder};
use crate::config::JobSource;
use crate::datapath::model::FixedScene;
use crate::datapath::record::RayRecord;
use crate::link::UnitId;
use crate::units::balancer::BalancerPorts;
use crate::units::cluster::Cluster;
use crate::units::ctu::Ctu;
use crate::units::ctu::CtuPorts;
use crate::units::icu::IcuPorts;
use crate::units::ray_buffer::BundlePorts;
use crate::units::ray_pool::RayList;

impl Machine<'_> {
    /// One clock cycle: tick every unit in `order`, then commit every link.
    pub fn tick(&mut self, order: TickOrder) {
        let now = self.cycle;
        let n = self.order.len();
        match order {
            // Forward walks the units in `order`'s sequence without reading it (each call
            // below is one unit's arm, inlined); reverse walks `order` itself; only a shuffle
            // needs the scratch copy.
            TickOrder::Forward => self.tick_forward(now),
            TickOrder::Reverse => {
                for i in (0..n).rev() {
                    self.tick_unit(self.order[i], now);
                }
            }
            TickOrder::Shuffled(seed) => {
                self.scratch.clear();
                self.scratch.extend_from_slice(&self.order);
                shuffle(
                    &mut self.scratch,
                    seed ^ now.wrapping_mul(0x9E37_79B9_7F4A_7C15),
                );
                for i in 0..n {
                    self.tick_unit(self.scratch[i], now);
                }
            }
        }
        self.links.commit_all(now);
        for cl in &mut self.clusters {
            cl.commit(now);
        }
        // The watchdog samples progress every 64 cycles (its resolution).
        if now.is_multiple_of(64) {
            let p = self.activity();
            if p != self.progress {
                self.progress = p;
                self.last_progress_cycle = now;
            }
        }
    }

    /// The forward order: memory, balancer, then per cluster its patch buffer, CTUs, ray
    /// buffer and ICU — `order`'s sequence, walked over the clusters and their slices of the
    /// per-CTU link families without indexing per unit.
    fn tick_forward(&mut self, now: u64) {
        let k = self.cfg.machine.ctus_per_cluster as usize;
        let bundle = self.cfg.machine.job_source == JobSource::Bundle;
        self.tick_unit(UnitId::Memory, now);
        if self.cfg.balance.enabled {
            self.tick_unit(UnitId::Balancer, now);
        }
        let (scene, rays) = (self.scene, self.rays);
        let l = &mut self.links;
        for (c, cl) in self.clusters.iter_mut().enumerate() {
            let at = c * k..(c + 1) * k;
            if quiet_cluster(cl, l, c) {
                // Every unit's cycle would only count: the CTUs' in DONE, the empty ICU's;
                // the empty buffers add nothing to their occupancy counters.
                for ctu in &mut cl.ctus {
                    ctu.finished_cycle();
                }
                cl.icu.idle_tick();
                continue;
            }
            cl.patch_buffer.tick(&mut l.arrivals[at.clone()]);
            // The idle test reads three links; the others are reached only for an active CTU.
            for (j, ctu) in cl.ctus.iter_mut().enumerate() {
                let i = at.start + j;
                if ctu.idle_tick(now, &l.results[i], &l.remote_in[i], &l.arrivals[i]) {
                    continue;
                }
                let mut io = ctu_ports(l, &mut self.pool, i);
                ctu.tick_active(now, &mut io, &scene.cells);
            }
            tick_ray_buffer(cl, l, &self.pool, c, k, bundle);
            tick_icu(cl, l, c, k, scene, rays);
        }
    }

    /// Ticks unit `u` at cycle `now`, handing it its ports.
    #[inline(always)]
    fn tick_unit(&mut self, u: UnitId, now: u64) {
        let k = self.cfg.machine.ctus_per_cluster as usize;
        let l = &mut self.links;
        match u {
            UnitId::Memory => self
                .memory
                .tick(now, &mut l.requests, self.clusters.as_mut_slice()),
            UnitId::Balancer => {
                // Registered ray-buffer occupancies (committed state, same in any order).
                for (o, cl) in self.occupancy.iter_mut().zip(&self.clusters) {
                    *o = cl.ray_buffer.waiting();
                }
                let mut io = BalancerPorts {
                    occupancy: &self.occupancy,
                    orders: &mut l.orders,
                    items: &mut l.items,
                    to_ray_buffers: &mut l.net_in,
                    desc_to_ray_buffers: &mut l.net_desc,
                    from_icus: &mut l.remote_out,
                    to_ctus: &mut l.remote_in,
                    ctus_per_cluster: k,
                };
                self.balancer.tick(now, &mut io);
            }
            UnitId::PatchBuffer(c) => {
                let arrivals = Links::of_cluster(&mut l.arrivals, k, c);
                self.clusters[c].patch_buffer.tick(arrivals);
            }
            UnitId::Ctu(c, j) => {
                let i = c * k + j;
                let mut io = ctu_ports(l, &mut self.pool, i);
                self.clusters[c].ctus[j].tick(now, &mut io, &self.scene.cells);
            }
            UnitId::RayBuffer(c) => {
                let bundle = self.cfg.machine.job_source == JobSource::Bundle;
                tick_ray_buffer(&mut self.clusters[c], l, &self.pool, c, k, bundle);
            }
            UnitId::Icu(c) => tick_icu(&mut self.clusters[c], l, c, k, self.scene, self.rays),
        }
    }
}

/// Cluster `c`'s ray buffer's cycle, its job form or (`bundle`) its descriptor form.
#[inline(always)]
fn tick_ray_buffer(
    cl: &mut Cluster,
    l: &mut Links,
    pool: &[RayList],
    c: usize,
    k: usize,
    bundle: bool,
) {
    if bundle {
        let mut io = BundlePorts {
            inputs: Links::of_cluster(&mut l.descs, k, c),
            from_network: &mut l.net_desc[c],
            orders: &mut l.orders[c],
            out: &mut l.items[c],
            pool,
            ctus_per_cluster: k,
        };
        cl.ray_buffer.tick_bundle(c as u16, &mut io);
    } else {
        cl.ray_buffer.tick(
            c as u16,
            Links::of_cluster(&mut l.jobs, k, c),
            &mut l.net_in[c],
            &mut l.orders[c],
            &mut l.items[c],
        );
    }
}

/// Cluster `c`'s ICU's cycle (it takes its jobs from the ray buffer's queue).
#[inline(always)]
fn tick_icu(
    cl: &mut Cluster,
    l: &mut Links,
    c: usize,
    k: usize,
    scene: &FixedScene,
    rays: &[RayRecord],
) {
    let mut io = IcuPorts {
        cluster: c as u16,
        input: &mut cl.ray_buffer.queue,
        results: Links::of_cluster(&mut l.results, k, c),
        remote: &mut l.remote_out[c],
    };
    cl.icu.tick(&mut io, rays, &scene.patches, &scene.formats);
}

/// CTU `i`'s ports (per-CTU families are cluster-major: `i = c·k + j`).
#[inline(always)]
fn ctu_ports<'a>(l: &'a mut Links, pool: &'a mut [RayList], i: usize) -> CtuPorts<'a> {
    CtuPorts {
        requests: &mut l.requests[i],
        arrivals: &mut l.arrivals[i],
        jobs: &mut l.jobs[i],
        results: &mut l.results[i],
        remote_results: &mut l.remote_in[i],
        descs: &mut l.descs[i],
        pool: &mut pool[i],
    }
}

/// True when cluster `c` has nothing to do this cycle: its CTUs are finished, its patch
/// buffer, ray buffer and ICU are empty, and nothing waits at the ray buffer's inputs
/// ([`Links::waiting_for`]; at the last edge, as each unit's own idle test sees it).
#[inline(always)]
fn quiet_cluster(cl: &Cluster, l: &Links, c: usize) -> bool {
    cl.ctus.iter().all(Ctu::is_finished)
        && cl.icu.is_empty()
        && cl.ray_buffer.is_empty()
        && cl.patch_buffer.store.is_empty()
        && !l.waiting_for(c)
}

/// A deterministic Fisher–Yates shuffle (splitmix64).
fn shuffle<T>(v: &mut [T], mut seed: u64) {
    let mut next = || {
        seed = seed.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = seed;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    };
    for i in (1..v.len()).rev() {
        let j = (next() % (i as u64 + 1)) as usize;
        v.swap(i, j);
    }
}
