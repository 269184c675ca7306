//! The queue level against the cycle level (`shellsim experiment levels`): every machine of
//! the speedup experiment (P = 1, 2, 4, 8 clusters, balancing off and on, and one ICU over the
//! same sectors) simulated cycle by cycle and estimated by the queueing network, with the
//! error of the estimate — cycles and per-ICU utilization — and the wall time of each.
//!
//! **Invariant:** every cycle-level run is checked against the untimed model (as in every
//! experiment), and the queue level's results are the untimed model's, so both levels give
//! the same per-ray results; only the timing differs, and the table measures by how much.

use super::{machine, one_cluster, prepare, simulate_checked, Point, Workload};
use crate::error::Result;
use crate::machine::queue;
use crate::machine::run::{MachineInput, RunSpec};
use serde::Serialize;
use shellsim_hw::config::MachineConfig;
use shellsim_hw::machine::TickOrder;
use std::fmt::Write as _;
use std::time::Instant;

/// One machine at both levels.
#[derive(Clone, Debug, Serialize)]
pub struct LevelRow {
    /// The machine: `P×K`, balancing, or `1×PK same work`.
    pub machine: String,
    pub clusters: u32,
    pub ctus_per_cluster: u32,
    pub balance: bool,
    pub ratio: usize,
    pub cycles: u64,
    pub queue_cycles: u64,
    /// (queue − cycle) / cycle.
    pub error: f64,
    pub efficiency: f64,
    pub queue_efficiency: f64,
    /// The largest |Δ| over ICUs of (jobs computed / cycles) between the levels.
    pub icu_utilization_error: f64,
    pub jobs_moved: u64,
    pub queue_jobs_moved: u64,
    /// Wall seconds (not in the CSV): the cycle level, the queue level's timing (walks and
    /// network) and its untimed results.
    #[serde(skip)]
    pub wall_cycle_s: f64,
    #[serde(skip)]
    pub wall_queue_s: f64,
    #[serde(skip)]
    pub wall_untimed_s: f64,
}

/// Runs `cfg` on `input` at both levels.
pub fn compare(
    w: &Workload,
    input: &MachineInput,
    cfg: &MachineConfig,
    ratio: usize,
    label: String,
) -> Result<LevelRow> {
    let t0 = Instant::now();
    let stats = simulate_checked(w, input, cfg, ratio)?;
    let wall_cycle_s = t0.elapsed().as_secs_f64();
    let point = Point::new(&stats, cfg, ratio);
    let spec = RunSpec {
        source: w.source,
        ratio,
        order: TickOrder::Forward,
    };
    let q = queue::estimate(input, &w.scene.name, cfg, &spec, None)?;
    let e = &q.estimate;
    let util = |jobs: u64, cycles: u64| jobs as f64 / cycles.max(1) as f64;
    let icu_utilization_error = stats
        .clusters
        .iter()
        .zip(&e.icu_jobs)
        .map(|(c, &b)| (util(c.icu.jobs_in, point.cycles) - util(b, e.cycles)).abs())
        .fold(0.0, f64::max);
    Ok(LevelRow {
        machine: label,
        clusters: cfg.machine.clusters,
        ctus_per_cluster: cfg.machine.ctus_per_cluster,
        balance: cfg.balance.enabled,
        ratio,
        cycles: point.cycles,
        queue_cycles: e.cycles,
        error: (e.cycles as f64 - point.cycles as f64) / point.cycles.max(1) as f64,
        efficiency: point.pipeline_efficiency,
        queue_efficiency: q.pipeline_efficiency,
        icu_utilization_error,
        jobs_moved: point.jobs_moved,
        queue_jobs_moved: e.jobs_moved,
        wall_cycle_s,
        wall_queue_s: q.wall.timing_s(),
        wall_untimed_s: q.wall.untimed_s,
    })
}

/// Both levels on the speedup experiment's machines at `ratio`, one after the other (so the
/// wall times are comparable).
pub fn levels(w: &Workload, clusters: &[u32], ratio: usize) -> Result<Vec<LevelRow>> {
    let k = w.base.machine.ctus_per_cluster;
    let mut rows = Vec::new();
    for &p in clusters {
        let prep = prepare(w, &machine(w.base, p, false), ratio)?;
        for on in [false, true] {
            let label = format!("{p}×{k} balance {}", if on { "on" } else { "off" });
            rows.push(compare(
                w,
                &prep.input(),
                &machine(w.base, p, on),
                ratio,
                label,
            )?);
        }
        if p > 1 {
            let sectors = one_cluster(&prep.sectors);
            let mut cfg = machine(w.base, 1, false);
            cfg.machine.ctus_per_cluster = k * p;
            let input = MachineInput {
                sectors: &sectors,
                ..prep.input()
            };
            let label = format!("1×{} same work", k * p);
            rows.push(compare(w, &input, &cfg, ratio, label)?);
        }
    }
    Ok(rows)
}

/// The rows as CSV (no wall times: the file is byte-identical across runs).
pub fn csv(rows: &[LevelRow]) -> String {
    let mut s = String::from(
        "machine,clusters,ctus_per_cluster,balance,ratio,cycles,queue_cycles,error,efficiency,queue_efficiency,icu_utilization_error,jobs_moved,queue_jobs_moved\n",
    );
    for r in rows {
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{:.4},{:.4},{:.4},{:.4},{},{}",
            r.machine,
            r.clusters,
            r.ctus_per_cluster,
            r.balance,
            r.ratio,
            r.cycles,
            r.queue_cycles,
            r.error,
            r.efficiency,
            r.queue_efficiency,
            r.icu_utilization_error,
            r.jobs_moved,
            r.queue_jobs_moved
        );
    }
    s
}

/// A table for the terminal, with the wall times and the summary of the errors.
pub fn summary(rows: &[LevelRow]) -> String {
    let mut s = String::from(
        "machine                    cycles    queue   error  eff    queue  ICU err  wall cycle  queue  (untimed)\n",
    );
    for r in rows {
        let _ = writeln!(
            s,
            "{:<24} {:>8} {:>8} {:>+6.1}% {:>5.3} {:>6.3} {:>7.3} {:>9.3}s {:>6.3}s ({:.3}s)",
            r.machine,
            r.cycles,
            r.queue_cycles,
            100.0 * r.error,
            r.efficiency,
            r.queue_efficiency,
            r.icu_utilization_error,
            r.wall_cycle_s,
            r.wall_queue_s,
            r.wall_untimed_s
        );
    }
    let n = rows.len().max(1) as f64;
    let mean = rows.iter().map(|r| r.error.abs()).sum::<f64>() / n;
    let max = rows.iter().map(|r| r.error.abs()).fold(0.0, f64::max);
    let cycle: f64 = rows.iter().map(|r| r.wall_cycle_s).sum();
    let qt: f64 = rows.iter().map(|r| r.wall_queue_s).sum();
    let qu: f64 = rows.iter().map(|r| r.wall_untimed_s).sum();
    let _ = writeln!(
        s,
        "mean |error| {:.1}%, max {:.1}%; wall: cycle {cycle:.2}s, queue timing {qt:.2}s ({:.1}× faster), with the untimed results {:.2}s ({:.1}×)",
        100.0 * mean,
        100.0 * max,
        cycle / qt.max(1e-9),
        qt + qu,
        cycle / (qt + qu).max(1e-9)
    );
    s
}

/// The error chart of `rows` (see [`crate::chart::experiments::levels_svg`]).
pub fn svg(title: &str, rows: &[LevelRow]) -> Result<String> {
    crate::chart::experiments::levels_svg(
        title,
        &rows
            .iter()
            .map(|r| (r.machine.clone(), r.error))
            .collect::<Vec<_>>(),
    )
}
