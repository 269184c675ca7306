//! The cycle-level machine: per-ray results equal the untimed fixed-point model over a
//! matrix of scenes × clusters × CTUs × arbiter × buffers × cycle jump (a flat table of
//! cases; `SHELLSIM_CASE=scene1/c4/k2 cargo test --release --test it machine::` runs the
//! cases whose name holds the text); ticking units in reverse or shuffled order changes
//! nothing, with balancing off and on; conservation of jobs, results and loads. Every
//! failing case prints the `shellsim run` command that repeats it and leaves its --hw file,
//! waveform and GTKWave save file under target/tmp/failures/ (`common::Evidence`).

use crate::common;

use common::{
    assert_same_run, check_variant, config, run_cases, spec, Evidence, Levers, MachineRun, Variant,
};
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

/// The knobs the matrix turns, one row per cell: clusters, CTUs, arbiter, small buffers,
/// cycle jump.
type Row = (u32, u32, ArbiterPolicy, bool, bool);

use ArbiterPolicy::{FixedPriority as Fp, RoundRobin as Rr};

/// Every seventh cell of the full matrix: 14 cells that take every value of every knob.
const SAMPLED: [Row; 14] = [
    (1, 1, Rr, true, true),
    (1, 1, Fp, false, false),
    (1, 2, Fp, false, true),
    (1, 4, Fp, true, false),
    (2, 1, Fp, true, true),
    (2, 2, Rr, false, false),
    (2, 4, Rr, false, true),
    (4, 1, Rr, true, false),
    (4, 2, Rr, true, true),
    (4, 2, Fp, false, false),
    (4, 4, Fp, false, true),
    (8, 1, Fp, true, false),
    (8, 2, Fp, true, true),
    (8, 4, Rr, false, false),
];

/// The full matrix: clusters 1/2/4/8 × CTUs 1/2/4 × both arbiters × small and paper
/// buffers × cycle jump on and off (96 cells).
fn full() -> Vec<Row> {
    let mut rows = Vec::new();
    for c in [1, 2, 4, 8] {
        for k in [1, 2, 4] {
            for a in [Rr, Fp] {
                for small in [true, false] {
                    for jump in [true, false] {
                        rows.push((c, k, a, small, jump));
                    }
                }
            }
        }
    }
    rows
}

/// The machine matrix as a flat table of cases: scene, then its cells (the full product on
/// scene1 and cornell, the sampled cells elsewhere, two hand-picked on the dense stress
/// scene). Each case is `check_variant`'s (equality with the untimed model, conservation),
/// named `scene/c4/k2/round_robin/small/jump`; `SHELLSIM_CASE=scene1/c4/k2 cargo test
/// --release --test it machine::matrix` runs those alone.
fn matrix() -> Vec<(&'static str, Variant)> {
    let dense: [Row; 2] = [(4, 2, Rr, false, true), (2, 1, Fp, true, false)];
    let table: [(&str, Vec<Row>); 7] = [
        ("scene1.json", full()),
        ("cornell.json", full()),
        ("scene2.json", SAMPLED.to_vec()),
        ("stress-edges.json", SAMPLED.to_vec()),
        ("stress-grazing.json", SAMPLED.to_vec()),
        ("stress-skewed.json", SAMPLED.to_vec()),
        ("stress-dense.json", dense.to_vec()),
    ];
    table
        .into_iter()
        .flat_map(|(f, rows)| {
            rows.into_iter()
                .map(move |(c, k, a, s, j)| (f, cell(c, k, a, s, j)))
        })
        .collect()
}

/// A case's name: the scene's stem, then the variant's.
fn case_name(file: &str, v: &Variant) -> String {
    format!("{}/{}", file.trim_end_matches(".json"), v.name())
}

/// One test per scene of the matrix, so they run in parallel with the rest of the suite.
fn matrix_of(file: &str) {
    let cases: Vec<_> = matrix().into_iter().filter(|(f, _)| *f == file).collect();
    assert!(!cases.is_empty(), "{file} has no case");
    run_cases(
        &cases,
        |(f, v)| case_name(f, v),
        |name, (f, v)| {
            check_variant(name, f, v);
        },
    );
}

mod matrix {
    use super::*;
    testcases! { matrix_of;
        scene1 => "scene1.json";
        cornell => "cornell.json";
        scene2 => "scene2.json";
        stress_edges => "stress-edges.json";
        stress_grazing => "stress-grazing.json";
        stress_skewed => "stress-skewed.json";
        stress_dense => "stress-dense.json";
    }

    #[test]
    fn every_committed_scene_is_in_the_matrix_and_the_sample_takes_every_value() {
        let m = matrix();
        assert_eq!(m.len(), 2 * 96 + 4 * 14 + 2);
        for f in common::COMMITTED {
            assert!(m.iter().any(|(g, _)| *g == f), "{f}");
        }
        let s = SAMPLED;
        for c in [1, 2, 4, 8] {
            assert!(s.iter().any(|r| r.0 == c), "clusters {c}");
        }
        for k in [1, 2, 4] {
            assert!(s.iter().any(|r| r.1 == k), "ctus {k}");
        }
        for a in [Rr, Fp] {
            assert!(s.iter().any(|r| r.2 == a), "{a:?}");
        }
        for b in [true, false] {
            assert!(s.iter().any(|r| r.3 == b) && s.iter().any(|r| r.4 == b));
        }
        // Every sampled cell is a cell of the full matrix, and every name is one case's.
        assert!(s.iter().all(|r| full().contains(r)));
        let names: std::collections::BTreeSet<_> = m.iter().map(|(f, v)| case_name(f, v)).collect();
        assert_eq!(names.len(), m.len());
    }
}

/// Slow DDA steps and a slow memory leave whole stretches where all units wait: the jump
/// skips them and changes no statistic.
fn the_cycle_jump_changes_no_statistic(file: &str) {
    let with = |jump: bool| {
        let mut c = config("paper");
        c.machine.dda_cycles_per_step = 20;
        c.machine.memory_latency = 60;
        c.machine.cycle_jump = jump;
        MachineRun::new(file, c, spec())
    };
    let (ra, rb) = (with(true), with(false));
    let _e = Evidence::for_test(&[&ra, &rb]);
    let (a, b) = (ra.run(), rb.run());
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

/// Two runs of `v` on `file`, forward and in `order`, give the same statistics and hits;
/// with balancing on, the run must move work-items between clusters, so the balancer's
/// links are exercised.
fn same_in_order(file: &str, v: &Variant, order: TickOrder) {
    let (fwd, other) = (
        MachineRun::of(file, v, TickOrder::Forward),
        MachineRun::of(file, v, order),
    );
    let _e = Evidence::for_test(&[&fwd, &other]);
    let a = fwd.run();
    if v.balance == Some(true) {
        assert!(
            a.stats.balancer.work_items > 0,
            "{file}: no work-item moved, the balancer is not exercised"
        );
    }
    assert_same_run(&other.run(), &a, &format!("{file} {order:?} {}", v.name()));
}

/// Ticking the units in another order changes no statistic and no hit, with balancing off
/// (2 × 2, small buffers) and on (4 × 2).
fn tick_order_changes_nothing(file: &str, balance: bool, order: TickOrder) {
    let v = Variant {
        balance: Some(balance),
        ..cell(if balance { 4 } else { 2 }, 2, Rr, !balance, false)
    };
    same_in_order(file, &v, order);
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
    let r = MachineRun::of("scene2.json", &Variant::PAPER, TickOrder::Forward);
    let _e = Evidence::for_test(&[&r, &r]);
    assert_same_run(&r.run(), &r.run(), "scene2, paper.toml, twice");
}

#[test]
fn the_watchdog_stops_a_run_that_makes_no_progress() {
    // A DDA step longer than the watchdog's patience: nothing moves for 1000 cycles. A file
    // with this is refused (`check_watchdog`: the watchdog must outlast the longest legal
    // wait; tests/it/watchdog.rs); built in code, it stands in for a real deadlock to test
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
    fn declare(
        &mut self,
        signals: &[shellsim_hw::trace::SignalDecl],
        _: &[shellsim_hw::trace::Pipeline],
    ) {
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

/// Issue 14's machine variants (`job_source`, `overlap_joins`) as a flat table of cases on
/// cells that take every value of every knob, with balancing off and on: equality with the
/// untimed model and conservation (`check_variant`); with balancing on and more than one
/// cluster, work moved between clusters.
#[rustfmt::skip]
const VARIANTS: [(&str, Row, bool, JobSource, bool); 19] = {
    use JobSource::{Bundle as B, Ctu as C};
    [
        ("scene1.json", (1, 1, Rr, true, true), false, B, false),
        ("scene1.json", (2, 4, Fp, false, false), true, B, false),
        ("scene1.json", (8, 2, Rr, true, true), true, B, false),
        ("cornell.json", (4, 1, Rr, false, true), true, B, false),
        ("cornell.json", (4, 2, Fp, true, false), false, B, false),
        ("scene2.json", (8, 2, Rr, false, true), true, B, false),
        ("stress-skewed.json", (4, 2, Rr, false, true), true, B, false),
        ("scene1.json", (1, 2, Rr, true, false), false, C, true),
        ("scene1.json", (4, 4, Fp, false, true), true, C, true),
        ("cornell.json", (8, 1, Rr, false, true), false, C, true),
        ("scene2.json", (2, 2, Rr, false, true), false, C, true),
        ("scene1.json", (1, 4, Rr, false, true), false, B, true),
        ("scene1.json", (8, 2, Fp, true, false), true, B, true),
        ("cornell.json", (2, 1, Fp, false, true), true, B, true),
        ("cornell.json", (4, 2, Rr, true, true), false, B, true),
        ("scene2.json", (8, 2, Rr, false, true), true, B, true),
        ("stress-grazing.json", (4, 2, Rr, false, false), true, B, true),
        ("stress-edges.json", (2, 4, Rr, true, true), true, B, true),
        ("stress-dense.json", (4, 2, Rr, false, true), true, B, true),
    ]
};

#[test]
fn variants() {
    let cases: Vec<(&str, Variant)> = VARIANTS
        .iter()
        .map(|&(f, (c, k, a, s, j), bal, src, ov)| {
            let v = Variant {
                balance: Some(bal),
                ..cell(c, k, a, s, j)
            };
            (f, v.with(src, ov))
        })
        .collect();
    run_cases(
        &cases,
        |(f, v)| case_name(f, v),
        |name, (f, v)| {
            let out = check_variant(name, f, v);
            if v.balance == Some(true) && v.clusters > 1 {
                assert!(
                    out.stats.balancer.work_items > 0,
                    "{name}: no work-item moved"
                );
            }
        },
    );
}

/// A lever case: scene, (clusters, CTUs, small buffers, jump), job source, overlapped joins,
/// the levers.
type LeverRow = (
    &'static str,
    (u32, u32, bool, bool),
    JobSource,
    bool,
    Levers,
);

/// Issue 36's levers (`scan_ids_per_cycle`, `descriptor_order`, `partition_granularity`)
/// over cells that take every value of each, under both job sources and with joins
/// overlapped or not, balancing on, round-robin: equality with the untimed model and
/// conservation (`check_variant`); the cycles differ from the same cell without the levers;
/// no CTU scanned more ids than `scan_ids_per_cycle` a scanning cycle.
#[rustfmt::skip]
const LEVERS: [LeverRow; 9] = {
    use JobSource::{Bundle as B, Ctu as C};
    const fn l(scan_ids_per_cycle: u32, largest_first: bool, ray_cuts: bool) -> Levers {
        Levers { scan_ids_per_cycle, largest_first, ray_cuts }
    }
    [
        ("scene1.json", (2, 2, false, true), C, false, l(2, false, false)),
        ("cornell.json", (4, 2, true, false), B, true, l(4, false, false)),
        ("scene2.json", (8, 2, false, true), C, true, l(3, false, false)),
        ("cornell.json", (4, 4, false, true), B, false, l(1, true, false)),
        ("scene2.json", (8, 2, false, true), B, true, l(2, true, false)),
        ("scene2.json", (4, 2, false, false), C, false, l(1, false, true)),
        ("stress-skewed.json", (8, 2, false, true), B, true, l(1, false, true)),
        ("stress-edges.json", (2, 4, true, true), B, true, l(8, true, true)),
        ("cornell.json", (1, 1, false, false), C, false, l(64, true, true)),
    ]
};

#[test]
fn levers() {
    let cases: Vec<(&str, Variant, Variant)> = LEVERS
        .iter()
        .map(|&(f, (c, k, s, j), src, ov, levers)| {
            let plain = Variant {
                balance: Some(true),
                ..cell(c, k, Rr, s, j)
            }
            .with(src, ov);
            (f, plain, Variant { levers, ..plain })
        })
        .collect();
    run_cases(
        &cases,
        |(f, _, v)| case_name(f, v),
        |name, (f, plain, v)| {
            let base = MachineRun::of(f, plain, TickOrder::Forward);
            let _e = Evidence::new(&format!("{name}/without"), &[&base]);
            let out = check_variant(name, f, v);
            assert_ne!(
                out.stats.cycles,
                base.run().stats.cycles,
                "{name}: the levers changed no cycle"
            );
            let scan = v.levers.scan_ids_per_cycle as u64;
            for c in out.stats.clusters.iter().flat_map(|c| &c.ctus) {
                let scanning = c.state_cycles.scan + c.state_cycles.request;
                assert!(scanning * scan >= c.ids_scanned, "{name}: {c:?}");
            }
        },
    );
}

/// Tick order changes nothing under a variant, with balancing on (work-items move).
fn variant_tick_order(file: &str, job_source: JobSource, overlap: bool, order: TickOrder) {
    let v = Variant {
        balance: Some(true),
        ..cell(4, 2, Rr, false, false)
    }
    .with(job_source, overlap);
    same_in_order(file, &v, order);
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
    for overlap in [false, true] {
        let with = |jump: bool| {
            let mut c = config("paper");
            c.machine.dda_cycles_per_step = 20;
            c.machine.memory_latency = 60;
            c.machine.cycle_jump = jump;
            c.machine.job_source = JobSource::Bundle;
            c.machine.overlap_joins = overlap;
            MachineRun::new("scene1.json", c, spec())
        };
        let (ra, rb) = (with(true), with(false));
        let _e = Evidence::for_test(&[&ra, &rb]);
        let (a, b) = (ra.run(), rb.run());
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
    /// The pipelines the machine declared.
    pipelines: Vec<shellsim_hw::trace::Pipeline>,
}

impl shellsim_hw::trace::Probe for StageProbe {
    fn declare(
        &mut self,
        signals: &[shellsim_hw::trace::SignalDecl],
        pipelines: &[shellsim_hw::trace::Pipeline],
    ) {
        self.pipelines = pipelines.to_vec();
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
        let mut keep = shellsim_hw::trace::KeepValues(&mut self.values, &self.pipelines);
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
    // Each ICU's stages declared once as a pipeline: stage 1 right after stage 0's four
    // signals, three of them moving, every later stage.
    assert_eq!(p.pipelines.len(), p.stages.len());
    for (pipe, icu) in p.pipelines.iter().zip(&p.stages) {
        assert_eq!((pipe.at, pipe.stride, pipe.width), (icu[1][0], 4, 3));
        assert_eq!(pipe.later, icu.len() - 1);
    }
}

/// `RunStats::verdict` (what `shellsim run` exits 1 on) catches a counter that breaks a
/// conservation law, naming it, and passes the run it came from.
#[test]
fn the_verdict_names_a_broken_conservation_law() {
    let out = MachineRun::of("scene1.json", &Variant::PAPER, TickOrder::Forward).run();
    assert!(out.stats.broken_laws().is_empty());
    out.stats.verdict().unwrap();
    let mut s = out.stats.clone();
    s.clusters[1].icu.results_out -= 1;
    s.memory.grants += 1;
    s.clusters[0].ctus[1].idle_cycles += 1;
    let broken = s.broken_laws();
    assert_eq!(broken.len(), 3, "{broken:?}");
    assert!(broken[0].contains("out"), "{broken:?}");
    assert!(broken[1].contains("grants"), "{broken:?}");
    assert!(broken[2].starts_with("cluster 0 ctu 1"), "{broken:?}");
    let e = s.verdict().unwrap_err().to_string();
    assert!(e.contains("3 conservation law(s)"), "{e}");
}

/// `--tick-order` takes forward, reverse and shuffled:SEED, and refuses anything else with
/// exit status 2 naming the value.
#[test]
fn tick_order_flag() {
    let run = |order: &str| {
        std::process::Command::new(env!("CARGO_BIN_EXE_shellsim"))
            .args([
                "run",
                "--scene",
                "scenes/scene1.json",
                "--ratio",
                "1",
                "--tick-order",
                order,
            ])
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .unwrap()
    };
    for ok in ["reverse", "shuffled:7"] {
        let o = run(ok);
        assert!(
            o.status.success(),
            "{ok}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
    let o = run("sideways");
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("sideways"));
}
