//! `shellsim run`: partition, simulate the cycle-level machine, check against the
//! fixed-point model.

use super::args::{MachineArgs, OnOff, SceneSourceArgs};
use crate::error::{Error, Result};
use crate::machine::run::{execute, RunSpec, Waveform};
use crate::output::{check_outputs, Output};
use crate::wave::{FstPack, ScopeFilter, WaveFormat, WaveOptions, Window};
use shellsim_hw::machine::TickOrder;
use std::path::PathBuf;

/// Arguments of `shellsim run`.
#[derive(clap::Args, Debug)]
pub struct RunArgs {
    #[command(flatten)]
    pub input: SceneSourceArgs,
    #[command(flatten)]
    pub machine: MachineArgs,
    /// Hi_Low_Ratio: the machine casts ratio × 969 rays.
    #[arg(long, default_value_t = 10)]
    pub ratio: usize,
    /// Write the statistics (and the resolved configuration) as JSON here (`-`: standard
    /// output).
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// The timing level: `cycle` steps the machine cycle by cycle and checks it against the
    /// fixed-point model; `queue` takes each ray's result from the fixed-point model and
    /// estimates the cycles with the paper's queueing network (`shellsim experiment levels`
    /// measures its error), several times faster and without a waveform.
    #[arg(long, value_enum, default_value_t = Level::Cycle)]
    pub level: Level,
    /// Dynamic workload balancing: overrides the configuration's [balance] enabled.
    #[arg(long, value_enum)]
    pub balance: Option<OnOff>,
    /// Write the machine's waveform as a VCD here, and a GTKWave save file (signals grouped
    /// per unit and formatted) beside it with the same stem and extension .gtkw, and a
    /// Surfer command file (the overview) with extension .sucl.
    #[arg(long, value_name = "OUT", group = "waveform")]
    pub vcd: Option<PathBuf>,
    /// Write the machine's waveform here: FILE.fst as FST (GTKWave's compressed format),
    /// any other name as VCD (`--wave FILE.vcd` is `--vcd FILE.vcd`); the .gtkw beside it
    /// as for --vcd.
    #[arg(long, value_name = "FILE", group = "waveform", conflicts_with = "vcd")]
    pub wave: Option<PathBuf>,
    /// The most bytes a VCD may take (`1G`, `500M`, `1T`; default 2 GiB): a waveform that
    /// passes it stops the run with an error (exit status 2) and leaves nothing behind —
    /// narrow it with --vcd-window or --vcd-scope, or raise this.
    #[arg(long, value_name = "BYTES", default_value = "2G", value_parser = parse_limit)]
    pub wave_limit: u64,
    /// Only cycles FROM..=TO in the waveform (either side may be left empty); the values
    /// holding at FROM are dumped in full.
    #[arg(long, value_name = "FROM:TO", requires = "waveform", value_parser = Window::parse, visible_alias = "wave-window")]
    pub vcd_window: Option<Window>,
    /// Only signals whose dotted scope matches PATTERN: a glob with * and ? on the whole
    /// scope (e.g. 'machine.cluster_0.*'), else a substring (e.g. 'icu').
    #[arg(
        long,
        value_name = "PATTERN",
        requires = "waveform",
        visible_alias = "wave-scope"
    )]
    pub vcd_scope: Option<String>,
    /// How an FST's value changes are compressed: zlib (the default, about 18× smaller
    /// than the VCD) or lz4 (about 8.5×, written faster; GTKWave's `vcd2fst --fastpack`).
    /// Only with an FST (`--wave FILE.fst`).
    #[arg(long, value_enum, value_name = "PACK", requires = "waveform")]
    pub fst_pack: Option<FstPack>,
    /// The order the units tick in within a cycle: `forward` (the default), `reverse` or
    /// `shuffled:SEED` (a new permutation every cycle). No result or statistic may depend on
    /// it; the tests compare the orders and print this flag when they differ.
    #[arg(long, value_name = "ORDER", default_value = "forward", value_parser = parse_tick_order)]
    pub tick_order: TickOrder,
}

/// `--tick-order`: `forward`, `reverse` or `shuffled:SEED`.
fn parse_tick_order(s: &str) -> std::result::Result<TickOrder, String> {
    match s {
        "forward" => Ok(TickOrder::Forward),
        "reverse" => Ok(TickOrder::Reverse),
        _ => s
            .strip_prefix("shuffled:")
            .and_then(|n| n.parse().ok())
            .map(TickOrder::Shuffled)
            .ok_or_else(|| format!("`{s}`: expected forward, reverse or shuffled:SEED")),
    }
}

/// A run's timing level.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Level {
    /// The cycle-level machine.
    Cycle,
    /// The queueing network over the CTUs' walks.
    Queue,
}

/// Runs `shellsim run`.
pub fn run(a: &RunArgs) -> Result<()> {
    if a.level == Level::Queue && (a.vcd.is_some() || a.wave.is_some()) {
        return Err(Error::Usage(
            "--level queue steps no machine, so it writes no waveform: drop --vcd/--wave or run --level cycle".into(),
        ));
    }
    check_outputs(&a.outputs()?)?;
    let (scene, source) = a.input.load()?;
    let mut cfg = a.machine.load()?;
    if let Some(b) = a.balance {
        cfg.balance.enabled = b == OnOff::On;
    }
    let spec = RunSpec {
        source,
        ratio: a.ratio,
        order: a.tick_order,
    };
    if a.level == Level::Queue {
        let q =
            crate::machine::queue::execute(&scene, a.input.path(), &cfg, &spec, a.json.as_deref())?;
        let e = &q.estimate;
        crate::output::outln!(
            "{}: {} rays, {} cycles (queue level), pipeline efficiency {:.3}, {} patch loads, {} jobs, {} work-items ({} jobs moved); results from the fixed-point model, {:.3} s",
            q.scene, q.rays, e.cycles, q.pipeline_efficiency, e.patch_loads, e.jobs, e.work_items, e.jobs_moved, q.wall.untimed_s + q.wall.timing_s()
        );
        return Ok(());
    }
    let vcd = a.vcd.as_ref().or(a.wave.as_ref()).map(|p| {
        (
            p.clone(),
            WaveOptions {
                window: a.vcd_window.unwrap_or(Window::ALL),
                scope: a.vcd_scope.as_deref().map(ScopeFilter::new),
                fst_pack: a.fst_pack.unwrap_or_default(),
                limit: a.wave_limit,
            },
        )
    });
    let out = execute(&scene, a.input.path(), &cfg, &spec, vcd, a.json.as_deref())?;
    if let Some(w) = &out.waveform {
        print_waveform(w);
    }
    let s = &out.stats;
    let escaped = out.escaped.len();
    crate::output::outln!(
        "{}: {} rays, {} cycles, pipeline efficiency {:.3}, {} patch loads, {} jobs, {} mismatches vs fixed, {} escaped, {:.2} M cycles/s",
        s.scene, s.rays, s.cycles, s.pipeline_efficiency, s.patch_loads, s.jobs, s.mismatches_vs_fixed, escaped, s.sim_rate_hz / 1e6
    );
    s.verdict()?;
    leak_verdict(&scene, &out.escaped, s.source)
}

/// `Err(Error::Check)` when the machine lost rays from a scene the float reference's
/// closure probe proves closed (`reference::orient::closure`): a leak, naming the first ray.
fn leak_verdict(scene: &crate::scene::Scene, escaped: &[u32], source: u32) -> Result<()> {
    let Some(&first) = escaped.first() else {
        return Ok(());
    };
    let tracer = crate::reference::tracer::Tracer::new(scene, scene.bounds.scale() / 20.0)?;
    if !crate::reference::orient::closure(scene, &tracer).closed() {
        return Ok(());
    }
    Err(Error::Check(format!(
        "the machine lost {} rays from source {source} of a closed scene (the first: ray {first}); \
         `shellsim check --source {source}` lists where they left",
        escaped.len()
    )))
}

impl RunArgs {
    /// The outputs asked for (the .gtkw beside the VCD among them), for the check before
    /// any work; a VCD on standard output is a usage error (its .gtkw needs a directory).
    pub fn outputs(&self) -> Result<Vec<Output>> {
        let mut v: Vec<Output> = self
            .json
            .iter()
            .map(|p| Output::file("--json", p))
            .collect();
        let wave = match (&self.vcd, &self.wave) {
            (Some(p), _) => Some(("--vcd", p)),
            (None, Some(p)) => Some(("--wave", p)),
            _ => None,
        };
        if let (Some(_), Some((flag, p))) = (self.fst_pack, wave) {
            if WaveFormat::of(p) != WaveFormat::Fst {
                return Err(Error::Usage(format!(
                    "--fst-pack applies to an FST, and {flag} {} writes a VCD (name it FILE.fst)",
                    p.display()
                )));
            }
        }
        if let Some((flag, p)) = wave {
            if crate::output::is_stdout(p) {
                return Err(Error::Usage(format!(
                    "{flag} -: the waveform needs a file name (its .gtkw is written beside it)"
                )));
            }
            v.push(Output::file(flag, p));
            if crate::output::is_file_path(p) {
                v.push(Output::file(
                    &format!("{flag} (its .gtkw)"),
                    &crate::wave::gtkw::path_for(p),
                ));
                v.push(Output::file(
                    &format!("{flag} (its .sucl)"),
                    &crate::wave::sucl::path_for(p),
                ));
            }
        }
        Ok(v)
    }
}

/// A byte count for `--wave-limit`.
fn parse_limit(s: &str) -> std::result::Result<u64, String> {
    crate::limits::parse_bytes(s)
        .ok_or_else(|| format!("{s:?} is not a byte count (e.g. 500M, 2G)"))
}

/// The waveform line.
pub fn print_waveform(w: &Waveform) {
    crate::output::outln!(
        "waveform: {} ({} signals, {} bytes) and {}",
        w.path.display(),
        w.signals,
        w.bytes,
        w.gtkw.display()
    );
}
