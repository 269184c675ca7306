//! The paper's experiments on the cycle-level machine (§12.3.2): pipeline efficiency with and
//! without dynamic balancing, efficiency against work-item size (Fig 12.14), speedup against
//! the number of ICUs (Fig 12.15) — each beside a lower bound on cycles from the machine's
//! resources, so a reader sees how close the machine runs to its limit and what binds it.
//!
//! Every configuration is one machine run on inputs prepared once per (scene, clusters, CTUs,
//! ratio) and shared by the runs that differ only in balancing (the partition does not depend
//! on it). Independent runs go in parallel (rayon); results keep their order, and neither CSV
//! nor SVG holds a timing, so both are byte-identical across runs.
//!
//! **Invariant:** every run's per-ray results equal the untimed fixed-point model's (checked;
//! an experiment with a mismatch is an error, not a data point).
//! **Invariant:** `Bound::cycles() <= cycles` for every run (tested).

pub mod levels;
pub mod levers;
pub mod outputs;
pub mod report;

use crate::error::{Error, Result};
use crate::machine::run::{self, MachineInput, Prepared, RunSpec, RunStats};
use crate::Scene;
use rayon::prelude::*;
use serde::Serialize;
use shellsim_hw::config::{JobSource, MachineConfig};
use shellsim_hw::machine::TickOrder;
use shellsim_hw::units::ctu::StateCycles;
use std::fmt::Write as _;
use std::path::Path;

/// What an experiment runs on.
#[derive(Clone, Copy)]
pub struct Workload<'a> {
    pub scene: &'a Scene,
    /// The scene's file (named in errors).
    pub file: &'a Path,
    pub source: u32,
    /// The machine: clusters, balancing and work-item size are set per run; the rest is kept.
    pub base: &'a MachineConfig,
}

/// A resource of the machine whose capacity bounds the cycles from below.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Resource {
    /// The ICUs: one job enters each per cycle, the last leaves `depth` cycles later.
    Icu,
    /// The global memory's one port: one word per cycle, then the latency.
    Memory,
    /// The busiest CTU's DDA: its steps × `dda_cycles_per_step` (steps never move).
    CtuDda,
    /// The busiest CTU's job issuer: one job per cycle (issuing never moves either); with
    /// `job_source = "bundle"`, one descriptor per cycle.
    CtuIssue,
}

impl Resource {
    /// The name in CSV and report.
    pub fn name(self) -> &'static str {
        match self {
            Resource::Icu => "icu",
            Resource::Memory => "memory",
            Resource::CtuDda => "ctu_dda",
            Resource::CtuIssue => "ctu_issue",
        }
    }
}

/// Lower bounds on a run's cycles, one per resource. Each counts only work the run actually
/// did (jobs, words, steps), so the bound is exact arithmetic on the run's statistics.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Bound {
    /// With balancing: ⌈jobs / P⌉ + depth (jobs may go to any ICU). Without: the most jobs
    /// any one ICU took + depth (a job stays in its section).
    pub icu: u64,
    /// Words through the memory port (1 per cycle) + the memory latency.
    pub memory: u64,
    /// The busiest CTU's DDA steps × cycles per step.
    pub ctu_dda: u64,
    /// The most jobs any one CTU issued (one per cycle); bundle: the most descriptors.
    pub ctu_issue: u64,
}

impl Bound {
    /// The bound: the largest of the four.
    pub fn cycles(&self) -> u64 {
        self.icu
            .max(self.memory)
            .max(self.ctu_dda)
            .max(self.ctu_issue)
    }

    /// The resource that sets the bound (ties go to the first in icu, memory, ctu_dda,
    /// ctu_issue order).
    pub fn binding(&self) -> Resource {
        let c = self.cycles();
        [
            (self.icu, Resource::Icu),
            (self.memory, Resource::Memory),
            (self.ctu_dda, Resource::CtuDda),
            (self.ctu_issue, Resource::CtuIssue),
        ]
        .into_iter()
        .find(|&(v, _)| v == c)
        .map_or(Resource::Icu, |(_, r)| r)
    }

    /// The bound of a run on `cfg` from its statistics.
    pub fn of(stats: &RunStats, cfg: &MachineConfig) -> Bound {
        let depth = cfg.pipeline_depth() as u64;
        let p = stats.clusters.len().max(1) as u64;
        let ctus = stats.clusters.iter().flat_map(|c| &c.ctus);
        let icu = if cfg.balance.enabled {
            stats.jobs.div_ceil(p)
        } else {
            stats
                .clusters
                .iter()
                .map(|c| c.icu.jobs_in)
                .max()
                .unwrap_or(0)
        } + depth;
        Bound {
            icu,
            memory: stats.memory.words + cfg.machine.memory_latency as u64,
            ctu_dda: ctus.clone().map(|c| c.dda_steps).max().unwrap_or(0)
                * cfg.machine.dda_cycles_per_step as u64,
            ctu_issue: if cfg.machine.job_source == JobSource::Bundle {
                ctus.map(|c| c.descriptors).max().unwrap_or(0)
            } else {
                ctus.map(|c| c.jobs_issued).max().unwrap_or(0)
            },
        }
    }
}

/// One machine run, measured: the configuration, the headline statistics, the per-unit
/// busy/idle/stall sums that explain them, and the resource bound.
#[derive(Clone, Debug, Serialize)]
pub struct Point {
    pub scene: String,
    pub ratio: usize,
    pub rays: usize,
    pub clusters: u32,
    pub ctus_per_cluster: u32,
    pub balance: bool,
    pub work_item_jobs: u32,
    pub cycles: u64,
    /// Σ busy stage-cycles over Σ stage-cycles of all ICUs.
    pub pipeline_efficiency: f64,
    pub jobs: u64,
    pub patch_loads: u64,
    pub work_items: u64,
    pub jobs_moved: u64,
    /// Balancer requests that found no work and waited a sampling interval.
    pub retries: u64,
    /// ICU cycles summed over ICUs: advancing with work inside, held by back-pressure, empty.
    pub icu_busy: u64,
    pub icu_stalled: u64,
    pub icu_idle: u64,
    /// CTU cycles summed over CTUs.
    pub ctu_busy: u64,
    pub ctu_stalled: u64,
    pub ctu_idle: u64,
    /// The busiest CTU's busy cycles.
    pub ctu_busy_max: u64,
    /// Cycles the memory port was occupied.
    pub memory_busy: u64,
    /// Cycles a ready patch record waited for room in its cluster's patch buffer, holding
    /// every record behind it.
    pub memory_delivery_stall: u64,
    /// CTU cycles per traversal state, summed over CTUs.
    pub ctu_states: StateCycles,
    /// Of the CTUs' JOIN cycles: waiting for patches, waiting for results (summed).
    pub join_wait_patches: u64,
    pub join_wait_results: u64,
    /// The CTU with the most jobs: its jobs, cycles traversing (SCAN, REQUEST, STEP) and
    /// cycles at joins.
    pub busiest_ctu_jobs: u64,
    pub busiest_ctu_traversal: u64,
    pub busiest_ctu_join: u64,
    pub bound: Bound,
}

impl Point {
    /// Measures `stats` of a run on `cfg` at `ratio`.
    pub fn new(stats: &RunStats, cfg: &MachineConfig, ratio: usize) -> Point {
        let icus = stats.clusters.iter().map(|c| &c.icu);
        let ctus = || stats.clusters.iter().flat_map(|c| &c.ctus);
        let busiest = ctus().max_by_key(|c| c.jobs_issued);
        Point {
            scene: stats.scene.clone(),
            ratio,
            rays: stats.rays,
            clusters: cfg.machine.clusters,
            ctus_per_cluster: cfg.machine.ctus_per_cluster,
            balance: cfg.balance.enabled,
            work_item_jobs: cfg.balance.work_item_jobs,
            cycles: stats.cycles,
            pipeline_efficiency: stats.pipeline_efficiency,
            jobs: stats.jobs,
            patch_loads: stats.patch_loads,
            work_items: stats.balancer.work_items,
            jobs_moved: stats.balancer.jobs_moved,
            retries: stats.balancer.retries,
            icu_busy: icus.clone().map(|i| i.busy_cycles).sum(),
            icu_stalled: icus.clone().map(|i| i.stalled_cycles).sum(),
            icu_idle: icus.map(|i| i.idle_cycles).sum(),
            ctu_busy: ctus().map(|c| c.busy_cycles).sum(),
            ctu_stalled: ctus().map(|c| c.stalled_cycles).sum(),
            ctu_idle: ctus().map(|c| c.idle_cycles).sum(),
            ctu_busy_max: ctus().map(|c| c.busy_cycles).max().unwrap_or(0),
            memory_busy: stats.memory.busy_cycles,
            memory_delivery_stall: stats.memory.delivery_stall_cycles,
            ctu_states: ctus().fold(StateCycles::default(), |mut a, c| {
                a.sum(&c.state_cycles);
                a
            }),
            join_wait_patches: ctus().map(|c| c.join_wait_patches).sum(),
            join_wait_results: ctus().map(|c| c.join_wait_results).sum(),
            busiest_ctu_jobs: busiest.map_or(0, |c| c.jobs_issued),
            busiest_ctu_traversal: busiest.map_or(0, |c| {
                c.state_cycles.scan + c.state_cycles.request + c.state_cycles.step
            }),
            busiest_ctu_join: busiest.map_or(0, |c| c.state_cycles.join),
            bound: Bound::of(stats, cfg),
        }
    }

    /// The bound over the measured cycles: 1 means the machine runs at its resource limit.
    pub fn of_bound(&self) -> f64 {
        self.bound.cycles() as f64 / self.cycles.max(1) as f64
    }

    /// Fraction of the ICUs' cycles spent empty (ray buffer and pipeline empty).
    pub fn icu_idle_fraction(&self) -> f64 {
        frac(
            self.icu_idle,
            self.icu_busy + self.icu_stalled + self.icu_idle,
        )
    }

    /// Fraction of all cycles the memory held a ready record back.
    pub fn delivery_stall_fraction(&self) -> f64 {
        frac(self.memory_delivery_stall, self.cycles)
    }
}

/// `a / b`, 0 when `b` is 0.
pub fn frac(a: u64, b: u64) -> f64 {
    if b == 0 {
        0.0
    } else {
        a as f64 / b as f64
    }
}

/// `base` with `clusters` clusters and balancing on or off.
pub fn machine(base: &MachineConfig, clusters: u32, balance: bool) -> MachineConfig {
    let mut c = *base;
    c.machine.clusters = clusters;
    c.balance.enabled = balance;
    c
}

fn spec(w: &Workload, ratio: usize) -> RunSpec {
    RunSpec {
        source: w.source,
        ratio,
        order: TickOrder::Forward,
    }
}

fn validate(cfg: &MachineConfig) -> Result<()> {
    cfg.validate()
        .map_err(|e| Error::input(Path::new("<experiment machine>"), e.key, e.what))
}

/// Partitions and converts `w` for `cfg`'s clusters and CTUs at `ratio`.
pub fn prepare(w: &Workload, cfg: &MachineConfig, ratio: usize) -> Result<Prepared> {
    validate(cfg)?;
    run::prepare(w.scene, w.file, cfg, &spec(w, ratio))
}

/// Runs `cfg` on `input` and measures it; a ray that differs from the untimed model is an
/// error.
pub fn measure(
    w: &Workload,
    input: &MachineInput,
    cfg: &MachineConfig,
    ratio: usize,
) -> Result<Point> {
    Ok(Point::new(
        &simulate_checked(w, input, cfg, ratio)?,
        cfg,
        ratio,
    ))
}

/// Runs `cfg` on `input` and returns its statistics; a ray that differs from the untimed
/// model is an error.
pub fn simulate_checked(
    w: &Workload,
    input: &MachineInput,
    cfg: &MachineConfig,
    ratio: usize,
) -> Result<RunStats> {
    validate(cfg)?;
    let s = run::simulate(input, &w.scene.name, cfg, &spec(w, ratio), None)?.stats;
    if s.mismatches_vs_fixed > 0 {
        return Err(Error::Check(format!(
            "{}: {} clusters, ratio {ratio}, balance {}: {} rays differ from the untimed model",
            s.scene, cfg.machine.clusters, cfg.balance.enabled, s.mismatches_vs_fixed
        )));
    }
    Ok(s)
}

/// The same sectors as `sectors` on one cluster whose CTUs are all of them (cluster-major):
/// the single-ICU machine that does exactly the work of the P-cluster one.
pub fn one_cluster(sectors: &[Vec<Vec<u32>>]) -> Vec<Vec<Vec<u32>>> {
    vec![sectors.iter().flatten().cloned().collect()]
}

/// Efficiency: for every ratio × cluster count, the machine with balancing off and on.
/// Rows: ratio-major, then clusters, then off before on.
pub fn efficiency(w: &Workload, clusters: &[u32], ratios: &[usize]) -> Result<Vec<Point>> {
    let keys: Vec<(usize, u32)> = ratios
        .iter()
        .flat_map(|&r| clusters.iter().map(move |&p| (r, p)))
        .collect();
    let preps: Vec<Prepared> = keys
        .par_iter()
        .map(|&(r, p)| prepare(w, &machine(w.base, p, false), r))
        .collect::<Result<_>>()?;
    let runs: Vec<(usize, bool)> = (0..keys.len())
        .flat_map(|i| [(i, false), (i, true)])
        .collect();
    runs.par_iter()
        .map(|&(i, on)| {
            let (r, p) = keys[i];
            measure(w, &preps[i].input(), &machine(w.base, p, on), r)
        })
        .collect()
}

/// The work-item experiment's rows: balancing off once, then on for each size.
#[derive(Clone, Debug)]
pub struct WorkItemRows {
    pub off: Point,
    pub on: Vec<Point>,
    /// Sizes left out: larger than the ray buffer (a work-item must fit).
    pub skipped: Vec<u32>,
}

/// Efficiency and cycles against work-item size at `clusters` clusters and `ratio`.
pub fn work_item(w: &Workload, clusters: u32, ratio: usize, sizes: &[u32]) -> Result<WorkItemRows> {
    let prep = prepare(w, &machine(w.base, clusters, false), ratio)?;
    let cap = w.base.machine.ray_buffer_capacity;
    let (fit, skipped): (Vec<u32>, Vec<u32>) = sizes.iter().partition(|&&s| s <= cap);
    let cfgs: Vec<MachineConfig> = std::iter::once(machine(w.base, clusters, false))
        .chain(fit.iter().map(|&s| {
            let mut c = machine(w.base, clusters, true);
            c.balance.work_item_jobs = s;
            c
        }))
        .collect();
    let mut points: Vec<Point> = cfgs
        .par_iter()
        .map(|c| measure(w, &prep.input(), c, ratio))
        .collect::<Result<_>>()?;
    let off = points.remove(0);
    Ok(WorkItemRows {
        off,
        on: points,
        skipped,
    })
}

/// One row of the speedup experiment.
#[derive(Clone, Debug, Serialize)]
pub struct SpeedupRow {
    pub point: Point,
    /// T(1): the one-cluster machine (K CTUs), same balancing setting.
    pub t1: u64,
    /// T(1) / T(P): the whole machine scaled (its work shrinks with finer sectors).
    pub speedup: f64,
    /// T(1) of one ICU over the same P × K sectors: the same work on one ICU.
    pub t1_same_work: u64,
    /// t1_same_work / T(P): what the P ICUs buy on the same work.
    pub speedup_same_work: f64,
    /// T(1) / bound(P) and t1_same_work / bound(P): the speedups at the resource limit.
    pub bound_speedup: f64,
    pub bound_speedup_same_work: f64,
}

/// Speedup T(1)/T(P) with balancing off and on; rows P-major, off before on. `T(1)` is the
/// one-cluster run with the same balancing setting, so the speedup at P = 1 is exactly 1.
pub fn speedup(w: &Workload, clusters: &[u32], ratio: usize) -> Result<Vec<SpeedupRow>> {
    let preps: Vec<Prepared> = clusters
        .par_iter()
        .map(|&p| prepare(w, &machine(w.base, p, false), ratio))
        .collect::<Result<_>>()?;
    // Each P with balancing off and on, and (P > 1) one ICU over the same sectors.
    enum Job {
        Run(usize, bool),
        SameWork(usize),
    }
    let mut jobs = Vec::new();
    for (i, &p) in clusters.iter().enumerate() {
        jobs.push(Job::Run(i, false));
        jobs.push(Job::Run(i, true));
        if p > 1 {
            jobs.push(Job::SameWork(i));
        }
    }
    let k = w.base.machine.ctus_per_cluster;
    let measured: Vec<Point> = jobs
        .par_iter()
        .map(|j| match *j {
            Job::Run(i, on) => measure(
                w,
                &preps[i].input(),
                &machine(w.base, clusters[i], on),
                ratio,
            ),
            Job::SameWork(i) => {
                let sectors = one_cluster(&preps[i].sectors);
                let mut cfg = machine(w.base, 1, false);
                cfg.machine.ctus_per_cluster = k * clusters[i];
                let input = MachineInput {
                    sectors: &sectors,
                    ..preps[i].input()
                };
                measure(w, &input, &cfg, ratio)
            }
        })
        .collect::<Result<_>>()?;
    let mut runs: Vec<[Option<Point>; 2]> = vec![[None, None]; clusters.len()];
    let mut same: Vec<Option<u64>> = vec![None; clusters.len()];
    for (j, m) in jobs.iter().zip(measured) {
        match *j {
            Job::Run(i, on) => runs[i][on as usize] = Some(m),
            Job::SameWork(i) => same[i] = Some(m.cycles),
        }
    }
    let base = clusters
        .iter()
        .position(|&p| p == 1)
        .ok_or_else(|| Error::Usage("the speedup experiment needs P = 1".into()))?;
    let t1: Vec<u64> = runs[base]
        .iter()
        .map(|p| p.as_ref().expect("every run measured").cycles)
        .collect();
    let mut rows = Vec::new();
    for (i, r) in runs.into_iter().enumerate() {
        for (on, point) in r.into_iter().enumerate() {
            let point = point.expect("every run measured");
            let t1 = t1[on];
            // At P = 1 the same work on one ICU is the run itself.
            let t1_same_work = same[i].unwrap_or(point.cycles);
            let tp = point.cycles.max(1) as f64;
            let b = point.bound.cycles().max(1) as f64;
            rows.push(SpeedupRow {
                t1,
                speedup: t1 as f64 / tp,
                t1_same_work,
                speedup_same_work: t1_same_work as f64 / tp,
                bound_speedup: t1 as f64 / b,
                bound_speedup_same_work: t1_same_work as f64 / b,
                point,
            });
        }
    }
    Ok(rows)
}

/// The CSV header of a [`Point`].
pub const POINT_HEADER: &str = "scene,ratio,rays,clusters,ctus_per_cluster,balance,work_item_jobs,\
cycles,pipeline_efficiency,jobs,patch_loads,work_items,jobs_moved,retries,\
icu_busy,icu_stalled,icu_idle,ctu_busy,ctu_stalled,ctu_idle,ctu_busy_max,\
memory_busy,memory_delivery_stall,\
bound_icu,bound_memory,bound_ctu_dda,bound_ctu_issue,bound_cycles,binding,bound_over_cycles";

/// A [`Point`] as CSV fields (no newline).
pub fn point_csv(p: &Point) -> String {
    let b = &p.bound;
    format!(
        "{},{},{},{},{},{},{},{},{:.6},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{:.6}",
        p.scene,
        p.ratio,
        p.rays,
        p.clusters,
        p.ctus_per_cluster,
        if p.balance { "on" } else { "off" },
        p.work_item_jobs,
        p.cycles,
        p.pipeline_efficiency,
        p.jobs,
        p.patch_loads,
        p.work_items,
        p.jobs_moved,
        p.retries,
        p.icu_busy,
        p.icu_stalled,
        p.icu_idle,
        p.ctu_busy,
        p.ctu_stalled,
        p.ctu_idle,
        p.ctu_busy_max,
        p.memory_busy,
        p.memory_delivery_stall,
        b.icu,
        b.memory,
        b.ctu_dda,
        b.ctu_issue,
        b.cycles(),
        b.binding().name(),
        p.of_bound()
    )
}

/// Points as CSV.
pub fn points_csv(points: &[Point]) -> String {
    let mut s = format!("{POINT_HEADER}\n");
    for p in points {
        let _ = writeln!(s, "{}", point_csv(p));
    }
    s
}

/// Work-item rows as CSV (balancing off first).
pub fn work_item_csv(rows: &WorkItemRows) -> String {
    points_csv(
        &std::iter::once(rows.off.clone())
            .chain(rows.on.iter().cloned())
            .collect::<Vec<_>>(),
    )
}

/// Speedup rows as CSV: the point's fields, then the speedups.
pub fn speedup_csv(rows: &[SpeedupRow]) -> String {
    let mut s = format!(
        "{POINT_HEADER},t1,speedup,t1_same_work,speedup_same_work,ideal,bound_speedup,bound_speedup_same_work\n"
    );
    for r in rows {
        let _ = writeln!(
            s,
            "{},{},{:.6},{},{:.6},{},{:.6},{:.6}",
            point_csv(&r.point),
            r.t1,
            r.speedup,
            r.t1_same_work,
            r.speedup_same_work,
            r.point.clusters,
            r.bound_speedup,
            r.bound_speedup_same_work
        );
    }
    s
}

/// A file-name-safe form of a scene name.
pub fn stem(name: &str) -> String {
    crate::output::file_stem(name)
}

impl Point {
    /// The point as the efficiency chart draws it.
    pub fn chart(&self) -> crate::chart::experiments::Point {
        crate::chart::experiments::Point {
            ratio: self.ratio,
            rays: self.rays,
            clusters: self.clusters,
            balance: self.balance,
            pipeline_efficiency: self.pipeline_efficiency,
        }
    }

    /// The point as the work-item chart draws it.
    pub fn work_item_chart(&self) -> crate::chart::experiments::WorkItemPoint {
        crate::chart::experiments::WorkItemPoint {
            work_item_jobs: self.work_item_jobs,
            pipeline_efficiency: self.pipeline_efficiency,
            cycles: self.cycles,
            bound_cycles: self.bound.cycles(),
            binding: self.bound.binding().name(),
        }
    }
}

impl WorkItemRows {
    /// The rows as the work-item chart draws them.
    pub fn chart(&self) -> crate::chart::experiments::WorkItemRows {
        crate::chart::experiments::WorkItemRows {
            off: self.off.work_item_chart(),
            on: self.on.iter().map(Point::work_item_chart).collect(),
        }
    }
}

impl SpeedupRow {
    /// The row as the speedup chart draws it.
    pub fn chart(&self) -> crate::chart::experiments::SpeedupRow {
        crate::chart::experiments::SpeedupRow {
            clusters: self.point.clusters,
            balance: self.point.balance,
            speedup: self.speedup,
            bound_speedup: self.bound_speedup,
            speedup_same_work: self.speedup_same_work,
            bound_speedup_same_work: self.bound_speedup_same_work,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bound_picks_the_largest_resource() {
        let b = Bound {
            icu: 10,
            memory: 3,
            ctu_dda: 12,
            ctu_issue: 12,
        };
        assert_eq!(b.cycles(), 12);
        assert_eq!(b.binding(), Resource::CtuDda);
    }

    #[test]
    fn one_cluster_keeps_every_sector_in_order() {
        let s = vec![vec![vec![1, 2], vec![3]], vec![vec![4], vec![5, 6]]];
        assert_eq!(
            one_cluster(&s),
            vec![vec![vec![1, 2], vec![3], vec![4], vec![5, 6]]]
        );
    }

    #[test]
    fn stems_are_safe() {
        assert_eq!(stem("stress-skewed"), "stress-skewed");
        assert_eq!(stem("a b/c"), "a_b_c");
    }
}
