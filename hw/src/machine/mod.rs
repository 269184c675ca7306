//! The machine: clusters, the global memory with its arbiter, the balancer, and every link
//! between them (links.rs), stepped cycle by cycle (tick.rs), with the cycle jump (jump.rs),
//! the watchdog (watchdog.rs) and the waveform probes (probe.rs).
//!
//! **Invariant:** a cycle ticks every unit once, in any order, then commits every link. Units
//! read only their own state and registered link state (see `link`), so the order cannot
//! change any result — `TickOrder` lets a test try another.
//!
//! The cycle jump: when no unit can act before some timer (a DDA step, the memory's port or
//! latency) and every link is empty, the clock moves straight to the earliest timer; each unit
//! accounts the skipped cycles as it would have spent them. Results and waveforms are the
//! same with or without it.
//!
//! The cold paths — the jump, its skip, the end test, the watchdog's progress and report —
//! reach the units through one registry, [`Machine::each_unit`] (the memory, each cluster's
//! units as `Cluster::each_unit` lists them, the balancer), each unit answering through the
//! `units::Unit` trait in its own file; the hot tick (tick.rs) calls each unit by hand.

mod jump;
pub mod links;
mod probe;
pub(crate) mod sink;
mod tick;
mod watchdog;

pub use links::Links;
pub use probe::Sampler;
pub use watchdog::Deadlock;

use crate::config::{JobSource, MachineConfig};
use crate::datapath::model::FixedScene;
use crate::datapath::record::{RayRecord, RecordSizes};
use crate::datapath::{Exceptions, FixedHit};
use crate::link::UnitId;
use crate::trace::Probe;
use crate::units::balancer::Balancer;
use crate::units::cluster::Cluster;
use crate::units::ctu::{Ctu, CtuParams};
use crate::units::memory::Memory;
use crate::units::ray_pool::RayList;
use crate::units::Unit;
use std::ops::ControlFlow;

/// The order units are ticked in within a cycle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TickOrder {
    Forward,
    Reverse,
    /// A fixed pseudo-random permutation from this seed, new every cycle.
    Shuffled(u64),
}

/// Cycles between two calls of [`Machine::run_reporting`]'s report.
pub const REPORT_CYCLES: u64 = 1 << 16;

/// The machine.
pub struct Machine<'a> {
    pub cfg: MachineConfig,
    scene: &'a FixedScene,
    rays: &'a [RayRecord],
    pub clusters: Vec<Cluster>,
    pub memory: Memory,
    /// Dynamic balancing: the balancer.
    pub balancer: Balancer,
    /// Every link between units.
    pub links: Links,
    /// Every CTU's ray pool, cluster-major (bundle only; empty lists otherwise).
    pool: Vec<RayList>,
    /// The balancer's view of each ray buffer's registered occupancy (reused every cycle).
    occupancy: Vec<usize>,
    pub cycle: u64,
    /// The units in forward tick order (computed once).
    order: Vec<UnitId>,
    /// This cycle's tick order: `order` copied and permuted in place (no allocation per
    /// cycle; its capacity is `order.len()`).
    scratch: Vec<UnitId>,
    /// Cycles the clock jumped over (not in the statistics, which must not depend on it).
    pub skipped_cycles: u64,
    progress: u64,
    last_progress_cycle: u64,
}

/// CTU `local` of cluster `cluster` on `cfg` (hardware units) with formats `f`, casting from
/// `source`; `shell_raw` is `cfg.shell_raw()`.
pub fn ctu_params(
    cfg: &MachineConfig,
    f: &crate::Formats,
    shell_raw: i64,
    source: u32,
    cluster: usize,
    local: usize,
) -> CtuParams {
    CtuParams {
        cluster: cluster as u16,
        local: local as u16,
        source,
        dda_cycles_per_step: cfg.machine.dda_cycles_per_step,
        subshell_max_patches: cfg.machine.subshell_max_patches,
        shell_raw,
        t_frac: f.t.frac_bits,
        t_max: f.t.max_raw() as i64,
        bundle: cfg.machine.job_source == JobSource::Bundle,
        overlap: cfg.machine.overlap_joins,
        scan_ids_per_cycle: cfg.machine.scan_ids_per_cycle,
    }
}

impl<'a> Machine<'a> {
    /// A machine for `sectors[cluster][ctu]` = the sector's ray ids (ascending), casting from
    /// patch `source` (excluded from every sector's loads).
    pub fn new(
        cfg: MachineConfig,
        scene: &'a FixedScene,
        rays: &'a [RayRecord],
        sectors: &[Vec<Vec<u32>>],
        source: u32,
    ) -> Self {
        let f = &scene.formats;
        let k = cfg.machine.ctus_per_cluster as usize;
        assert_eq!(
            sectors.len(),
            cfg.machine.clusters as usize,
            "one section per cluster"
        );
        // Quantized once by the configuration; a radius that does not fit is a config error.
        let shell_raw = cfg
            .shell_raw()
            .unwrap_or_else(|e| panic!("an unvalidated machine configuration: {e}"));
        let bundle = cfg.machine.job_source == JobSource::Bundle;
        let pool: Vec<RayList> = sectors
            .iter()
            .flatten()
            .map(|r| {
                if bundle {
                    RayList::new(r)
                } else {
                    RayList::default()
                }
            })
            .collect();
        let clusters: Vec<Cluster> = sectors
            .iter()
            .enumerate()
            .map(|(c, secs)| {
                assert_eq!(secs.len(), k, "one sector per CTU");
                let ctus = secs
                    .iter()
                    .enumerate()
                    .map(|(j, r)| {
                        let p = ctu_params(&cfg, f, shell_raw, source, c, j);
                        Ctu::new(p, r, rays, &scene.cells, scene.patches.len())
                            .skipping(scene.twins_of(Some(source)))
                    })
                    .collect();
                Cluster::new(&cfg, c, ctus)
            })
            .collect();
        let words = RecordSizes::of(f).patch_words;
        let nc = clusters.len();
        // The tick order: the memory, the balancer when balancing is on, then each
        // cluster's units in the order it lists them.
        let mut order = vec![UnitId::Memory];
        if cfg.balance.enabled {
            order.push(UnitId::Balancer);
        }
        for (c, cl) in clusters.iter().enumerate() {
            let _ = cl.each_unit(c, |u, _| {
                order.push(u);
                ControlFlow::<()>::Continue(())
            });
        }
        Machine {
            balancer: Balancer::new(cfg.balance, nc).with_low_water(if bundle {
                cfg.balance.work_item_jobs as usize
            } else {
                0
            }),
            links: Links::new(&cfg.machine),
            occupancy: vec![0; nc],
            pool,
            memory: Memory::new(cfg.machine.arbiter, cfg.machine.memory_latency, words, nc),
            clusters,
            cfg,
            scene,
            rays,
            cycle: 0,
            scratch: Vec::with_capacity(order.len()),
            order,
            skipped_cycles: 0,
            progress: 0,
            last_progress_cycle: 0,
        }
    }

    /// Bytes the machine's state takes for `cfg` on `patches` patches and `rays` rays, before
    /// it runs: every link's slots ([`Links::memory_estimate`], generated from the table and
    /// tested against what it allocates), each cluster's units' stores
    /// ([`Cluster::memory_estimate`]: the ray buffers and patch buffers dominate for big
    /// buffers), each CTU's loaded-patch bitmap, the rays' state.
    /// An estimate from the configuration alone, for refusing a machine that cannot fit
    /// before allocating it.
    pub fn memory_estimate(cfg: &MachineConfig, patches: usize, rays: usize) -> u64 {
        let m = &cfg.machine;
        let (c, k) = (m.clusters as u64, m.ctus_per_cluster as u64);
        let per_ctu = (patches as u64).div_ceil(8) + 4096;
        // Bundle: the ray pools' two lists of (slot, ray).
        let pools = if m.job_source == JobSource::Bundle {
            rays as u64 * 16
        } else {
            0
        };
        Links::memory_estimate(m)
            + c * Cluster::memory_estimate(cfg)
            + c * k * per_ctu
            + rays as u64 * 64
            + pools
    }

    /// Visits every unit — the memory, each cluster's units ([`Cluster::each_unit`]), the
    /// balancer — until `f` breaks: the registry the cold paths (the cycle jump, the end
    /// test, the watchdog) walk. The hot tick calls each unit by hand (tick.rs).
    #[inline]
    pub fn each_unit<B>(
        &self,
        mut f: impl FnMut(UnitId, &dyn Unit) -> ControlFlow<B>,
    ) -> ControlFlow<B> {
        f(UnitId::Memory, &self.memory)?;
        for (c, cl) in self.clusters.iter().enumerate() {
            cl.each_unit(c, &mut f)?;
        }
        f(UnitId::Balancer, &self.balancer)
    }

    /// [`Machine::each_unit`], each unit mutable, all of them.
    #[inline]
    fn each_unit_mut(&mut self, mut f: impl FnMut(UnitId, &mut dyn Unit)) {
        f(UnitId::Memory, &mut self.memory);
        for (c, cl) in self.clusters.iter_mut().enumerate() {
            cl.each_unit_mut(c, &mut f);
        }
        f(UnitId::Balancer, &mut self.balancer);
    }

    /// True when some cluster's ICU or buffers hold work (then the machine is neither done
    /// nor quiet). Looks first at cluster `busy`, the run's hint (the last cluster found
    /// busy: a working machine most likely still has work there), and updates it.
    #[inline]
    fn some_cluster_busy(&self, busy: &mut usize) -> bool {
        if self.clusters.get(*busy).is_some_and(|c| !c.is_empty()) {
            return true;
        }
        match self.clusters.iter().position(|c| !c.is_empty()) {
            Some(c) => {
                *busy = c;
                true
            }
            None => false,
        }
    }

    /// True when every sector is finished and nothing is in flight: every unit done
    /// (`Unit::done`), every link empty.
    pub fn done(&self) -> bool {
        self.done_from(&mut 0)
    }

    /// [`Machine::done`], looking first at cluster `busy` ([`Machine::some_cluster_busy`]).
    #[inline]
    fn done_from(&self, busy: &mut usize) -> bool {
        !self.some_cluster_busy(busy)
            && self
                .each_unit(|_, u| {
                    if u.done() {
                        ControlFlow::Continue(())
                    } else {
                        ControlFlow::Break(())
                    }
                })
                .is_continue()
            && self.links.all_empty()
    }

    /// Runs to the end; `probe` sees every unit's signals after every edge that changed them.
    pub fn run(&mut self, order: TickOrder, probe: Option<&mut dyn Probe>) -> Result<(), Deadlock> {
        self.run_reporting(order, probe, None)
    }

    /// As [`Machine::run`], calling `report` with the cycle count every
    /// [`REPORT_CYCLES`] cycles or so (for a progress display; it does not touch the model).
    pub fn run_reporting(
        &mut self,
        order: TickOrder,
        mut probe: Option<&mut dyn Probe>,
        mut report: Option<&mut dyn FnMut(u64)>,
    ) -> Result<(), Deadlock> {
        // Without a report the comparison below is never true.
        let mut next_report = match report {
            Some(_) => self.cycle + REPORT_CYCLES,
            None => u64::MAX,
        };
        // What the run keeps to look at the machine (the model keeps none of it): the
        // waveform's sampler and the cluster last found busy.
        let mut sampler = Sampler::default();
        let mut busy = 0;
        loop {
            self.tick(order);
            if self.cycle >= next_report {
                if let Some(r) = report.as_deref_mut() {
                    r(self.cycle);
                }
                next_report = self.cycle + REPORT_CYCLES;
            }
            if let Some(p) = probe.as_deref_mut() {
                sampler.sample(self, p);
                if p.stop() {
                    self.cycle += 1;
                    return Ok(());
                }
            }
            if self.done_from(&mut busy) {
                self.cycle += 1;
                return Ok(());
            }
            if self.cycle - self.last_progress_cycle > self.cfg.machine.watchdog_cycles {
                // Progress is sampled every 64 cycles (and a cycle jump can step over the
                // sample): look again before reporting, so only a real stretch of
                // `watchdog_cycles` ticked cycles without any progress event trips it.
                let p = self.activity();
                if p == self.progress {
                    return Err(self.deadlock());
                }
                self.progress = p;
                self.last_progress_cycle = self.cycle;
            }
            self.cycle += 1;
            if self.cfg.machine.cycle_jump {
                if let Some(t) = self.quiet_until(self.cycle, &mut busy) {
                    let n = t - self.cycle;
                    self.skip(n);
                    self.cycle = t;
                }
            }
        }
    }

    /// Every ray's nearest hit, by ray id.
    pub fn hits(&self) -> Vec<Option<FixedHit>> {
        let mut out = vec![None; self.rays.len()];
        for c in self.clusters.iter().flat_map(|c| &c.ctus) {
            for (r, h) in c.hits() {
                out[r as usize] = h;
            }
        }
        out
    }

    /// Exceptions counted by all ICUs.
    pub fn exceptions(&self) -> Exceptions {
        let mut e = Exceptions::default();
        for cl in &self.clusters {
            e.add(&cl.icu.exceptions);
        }
        e
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::datapath::record::CellTable;

    /// The registry lists every unit once: the memory, each cluster's units in tick order, the
    /// balancer; the tick order is the same units with the balancer second (when balancing
    /// is on), and the watchdog reports one line per unit. A machine without rays runs to
    /// its end.
    #[test]
    fn the_registry_lists_every_unit_once_in_tick_order() {
        for (clusters, ctus, balance) in [(1, 1, false), (4, 2, true), (3, 5, false), (2, 3, true)]
        {
            let mut cfg = crate::config::paper();
            (cfg.machine.clusters, cfg.machine.ctus_per_cluster) = (clusters, ctus);
            cfg.balance.enabled = balance;
            cfg.machine.shell_radius = crate::config::Length::Value(0.25);
            let scene = FixedScene {
                formats: cfg.datapath.formats().unwrap(),
                patches: Vec::new(),
                cells: CellTable {
                    dims: [1, 1, 1],
                    cell_raw: 1,
                    first: vec![0],
                    count: vec![0],
                    ids: Vec::new(),
                },
                twins: Vec::new(),
            };
            let sectors = vec![vec![Vec::new(); ctus as usize]; clusters as usize];
            let m = Machine::new(cfg, &scene, &[], &sectors, 0);
            let mut ids = Vec::new();
            let _ = m.each_unit(|u, _| {
                ids.push(u);
                ControlFlow::<()>::Continue(())
            });
            let (c, k) = (clusters as usize, ctus as usize);
            assert_eq!(ids.len(), 2 + c * (k + 3), "{c} × {k}");
            assert_eq!(
                (ids[0], ids[ids.len() - 1]),
                (UnitId::Memory, UnitId::Balancer)
            );
            for (i, u) in ids.iter().enumerate() {
                assert!(!ids[..i].contains(u), "{u} listed twice");
            }
            let mut order = vec![UnitId::Memory];
            order.extend(balance.then_some(UnitId::Balancer));
            order.extend(&ids[1..ids.len() - 1]);
            assert_eq!(m.order, order);
            let report = m.deadlock().report;
            assert_eq!(report.len(), ids.len());
            assert_eq!(report[1], "cluster 0 patch buffer: 0 patches");
            let mut m = m;
            m.run(TickOrder::Forward, None).unwrap();
            assert!(m.done());
        }
    }
}
