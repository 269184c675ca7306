//! Helpers shared by the integration tests: committed scenes, machine configurations by name,
//! the standard run specification, one machine variant run with its equality and
//! conservation checks, and the `testcases!` macro that makes one `#[test]` per matrix cell.
#![allow(dead_code)]

use shellsim::machine::run::{run, RunOutput, RunSpec};
use shellsim::scene::Scene;
use shellsim_hw::config::{
    ArbiterPolicy, DescriptorOrder, JobSource, MachineConfig, PartitionGranularity,
};
use shellsim_hw::machine::TickOrder;
use std::path::{Path, PathBuf};

/// The committed scene files, by file name.
pub const COMMITTED: [&str; 7] = [
    "scene1.json",
    "scene2.json",
    "cornell.json",
    "stress-edges.json",
    "stress-grazing.json",
    "stress-skewed.json",
    "stress-dense.json",
];

/// Path of a committed scene.
pub fn scene_path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name)
}

/// Loads a committed scene.
pub fn load(name: &str) -> Scene {
    let p = scene_path(name);
    Scene::load_json(&p).unwrap_or_else(|e| panic!("{e}"))
}

/// The unit cube's six walls facing inward: 0 floor (z=0), 1 ceiling, 2 x=0, 3 x=1, 4 y=0, 5 y=1.
pub fn unit_cube() -> Scene {
    shellsim::scene::gen::unit_cube()
}

/// Path of a committed machine configuration, `hw/configs/NAME.toml`.
pub fn config_path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("hw/configs")
        .join(format!("{name}.toml"))
}

/// A committed machine configuration by name (`paper`, `small`), loaded as the CLI loads it.
pub fn config(name: &str) -> MachineConfig {
    shellsim::config::machine(Some(&config_path(name))).unwrap_or_else(|e| panic!("{e}"))
}

/// The run every machine test starts from: source patch 0, Hi_Low_Ratio 1 (the cell size is the configuration's),
/// units ticked in their natural order.
pub fn spec() -> RunSpec {
    RunSpec {
        source: 0,
        ratio: 1,
        order: TickOrder::Forward,
    }
}

/// One cell of the machine matrix: a committed configuration with the knobs the matrix turns.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Variant {
    pub clusters: u32,
    pub ctus: u32,
    pub arbiter: ArbiterPolicy,
    /// small.toml (small buffers, short queues) rather than paper.toml.
    pub small_buffers: bool,
    pub jump: bool,
    /// Dynamic balancing; `None` keeps the configuration file's setting.
    pub balance: Option<bool>,
    /// Where jobs are made, and overlapped joins (issue 14's machine variants).
    pub job_source: JobSource,
    pub overlap_joins: bool,
    /// Issue 36's levers.
    pub levers: Levers,
}

/// Issue 36's machine options: ids scanned per cycle, the bundle buffer's descriptor order,
/// the partitioner's cuts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Levers {
    pub scan_ids_per_cycle: u32,
    pub largest_first: bool,
    pub ray_cuts: bool,
}

impl Levers {
    /// paper.toml's: one id per cycle, FIFO, cuts at subregion boundaries.
    pub const PAPER: Levers = Levers {
        scan_ids_per_cycle: 1,
        largest_first: false,
        ray_cuts: false,
    };
}

impl Variant {
    /// paper.toml's machine shape with its own balancing, round-robin, cycle jump on.
    pub const PAPER: Variant = Variant {
        clusters: 4,
        ctus: 2,
        arbiter: ArbiterPolicy::RoundRobin,
        small_buffers: false,
        jump: true,
        balance: None,
        job_source: JobSource::Ctu,
        overlap_joins: false,
        levers: Levers::PAPER,
    };

    /// The same cell with jobs made at `source`, joins overlapped or not.
    pub const fn with(self, job_source: JobSource, overlap_joins: bool) -> Variant {
        Variant {
            job_source,
            overlap_joins,
            ..self
        }
    }

    /// The configuration this variant names.
    pub fn config(&self) -> MachineConfig {
        let mut c = config(if self.small_buffers { "small" } else { "paper" });
        c.machine.clusters = self.clusters;
        c.machine.ctus_per_cluster = self.ctus;
        c.machine.arbiter = self.arbiter;
        c.machine.cycle_jump = self.jump;
        if let Some(on) = self.balance {
            c.balance.enabled = on;
        }
        c.machine.job_source = self.job_source;
        c.machine.overlap_joins = self.overlap_joins;
        let l = &self.levers;
        c.machine.scan_ids_per_cycle = l.scan_ids_per_cycle;
        if l.largest_first {
            c.machine.descriptor_order = DescriptorOrder::LargestFirst;
        }
        if l.ray_cuts {
            c.machine.partition_granularity = PartitionGranularity::Ray;
        }
        c
    }

    /// The command that reproduces a failure of this variant.
    pub fn repro(&self, file: &str) -> String {
        format!(
            "reproduce: shellsim run --scene scenes/{file} --ratio 1 --hw hw/configs/{}.toml with clusters={} ctus_per_cluster={} arbiter={:?} cycle_jump={} balance={:?} job_source={} overlap_joins={} {:?}",
            if self.small_buffers { "small" } else { "paper" },
            self.clusters,
            self.ctus,
            self.arbiter,
            self.jump,
            self.balance,
            self.job_source.name(),
            self.overlap_joins,
            self.levers
        )
    }
}

/// Runs a committed scene on a variant in the given tick order.
pub fn run_variant(file: &str, v: &Variant, order: TickOrder) -> RunOutput {
    let scene = load(file);
    let spec = RunSpec { order, ..spec() };
    run(&scene, Path::new(file), &v.config(), &spec, None)
        .unwrap_or_else(|e| panic!("{file} {v:?}: {e}\n{}", v.repro(file)))
}

/// Runs a variant and checks equality with the untimed model and conservation: as many
/// results as rays; jobs issued = jobs through the ICUs = results returned; memory grants =
/// requests = patch loads; every unit's cycles partition into busy, stalled and idle.
pub fn check_variant(file: &str, v: &Variant) -> RunOutput {
    let out = run_variant(file, v, TickOrder::Forward);
    let s = &out.stats;
    let repro = v.repro(file);
    assert_eq!(s.mismatches_vs_fixed, 0, "{repro}");
    assert_eq!(out.hits, out.reference, "{repro}");
    assert_eq!(out.hits.len(), s.rays, "{repro}");
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
    assert_eq!(s.memory.grants, s.patch_loads, "{repro}");
    // Moved = given; every moved job's result came home.
    let given: u64 = s.clusters.iter().map(|c| c.ray_buffer.jobs_given).sum();
    let remote: u64 = s.clusters.iter().map(|c| c.icu.remote_results_out).sum();
    assert_eq!(s.balancer.jobs_moved, given, "{repro}");
    assert_eq!(s.balancer.results_returned, remote, "{repro}");
    if v.job_source == JobSource::Bundle {
        // Every job came out of a descriptor, once: the ray buffers expanded all of them.
        let expanded: u64 = s.clusters.iter().map(|c| c.ray_buffer.jobs_in).sum();
        let descs: u64 = s
            .clusters
            .iter()
            .flat_map(|c| &c.ctus)
            .map(|c| c.descriptors)
            .sum();
        let taken: u64 = s.clusters.iter().map(|c| c.ray_buffer.descriptors_in).sum();
        assert_eq!(expanded, s.jobs, "{repro}");
        assert_eq!(taken, descs + s.balancer.work_items, "{repro}");
    }
    assert_eq!(s.memory_requests, s.patch_loads, "{repro}");
    for c in s.clusters.iter().flat_map(|c| &c.ctus) {
        assert_eq!(
            c.busy_cycles + c.stalled_cycles + c.idle_cycles,
            s.cycles,
            "{repro}"
        );
        // The per-state counters partition the cycles too; the join waits are JOIN cycles.
        assert_eq!(c.state_cycles.total(), s.cycles, "{repro}");
        assert!(
            c.join_wait_patches + c.join_wait_results <= c.state_cycles.join,
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

/// Two runs gave the same statistics (their deterministic JSON) and the same hits.
pub fn assert_same_run(a: &RunOutput, b: &RunOutput, what: &str) {
    assert_eq!(
        serde_json::to_string(&a.stats).unwrap(),
        serde_json::to_string(&b.stats).unwrap(),
        "{what}: statistics differ"
    );
    assert_eq!(a.hits, b.hits, "{what}: hits differ");
}

/// One `#[test]` per case, as mooneye-gb's suite builds one test per ROM × model: each case
/// is a name and the expression it runs, so a failing case hides no other and runs alone by
/// name (`cargo test --test machine scene1::c4::k2`).
///
/// ```ignore
/// testcases! { check_scene; scene1 => "scene1.json", cornell => "cornell.json" }
/// ```
/// expands to `#[test] fn scene1() { check_scene("scene1.json") }` and so on.
#[macro_export]
macro_rules! testcases {
    ($f:path; $($name:ident => $($arg:expr),+);* $(;)?) => {$(
        #[test]
        fn $name() {
            $f($($arg),+);
        }
    )*};
}
