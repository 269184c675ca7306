//! Helpers shared by the integration tests: committed scenes, machine configurations by name,
//! the standard run specification, one machine variant run with its equality and
//! conservation checks, and the `testcases!` macro that makes one `#[test]` per matrix cell.

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

    /// The cell's name, `c4/k2/round_robin/small/jump`, then whatever differs from the
    /// paper's job source, joins, balancing and levers.
    pub fn name(&self) -> String {
        let mut n = format!(
            "c{}/k{}/{}/{}/{}",
            self.clusters,
            self.ctus,
            match self.arbiter {
                ArbiterPolicy::RoundRobin => "round_robin",
                ArbiterPolicy::FixedPriority => "fixed_priority",
            },
            if self.small_buffers { "small" } else { "paper" },
            if self.jump { "jump" } else { "step" }
        );
        if self.job_source != JobSource::Ctu {
            n += &format!("/{}", self.job_source.name());
        }
        if self.overlap_joins {
            n += "/overlap";
        }
        if let Some(b) = self.balance {
            n += if b { "/balance" } else { "/no_balance" };
        }
        let l = &self.levers;
        if l.scan_ids_per_cycle != 1 {
            n += &format!("/scan{}", l.scan_ids_per_cycle);
        }
        if l.largest_first {
            n += "/largest_first";
        }
        if l.ray_cuts {
            n += "/ray_cuts";
        }
        n
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
}

/// A machine run a test makes, as the CLI can repeat it: a committed scene, a configuration
/// and a run specification.
#[derive(Clone, Debug)]
pub struct MachineRun {
    pub file: String,
    pub cfg: MachineConfig,
    pub spec: RunSpec,
}

impl MachineRun {
    pub fn new(file: &str, cfg: MachineConfig, spec: RunSpec) -> Self {
        MachineRun {
            file: file.to_string(),
            cfg,
            spec,
        }
    }

    /// A committed scene on a variant, its units ticked in `order`.
    pub fn of(file: &str, v: &Variant, order: TickOrder) -> Self {
        MachineRun::new(file, v.config(), RunSpec { order, ..spec() })
    }

    /// Runs it through the library; an error fails the test.
    pub fn run(&self) -> RunOutput {
        let scene = load(&self.file);
        run(&scene, Path::new(&self.file), &self.cfg, &self.spec, None)
            .unwrap_or_else(|e| panic!("{}: {e}", self.file))
    }

    /// The `shellsim run` arguments that repeat it, its configuration read from `hw`.
    pub fn args(&self, hw: &Path) -> Vec<String> {
        let order = match self.spec.order {
            TickOrder::Forward => "forward".to_string(),
            TickOrder::Reverse => "reverse".to_string(),
            TickOrder::Shuffled(s) => format!("shuffled:{s}"),
        };
        [
            "run",
            "--scene",
            &format!("scenes/{}", self.file),
            "--source",
            &self.spec.source.to_string(),
            "--ratio",
            &self.spec.ratio.to_string(),
            "--hw",
            &hw.display().to_string(),
            "--tick-order",
            &order,
        ]
        .map(String::from)
        .to_vec()
    }
}

/// The evidence a failing machine-level test leaves: while a guard lives, a panic of its
/// thread writes under `target/tmp/failures/NAME/`, for each of its runs, the configuration
/// (`runK.toml`), and repeats the run through the CLI with its waveform (`runK.vcd` and the
/// GTKWave save file `runK.gtkw` beside it) and JSON; then it prints the commands, which
/// `reproduce.sh` there holds too. Two runs are a comparison: the command ends in a diff of
/// their statistics.
pub struct Evidence {
    name: String,
    runs: Vec<MachineRun>,
}

impl Evidence {
    pub fn new(name: &str, runs: &[&MachineRun]) -> Self {
        Evidence {
            name: name.to_string(),
            runs: runs.iter().map(|r| (*r).clone()).collect(),
        }
    }

    /// A guard named by the running test (its thread's name).
    pub fn for_test(runs: &[&MachineRun]) -> Self {
        let name = std::thread::current()
            .name()
            .unwrap_or("unnamed")
            .to_string();
        Evidence::new(&name, runs)
    }

    /// Writes the evidence and returns the lines that describe it.
    pub fn write(&self) -> std::io::Result<Vec<String>> {
        // One directory per failure, its path relative to the repository root when it can be
        // (the commands run from there).
        let flat = self.name.replace("::", ".").replace('/', ".");
        let tmp = PathBuf::from(env!("CARGO_TARGET_TMPDIR"));
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let dir = tmp
            .strip_prefix(root)
            .unwrap_or(&tmp)
            .join("failures")
            .join(flat);
        std::fs::create_dir_all(root.join(&dir))?;
        let mut lines = vec![format!(
            "evidence of {} in {} (from the repository root):",
            self.name,
            dir.display()
        )];
        let mut script = vec!["#!/bin/sh".to_string(), "set -x".to_string()];
        let mut jsons = Vec::new();
        for (k, r) in self.runs.iter().enumerate() {
            let stem = dir.join(format!("run{}", k + 1));
            let hw = stem.with_extension("toml");
            let body = toml::to_string(&r.cfg).expect("a configuration serializes");
            std::fs::write(root.join(&hw), body)?;
            let (vcd, json) = (stem.with_extension("vcd"), stem.with_extension("json"));
            let mut args = r.args(&hw);
            for (flag, p) in [("--vcd", &vcd), ("--json", &json)] {
                args.push(flag.into());
                args.push(p.display().to_string());
            }
            let out = std::process::Command::new(env!("CARGO_BIN_EXE_shellsim"))
                .args(&args)
                .current_dir(env!("CARGO_MANIFEST_DIR"))
                .output()?;
            let command = format!("cargo run --release -- {}", args.join(" "));
            lines.push(format!("  reproduce: {command}"));
            lines.push(format!(
                "    exit status {:?}; {}",
                out.status.code(),
                String::from_utf8_lossy(&out.stderr).trim()
            ));
            lines.push(format!(
                "    waveform: gtkwave {} {}",
                vcd.display(),
                vcd.with_extension("gtkw").display()
            ));
            script.push(command);
            jsons.push(json);
        }
        if let [a, b] = &jsons[..] {
            let diff = format!(
                "diff <(jq -S 'del(.host)' {}) <(jq -S 'del(.host)' {})",
                a.display(),
                b.display()
            );
            lines.push(format!("  then: {diff}"));
            script.push(format!("bash -c \"{diff}\""));
        }
        std::fs::write(
            root.join(&dir).join("reproduce.sh"),
            script.join("\n") + "\n",
        )?;
        Ok(lines)
    }
}

impl Drop for Evidence {
    fn drop(&mut self) {
        if std::thread::panicking() {
            match self.write() {
                Ok(lines) => eprintln!("{}", lines.join("\n")),
                Err(e) => eprintln!("{}: writing the evidence failed: {e}", self.name),
            }
        }
    }
}

/// Runs every case, in parallel, each under `check` with its name, and fails naming every
/// case that failed (each failing case leaves its own evidence). `SHELLSIM_CASE=TEXT` runs
/// only the cases whose name contains TEXT.
pub fn run_cases<T: Sync>(
    cases: &[T],
    name: impl Fn(&T) -> String + Sync,
    check: impl Fn(&str, &T) + Sync,
) {
    use rayon::prelude::*;
    let only = std::env::var("SHELLSIM_CASE").ok();
    let failed: Vec<String> = cases
        .par_iter()
        .map(|c| (name(c), c))
        .filter(|(n, _)| only.as_ref().is_none_or(|o| n.contains(o.as_str())))
        .filter_map(|(n, c)| {
            let ok = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| check(&n, c)));
            ok.is_err().then_some(n)
        })
        .collect();
    assert!(
        failed.is_empty(),
        "{} of {} cases failed (each printed its reproduce command above): {}\n\
         rerun one: SHELLSIM_CASE=NAME cargo test --release --test it machine::",
        failed.len(),
        cases.len(),
        failed.join(", ")
    );
}

/// Runs `r` and checks equality with the untimed model and the machine's conservation laws
/// (`RunStats::verdict`, as `shellsim run` checks them), and that every ray has a result.
pub fn check_run(r: &MachineRun) -> RunOutput {
    let out = r.run();
    if let Err(e) = out.stats.verdict() {
        panic!("{}: {e}", r.file);
    }
    assert_eq!(out.hits, out.reference, "{}: hits", r.file);
    assert_eq!(out.hits.len(), out.stats.rays, "{}: results", r.file);
    out
}

/// A variant on a committed scene checked by [`check_run`], leaving evidence named `name`
/// when it fails.
pub fn check_variant(name: &str, file: &str, v: &Variant) -> RunOutput {
    let r = MachineRun::of(file, v, TickOrder::Forward);
    let _e = Evidence::new(name, &[&r]);
    check_run(&r)
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
/// name (`cargo test --test it machine::scene1::c4::k2`).
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
