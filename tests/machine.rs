//! The cycle-level machine: per-ray results equal the untimed fixed-point model over a
//! matrix of scenes × clusters × CTUs × arbiter × buffers × cycle jump, one `#[test]` per
//! cell (`cargo test --test machine scene1::c4::k2::round_robin::small::jump` runs one);
//! ticking units in reverse or shuffled order changes nothing, with balancing off and on;
//! conservation of jobs, results and loads.

mod common;

use common::{assert_same_run, check_variant, config, run_variant, spec, Levers, Variant};
use shellsim::machine::run::run;
use shellsim_hw::config::{ArbiterPolicy, JobSource};
use shellsim_hw::machine::TickOrder;
use std::path::Path;

/// A matrix cell: clusters, CTUs, arbiter, small buffers, cycle jump; the file's balancing.
const fn cell(
    clusters: u32,
    ctus: u32,
    arbiter: ArbiterPolicy,
    small: bool,
    jump: bool,
) -> Variant {
    Variant {
        clusters,
        ctus,
        arbiter,
        small_buffers: small,
        jump,
        balance: None,
        job_source: JobSource::Ctu,
        overlap_joins: false,
        levers: Levers::PAPER,
    }
}

/// One `#[test]` per cell of clusters 1/2/4/8 × CTUs 1/2/4 × both arbiters × small and
/// paper buffers × cycle jump on and off, in nested modules named by the knobs.
macro_rules! full_matrix {
    ($($scene:ident => $file:literal),* $(,)?) => {$(
        mod $scene {
            use super::*;
            full_matrix!(@c $file; c1 1, c2 2, c4 4, c8 8);
        }
    )*};
    (@c $file:literal; $($c:ident $cn:literal),*) => {$(
        mod $c {
            use super::*;
            full_matrix!(@k $file, $cn; k1 1, k2 2, k4 4);
        }
    )*};
    (@k $file:literal, $cn:literal; $($k:ident $kn:literal),*) => {$(
        mod $k {
            use super::*;
            full_matrix!(@a $file, $cn, $kn; round_robin RoundRobin, fixed_priority FixedPriority);
        }
    )*};
    (@a $file:literal, $cn:literal, $kn:literal; $($a:ident $an:ident),*) => {$(
        mod $a {
            use super::*;
            full_matrix!(@b $file, $cn, $kn, $an; small true, paper false);
        }
    )*};
    (@b $file:literal, $cn:literal, $kn:literal, $an:ident; $($b:ident $bn:literal),*) => {$(
        mod $b {
            use super::*;
            full_matrix!(@j $file, $cn, $kn, $an, $bn; jump true, step false);
        }
    )*};
    (@j $file:literal, $cn:literal, $kn:literal, $an:ident, $bn:literal; $($j:ident $jn:literal),*) => {$(
        #[test]
        fn $j() {
            check_variant($file, &cell($cn, $kn, ArbiterPolicy::$an, $bn, $jn));
        }
    )*};
}

full_matrix! {
    scene1 => "scene1.json",
    cornell => "cornell.json",
}

/// One `#[test]` per listed cell, and the cells as `CELLS` for the coverage check.
macro_rules! cells {
    ($file:literal; $($name:ident => $cn:literal, $kn:literal, $an:ident, $bn:literal, $jn:literal;)*) => {
        pub const CELLS: &[Variant] = &[$(cell($cn, $kn, ArbiterPolicy::$an, $bn, $jn)),*];
        $(
            #[test]
            fn $name() {
                check_variant($file, &cell($cn, $kn, ArbiterPolicy::$an, $bn, $jn));
            }
        )*
    };
}

/// Every seventh cell of the full matrix: 14 cells that take every value of every knob.
macro_rules! sampled_matrix {
    ($($scene:ident => $file:literal),* $(,)?) => {$(
        pub mod $scene {
            use super::*;
            cells! { $file;
                c1_k1_round_robin_small_jump => 1, 1, RoundRobin, true, true;
                c1_k1_fixed_priority_paper_step => 1, 1, FixedPriority, false, false;
                c1_k2_fixed_priority_paper_jump => 1, 2, FixedPriority, false, true;
                c1_k4_fixed_priority_small_step => 1, 4, FixedPriority, true, false;
                c2_k1_fixed_priority_small_jump => 2, 1, FixedPriority, true, true;
                c2_k2_round_robin_paper_step => 2, 2, RoundRobin, false, false;
                c2_k4_round_robin_paper_jump => 2, 4, RoundRobin, false, true;
                c4_k1_round_robin_small_step => 4, 1, RoundRobin, true, false;
                c4_k2_round_robin_small_jump => 4, 2, RoundRobin, true, true;
                c4_k2_fixed_priority_paper_step => 4, 2, FixedPriority, false, false;
                c4_k4_fixed_priority_paper_jump => 4, 4, FixedPriority, false, true;
                c8_k1_fixed_priority_small_step => 8, 1, FixedPriority, true, false;
                c8_k2_fixed_priority_small_jump => 8, 2, FixedPriority, true, true;
                c8_k4_round_robin_paper_step => 8, 4, RoundRobin, false, false;
            }
        }
    )*};
}

sampled_matrix! {
    scene2 => "scene2.json",
    stress_edges => "stress-edges.json",
    stress_grazing => "stress-grazing.json",
    stress_skewed => "stress-skewed.json",
}

#[test]
fn sampled_matrix_takes_every_value() {
    let m = scene2::CELLS;
    for c in [1, 2, 4, 8] {
        assert!(m.iter().any(|v| v.clusters == c), "clusters {c}");
    }
    for k in [1, 2, 4] {
        assert!(m.iter().any(|v| v.ctus == k), "ctus {k}");
    }
    assert!(m.iter().any(|v| v.jump) && m.iter().any(|v| !v.jump));
    assert!(m.iter().any(|v| v.small_buffers) && m.iter().any(|v| !v.small_buffers));
    for a in [ArbiterPolicy::RoundRobin, ArbiterPolicy::FixedPriority] {
        assert!(m.iter().any(|v| v.arbiter == a), "{a:?}");
    }
    // Every sampled scene runs the same cells.
    for other in [
        stress_edges::CELLS,
        stress_grazing::CELLS,
        stress_skewed::CELLS,
    ] {
        assert_eq!(other, m);
    }
}

mod stress_dense {
    use super::*;

    #[test]
    fn c4_k2_round_robin_paper_jump() {
        check_variant("stress-dense.json", &Variant::PAPER);
    }

    #[test]
    fn c2_k1_fixed_priority_small_step() {
        let v = cell(2, 1, ArbiterPolicy::FixedPriority, true, false);
        check_variant("stress-dense.json", &v);
    }
}

/// Slow DDA steps and a slow memory leave whole stretches where all units wait: the jump
/// skips them and changes no statistic.
fn the_cycle_jump_changes_no_statistic(file: &str) {
    let run_with = |jump: bool| {
        let mut c = config("paper");
        c.machine.dda_cycles_per_step = 20;
        c.machine.memory_latency = 60;
        c.machine.cycle_jump = jump;
        let scene = common::load(file);
        run(&scene, Path::new(file), &c, &spec(), None).unwrap()
    };
    let (a, b) = (run_with(true), run_with(false));
    assert!(
        a.stats.skipped_cycles > a.stats.cycles / 10,
        "{file}: the jump skipped only {} of {}",
        a.stats.skipped_cycles,
        a.stats.cycles
    );
    assert_eq!(b.stats.skipped_cycles, 0);
    assert_same_run(&a, &b, file);
}

mod cycle_jump {
    use super::*;
    testcases! { the_cycle_jump_changes_no_statistic;
        scene1 => "scene1.json";
        cornell => "cornell.json";
    }
}

/// Ticking the units in another order changes no statistic and no hit. With balancing on,
/// the run must move work-items between clusters, so the balancer's links are exercised.
fn tick_order_changes_nothing(file: &str, balance: bool, order: TickOrder) {
    let v = Variant {
        clusters: if balance { 4 } else { 2 },
        ctus: 2,
        arbiter: ArbiterPolicy::RoundRobin,
        small_buffers: !balance,
        jump: false,
        balance: Some(balance),
        job_source: JobSource::Ctu,
        overlap_joins: false,
        levers: Levers::PAPER,
    };
    let fwd = run_variant(file, &v, TickOrder::Forward);
    if balance {
        assert!(
            fwd.stats.balancer.work_items > 0,
            "{file}: no work-item moved, the balancer is not exercised"
        );
    }
    let other = run_variant(file, &v, order);
    assert_same_run(&other, &fwd, &format!("{file} {order:?} balance {balance}"));
}

mod tick_order {
    use super::*;
    testcases! { tick_order_changes_nothing;
        scene1_reverse => "scene1.json", false, TickOrder::Reverse;
        scene1_shuffled_1 => "scene1.json", false, TickOrder::Shuffled(1);
        scene1_shuffled_99 => "scene1.json", false, TickOrder::Shuffled(99);
        cornell_reverse => "cornell.json", false, TickOrder::Reverse;
        cornell_shuffled_1 => "cornell.json", false, TickOrder::Shuffled(1);
        cornell_shuffled_99 => "cornell.json", false, TickOrder::Shuffled(99);
        balanced_scene1_reverse => "scene1.json", true, TickOrder::Reverse;
        balanced_scene1_shuffled_7 => "scene1.json", true, TickOrder::Shuffled(7);
        balanced_scene2_reverse => "scene2.json", true, TickOrder::Reverse;
        balanced_scene2_shuffled_3 => "scene2.json", true, TickOrder::Shuffled(3);
        balanced_stress_skewed_shuffled_5 => "stress-skewed.json", true, TickOrder::Shuffled(5);
    }
}

#[test]
fn two_runs_give_identical_json() {
    let a = run_variant("scene2.json", &Variant::PAPER, TickOrder::Forward);
    let b = run_variant("scene2.json", &Variant::PAPER, TickOrder::Forward);
    assert_same_run(&a, &b, "scene2, paper.toml, twice");
}

#[test]
fn the_watchdog_stops_a_run_that_makes_no_progress() {
    // A DDA step longer than the watchdog's patience: nothing moves for 1000 cycles. A file
    // with this is refused (`check_watchdog`: the watchdog must outlast the longest legal
    // wait; tests/watchdog.rs); built in code, it stands in for a real deadlock to test
    // the report.
    let mut c = config("small");
    c.machine.dda_cycles_per_step = 1000;
    c.machine.watchdog_cycles = 100;
    c.machine.cycle_jump = false;
    let scene = common::load("scene1.json");
    let spec = spec();
    let err = match run(&scene, Path::new("scene1.json"), &c, &spec, None) {
        Err(e) => e.to_string(),
        Ok(_) => panic!("the run finished"),
    };
    assert!(err.contains("no progress"), "{err}");
    assert!(
        err.contains("ctu 0: STEP"),
        "the report names every unit's state: {err}"
    );
    assert!(err.contains("memory:"), "{err}");
}

/// Records every probed value that changed, with its cycle, and checks the machine's change
/// list of every sample against the values (`zeros_before`: the values of the last sample,
/// zeros before the first, as the list's contract says).
struct ChangeLog {
    names: Vec<String>,
    last: Option<Vec<u64>>,
    changes: Vec<String>,
    zeros_before: Vec<u64>,
    /// Samples whose change list was checked, and the positions listed in all.
    lists: u64,
    listed: u64,
}

impl ChangeLog {
    fn new() -> Self {
        ChangeLog {
            names: Vec::new(),
            last: None,
            changes: Vec::new(),
            zeros_before: Vec::new(),
            lists: 0,
            listed: 0,
        }
    }
}

impl shellsim_hw::trace::Probe for ChangeLog {
    fn declare(&mut self, signals: &[shellsim_hw::trace::SignalDecl]) {
        self.names = signals
            .iter()
            .map(|d| format!("{}.{}", d.scope, d.name))
            .collect();
    }
    fn sample_changes(&mut self, t: u64, values: &[u64], changed: &[u32]) {
        if self.zeros_before.is_empty() {
            self.zeros_before = vec![0; values.len()];
        }
        let want: Vec<u32> = (0..values.len() as u32)
            .filter(|&i| values[i as usize] != self.zeros_before[i as usize])
            .collect();
        assert_eq!(changed, &want[..], "cycle {t}: the change list");
        self.zeros_before.copy_from_slice(values);
        self.lists += 1;
        self.listed += changed.len() as u64;
        self.sample(t, values);
    }
    fn sample(&mut self, t: u64, values: &[u64]) {
        let last = self
            .last
            .get_or_insert_with(|| vec![u64::MAX; values.len()]);
        for (i, (l, &v)) in last.iter_mut().zip(values).enumerate() {
            if *l != v {
                self.changes.push(format!("{t} {}={v}", self.names[i]));
                *l = v;
            }
        }
    }
}

#[test]
fn waveforms_are_the_same_with_and_without_the_cycle_jump() {
    // Every signal changes at the same cycle to the same value, balancing on, slow timers.
    let mut c = config("paper");
    c.machine.dda_cycles_per_step = 20;
    c.machine.memory_latency = 60;
    let scene = common::load("scene1.json");
    let spec = spec();
    let logs: Vec<Vec<String>> = [true, false]
        .into_iter()
        .map(|jump| {
            c.machine.cycle_jump = jump;
            let mut log = ChangeLog::new();
            let out = run(&scene, Path::new("scene1.json"), &c, &spec, Some(&mut log)).unwrap();
            assert_eq!(out.stats.skipped_cycles > 0, jump);
            assert!(
                log.lists > 100 && log.listed > 1000,
                "{} {}",
                log.lists,
                log.listed
            );
            log.changes
        })
        .collect();
    let first = logs[0].iter().zip(&logs[1]).position(|(a, b)| a != b);
    assert_eq!(
        first,
        None,
        "first difference: {:?}",
        first.map(|i| (&logs[0][i], &logs[1][i]))
    );
    assert_eq!(logs[0].len(), logs[1].len());
}

/// Issue 14's machine variants (`job_source`, `overlap_joins`) on a subset of the matrix
/// that takes every value of every knob, one `#[test]` per cell, with balancing off and on:
/// equality with the untimed model and conservation (`check_variant`).
macro_rules! variant_cells {
    ($($name:ident => $file:literal, $cn:literal, $kn:literal, $an:ident, $bn:literal, $jn:literal, $bal:literal, $src:ident, $ov:literal;)*) => {$(
        #[test]
        fn $name() {
            let v = Variant {
                balance: Some($bal),
                ..cell($cn, $kn, ArbiterPolicy::$an, $bn, $jn)
            }
            .with(JobSource::$src, $ov);
            let out = check_variant($file, &v);
            if $bal && $cn > 1 {
                // Balancing is exercised: work moved between clusters.
                assert!(out.stats.balancer.work_items > 0, "{}", v.repro($file));
            }
        }
    )*};
}

mod variants {
    use super::*;
    variant_cells! {
        bundle_scene1_c1_k1_small_jump => "scene1.json", 1, 1, RoundRobin, true, true, false, Bundle, false;
        bundle_scene1_c2_k4_paper_step => "scene1.json", 2, 4, FixedPriority, false, false, true, Bundle, false;
        bundle_scene1_c8_k2_small_jump => "scene1.json", 8, 2, RoundRobin, true, true, true, Bundle, false;
        bundle_cornell_c4_k1_paper_jump => "cornell.json", 4, 1, RoundRobin, false, true, true, Bundle, false;
        bundle_cornell_c4_k2_small_step => "cornell.json", 4, 2, FixedPriority, true, false, false, Bundle, false;
        bundle_scene2_c8_k2_paper_jump => "scene2.json", 8, 2, RoundRobin, false, true, true, Bundle, false;
        bundle_stress_skewed_c4_k2_paper_jump => "stress-skewed.json", 4, 2, RoundRobin, false, true, true, Bundle, false;
        overlap_scene1_c1_k2_small_step => "scene1.json", 1, 2, RoundRobin, true, false, false, Ctu, true;
        overlap_scene1_c4_k4_paper_jump => "scene1.json", 4, 4, FixedPriority, false, true, true, Ctu, true;
        overlap_cornell_c8_k1_paper_jump => "cornell.json", 8, 1, RoundRobin, false, true, false, Ctu, true;
        overlap_scene2_c2_k2_paper_jump => "scene2.json", 2, 2, RoundRobin, false, true, false, Ctu, true;
        bundle_overlap_scene1_c1_k4_paper_jump => "scene1.json", 1, 4, RoundRobin, false, true, false, Bundle, true;
        bundle_overlap_scene1_c8_k2_small_step => "scene1.json", 8, 2, FixedPriority, true, false, true, Bundle, true;
        bundle_overlap_cornell_c2_k1_paper_jump => "cornell.json", 2, 1, FixedPriority, false, true, true, Bundle, true;
        bundle_overlap_cornell_c4_k2_small_jump => "cornell.json", 4, 2, RoundRobin, true, true, false, Bundle, true;
        bundle_overlap_scene2_c8_k2_paper_jump => "scene2.json", 8, 2, RoundRobin, false, true, true, Bundle, true;
        bundle_overlap_stress_grazing_c4_k2_paper_step => "stress-grazing.json", 4, 2, RoundRobin, false, false, true, Bundle, true;
        bundle_overlap_stress_edges_c2_k4_small_jump => "stress-edges.json", 2, 4, RoundRobin, true, true, true, Bundle, true;
        bundle_overlap_stress_dense_c4_k2_paper_jump => "stress-dense.json", 4, 2, RoundRobin, false, true, true, Bundle, true;
    }
}

/// Issue 36's levers (`scan_ids_per_cycle`, `descriptor_order`, `partition_granularity`)
/// over cells that take every value of each, under both job sources and with joins
/// overlapped or not, balancing on: equality with the untimed model and conservation
/// (`check_variant`); where the lever changes the machine's timing, the cycles differ from
/// the same cell without it.
macro_rules! lever_cells {
    ($($name:ident => $file:literal, $cn:literal, $kn:literal, $bn:literal, $jn:literal, $src:ident, $ov:literal, $scan:literal, $lf:literal, $ray:literal;)*) => {$(
        #[test]
        fn $name() {
            let plain = Variant {
                balance: Some(true),
                ..cell($cn, $kn, ArbiterPolicy::RoundRobin, $bn, $jn)
            }
            .with(JobSource::$src, $ov);
            let v = Variant {
                levers: Levers {
                    scan_ids_per_cycle: $scan,
                    largest_first: $lf,
                    ray_cuts: $ray,
                },
                ..plain
            };
            let out = check_variant($file, &v);
            let base = run_variant($file, &plain, TickOrder::Forward);
            assert_ne!(out.stats.cycles, base.stats.cycles, "{}: the levers changed no cycle", v.repro($file));
            // Every id is looked at once per visit of its cell, at most scan_ids_per_cycle a cycle.
            for c in out.stats.clusters.iter().flat_map(|c| &c.ctus) {
                let scanning = c.state_cycles.scan + c.state_cycles.request;
                assert!(scanning * $scan >= c.ids_scanned, "{}: {c:?}", v.repro($file));
            }
        }
    )*};
}

mod levers {
    use super::*;
    lever_cells! {
        scan2_scene1_c2_k2_ctu => "scene1.json", 2, 2, false, true, Ctu, false, 2, false, false;
        scan4_cornell_c4_k2_bundle_overlap => "cornell.json", 4, 2, true, false, Bundle, true, 4, false, false;
        scan3_scene2_c8_k2_ctu_overlap => "scene2.json", 8, 2, false, true, Ctu, true, 3, false, false;
        largest_cornell_c4_k4_bundle => "cornell.json", 4, 4, false, true, Bundle, false, 1, true, false;
        largest_scene2_c8_k2_bundle_overlap => "scene2.json", 8, 2, false, true, Bundle, true, 2, true, false;
        ray_cuts_scene2_c4_k2_ctu => "scene2.json", 4, 2, false, false, Ctu, false, 1, false, true;
        ray_cuts_stress_skewed_c8_k2_bundle_overlap => "stress-skewed.json", 8, 2, false, true, Bundle, true, 1, false, true;
        all_stress_edges_c2_k4_bundle_overlap => "stress-edges.json", 2, 4, true, true, Bundle, true, 8, true, true;
        all_cornell_c1_k1_ctu => "cornell.json", 1, 1, false, false, Ctu, false, 64, true, true;
    }
}

/// Tick order changes nothing under a variant, with balancing on (work-items move).
fn variant_tick_order(file: &str, job_source: JobSource, overlap: bool, order: TickOrder) {
    let v = Variant {
        balance: Some(true),
        ..cell(4, 2, ArbiterPolicy::RoundRobin, false, false)
    }
    .with(job_source, overlap);
    let fwd = run_variant(file, &v, TickOrder::Forward);
    assert!(fwd.stats.balancer.work_items > 0, "{}", v.repro(file));
    let other = run_variant(file, &v, order);
    assert_same_run(&other, &fwd, &format!("{file} {order:?} {v:?}"));
}

mod variant_tick_order {
    use super::*;
    testcases! { variant_tick_order;
        bundle_scene1_reverse => "scene1.json", JobSource::Bundle, false, TickOrder::Reverse;
        bundle_scene1_shuffled_7 => "scene1.json", JobSource::Bundle, false, TickOrder::Shuffled(7);
        bundle_cornell_shuffled_3 => "cornell.json", JobSource::Bundle, false, TickOrder::Shuffled(3);
        overlap_scene1_shuffled_5 => "scene1.json", JobSource::Ctu, true, TickOrder::Shuffled(5);
        bundle_overlap_scene1_reverse => "scene1.json", JobSource::Bundle, true, TickOrder::Reverse;
        bundle_overlap_scene2_shuffled_11 => "scene2.json", JobSource::Bundle, true, TickOrder::Shuffled(11);
    }
}

/// The cycle jump changes no statistic under the bundle variant, joins overlapped or not.
#[test]
fn the_cycle_jump_changes_no_statistic_with_the_variants() {
    let run_with = |jump: bool, overlap: bool| {
        let mut c = config("paper");
        c.machine.dda_cycles_per_step = 20;
        c.machine.memory_latency = 60;
        c.machine.cycle_jump = jump;
        c.machine.job_source = JobSource::Bundle;
        c.machine.overlap_joins = overlap;
        let scene = common::load("scene1.json");
        run(&scene, Path::new("scene1.json"), &c, &spec(), None).unwrap()
    };
    for overlap in [false, true] {
        let (a, b) = (run_with(true, overlap), run_with(false, overlap));
        assert!(a.stats.skipped_cycles > 0);
        assert_same_run(&a, &b, &format!("scene1 bundle, overlap_joins {overlap}"));
    }
}

#[test]
fn the_waveform_shows_descriptors_their_expansion_and_splits() {
    let mut c = config("paper");
    c.machine.job_source = JobSource::Bundle;
    let scene = common::load("scene1.json");
    let mut log = ChangeLog::new();
    let out = run(
        &scene,
        Path::new("scene1.json"),
        &c,
        &spec(),
        Some(&mut log),
    )
    .unwrap();
    assert!(out.stats.balancer.work_items > 0);
    let changed = |name: &str| log.changes.iter().filter(|l| l.contains(name)).count();
    for name in [
        "ctu_0.descriptors=",
        "ray_buffer.descriptors=",
        "ray_buffer.expanding_patch=",
        "ray_buffer.expanding_left=",
        "ray_buffer.splits=",
        "ray_buffer.net_descriptors.transfers=",
        "ctu_1.descriptors.transfers=",
    ] {
        assert!(changed(name) > 1, "{name} never changes");
    }
    // The ctu machine's waveform has none of them.
    c.machine.job_source = JobSource::Ctu;
    let mut plain = ChangeLog::new();
    run(
        &scene,
        Path::new("scene1.json"),
        &c,
        &spec(),
        Some(&mut plain),
    )
    .unwrap();
    assert!(!plain.names.iter().any(|n| n.contains("descriptor")));
}

#[test]
fn a_layout_past_the_probes_fill_array_reports_every_signal() {
    // 48 clusters declare more signals than the probe's unchecked fill holds (4,096), so the
    // checked fill runs; the counters it reports end at the run's statistics.
    let mut c = config("paper");
    c.machine.clusters = 48;
    let scene = common::load("cornell.json");
    let mut log = ChangeLog::new();
    let out = run(
        &scene,
        Path::new("cornell.json"),
        &c,
        &spec(),
        Some(&mut log),
    )
    .unwrap();
    assert!(log.names.len() > 4096, "{} signals", log.names.len());
    assert!(
        log.lists > 100 && log.listed > 1000,
        "{} {}",
        log.lists,
        log.listed
    );
    let last = log.last.as_ref().expect("sampled");
    let value = |name: &str| {
        let i = log.names.iter().position(|n| n == name).expect(name);
        last[i]
    };
    assert_eq!(value("machine.memory.grants"), out.stats.memory.grants);
    for (k, cl) in out.stats.clusters.iter().enumerate() {
        let base = format!("machine.cluster_{k}");
        assert_eq!(value(&format!("{base}.icu.jobs_in")), cl.icu.jobs_in);
        for (j, ctu) in cl.ctus.iter().enumerate() {
            let issued = value(&format!("{base}.ctu_{j}.jobs_issued"));
            assert_eq!(issued, ctu.jobs_issued, "{base}.ctu_{j}");
        }
    }
    assert!(out.stats.jobs > 0);
}

/// Keeps the last sample's values and, per ICU and stage, the positions of its valid, ray,
/// patch and t signals and the width of t.
#[derive(Default)]
struct StageProbe {
    values: Vec<u64>,
    stages: Vec<Vec<[usize; 4]>>,
    t_width: u32,
    /// It moves the later stages itself (`Probe::shifts_stages`), applying each change list
    /// to the values it keeps; else it takes the machine's whole arrays.
    shifts: bool,
    /// Shift entries seen.
    shift_entries: u64,
}

impl shellsim_hw::trace::Probe for StageProbe {
    fn declare(&mut self, signals: &[shellsim_hw::trace::SignalDecl]) {
        for c in 0.. {
            let mut icu = Vec::new();
            for k in 0.. {
                let scope = format!("machine.cluster_{c}.icu.stage_{k}");
                let at = |n: &str| signals.iter().position(|d| d.scope == scope && d.name == n);
                let (Some(v), Some(r), Some(p), Some(t)) =
                    (at("valid"), at("ray"), at("patch"), at("t"))
                else {
                    break;
                };
                self.t_width = signals[t].width;
                icu.push([v, r, p, t]);
            }
            if icu.is_empty() {
                break;
            }
            self.stages.push(icu);
        }
        self.values = vec![0; signals.len()];
    }
    fn sample(&mut self, _: u64, values: &[u64]) {
        self.values.copy_from_slice(values);
    }
    fn sample_changes(&mut self, t: u64, values: &[u64], changed: &[u32]) {
        if !self.shifts {
            return self.sample(t, values);
        }
        let flag = shellsim_hw::trace::STAGE_SHIFT;
        self.shift_entries += changed.iter().filter(|&&c| c & flag != 0).count() as u64;
        let entries = changed
            .iter()
            .map(|&c| (c as u64, values.get(c as usize).copied().unwrap_or(0)));
        let mut keep = shellsim_hw::trace::KeepValues(&mut self.values);
        shellsim_hw::trace::apply_changes(&mut keep, entries).expect("well-formed lists");
    }
    fn shifts_stages(&self) -> bool {
        self.shifts
    }
}

/// The waveform's ICU stages — moved along the pipeline by the walk itself when the ring
/// advances — hold at every cycle each stage's job, and the result stage its t, as the ICU
/// has them (small machine, tiny buffers, balancing on; the machine stepped by hand).
#[test]
fn the_waveforms_icu_stages_are_the_icus_own_at_every_cycle() {
    stages_are_the_icus_own(false);
}

/// The same when the probe moves the later stages itself from one shift entry per advanced
/// ICU (as the VCD's thread does): every value it keeps is the ICU's at every cycle.
#[test]
fn a_shifting_probes_icu_stages_are_the_icus_own_at_every_cycle() {
    stages_are_the_icus_own(true);
}

fn stages_are_the_icus_own(shifts: bool) {
    let mut c = config("small");
    c.balance.enabled = true;
    let scene = common::load("scene1.json");
    let file = common::scene_path("scene1.json");
    let prep = shellsim::machine::run::prepare(&scene, &file, &c, &spec()).unwrap();
    let hw = shellsim::config::in_hardware_units(
        &c,
        shellsim::config::SceneSize {
            scale: prep.host.scale,
            patches: prep.host.scene.patches.len(),
        },
    )
    .unwrap();
    let mut m =
        shellsim_hw::machine::Machine::new(hw, &prep.host.scene, &prep.records, &prep.sectors, 0);
    let mut p = StageProbe {
        shifts,
        ..StageProbe::default()
    };
    let (mut held, mut cycles) = (0u64, 0u64);
    let mut sampler = shellsim_hw::machine::Sampler::default();
    loop {
        m.tick(TickOrder::Forward);
        sampler.sample(&m, &mut p);
        assert_eq!(p.stages.len(), m.clusters.len());
        let t_mask = (1u64 << p.t_width) - 1;
        for (c, stages) in p.stages.iter().enumerate() {
            let icu = &m.clusters[c].icu;
            for (k, &[v, r, pa, t]) in stages.iter().enumerate() {
                let want = icu.stage_job(k).map_or((0, 0, 0, 0), |(j, t)| {
                    let t = t.map_or(0, |t| t as u64 & t_mask);
                    (1, j.ray as u64, j.patch as u64 & 0xFF_FFFF, t)
                });
                let got = (p.values[v], p.values[r], p.values[pa], p.values[t]);
                assert_eq!(got, want, "cycle {}: cluster {c} stage {k}", m.cycle);
                held += got.0;
            }
        }
        cycles += 1;
        if m.done() {
            break;
        }
        m.cycle += 1;
    }
    assert!(
        cycles > 1000 && held > 1000,
        "{cycles} cycles, {held} stage-cycles held"
    );
    // A shifting probe got its later stages as shift entries (one per advanced ICU, at
    // least one per 20 stage-cycles held); the other, none.
    assert_eq!(
        p.shift_entries > held / 20,
        shifts,
        "{} shifts",
        p.shift_entries
    );
}
