//! The cycle-level machine: per-ray results equal the untimed fixed-point model over a
//! matrix of scenes × clusters × CTUs × arbiter × buffers × cycle jump; ticking units in
//! reverse or shuffled order changes nothing; conservation of jobs, results and loads.

mod common;

use shellsim::machine::run::{run, RunOutput, RunSpec};
use shellsim_hw::machine::TickOrder;
use shellsim_hw::machine_config::{ArbiterPolicy, MachineConfig};
use std::path::Path;

fn config(base: &str) -> MachineConfig {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("hw/configs")
        .join(base);
    shellsim::config::machine(Some(&p)).unwrap()
}

#[derive(Clone, Copy, Debug)]
struct Variant {
    clusters: u32,
    ctus: u32,
    arbiter: ArbiterPolicy,
    small_buffers: bool,
    jump: bool,
}

impl Variant {
    fn config(&self) -> MachineConfig {
        let mut c = config(if self.small_buffers {
            "small.toml"
        } else {
            "paper.toml"
        });
        c.machine.clusters = self.clusters;
        c.machine.ctus_per_cluster = self.ctus;
        c.machine.arbiter = self.arbiter;
        c.machine.cycle_jump = self.jump;
        c
    }
}

fn simulate(file: &str, v: &Variant, order: TickOrder) -> RunOutput {
    let scene = common::load(file);
    let spec = RunSpec {
        source: 0,
        ratio: 1,
        cell: 0.05,
        order,
    };
    run(&scene, Path::new(file), &v.config(), &spec, None)
        .unwrap_or_else(|e| panic!("{file} {v:?}: {e}"))
}

/// Equality with the untimed model and conservation, for one run.
fn check(file: &str, v: &Variant) -> RunOutput {
    let out = simulate(file, v, TickOrder::Forward);
    let s = &out.stats;
    let repro = format!(
        "reproduce: shellsim run --scene scenes/{file} --ratio 1 with clusters={} ctus_per_cluster={} arbiter={:?} small={} cycle_jump={}",
        v.clusters, v.ctus, v.arbiter, v.small_buffers, v.jump
    );
    assert_eq!(s.mismatches_vs_fixed, 0, "{repro}");
    assert_eq!(out.hits, out.reference, "{repro}");
    // Every ray has exactly one result slot: as many results as rays.
    assert_eq!(out.hits.len(), s.rays, "{repro}");
    // Jobs issued = jobs through the ICUs = results returned.
    let icu_in: u64 = s.clusters.iter().map(|c| c.icu.jobs_in).sum();
    let icu_out: u64 = s.clusters.iter().map(|c| c.icu.results_out).sum();
    let results: u64 = s
        .clusters
        .iter()
        .flat_map(|c| &c.ctus)
        .map(|c| c.results)
        .sum();
    assert_eq!(
        (icu_in, icu_out, results),
        (s.jobs, s.jobs, s.jobs),
        "{repro}"
    );
    // Memory grants = patch loads = requests; each CTU's cycles partition into states.
    assert_eq!(s.memory.grants, s.patch_loads, "{repro}");
    assert_eq!(s.memory_requests, s.patch_loads, "{repro}");
    for c in s.clusters.iter().flat_map(|c| &c.ctus) {
        assert_eq!(
            c.busy_cycles + c.stalled_cycles + c.idle_cycles,
            s.cycles,
            "{repro}"
        );
    }
    for c in &s.clusters {
        assert_eq!(
            c.icu.busy_cycles + c.icu.stalled_cycles + c.icu.idle_cycles,
            s.cycles,
            "{repro}"
        );
    }
    out
}

/// Every combination of 1/2/4/8 clusters, 1/2/4 CTUs, both arbiters, small and large
/// buffers, with and without the cycle jump.
fn full_matrix() -> Vec<Variant> {
    let mut v = Vec::new();
    for clusters in [1, 2, 4, 8] {
        for ctus in [1, 2, 4] {
            for arbiter in [ArbiterPolicy::RoundRobin, ArbiterPolicy::FixedPriority] {
                for small_buffers in [true, false] {
                    for jump in [true, false] {
                        v.push(Variant {
                            clusters,
                            ctus,
                            arbiter,
                            small_buffers,
                            jump,
                        });
                    }
                }
            }
        }
    }
    v
}

/// A sample of the matrix that still takes every value of every knob.
fn sampled_matrix() -> Vec<Variant> {
    full_matrix().into_iter().step_by(7).collect()
}

#[test]
fn scene1_full_matrix() {
    for v in full_matrix() {
        check("scene1.json", &v);
    }
}

#[test]
fn cornell_full_matrix() {
    for v in full_matrix() {
        check("cornell.json", &v);
    }
}

#[test]
fn sampled_matrix_takes_every_value() {
    let m = sampled_matrix();
    for c in [1, 2, 4, 8] {
        assert!(m.iter().any(|v| v.clusters == c));
    }
    for k in [1, 2, 4] {
        assert!(m.iter().any(|v| v.ctus == k));
    }
    assert!(m.iter().any(|v| v.jump) && m.iter().any(|v| !v.jump));
    assert!(m.iter().any(|v| v.small_buffers) && m.iter().any(|v| !v.small_buffers));
    assert!(m.iter().any(|v| v.arbiter == ArbiterPolicy::FixedPriority));
}

macro_rules! sampled {
    ($($name:ident => $file:expr),* $(,)?) => {$(
        #[test]
        fn $name() {
            for v in sampled_matrix() {
                check($file, &v);
            }
        }
    )*};
}

sampled! {
    scene2_sampled => "scene2.json",
    stress_edges_sampled => "stress-edges.json",
    stress_grazing_sampled => "stress-grazing.json",
    stress_skewed_sampled => "stress-skewed.json",
}

#[test]
fn stress_dense_two_machines() {
    for v in [
        Variant {
            clusters: 4,
            ctus: 2,
            arbiter: ArbiterPolicy::RoundRobin,
            small_buffers: false,
            jump: true,
        },
        Variant {
            clusters: 2,
            ctus: 1,
            arbiter: ArbiterPolicy::FixedPriority,
            small_buffers: true,
            jump: false,
        },
    ] {
        check("stress-dense.json", &v);
    }
}

#[test]
fn the_cycle_jump_changes_no_statistic() {
    for file in ["scene1.json", "cornell.json"] {
        // Slow DDA steps and a slow memory leave whole stretches where all units wait.
        let run_with = |jump: bool| {
            let mut c = config("paper.toml");
            c.machine.dda_cycles_per_step = 20;
            c.machine.memory_latency = 60;
            c.machine.cycle_jump = jump;
            let scene = common::load(file);
            let spec = RunSpec {
                source: 0,
                ratio: 1,
                cell: 0.05,
                order: TickOrder::Forward,
            };
            run(&scene, Path::new(file), &c, &spec, None).unwrap()
        };
        let (a, b) = (run_with(true), run_with(false));
        assert!(
            a.stats.skipped_cycles > a.stats.cycles / 10,
            "{file}: the jump skipped only {} of {}",
            a.stats.skipped_cycles,
            a.stats.cycles
        );
        assert_eq!(b.stats.skipped_cycles, 0);
        assert_eq!(
            serde_json::to_string(&a.stats).unwrap(),
            serde_json::to_string(&b.stats).unwrap(),
            "{file}"
        );
        assert_eq!(a.hits, b.hits);
    }
}

#[test]
fn tick_order_changes_nothing() {
    for file in ["scene1.json", "cornell.json"] {
        let v = Variant {
            clusters: 2,
            ctus: 2,
            arbiter: ArbiterPolicy::RoundRobin,
            small_buffers: true,
            jump: false,
        };
        let fwd = simulate(file, &v, TickOrder::Forward);
        let json = serde_json::to_string(&fwd.stats).unwrap();
        for order in [
            TickOrder::Reverse,
            TickOrder::Shuffled(1),
            TickOrder::Shuffled(99),
        ] {
            let other = simulate(file, &v, order);
            assert_eq!(
                serde_json::to_string(&other.stats).unwrap(),
                json,
                "{file} {order:?}"
            );
            assert_eq!(other.hits, fwd.hits);
        }
    }
}

#[test]
fn two_runs_give_identical_json() {
    let v = Variant {
        clusters: 4,
        ctus: 2,
        arbiter: ArbiterPolicy::RoundRobin,
        small_buffers: false,
        jump: true,
    };
    let a = simulate("scene2.json", &v, TickOrder::Forward);
    let b = simulate("scene2.json", &v, TickOrder::Forward);
    assert_eq!(
        serde_json::to_string(&a.stats).unwrap(),
        serde_json::to_string(&b.stats).unwrap()
    );
}

#[test]
fn the_watchdog_stops_a_run_that_makes_no_progress() {
    // A DDA step longer than the watchdog's patience: nothing moves for 1000 cycles.
    let mut c = config("small.toml");
    c.machine.dda_cycles_per_step = 1000;
    c.machine.watchdog_cycles = 100;
    c.machine.cycle_jump = false;
    let scene = common::load("scene1.json");
    let spec = RunSpec {
        source: 0,
        ratio: 1,
        cell: 0.05,
        order: TickOrder::Forward,
    };
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

/// Records every probed value that changed, with its cycle.
struct ChangeLog {
    now: u64,
    last: std::collections::HashMap<String, String>,
    changes: Vec<String>,
}

impl ChangeLog {
    fn new() -> Self {
        ChangeLog {
            now: 0,
            last: Default::default(),
            changes: Vec::new(),
        }
    }
    fn see(&mut self, key: String, val: String) {
        if self.last.get(&key) != Some(&val) {
            self.changes.push(format!("{} {key}={val}", self.now));
            self.last.insert(key, val);
        }
    }
}

impl shellsim_hw::trace::Probe for ChangeLog {
    fn cycle(&mut self, t: u64) {
        self.now = t;
    }
    fn bits(&mut self, s: &str, n: &str, _: u32, v: u64) {
        self.see(format!("{s}.{n}"), v.to_string());
    }
    fn text(&mut self, s: &str, n: &str, v: &str) {
        self.see(format!("{s}.{n}"), v.to_string());
    }
    fn fixed(&mut self, s: &str, n: &str, _: u32, _: u32, raw: i64) {
        self.see(format!("{s}.{n}"), raw.to_string());
    }
}

#[test]
fn waveforms_are_the_same_with_and_without_the_cycle_jump() {
    // Every signal changes at the same cycle to the same value, balancing on, slow timers.
    let mut c = config("paper.toml");
    c.machine.dda_cycles_per_step = 20;
    c.machine.memory_latency = 60;
    let scene = common::load("scene1.json");
    let spec = RunSpec {
        source: 0,
        ratio: 1,
        cell: 0.05,
        order: TickOrder::Forward,
    };
    let logs: Vec<Vec<String>> = [true, false]
        .into_iter()
        .map(|jump| {
            c.machine.cycle_jump = jump;
            let mut log = ChangeLog::new();
            let out = run(&scene, Path::new("scene1.json"), &c, &spec, Some(&mut log)).unwrap();
            assert_eq!(out.stats.skipped_cycles > 0, jump);
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
