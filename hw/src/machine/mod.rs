//! The machine: clusters, the global memory with its arbiter, and the request links between
//! them, stepped cycle by cycle.
//!
//! **Invariant:** a cycle ticks every unit once, in any order, then commits every link. Units
//! read only their own state and registered link state (see `link`), so the order cannot
//! change any result — `TickOrder` lets a test try another.
//!
//! The cycle jump: when no unit can act before some timer (a DDA step, the memory's port or
//! latency) and every link is empty, the clock moves straight to the earliest timer; each unit
//! accounts the skipped cycles as it would have spent them. Results and waveforms are the
//! same with or without it.

use crate::config::MachineConfig;
use crate::datapath::model::FixedScene;
use crate::datapath::record::{RayRecord, RecordSizes};
use crate::datapath::{Exceptions, FixedHit};
use crate::link::Link;
use crate::msg::{Job, JobResult, MemRequest, PatchArrival, RemoteResult, SplitOrder, WorkItem};
use crate::trace::Probe;
use crate::units::balancer::{Balancer, BalancerPorts};
use crate::units::cluster::Cluster;
use crate::units::ctu::{Ctu, CtuParams};
use crate::units::icu::Icu;
use crate::units::memory::Memory;
use crate::units::ray_buffer::RayBuffer;

/// The order units are ticked in within a cycle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TickOrder {
    Forward,
    Reverse,
    /// A fixed pseudo-random permutation from this seed, new every cycle.
    Shuffled(u64),
}

/// A unit of the machine.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Unit {
    Memory,
    Balancer,
    Ctu(usize, usize),
    Icu(usize),
    RayBuffer(usize),
    PatchBuffer(usize),
}

/// Why a run stopped without finishing.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Deadlock {
    pub cycle: u64,
    /// One line per unit: its state.
    pub report: Vec<String>,
}

impl std::fmt::Display for Deadlock {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "no progress for the watchdog's cycles; at cycle {}:",
            self.cycle
        )?;
        for l in &self.report {
            writeln!(f, "  {l}")?;
        }
        Ok(())
    }
}

/// The machine.
pub struct Machine<'a> {
    pub cfg: MachineConfig,
    scene: &'a FixedScene,
    rays: &'a [RayRecord],
    pub clusters: Vec<Cluster>,
    pub memory: Memory,
    /// CTU → arbiter, indexed cluster-major.
    pub requests: Vec<Link<MemRequest>>,
    /// Memory → each cluster's patch buffer (the buffer's store).
    pub stores: Vec<Link<PatchArrival>>,
    /// Dynamic balancing: the balancer and, per cluster, its links.
    pub balancer: Balancer,
    pub orders: Vec<Link<SplitOrder>>,
    pub items: Vec<Link<WorkItem>>,
    pub net_in: Vec<Link<Job>>,
    pub remote_out: Vec<Link<RemoteResult>>,
    /// Per cluster, per CTU.
    pub remote_in: Vec<Vec<Link<JobResult>>>,
    occupancy: Vec<usize>,
    pub cycle: u64,
    /// Scratch for the per-cycle tick order (no allocation per cycle).
    scratch: Vec<Unit>,
    /// Scope names for probes, built on the first probe.
    scopes: Option<Scopes>,
    /// Cycles the clock jumped over (not in the statistics, which must not depend on it).
    pub skipped_cycles: u64,
    order: Vec<Unit>,
    progress: u64,
    last_progress_cycle: u64,
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
        let clusters: Vec<Cluster> = sectors
            .iter()
            .enumerate()
            .map(|(c, secs)| {
                assert_eq!(secs.len(), k, "one sector per CTU");
                let ctus = secs
                    .iter()
                    .enumerate()
                    .map(|(j, r)| {
                        let p = CtuParams {
                            cluster: c as u16,
                            local: j as u16,
                            source,
                            dda_cycles_per_step: cfg.machine.dda_cycles_per_step,
                            subshell_max_patches: cfg.machine.subshell_max_patches,
                            shell_raw,
                            t_frac: f.t.frac_bits,
                            t_max: f.t.max_raw() as i64,
                        };
                        Ctu::new(p, r, rays, &scene.cells, scene.patches.len())
                    })
                    .collect();
                Cluster::new(
                    ctus,
                    Icu::new(cfg.divider_stages()),
                    RayBuffer::new(cfg.machine.ray_buffer_capacity, k + 1),
                )
            })
            .collect();
        let n_req = clusters.len() * k;
        let words = RecordSizes::of(f).patch_words;
        let mut order = vec![Unit::Memory];
        if cfg.balance.enabled {
            order.push(Unit::Balancer);
        }
        for c in 0..clusters.len() {
            order.push(Unit::PatchBuffer(c));
            for j in 0..k {
                order.push(Unit::Ctu(c, j));
            }
            order.push(Unit::RayBuffer(c));
            order.push(Unit::Icu(c));
        }
        let nc = clusters.len();
        Machine {
            balancer: Balancer::new(cfg.balance, nc),
            orders: (0..nc).map(|_| Link::new(1)).collect(),
            items: (0..nc).map(|_| Link::new(1)).collect(),
            net_in: (0..nc).map(|_| Link::new(2)).collect(),
            remote_out: (0..nc).map(|_| Link::new(2)).collect(),
            remote_in: (0..nc)
                .map(|_| (0..k).map(|_| Link::new(2)).collect())
                .collect(),
            occupancy: vec![0; nc],
            memory: Memory::new(cfg.machine.arbiter, cfg.machine.memory_latency, words, nc),
            requests: (0..n_req)
                .map(|_| Link::new(cfg.machine.request_queue_capacity as usize))
                .collect(),
            stores: (0..clusters.len())
                .map(|_| Link::new(cfg.machine.patch_buffer_capacity as usize))
                .collect(),
            clusters,
            cfg,
            scene,
            rays,
            cycle: 0,
            scratch: Vec::with_capacity(order.len()),
            scopes: None,
            skipped_cycles: 0,
            order,
            progress: 0,
            last_progress_cycle: 0,
        }
    }

    /// True when every sector is finished and nothing is in flight.
    pub fn done(&self) -> bool {
        self.clusters.iter().all(Cluster::drained)
            && self.memory.inflight() == 0
            && self.requests.iter().all(Link::is_empty)
            && self.stores.iter().all(Link::is_empty)
            && self.balance_links_empty()
            && self.balancer.idle()
    }

    /// True when every link of the balancer is empty.
    fn balance_links_empty(&self) -> bool {
        self.orders.iter().all(Link::is_empty)
            && self.items.iter().all(Link::is_empty)
            && self.net_in.iter().all(Link::is_empty)
            && self.remote_out.iter().all(Link::is_empty)
            && self.remote_in.iter().flatten().all(Link::is_empty)
    }

    /// One clock cycle: tick every unit in `order`, then commit every link.
    pub fn tick(&mut self, order: TickOrder) {
        let now = self.cycle;
        let mut units = self.order.clone();
        match order {
            TickOrder::Forward => {}
            TickOrder::Reverse => units.reverse(),
            TickOrder::Shuffled(seed) => {
                shuffle(&mut units, seed ^ now.wrapping_mul(0x9E37_79B9_7F4A_7C15))
            }
        }
        let k = self.cfg.machine.ctus_per_cluster as usize;
        let f = self.scene.formats;
        for &u in &units {
            match u {
                Unit::Memory => self.memory.tick(now, &mut self.requests, &mut self.stores),
                Unit::Balancer => {
                    // Registered ray-buffer occupancies (committed state, same in any order).
                    for (o, cl) in self.occupancy.iter_mut().zip(&self.clusters) {
                        *o = cl.ray_buffer.queue.len();
                    }
                    let mut io = BalancerPorts {
                        occupancy: &self.occupancy,
                        orders: &mut self.orders,
                        items: &mut self.items,
                        to_ray_buffers: &mut self.net_in,
                        from_icus: &mut self.remote_out,
                        to_ctus: &mut self.remote_in,
                    };
                    self.balancer.tick(now, &mut io);
                }
                Unit::PatchBuffer(c) => {
                    let cl = &mut self.clusters[c];
                    cl.patch_buffer
                        .tick(&mut self.stores[c], &mut cl.arrival_links);
                }
                Unit::Ctu(c, j) => {
                    let cl = &mut self.clusters[c];
                    let mut io = crate::units::ctu::CtuPorts {
                        requests: &mut self.requests[c * k + j],
                        arrivals: &mut cl.arrival_links[j],
                        jobs: &mut cl.job_links[j],
                        results: &mut cl.result_links[j],
                        remote_results: &mut self.remote_in[c][j],
                    };
                    cl.ctus[j].tick(now, &mut io, &self.scene.cells);
                }
                Unit::RayBuffer(c) => {
                    let cl = &mut self.clusters[c];
                    cl.ray_buffer.tick(
                        c as u16,
                        &mut cl.job_links,
                        &mut self.net_in[c],
                        &mut self.orders[c],
                        &mut self.items[c],
                    );
                }
                Unit::Icu(c) => {
                    let cl = &mut self.clusters[c];
                    let mut io = crate::units::icu::IcuPorts {
                        cluster: c as u16,
                        input: &mut cl.ray_buffer.queue,
                        results: &mut cl.result_links,
                        remote: &mut self.remote_out[c],
                    };
                    cl.icu.tick(&mut io, self.rays, &self.scene.patches, &f);
                }
            }
        }
        self.scratch = units;
        for l in &mut self.requests {
            l.commit();
        }
        for l in &mut self.stores {
            l.commit();
        }
        for cl in &mut self.clusters {
            cl.commit();
        }
        for l in &mut self.orders {
            l.commit();
        }
        for l in &mut self.items {
            l.commit();
        }
        for l in &mut self.net_in {
            l.commit();
        }
        for l in &mut self.remote_out {
            l.commit();
        }
        for l in self.remote_in.iter_mut().flatten() {
            l.commit();
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

    /// A number that grows whenever anything moves (transfers, steps, grants).
    fn activity(&self) -> u64 {
        let mut a =
            self.memory.stats.grants + self.requests.iter().map(|l| l.transfers).sum::<u64>();
        a += self.stores.iter().map(|l| l.transfers).sum::<u64>();
        a += self.balancer.stats.jobs_moved + self.balancer.stats.results_returned;
        for cl in &self.clusters {
            a += cl.icu.stats.jobs_in + cl.icu.stats.results_out;
            for c in &cl.ctus {
                a +=
                    c.stats.dda_steps + c.stats.patch_requests + c.stats.shells + c.stats.subshells;
            }
        }
        a
    }

    /// The cycle the clock may jump to from `now`: every link empty, every ICU empty, every
    /// CTU quiet, and a timer ahead. `None` when something can act at `now`.
    fn quiet_until(&self, now: u64) -> Option<u64> {
        let links_empty = self.requests.iter().all(Link::is_empty)
            && self.stores.iter().all(Link::is_empty)
            && self
                .clusters
                .iter()
                .all(|c| c.links_empty() && c.ray_buffer.queue.is_empty() && c.icu.is_empty());
        let balancer_acts = self.cfg.balance.enabled
            && (!self.balance_links_empty()
                || self.balancer.due(now)
                || (0..self.clusters.len()).any(|c| {
                    self.balancer.would_request(
                        c,
                        self.clusters[c].ray_buffer.queue.len(),
                        self.net_in[c].is_empty(),
                    )
                }));
        if !links_empty
            || balancer_acts
            || !self
                .clusters
                .iter()
                .flat_map(|c| &c.ctus)
                .all(|c| c.quiet(now))
        {
            return None;
        }
        let mut t = self.memory.timer(now);
        if let Some(x) = self.balancer.timer(now) {
            t = Some(t.map_or(x, |y: u64| y.min(x)));
        }
        for c in self.clusters.iter().flat_map(|c| &c.ctus) {
            if let Some(x) = c.timer(now) {
                t = Some(t.map_or(x, |y: u64| y.min(x)));
            }
        }
        // Only a jump of at least one cycle is worth it; a pending delivery acts at once.
        t.filter(|&t| t > now + 1 && self.memory.inflight_ready(now).is_none())
    }

    /// Runs to the end; `probe` sees every unit's signals after every edge that changed them.
    pub fn run(
        &mut self,
        order: TickOrder,
        mut probe: Option<&mut dyn Probe>,
    ) -> Result<(), Deadlock> {
        loop {
            self.tick(order);
            if let Some(p) = probe.as_deref_mut() {
                self.probe(p);
            }
            if self.done() {
                self.cycle += 1;
                return Ok(());
            }
            if self.cycle - self.last_progress_cycle > self.cfg.machine.watchdog_cycles {
                return Err(self.deadlock());
            }
            self.cycle += 1;
            if self.cfg.machine.cycle_jump {
                if let Some(t) = self.quiet_until(self.cycle) {
                    let n = t - self.cycle;
                    self.skip(n);
                    self.cycle = t;
                }
            }
        }
    }

    /// Accounts `n` skipped cycles in every unit.
    fn skip(&mut self, n: u64) {
        let now = self.cycle;
        self.memory.skip(now, n);
        for cl in &mut self.clusters {
            cl.icu.skip(n);
            for c in &mut cl.ctus {
                c.skip(n);
            }
        }
        self.last_progress_cycle += n;
        self.skipped_cycles += n;
    }

    /// The watchdog's report: every unit's state.
    fn deadlock(&self) -> Deadlock {
        let mut report = vec![format!(
            "memory: port {}, {} in flight, {} grants",
            if self.memory.port_busy(self.cycle) {
                "busy"
            } else {
                "free"
            },
            self.memory.inflight(),
            self.memory.stats.grants
        )];
        for (i, cl) in self.clusters.iter().enumerate() {
            report.push(format!(
                "cluster {i}: icu {} of {} stages full, ray buffer {}/{}, patch buffer {}",
                cl.icu.occupied(),
                cl.icu.depth(),
                cl.ray_buffer.queue.len(),
                cl.ray_buffer.queue.capacity(),
                self.stores[i].len()
            ));
            for (j, c) in cl.ctus.iter().enumerate() {
                report.push(format!(
                    "cluster {i} ctu {j}: {} shell {} remaining {} outstanding {} pending loads {}",
                    c.state.name(),
                    c.shell(),
                    c.remaining(),
                    c.outstanding(),
                    c.pending_loads()
                ));
            }
        }
        Deadlock {
            cycle: self.cycle,
            report,
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

    /// Reports every unit's signals to `p` (scope names are built once, not per cycle).
    pub fn probe(&mut self, p: &mut dyn Probe) {
        if self.scopes.is_none() {
            self.scopes = Some(Scopes::new(self));
        }
        let sc = self.scopes.as_ref().expect("built above");
        let now = self.cycle;
        p.cycle(now);
        let t_frac = self.scene.formats.t.frac_bits;
        let t_bits = self.scene.formats.t.bits();
        p.bits(
            &sc.memory,
            "port_busy",
            1,
            self.memory.port_busy(now) as u64,
        );
        p.bits(&sc.memory, "in_flight", 16, self.memory.inflight() as u64);
        p.bits(&sc.memory, "grants", 32, self.memory.stats.grants);
        p.bits(
            &sc.arbiter,
            "last_grant",
            16,
            self.memory.last_grant.min(0xFFFF) as u64,
        );
        for (l, s) in self.requests.iter().zip(&sc.requests) {
            probe_link(p, s, l);
        }
        if self.cfg.balance.enabled {
            p.bits(
                &sc.balancer,
                "split_orders",
                32,
                self.balancer.stats.split_orders,
            );
            p.bits(
                &sc.balancer,
                "jobs_moved",
                32,
                self.balancer.stats.jobs_moved,
            );
            p.bits(&sc.balancer, "retries", 32, self.balancer.stats.retries);
        }
        for (c, cl) in self.clusters.iter().enumerate() {
            let cs = &sc.clusters[c];
            if self.cfg.balance.enabled {
                p.bits(
                    &cs.balance,
                    "work_request",
                    1,
                    self.balancer.requesting(c) as u64,
                );
                p.bits(
                    &cs.balance,
                    "jobs_inbound",
                    16,
                    self.balancer.inbound(c) as u64,
                );
                probe_link(p, &cs.split_order, &self.orders[c]);
                probe_link(p, &cs.work_item, &self.items[c]);
                probe_link(p, &cs.net_in, &self.net_in[c]);
                probe_link(p, &cs.remote_out, &self.remote_out[c]);
            }
            probe_link(p, &cs.patch_buffer, &self.stores[c]);
            probe_link(p, &cs.ray_buffer, &cl.ray_buffer.queue);
            for (j, ctu) in cl.ctus.iter().enumerate() {
                let s = &cs.ctus[j];
                p.text(&s[0], "state", ctu.state.name());
                p.bits(&s[0], "shell", 16, ctu.shell() as u64);
                p.bits(&s[0], "remaining_rays", 32, ctu.remaining() as u64);
                p.bits(&s[0], "outstanding_jobs", 32, ctu.outstanding());
                p.bits(&s[0], "pending_loads", 16, ctu.pending_loads() as u64);
                p.bits(&s[0], "jobs_issued", 32, ctu.stats.jobs_issued);
                probe_link(p, &s[1], &cl.job_links[j]);
                probe_link(p, &s[2], &cl.result_links[j]);
                probe_link(p, &s[3], &cl.arrival_links[j]);
            }
            p.bits(&cs.icu, "jobs_in", 32, cl.icu.stats.jobs_in);
            for n in 0..cl.icu.depth() {
                let st = cl.icu.stage(n).copied();
                let ss = &cs.stages[n];
                p.bits(ss, "valid", 1, st.is_some() as u64);
                p.bits(ss, "ray", 32, st.map_or(0, |r| r.job.ray as u64));
                p.bits(ss, "patch", 24, st.map_or(0, |r| r.job.patch as u64));
                let t = match st.map(|r| r.value) {
                    Some(crate::units::icu::StageValue::Result(Some(t))) => t,
                    _ => 0,
                };
                p.fixed(ss, "t", t_bits, t_frac, t);
            }
        }
    }
}

/// The dotted scope names of every unit, built once per machine.
#[derive(Clone, Debug)]
struct Scopes {
    memory: String,
    balancer: String,
    arbiter: String,
    requests: Vec<String>,
    clusters: Vec<ClusterScopes>,
}

#[derive(Clone, Debug)]
struct ClusterScopes {
    balance: String,
    split_order: String,
    work_item: String,
    net_in: String,
    remote_out: String,
    patch_buffer: String,
    ray_buffer: String,
    /// Per CTU: the CTU, its jobs, results and arrivals links.
    ctus: Vec<[String; 4]>,
    icu: String,
    stages: Vec<String>,
}

impl Scopes {
    fn new(m: &Machine) -> Self {
        let k = m.cfg.machine.ctus_per_cluster as usize;
        Scopes {
            memory: "machine.memory".into(),
            balancer: "machine.balancer".into(),
            arbiter: "machine.memory.arbiter".into(),
            requests: (0..m.requests.len())
                .map(|i| format!("machine.memory.arbiter.req_{}_{}", i / k, i % k))
                .collect(),
            clusters: (0..m.clusters.len())
                .map(|c| {
                    let base = format!("machine.cluster_{c}");
                    ClusterScopes {
                        balance: format!("{base}.balance"),
                        split_order: format!("{base}.balance.split_order"),
                        work_item: format!("{base}.balance.work_item"),
                        net_in: format!("{base}.balance.net_in"),
                        remote_out: format!("{base}.balance.remote_out"),
                        patch_buffer: format!("{base}.patch_buffer"),
                        ray_buffer: format!("{base}.ray_buffer"),
                        ctus: (0..k)
                            .map(|j| {
                                let s = format!("{base}.ctu_{j}");
                                [
                                    s.clone(),
                                    format!("{s}.jobs"),
                                    format!("{s}.results"),
                                    format!("{s}.arrivals"),
                                ]
                            })
                            .collect(),
                        icu: format!("{base}.icu"),
                        stages: (0..m.clusters[c].icu.depth())
                            .map(|n| format!("{base}.icu.stage_{n}"))
                            .collect(),
                    }
                })
                .collect(),
        }
    }
}

/// Reports a link's registered valid, ready, occupancy and transfer count.
fn probe_link<T: Clone>(p: &mut dyn Probe, scope: &str, l: &Link<T>) {
    p.bits(scope, "valid", 1, l.valid() as u64);
    p.bits(scope, "ready", 1, l.ready() as u64);
    p.bits(scope, "occupancy", 16, l.len() as u64);
    p.bits(scope, "transfers", 32, l.transfers);
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
