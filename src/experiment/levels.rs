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
    /// The resource bound's cycles (the lowest level: no timing at all).
    pub bound_cycles: u64,
    /// Wall seconds (not in the CSV): the cycle level, the queue level's timing (walks and
    /// network) and its untimed results. Machines that differ only in timing knobs share
    /// one walk: the first pays for it (and for the untimed results), the others only for the
    /// network.
    #[serde(skip)]
    pub wall_cycle_s: f64,
    #[serde(skip)]
    pub wall_queue_s: f64,
    #[serde(skip)]
    pub wall_untimed_s: f64,
    /// Wall seconds of the network alone.
    #[serde(skip)]
    pub wall_network_s: f64,
    /// Wall seconds of the bound's counts: the untimed model's results.
    #[serde(skip)]
    pub wall_bound_s: f64,
    /// Wall seconds of the cycle level without `cycle_jump` (when measured; its cycles are
    /// checked equal).
    #[serde(skip)]
    pub wall_cycle_nojump_s: Option<f64>,
}

/// Runs `cfg` on `input` at both levels; the queue level re-times `walks` when they are
/// there (a machine of the same partition and CTUs), else walks and keeps them there.
pub fn compare(
    w: &Workload,
    input: &MachineInput,
    cfg: &MachineConfig,
    ratio: usize,
    label: String,
    walks: &mut Option<queue::Walks>,
    nojump: bool,
) -> Result<LevelRow> {
    let t0 = Instant::now();
    let stats = simulate_checked(w, input, cfg, ratio)?;
    let wall_cycle_s = t0.elapsed().as_secs_f64();
    let wall_cycle_nojump_s = if nojump && cfg.machine.cycle_jump {
        let mut stepped = *cfg;
        stepped.machine.cycle_jump = false;
        let t0 = Instant::now();
        let s = simulate_checked(w, input, &stepped, ratio)?;
        if s.cycles != stats.cycles {
            return Err(crate::error::Error::Check(format!(
                "{label}: {} cycles stepping every cycle, {} with cycle_jump",
                s.cycles, stats.cycles
            )));
        }
        Some(t0.elapsed().as_secs_f64())
    } else {
        None
    };
    let point = Point::new(&stats, cfg, ratio);
    let spec = RunSpec {
        source: w.source,
        ratio,
        order: TickOrder::Forward,
    };
    let (mut walk_s, mut untimed_s) = (0.0, 0.0);
    if walks.is_none() {
        let wk = queue::walks(input, cfg, &spec, None)?;
        (walk_s, untimed_s) = (wk.walks_s, wk.untimed_s);
        *walks = Some(wk);
    }
    let walked = walks.as_ref().expect("walked");
    let wall_bound_s = walked.untimed_s;
    let q = queue::retime(walked, input, &w.scene.name, cfg, &spec)?;
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
        bound_cycles: point.bound.cycles(),
        wall_cycle_s,
        wall_queue_s: walk_s + q.wall.network_s,
        wall_untimed_s: untimed_s,
        wall_network_s: q.wall.network_s,
        wall_bound_s,
        wall_cycle_nojump_s,
    })
}

/// Both levels on the speedup experiment's machines at `ratio`, one after the other (so the
/// wall times are comparable).
/// With `nojump`, each machine also runs without `cycle_jump` (its wall time, cycles checked
/// equal).
pub fn levels(w: &Workload, clusters: &[u32], ratio: usize, nojump: bool) -> Result<Vec<LevelRow>> {
    let k = w.base.machine.ctus_per_cluster;
    let mut rows = Vec::new();
    for &p in clusters {
        let prep = prepare(w, &machine(w.base, p, false), ratio)?;
        let mut walks = None;
        for on in [false, true] {
            let label = format!("{p}×{k} balance {}", if on { "on" } else { "off" });
            rows.push(compare(
                w,
                &prep.input(),
                &machine(w.base, p, on),
                ratio,
                label,
                &mut walks,
                nojump,
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
            rows.push(compare(w, &input, &cfg, ratio, label, &mut None, nojump)?);
        }
    }
    Ok(rows)
}

/// The rows as CSV (no wall times: the file is byte-identical across runs).
pub fn csv(rows: &[LevelRow]) -> String {
    let mut s = String::from(
        "machine,clusters,ctus_per_cluster,balance,ratio,cycles,queue_cycles,error,efficiency,queue_efficiency,icu_utilization_error,jobs_moved,queue_jobs_moved,bound_cycles\n",
    );
    for r in rows {
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{:.4},{:.4},{:.4},{:.4},{},{},{}",
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
            r.queue_jobs_moved,
            r.bound_cycles
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
    let (mean, max) = abs_errors(rows);
    let cycle: f64 = rows.iter().map(|r| r.wall_cycle_s).sum();
    let qt: f64 = rows.iter().map(|r| r.wall_queue_s).sum();
    let qu: f64 = rows.iter().map(|r| r.wall_untimed_s).sum();
    let qn: f64 = rows.iter().map(|r| r.wall_network_s).sum();
    let _ = writeln!(
        s,
        "mean |error| {:.1}%, max {:.1}%; wall: cycle {cycle:.2}s, queue timing {qt:.2}s ({:.1}× faster), with the untimed results {:.2}s ({:.1}×); the network alone {qn:.3}s ({:.0}×: a machine re-timing walks it shares)",
        100.0 * mean,
        100.0 * max,
        cycle / qt.max(1e-9),
        qt + qu,
        cycle / (qt + qu).max(1e-9),
        cycle / qn.max(1e-9)
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

/// Mean and max |error| of `rows` (0 for none).
fn abs_errors(rows: &[LevelRow]) -> (f64, f64) {
    let n = rows.len().max(1) as f64;
    let mean = rows.iter().map(|r| r.error.abs()).sum::<f64>() / n;
    let max = rows.iter().map(|r| r.error.abs()).fold(0.0, f64::max);
    (mean, max)
}

/// One of the paper's figures re-measured at both levels, on one scene and configuration.
#[derive(Clone, Debug)]
pub struct FigureLevels {
    pub figure: &'static str,
    pub scene: String,
    pub config: &'static str,
    pub rows: Vec<LevelRow>,
}

impl FigureLevels {
    fn errors(&self) -> (f64, f64) {
        abs_errors(&self.rows)
    }

    fn efficiency_error(&self) -> f64 {
        (self.rows.iter())
            .map(|r| (r.queue_efficiency - r.efficiency).abs())
            .fold(0.0, f64::max)
    }

    /// Same-work speedup at the most clusters with balancing: (cycle level, queue level).
    fn speedup(&self) -> Option<(u32, f64, f64)> {
        let p = self.rows.iter().map(|r| r.clusters).max()?;
        let k = self.rows.first()?.ctus_per_cluster;
        let on = (self.rows.iter()).find(|r| r.clusters == p && r.balance)?;
        let same = (self.rows.iter()).find(|r| r.clusters == 1 && r.ctus_per_cluster == k * p)?;
        let s = |a: u64, b: u64| a as f64 / b.max(1) as f64;
        Some((
            p,
            s(same.cycles, on.cycles),
            s(same.queue_cycles, on.queue_cycles),
        ))
    }
}

/// Kendall's τ between two rankings (ties count as neither concordant nor discordant).
pub fn kendall_tau(a: &[u64], b: &[u64]) -> f64 {
    let n = a.len().min(b.len());
    let (mut c, mut d) = (0i64, 0i64);
    for i in 0..n {
        for j in i + 1..n {
            let s = (a[i].cmp(&a[j]) as i64) * (b[i].cmp(&b[j]) as i64);
            c += (s > 0) as i64;
            d += (s < 0) as i64;
        }
    }
    let pairs = (n * n.saturating_sub(1) / 2).max(1) as f64;
    (c - d) as f64 / pairs
}

/// The paper's figures at both levels: the speedup machines (Fig 12.15, which hold the
/// efficiency figures' ratio-10 points) on scene2 and stress-skewed for paper.toml and
/// `balanced`; the efficiency figures' other ratios on paper.toml; the work-item sweep
/// (Fig 12.14) on scene2. Sequential, so the wall times compare.
pub fn figures(
    w2: &Workload,
    wk: &Workload,
    balanced: &MachineConfig,
    speedup_clusters: &[u32],
    efficiency: (&[u32], &[usize]),
    work_items: (u32, &[u32]),
    ratio: usize,
) -> Result<Vec<FigureLevels>> {
    let mut out = Vec::new();
    for w in [w2, wk] {
        for (config, base) in [("paper.toml", w.base), ("balanced.toml", balanced)] {
            let wc = Workload { base, ..*w };
            out.push(FigureLevels {
                figure: "speedup (Fig 12.15)",
                scene: w.scene.name.clone(),
                config,
                rows: levels(&wc, speedup_clusters, ratio, false)?,
            });
        }
        let mut rows = Vec::new();
        for &r in efficiency.1.iter().filter(|&&r| r != ratio) {
            for &p in efficiency.0 {
                let prep = prepare(w, &machine(w.base, p, false), r)?;
                let mut walks = None;
                for on in [false, true] {
                    let label =
                        format!("P={p} ratio {r} balance {}", if on { "on" } else { "off" });
                    rows.push(compare(
                        w,
                        &prep.input(),
                        &machine(w.base, p, on),
                        r,
                        label,
                        &mut walks,
                        false,
                    )?);
                }
            }
        }
        out.push(FigureLevels {
            figure: "efficiency (other ratios)",
            scene: w.scene.name.clone(),
            config: "paper.toml",
            rows,
        });
    }
    let (p, sizes) = work_items;
    let prep = prepare(w2, &machine(w2.base, p, false), ratio)?;
    let mut rows = Vec::new();
    let mut walks = None;
    for &n in sizes {
        let mut cfg = machine(w2.base, p, true);
        cfg.balance.work_item_jobs = n;
        rows.push(compare(
            w2,
            &prep.input(),
            &cfg,
            ratio,
            format!("P={p} work-item {n}"),
            &mut walks,
            false,
        )?);
    }
    out.push(FigureLevels {
        figure: "work-item (Fig 12.14)",
        scene: w2.scene.name.clone(),
        config: "paper.toml",
        rows,
    });
    Ok(out)
}

/// Every figure's rows as one CSV (no wall times).
pub fn figures_csv(figs: &[FigureLevels]) -> String {
    let mut s = String::new();
    for f in figs {
        let body = csv(&f.rows);
        let mut lines = body.lines();
        if s.is_empty() {
            let _ = writeln!(s, "figure,scene,config,{}", lines.next().unwrap_or(""));
        } else {
            lines.next();
        }
        for l in lines {
            let _ = writeln!(s, "{},{},{},{l}", f.figure, f.scene, f.config);
        }
    }
    s
}

/// The report's section: how far the paper's method (a queueing network driven by the walk's
/// trace) is from cycle-level truth, per figure.
pub fn section(figs: &[FigureLevels]) -> String {
    let mut s = String::from(
        "## The paper's method against cycle-level truth (issue 33)\n\n\
         The paper evaluated its machine with a trace-driven queueing network (Figs 12.4–12.5).\n\
         `shellsim run --level queue` is that method: each CTU's walk is traced against an ideal\n\
         environment, and an event network with the paper's service centres (memory port,\n\
         patch buffer, ray buffer and ICU, joins, Split/Distribute/Sampling Work, the link and\n\
         the moved results' return port) re-times it. Its results are the fixed-point model's;\n\
         only the timing is estimated. Here every machine of each figure runs at both levels\n\
         ([CSV](levels.csv); `shellsim experiment levels --scene S [--hw H]` for one scene).\n\
         Δ = (queue − cycle) / cycle; efficiency = Σ jobs / (ICUs × cycles).\n\n\
         | figure | scene | configuration | machines | mean abs Δcycles | max abs Δcycles | max abs Δefficiency | figure-level: cycle / queue |\n\
         | --- | --- | --- | --- | --- | --- | --- | --- |\n",
    );
    for f in figs {
        let (mean, max) = f.errors();
        let derived = if f.figure.starts_with("work-item") {
            let c: Vec<u64> = f.rows.iter().map(|r| r.cycles).collect();
            let q: Vec<u64> = f.rows.iter().map(|r| r.queue_cycles).collect();
            let best = |v: &[u64]| {
                (f.rows.iter().zip(v))
                    .min_by_key(|(_, &c)| c)
                    .map_or(String::new(), |(r, _)| r.machine.clone())
            };
            format!(
                "Kendall τ {:.2}; best: {} / {}",
                kendall_tau(&c, &q),
                best(&c),
                best(&q)
            )
        } else if let Some((p, a, b)) = f.speedup() {
            format!("speedup at {p}: {a:.2} / {b:.2}")
        } else {
            String::from("—")
        };
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {:.1}% | {:.1}% | {:.3} | {derived} |",
            f.figure,
            f.scene,
            f.config,
            f.rows.len(),
            100.0 * mean,
            100.0 * max,
            f.efficiency_error(),
        );
    }
    let all: Vec<LevelRow> = figs.iter().flat_map(|f| f.rows.iter().cloned()).collect();
    let (mean, max) = abs_errors(&all);
    let _ = writeln!(
        s,
        "\nOver all {} machines: mean abs Δcycles {:.1}%, max {:.1}% (targets 5 % and 10 %).",
        all.len(),
        100.0 * mean,
        100.0 * max
    );
    s
}

/// Wall seconds per figure at both levels (for the terminal: they vary from run to run).
pub fn wall_summary(figs: &[FigureLevels]) -> String {
    let mut s = String::new();
    let (mut tc, mut tq, mut tn) = (0.0, 0.0, 0.0);
    for f in figs {
        let wc: f64 = f.rows.iter().map(|r| r.wall_cycle_s).sum();
        let wq: f64 = f
            .rows
            .iter()
            .map(|r| r.wall_queue_s + r.wall_untimed_s)
            .sum();
        tc += wc;
        tq += wq;
        tn += f.rows.iter().map(|r| r.wall_network_s).sum::<f64>();
        let _ = writeln!(
            s,
            "levels: {} {} {}: cycle level {wc:.2} s, queue level {wq:.2} s ({:.1}×)",
            f.figure,
            f.scene,
            f.config,
            wc / wq.max(1e-9)
        );
    }
    let _ = writeln!(
        s,
        "levels: all figures: cycle level {tc:.2} s, queue level {tq:.2} s ({:.1}×, the queue level counting the fixed-point results and its walks); the network alone {tn:.3} s ({:.0}×)",
        tc / tq.max(1e-9),
        tc / tn.max(1e-9)
    );
    s
}

/// The speed–accuracy chart of `rows` (host figures): one mark per machine and level — the
/// resource bound, the queue level walking and re-timing, re-timing a shared walk, the
/// cycle level with and without `cycle_jump` — wall seconds against |Δcycles|.
pub fn wall_svg(title: &str, rows: &[LevelRow]) -> Result<String> {
    let err =
        |c: u64, r: &LevelRow| 100.0 * (c as f64 - r.cycles as f64).abs() / r.cycles.max(1) as f64;
    let mut marks: Vec<(&'static str, Vec<(f64, f64)>)> = vec![
        ("resource bound (the untimed model's counts)", Vec::new()),
        ("queue level: walk + network", Vec::new()),
        ("queue level: network on a shared walk", Vec::new()),
        ("cycle level (cycle_jump)", Vec::new()),
        ("cycle level, every cycle stepped", Vec::new()),
    ];
    for r in rows {
        marks[0].1.push((r.wall_bound_s, err(r.bound_cycles, r)));
        let q = err(r.queue_cycles, r);
        if r.wall_queue_s > r.wall_network_s {
            marks[1].1.push((r.wall_queue_s + r.wall_untimed_s, q));
        }
        marks[2].1.push((r.wall_network_s, q));
        marks[3].1.push((r.wall_cycle_s, 0.0));
        if let Some(t) = r.wall_cycle_nojump_s {
            marks[4].1.push((t, 0.0));
        }
    }
    crate::chart::experiments::wall_svg(title, &marks)
}

#[cfg(test)]
mod tests {
    use super::kendall_tau;

    #[test]
    fn kendall_tau_counts_concordant_less_discordant_pairs() {
        assert_eq!(kendall_tau(&[1, 2, 3, 4], &[10, 20, 30, 40]), 1.0);
        assert_eq!(kendall_tau(&[1, 2, 3, 4], &[40, 30, 20, 10]), -1.0);
        // One swapped neighbour pair of six: (5 − 1) / 6.
        assert!((kendall_tau(&[1, 2, 3, 4], &[10, 30, 20, 40]) - 4.0 / 6.0).abs() < 1e-12);
    }
}
