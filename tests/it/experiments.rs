//! The paper's experiments: dynamic balancing beats static partitioning where the paper says
//! it should (scene2, stress-skewed); random machine configurations with balancing finish,
//! equal the untimed model and lose or duplicate no job; the experiments' CSV and SVG are
//! byte-identical across runs, the speedup at P = 1 is exactly 1 and no run beats its
//! resource bound.

use crate::common;

use proptest::prelude::*;
use shellsim::experiment::{
    self,
    outputs::{self, speedup_outputs, Which},
    Point, Workload,
};
use shellsim::machine::run::{run, RunSpec};
use shellsim_hw::config::{
    ArbiterPolicy, DescriptorOrder, JobSource, MachineConfig, PartitionGranularity, VictimPolicy,
};
use shellsim_hw::machine::TickOrder;
use std::path::Path;
use std::process::Command;

fn paper_config() -> MachineConfig {
    common::config("paper")
}

/// Static and balanced runs of `file` at `clusters` clusters and `ratio` on paper.toml.
fn static_and_balanced(file: &str, clusters: u32, ratio: usize) -> (Point, Point) {
    let scene = common::load(file);
    let base = paper_config();
    let path = common::scene_path(file);
    let w = Workload {
        scene: &scene,
        file: &path,
        source: 0,
        base: &base,
    };
    let prep = experiment::prepare(&w, &experiment::machine(&base, clusters, false), ratio)
        .unwrap_or_else(|e| panic!("{file}: {e}"));
    let run = |on| {
        experiment::measure(
            &w,
            &prep.input(),
            &experiment::machine(&base, clusters, on),
            ratio,
        )
        .unwrap_or_else(|e| panic!("{file}: {e}"))
    };
    (run(false), run(true))
}

/// Balancing raises pipeline efficiency and cuts cycles at Hi_Low_Ratio 10 on the paper's
/// machine (hw/configs/paper.toml): scene2 at 8 ICUs, stress-skewed at 4.
fn balancing_beats_static_partitioning(file: &str, icus: u32) {
    let (off, on) = static_and_balanced(file, icus, 10);
    let msg = format!(
        "{file}, {icus} ICUs, ratio 10, paper.toml: efficiency static {:.4} balanced {:.4}, cycles static {} balanced {} ({} jobs moved)",
        off.pipeline_efficiency, on.pipeline_efficiency, off.cycles, on.cycles, on.jobs_moved
    );
    eprintln!("{msg}");
    assert!(
        on.pipeline_efficiency > off.pipeline_efficiency,
        "efficiency: {msg}"
    );
    assert!(on.cycles < off.cycles, "cycles: {msg}");
    assert!(on.jobs_moved > 0, "balancing moved nothing: {msg}");
    // The partition and the work are shared: only the timing differs.
    assert_eq!(
        (off.jobs, off.patch_loads),
        (on.jobs, on.patch_loads),
        "{msg}"
    );
    for p in [&off, &on] {
        assert!(p.bound.cycles() <= p.cycles, "bound above cycles: {p:?}");
    }
}

mod balancing_beats_static_partitioning {
    use super::*;
    // On stress-skewed at 8 ICUs one sector's CTU binds (`ctu_issue`, docs/paper/report.md):
    // no balancing of ICUs can shorten that run, so the claim is made at 4 ICUs there.
    testcases! { balancing_beats_static_partitioning;
        scene2_8_icus => "scene2.json", 8;
        stress_skewed_4_icus => "stress-skewed.json", 4;
    }
}

/// A random machine with balancing (mostly on) and small, back-pressuring buffers.
#[derive(Clone, Debug)]
struct Random {
    cornell: bool,
    clusters: u32,
    ctus: u32,
    balance: bool,
    ray_buffer: u32,
    work_item: u32,
    sampling: u32,
    link_latency: u32,
    link_width: u32,
    round_robin_victim: bool,
    patch_buffer: u32,
    request_queue: u32,
    fixed_priority: bool,
    jump: bool,
    /// Issue 14's variants.
    bundle: bool,
    overlap_joins: bool,
    /// Issue 36's levers.
    scan_ids: u32,
    largest_first: bool,
    ray_cuts: bool,
}

impl Random {
    fn config(&self) -> MachineConfig {
        let mut c = paper_config();
        let m = &mut c.machine;
        m.clusters = self.clusters;
        m.ctus_per_cluster = self.ctus;
        m.ray_buffer_capacity = self.ray_buffer;
        m.patch_buffer_capacity = self.patch_buffer;
        m.request_queue_capacity = self.request_queue;
        m.arbiter = if self.fixed_priority {
            ArbiterPolicy::FixedPriority
        } else {
            ArbiterPolicy::RoundRobin
        };
        m.cycle_jump = self.jump;
        m.job_source = if self.bundle {
            JobSource::Bundle
        } else {
            JobSource::Ctu
        };
        m.overlap_joins = self.overlap_joins;
        m.scan_ids_per_cycle = self.scan_ids;
        if self.largest_first {
            m.descriptor_order = DescriptorOrder::LargestFirst;
        }
        if self.ray_cuts {
            m.partition_granularity = PartitionGranularity::Ray;
        }
        let b = &mut c.balance;
        b.enabled = self.balance;
        b.work_item_jobs = self.work_item;
        b.sampling_interval = self.sampling;
        b.link_latency = self.link_latency;
        b.link_words_per_cycle = self.link_width;
        b.victim = if self.round_robin_victim {
            VictimPolicy::RoundRobin
        } else {
            VictimPolicy::MostPending
        };
        c.validate().expect("a valid random configuration");
        c
    }
}

fn random() -> impl Strategy<Value = Random> {
    (
        (
            any::<bool>(),
            1u32..=8,
            1u32..=4,
            prop::bool::weighted(0.85),
        ),
        (1u32..=64, 1u32..=128, 1u32..=64),
        (0u32..=24, 1u32..=4, any::<bool>()),
        (1u32..=8, 1u32..=3, any::<bool>(), any::<bool>()),
        (any::<bool>(), any::<bool>()),
        (1u32..=4, any::<bool>(), any::<bool>()),
    )
        .prop_map(
            |(
                (cornell, clusters, ctus, balance),
                (ray_buffer, work_item, sampling),
                (link_latency, link_width, round_robin_victim),
                (patch_buffer, request_queue, fixed_priority, jump),
                (bundle, overlap_joins),
                (scan_ids, largest_first, ray_cuts),
            )| Random {
                cornell,
                clusters,
                ctus,
                balance,
                ray_buffer,
                // A work-item fits the ray buffer.
                work_item: 1 + (work_item - 1) % ray_buffer,
                sampling,
                link_latency,
                link_width,
                round_robin_victim,
                patch_buffer,
                request_queue,
                fixed_priority,
                jump,
                bundle,
                overlap_joins,
                scan_ids,
                largest_first,
                ray_cuts,
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 20, ..ProptestConfig::default() })]

    /// Any configuration finishes (no deadlock), equals the untimed model ray for ray, and
    /// computes every job exactly once: Σ ICU jobs_in = jobs issued = Σ CTU results; jobs
    /// moved by the balancer = jobs given by ray buffers; results sent home = results
    /// returned.
    #[test]
    fn random_balanced_machines_are_exact(r in random()) {
        let (file, source) = if r.cornell { ("cornell.json", 1) } else { ("scene1.json", 0) };
        let scene = common::load(file);
        let spec = RunSpec { source, ratio: 1, order: TickOrder::Forward };
        let out = run(&scene, Path::new(file), &r.config(), &spec, None)
            .unwrap_or_else(|e| panic!("{file} {r:?}: {e}"));
        let s = &out.stats;
        prop_assert_eq!(s.mismatches_vs_fixed, 0, "{} {:?}", file, r);
        prop_assert!(out.hits == out.reference, "{} {:?}: hits differ", file, r);
        let icu_in: u64 = s.clusters.iter().map(|c| c.icu.jobs_in).sum();
        let icu_out: u64 = s.clusters.iter().map(|c| c.icu.results_out).sum();
        let results: u64 = s.clusters.iter().flat_map(|c| &c.ctus).map(|c| c.results).sum();
        prop_assert_eq!((icu_in, icu_out, results), (s.jobs, s.jobs, s.jobs), "{} {:?}", file, r);
        let given: u64 = s.clusters.iter().map(|c| c.ray_buffer.jobs_given).sum();
        prop_assert_eq!(s.balancer.jobs_moved, given, "{} {:?}", file, r);
        let remote: u64 = s.clusters.iter().map(|c| c.icu.remote_results_out).sum();
        prop_assert_eq!(s.balancer.results_returned, remote, "{} {:?}", file, r);
        if !r.balance || r.clusters == 1 {
            prop_assert_eq!(s.balancer.jobs_moved, 0, "{} {:?}", file, r);
        }
        let p = Point::new(s, &r.config(), 1);
        prop_assert!(p.bound.cycles() <= s.cycles, "{} {:?}: bound {:?} above {} cycles", file, r, p.bound, s.cycles);
    }
}

/// The speedup experiment twice on scene1: byte-identical CSV and SVG; the speedup at P = 1
/// is exactly 1 (whole machine and same work, balancing off and on); no run beats its bound.
#[test]
fn experiments_are_deterministic_and_speedup_starts_at_one() {
    let scene = common::load("scene1.json");
    let base = paper_config();
    let path = common::scene_path("scene1.json");
    let w = Workload {
        scene: &scene,
        file: &path,
        source: 0,
        base: &base,
    };
    let a = experiment::speedup(&w, &[1, 2, 8], 1).unwrap();
    let b = experiment::speedup(&w, &[1, 2, 8], 1).unwrap();
    let (oa, ob) = (
        speedup_outputs(&w, &a).unwrap(),
        speedup_outputs(&w, &b).unwrap(),
    );
    assert_eq!(oa.csv, ob.csv, "speedup CSV differs between runs");
    assert_eq!(oa.svg, ob.svg, "speedup SVG differs between runs");
    let p1: Vec<_> = a.iter().filter(|r| r.point.clusters == 1).collect();
    assert_eq!(p1.len(), 2, "P = 1 with balancing off and on");
    for r in &p1 {
        assert_eq!(r.speedup, 1.0, "{r:?}");
        assert_eq!(r.speedup_same_work, 1.0, "{r:?}");
    }
    assert!(oa.csv.lines().nth(1).unwrap().contains(",1.000000,"));
    for r in &a {
        assert!(r.point.bound.cycles() <= r.point.cycles, "{r:?}");
        assert!(r.bound_speedup >= r.speedup, "{r:?}");
    }
    let e1 = experiment::efficiency(&w, &[2, 4], &[1]).unwrap();
    let e2 = experiment::efficiency(&w, &[2, 4], &[1]).unwrap();
    assert_eq!(experiment::points_csv(&e1), experiment::points_csv(&e2));
    assert_eq!(
        outputs::efficiency_svg("t", &e1).unwrap(),
        outputs::efficiency_svg("t", &e2).unwrap()
    );
    let wi = experiment::work_item(&w, 4, 1, &[1, 8, 512]).unwrap();
    assert_eq!(
        wi.skipped,
        vec![512],
        "a work-item larger than the ray buffer"
    );
    assert_eq!(wi.on.len(), 2);
    assert!(!wi.off.balance && wi.on.iter().all(|p| p.balance));
}

/// The CLI writes WHICH-SCENE.csv and .svg, byte-identical across runs; a bad source exits 2.
#[test]
fn cli_writes_csv_and_svg() {
    let exe = env!("CARGO_BIN_EXE_shellsim");
    let dir = tempfile::tempdir().unwrap();
    let scene = common::scene_path("cornell.json");
    let go = |out: &Path| {
        Command::new(exe)
            .args(["experiment", Which::Workitem.name()])
            .arg("--scene")
            .arg(&scene)
            .args(["--source", "1", "--out"])
            .arg(out)
            .output()
            .unwrap()
    };
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    for d in [&a, &b] {
        let o = go(d);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    for f in ["workitem-cornell.csv", "workitem-cornell.svg"] {
        let x = std::fs::read(a.join(f)).unwrap();
        assert!(!x.is_empty(), "{f}");
        assert_eq!(x, std::fs::read(b.join(f)).unwrap(), "{f} differs");
    }
    let o = Command::new(exe)
        .args(["experiment", "speedup", "--source", "999", "--scene"])
        .arg(&scene)
        .arg("--out")
        .arg(dir.path().join("c"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{o:?}");
    assert!(!dir.path().join("c").exists());
}

/// Issue 36's aim held by hw/configs/balanced.toml: on scene2 at ratio 10 (the paper's
/// Fig 12.15 setting), 8 ICUs with balancing reach 0.9 of the ideal same-work speedup, the
/// paper's machine does not, and balancing is worth more than the paper's 15 %.
#[test]
fn the_balanced_configuration_keeps_eight_icus_busy() {
    let scene = common::load("scene2.json");
    let path = common::scene_path("scene2.json");
    let at8 = |name: &str| {
        let base = common::config(name);
        let w = Workload {
            scene: &scene,
            file: &path,
            source: 0,
            base: &base,
        };
        let rows = experiment::speedup(&w, &[1, 8], 10).unwrap();
        let get = |on: bool| {
            rows.iter()
                .find(|r| r.point.clusters == 8 && r.point.balance == on)
                .unwrap_or_else(|| panic!("{name}: no 8-ICU row with balance {on}"))
                .speedup_same_work
        };
        (get(true), get(false))
    };
    let (on, off) = at8("balanced");
    assert!(
        on >= 0.9 * 8.0,
        "balanced.toml: same-work speedup {on:.3} at 8 ICUs < 7.2"
    );
    assert!(
        on > 1.15 * off,
        "balanced.toml: balancing {off:.3} → {on:.3}"
    );
    let (paper, _) = at8("paper");
    assert!(
        paper < on,
        "paper.toml {paper:.3} at or above balanced.toml {on:.3}"
    );
}

/// Issue 33: the queueing network (`experiment levels`) estimates the cycle model's cycles
/// within 5 % on every machine of the speedup experiment up to 4 ICUs, on the paper's
/// machine (one job per cycle from the CTU), the same with overlapped joins, and on
/// balanced.toml (bundles, overlapped joins, ray cuts), with balancing off and on; each ICU's
/// utilization within 0.08, and no work moves without balancing.
#[test]
fn the_queue_level_estimates_the_cycle_level_within_five_percent() {
    let scene = common::load("scene2.json");
    let path = common::scene_path("scene2.json");
    // paper.toml with overlapped joins: the CTUs' issuers wait for room in the ray buffer,
    // which once left balancing 14 % too optimistic at 4 × 2 in the network.
    let mut ctu_overlap = common::config("paper");
    ctu_overlap.machine.overlap_joins = true;
    for (name, base) in [
        ("paper", common::config("paper")),
        ("balanced", common::config("balanced")),
        ("paper + overlap_joins", ctu_overlap),
    ] {
        let w = Workload {
            scene: &scene,
            file: &path,
            source: 0,
            base: &base,
        };
        let rows = experiment::levels::levels(&w, &[1, 2, 4], 10, false).unwrap();
        assert_eq!(rows.len(), 3 * 2 + 2, "{name}");
        for r in &rows {
            assert!(
                r.error.abs() <= 0.05,
                "{name} {}: queue {} vs cycle {} cycles ({:+.1} %)",
                r.machine,
                r.queue_cycles,
                r.cycles,
                100.0 * r.error
            );
            assert!(
                r.icu_utilization_error <= 0.08,
                "{name} {}: {r:?}",
                r.machine
            );
            if !r.balance {
                assert_eq!(r.queue_jobs_moved, 0, "{name} {}", r.machine);
            }
        }
        assert!(
            rows.iter().any(|r| r.balance && r.queue_jobs_moved > 0),
            "{name}"
        );
    }
}

/// `run --level queue` estimates the run's cycles within 5 % of `run`'s on scene2 with
/// balanced.toml, writes the same JSON shape with `"level": "queue"`, and refuses a
/// waveform (exit 2, nothing written).
#[test]
fn run_at_the_queue_level_estimates_the_cycle_run() {
    let exe = env!("CARGO_BIN_EXE_shellsim");
    let dir = tempfile::tempdir().unwrap();
    let scene = common::scene_path("scene2.json");
    let go = |extra: &[&str], json: &Path| {
        Command::new(exe)
            .arg("run")
            .arg("--scene")
            .arg(&scene)
            .arg("--hw")
            .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("hw/configs/balanced.toml"))
            .args(extra)
            .arg("--json")
            .arg(json)
            .output()
            .unwrap()
    };
    let cycles = |p: &Path, key: &str| -> u64 {
        let v: serde_json::Value = serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap();
        v[key]["cycles"].as_u64().unwrap_or_else(|| panic!("{v}"))
    };
    let (c, q) = (dir.path().join("c.json"), dir.path().join("q.json"));
    for (extra, p) in [(&[][..], &c), (&["--level", "queue"][..], &q)] {
        let o = go(extra, p);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let tc = cycles(&c, "stats");
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&q).unwrap()).unwrap();
    assert_eq!(v["level"], "queue");
    let tq = v["run"]["estimate"]["cycles"].as_u64().unwrap();
    let err = (tq as f64 - tc as f64).abs() / tc as f64;
    assert!(err <= 0.05, "queue {tq} vs cycle {tc}");
    let w = dir.path().join("w.vcd");
    let o = Command::new(exe)
        .args(["run", "--level", "queue", "--scene"])
        .arg(&scene)
        .arg("--vcd")
        .arg(&w)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{o:?}");
    assert!(!w.exists());
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 16,
        rng_seed: proptest::test_runner::RngSeed::Fixed(33),
        ..ProptestConfig::default()
    })]

    /// The queue level on any configuration: the network finishes (never stuck), its jobs
    /// are the cycle model's when joins do not overlap (the walk is then timing-free), and
    /// its cycles lie within 25 % of the cycle model's. The committed figures' table holds
    /// the tighter targets. Over 300 draws the mean |error| was 0.4 % and the largest −20 %,
    /// on a one-job ray buffer, which the network does not model (it passes a job every
    /// cycle; the machine's cannot). The draws are seeded so the test is the same each run.
    #[test]
    fn the_queue_level_follows_the_cycle_level_on_random_machines(r in random()) {
        let (file, source) = if r.cornell { ("cornell.json", 1) } else { ("scene1.json", 0) };
        let scene = common::load(file);
        let spec = RunSpec { source, ratio: 1, order: TickOrder::Forward };
        let cfg = r.config();
        let out = run(&scene, Path::new(file), &cfg, &spec, None)
            .unwrap_or_else(|e| panic!("{file} {r:?}: {e}"));
        let prep = shellsim::machine::run::prepare(&scene, Path::new(file), &cfg, &spec).unwrap();
        let q = shellsim::machine::queue::estimate(&prep.input(), &scene.name, &cfg, &spec, None)
            .unwrap_or_else(|e| panic!("{file} {r:?}: {e}"));
        let (c, e) = (out.stats.cycles, q.estimate.cycles);
        let err = (e as f64 - c as f64) / c as f64;
        if !r.overlap_joins {
            prop_assert_eq!(q.estimate.jobs, out.stats.jobs, "{} {:?}", file, r);
        }
        prop_assert!(err.abs() <= 0.25, "{} {:?}: queue {} vs cycle {} ({:+.1} %)", file, r, e, c, 100.0 * err);
    }
}
