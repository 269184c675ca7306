//! A run of the cycle-level machine (`shellsim run`): partition, convert to records
//! ([`prepare`]), simulate, check every ray against the untimed fixed-point model and gather
//! statistics ([`simulate`]; JSON, units in the names), with the waveform and the report
//! written beside it ([`execute`]).

use crate::config;
use crate::error::{Error, Result};
use crate::fixed::records::HostFixed;
use crate::output::write_json;
use crate::partition::{self, Config as PartitionConfig};
use crate::reference::tracer::Tracer;
use crate::wave::{WaveOptions, WaveWriter};
use crate::Scene;
use serde::Serialize;
use shellsim_hw::config::MachineConfig;
use shellsim_hw::machine::{Machine, TickOrder};
use shellsim_hw::trace::Probe;
use shellsim_hw::units::ctu::CtuStats;
use shellsim_hw::units::icu::IcuStats;
use shellsim_hw::units::memory::MemoryStats;
use shellsim_hw::units::patch_buffer::PatchBufferStats;
use shellsim_hw::units::ray_buffer::RayBufferStats;
use shellsim_hw::{Exceptions, FixedHit, RayRecord};
use std::path::{Path, PathBuf};

/// What to run.
#[derive(Clone, Debug)]
pub struct RunSpec {
    pub source: u32,
    /// Hi_Low_Ratio: N_high = ratio × 969.
    pub ratio: usize,
    pub order: TickOrder,
}

/// Per-cluster statistics.
#[derive(Clone, Debug, Serialize)]
pub struct ClusterStats {
    pub icu: IcuStats,
    /// busy stage-cycles over all stage-cycles of this ICU.
    pub pipeline_efficiency: f64,
    pub ray_buffer: RayBufferStats,
    pub patch_buffer: PatchBufferStats,
    pub ctus: Vec<CtuStats>,
}

/// The statistics of a run.
#[derive(Clone, Debug, Serialize)]
pub struct RunStats {
    pub scene: String,
    pub source: u32,
    pub rays: usize,
    pub cycles: u64,
    /// Σ busy stage-cycles over Σ stage-cycles, all ICUs (the paper's time-space measure).
    pub pipeline_efficiency: f64,
    pub clusters: Vec<ClusterStats>,
    pub memory: MemoryStats,
    /// Dynamic balancing (all zero when it is off).
    pub balancer: shellsim_hw::units::balancer::BalancerStats,
    pub memory_requests: u64,
    /// Port-busy cycles over all cycles.
    pub memory_utilization: f64,
    pub patch_loads: u64,
    pub jobs: u64,
    pub exceptions: Exceptions,
    /// Rays whose nearest hit differs from the untimed fixed-point model's (must be 0).
    pub mismatches_vs_fixed: u64,
    /// Cycles the clock jumped over (not in the JSON, which must not depend on the jump).
    #[serde(skip)]
    pub skipped_cycles: u64,
    /// Timing of the simulator (not part of the deterministic JSON).
    #[serde(skip)]
    pub sim_wall_s: f64,
    #[serde(skip)]
    pub sim_rate_hz: f64,
}

/// Everything a run produced.
pub struct RunOutput {
    pub stats: RunStats,
    pub hits: Vec<Option<FixedHit>>,
    pub reference: Vec<Option<FixedHit>>,
}

/// The machine's inputs: the scene in hardware form, the ray records, the sectors.
pub struct Prepared {
    pub host: HostFixed,
    pub records: Vec<RayRecord>,
    /// `sectors[cluster][ctu]`: the sector's ray ids, ascending.
    pub sectors: Vec<Vec<Vec<u32>>>,
}

/// Partitions `scene` and converts it and the high-resolution rays for the machine.
pub fn prepare(
    scene: &Scene,
    file: &Path,
    cfg: &MachineConfig,
    spec: &RunSpec,
) -> Result<Prepared> {
    let cfg = &config::resolve(cfg, scene.size())?;
    let m = &cfg.machine;
    let cell = m.cell_size.value();
    let tracer = Tracer::new(scene, cell).map_err(|e| e.for_scene(file))?;
    let mut pcfg = PartitionConfig::paper(
        spec.source,
        m.clusters as usize,
        m.ctus_per_cluster as usize,
        spec.ratio,
    );
    pcfg.shell_radius = m.shell_radius.value();
    pcfg.subshell_max = m.subshell_max_patches as usize;
    pcfg.cell_size = cell;
    pcfg.granularity = m.partition_granularity.into();
    pcfg.validate(scene, file)
        .map_err(|e| config_param(e, file))?;
    let part = partition::partition(scene, &tracer, &pcfg);
    let host = HostFixed::new(scene, file, cfg.datapath, cell)?;
    let records: Vec<RayRecord> = part
        .high_rays
        .rays
        .iter()
        .enumerate()
        .map(|(i, r)| {
            host.ray_from(i as u32, r, spec.source).ok_or_else(|| {
                Error::input(
                    file,
                    format!("ray {i}"),
                    "does not fit the datapath's formats",
                )
            })
        })
        .collect::<Result<_>>()?;
    let k = m.ctus_per_cluster as usize;
    let mut sectors = vec![vec![Vec::new(); k]; m.clusters as usize];
    for s in &part.sectors {
        sectors[s.section][s.sector] = s.rays.clone();
    }
    Ok(Prepared {
        host,
        records,
        sectors,
    })
}

/// Partitions `scene`, runs the machine, checks each ray against the untimed model.
pub fn run(
    scene: &Scene,
    file: &Path,
    cfg: &MachineConfig,
    spec: &RunSpec,
    probe: Option<&mut dyn Probe>,
) -> Result<RunOutput> {
    let prep = prepare(scene, file, cfg, spec)?;
    simulate(&prep.input(), &scene.name, cfg, spec, probe)
}

/// What the machine runs on, borrowed: the scene in hardware form, the ray records and the
/// sectors (`sectors[cluster][ctu]`, each sector's ray ids ascending). Experiments reuse one
/// [`Prepared`] across configurations, or regroup its sectors.
#[derive(Clone, Copy)]
pub struct MachineInput<'a> {
    pub host: &'a HostFixed,
    pub records: &'a [RayRecord],
    pub sectors: &'a [Vec<Vec<u32>>],
}

impl Prepared {
    /// The prepared inputs, borrowed.
    pub fn input(&self) -> MachineInput<'_> {
        MachineInput {
            host: &self.host,
            records: &self.records,
            sectors: &self.sectors,
        }
    }
}

/// Runs the machine on prepared inputs (`cfg` must have one cluster per section and one CTU
/// per sector of `input.sectors`), checks each ray against the untimed model and gathers the
/// statistics. `scene_name` labels them.
pub fn simulate(
    input: &MachineInput,
    scene_name: &str,
    cfg: &MachineConfig,
    spec: &RunSpec,
    probe: Option<&mut dyn Probe>,
) -> Result<RunOutput> {
    simulate_reporting(input, scene_name, cfg, spec, probe, false)
}

/// As [`simulate`], with a counter of simulated cycles on a terminal when `progress`.
fn simulate_reporting(
    input: &MachineInput,
    scene_name: &str,
    cfg: &MachineConfig,
    spec: &RunSpec,
    probe: Option<&mut dyn Probe>,
    progress: bool,
) -> Result<RunOutput> {
    let MachineInput {
        host,
        records,
        sectors,
    } = *input;
    let start = std::time::Instant::now();
    let hw = config::in_hardware_units(
        cfg,
        config::SceneSize {
            scale: host.scale,
            patches: host.scene.patches.len(),
        },
    )?;
    crate::limits::check_machine_memory(Machine::memory_estimate(
        &hw,
        host.scene.patches.len(),
        records.len(),
    ))?;
    let mut machine = Machine::new(hw, &host.scene, records, sectors, spec.source);
    let mut bar = progress.then(|| crate::progress::Progress::counter("cycles"));
    let mut report = |c: u64| {
        if let Some(b) = bar.as_mut() {
            b.set(c)
        }
    };
    machine
        .run_reporting(spec.order, probe, Some(&mut report))
        .map_err(|d| Error::Check(d.to_string()))?;
    if let Some(b) = bar {
        b.finish();
    }
    let wall = start.elapsed().as_secs_f64();
    let hits = machine.hits();
    let reference: Vec<Option<FixedHit>> = records
        .iter()
        .map(|r| {
            let mut e = Exceptions::default();
            host.scene.nearest_grid(r, Some(spec.source), &mut e).0
        })
        .collect();
    let mismatches = hits.iter().zip(&reference).filter(|(a, b)| a != b).count() as u64;
    let cycles = machine.cycle;
    let mut busy = 0u64;
    let mut total = 0u64;
    let clusters: Vec<ClusterStats> = machine
        .clusters
        .iter()
        .map(|cl| {
            busy += cl.icu.stats.busy_stage_cycles;
            total += cl.icu.stats.stage_cycles;
            ClusterStats {
                icu: cl.icu.stats,
                pipeline_efficiency: ratio(
                    cl.icu.stats.busy_stage_cycles,
                    cl.icu.stats.stage_cycles,
                ),
                ray_buffer: cl.ray_buffer.stats,
                patch_buffer: cl.patch_buffer.stats,
                ctus: cl.ctus.iter().map(|c| c.stats).collect(),
            }
        })
        .collect();
    let jobs = clusters
        .iter()
        .flat_map(|c| &c.ctus)
        .map(|c| c.jobs_issued)
        .sum();
    let requests = clusters
        .iter()
        .flat_map(|c| &c.ctus)
        .map(|c| c.patch_requests)
        .sum();
    let stats = RunStats {
        scene: scene_name.to_string(),
        source: spec.source,
        rays: records.len(),
        cycles,
        pipeline_efficiency: ratio(busy, total),
        clusters,
        memory: machine.memory.stats,
        balancer: machine.balancer.stats,
        memory_requests: requests,
        memory_utilization: ratio(machine.memory.stats.busy_cycles, cycles),
        patch_loads: machine.memory.stats.grants,
        jobs,
        exceptions: machine.exceptions(),
        mismatches_vs_fixed: mismatches,
        skipped_cycles: machine.skipped_cycles,
        sim_wall_s: wall,
        sim_rate_hz: cycles as f64 / wall.max(1e-9),
    };
    Ok(RunOutput {
        stats,
        hits,
        reference,
    })
}

/// A partition parameter that came from the machine configuration, named by its key there
/// (`machine.shell_radius`) against the scene `file` — never by a flag `run` does not have.
fn config_param(e: Error, file: &Path) -> Error {
    let key = match &e {
        Error::Param { key, .. } => match key.as_str() {
            "sections" => "machine.clusters",
            "ctus" => "machine.ctus_per_cluster",
            "shell_radius" => "machine.shell_radius",
            "subshell_max" => "machine.subshell_max_patches",
            "cell_size" => "machine.cell_size",
            _ => return e,
        },
        _ => return e,
    };
    match e {
        Error::Param { what, .. } => {
            Error::input(file, format!("{key} of the machine configuration"), what)
        }
        e => e,
    }
}

fn ratio(a: u64, b: u64) -> f64 {
    if b == 0 {
        0.0
    } else {
        a as f64 / b as f64
    }
}

impl RunStats {
    /// `Err(Error::Check)` when some ray's result differs from the untimed fixed-point
    /// model's, or when the counters break a conservation law ([`RunStats::broken_laws`]).
    pub fn verdict(&self) -> Result<()> {
        if self.mismatches_vs_fixed > 0 {
            return Err(Error::Check(format!(
                "{} rays differ from the fixed-point model",
                self.mismatches_vs_fixed
            )));
        }
        let broken = self.broken_laws();
        if !broken.is_empty() {
            return Err(Error::Check(format!(
                "the machine's counters break {} conservation law(s): {}",
                broken.len(),
                broken.join("; ")
            )));
        }
        Ok(())
    }

    /// The conservation laws a finished cycle-level run keeps, each broken one described:
    /// every job goes through an ICU and its result comes home to a CTU; memory grants =
    /// requests = patch loads; jobs moved = jobs given, remote results = results returned;
    /// with descriptors, every job came out of one, each descriptor taken once; every unit's
    /// cycles partition into busy, stalled and idle, a CTU's also into its FSM states, its
    /// join waits inside JOIN.
    pub fn broken_laws(&self) -> Vec<String> {
        let mut broken = Vec::new();
        let mut law = |holds: bool, what: String| {
            if !holds {
                broken.push(what);
            }
        };
        let cl = &self.clusters;
        let ctus = || cl.iter().flat_map(|c| &c.ctus);
        let icu_in: u64 = cl.iter().map(|c| c.icu.jobs_in).sum();
        let icu_out: u64 = cl.iter().map(|c| c.icu.results_out).sum();
        let results: u64 = ctus().map(|c| c.results).sum();
        law(
            icu_in == self.jobs && icu_out == self.jobs && results == self.jobs,
            format!(
                "{} jobs, {icu_in} into the ICUs, {icu_out} out, {results} results at the CTUs",
                self.jobs
            ),
        );
        law(
            self.memory.grants == self.patch_loads && self.memory_requests == self.patch_loads,
            format!(
                "{} memory grants, {} requests, {} patch loads",
                self.memory.grants, self.memory_requests, self.patch_loads
            ),
        );
        let given: u64 = cl.iter().map(|c| c.ray_buffer.jobs_given).sum();
        let remote: u64 = cl.iter().map(|c| c.icu.remote_results_out).sum();
        law(
            self.balancer.jobs_moved == given,
            format!(
                "the balancer moved {} jobs, the ray buffers gave {given}",
                self.balancer.jobs_moved
            ),
        );
        law(
            self.balancer.results_returned == remote,
            format!(
                "the balancer returned {} results, the ICUs sent {remote} home",
                self.balancer.results_returned
            ),
        );
        let descs: u64 = ctus().map(|c| c.descriptors).sum();
        if descs > 0 {
            let expanded: u64 = cl.iter().map(|c| c.ray_buffer.jobs_in).sum();
            let taken: u64 = cl.iter().map(|c| c.ray_buffer.descriptors_in).sum();
            law(
                expanded == self.jobs,
                format!("the ray buffers expanded {expanded} of {} jobs", self.jobs),
            );
            law(
                taken == descs + self.balancer.work_items,
                format!(
                    "the ray buffers took {taken} descriptors, {descs} made + {} work-items",
                    self.balancer.work_items
                ),
            );
        }
        for (i, c) in cl.iter().enumerate() {
            let s = &c.icu;
            law(
                s.busy_cycles + s.stalled_cycles + s.idle_cycles == self.cycles,
                format!(
                    "cluster {i}'s ICU: busy + stalled + idle ≠ {} cycles",
                    self.cycles
                ),
            );
            for (j, s) in c.ctus.iter().enumerate() {
                law(
                    s.busy_cycles + s.stalled_cycles + s.idle_cycles == self.cycles,
                    format!(
                        "cluster {i} ctu {j}: busy + stalled + idle ≠ {} cycles",
                        self.cycles
                    ),
                );
                law(
                    s.state_cycles.total() == self.cycles,
                    format!(
                        "cluster {i} ctu {j}: its state cycles ≠ {} cycles",
                        self.cycles
                    ),
                );
                law(
                    s.join_wait_patches + s.join_wait_results <= s.state_cycles.join,
                    format!("cluster {i} ctu {j}: join waits exceed its JOIN cycles"),
                );
            }
        }
        broken
    }
}

/// The waveform a run wrote: the VCD or FST and the GTKWave save file beside it (and the
/// Surfer command file, wave/sucl.rs).
#[derive(Clone, Debug)]
pub struct Waveform {
    pub path: PathBuf,
    pub signals: usize,
    pub bytes: u64,
    pub gtkw: PathBuf,
}

/// What [`execute`] produced.
#[derive(Clone, Debug)]
pub struct Executed {
    pub stats: RunStats,
    pub waveform: Option<Waveform>,
    /// Rays that hit nothing (ray ids), for the leak verdict.
    pub escaped: Vec<u32>,
}

/// Runs the machine ([`run`]), writing the VCD (+ .gtkw, .sucl) and the JSON (configuration +
/// statistics) when asked. The VCD streams into a temporary file; an error drops the
/// writer, which removes it, so a failed run leaves no waveform behind. A VCD path whose
/// GTKWave save file or Surfer command file would be itself is `Error::Param` `vcd`.
pub fn execute(
    scene: &Scene,
    file: &Path,
    cfg: &MachineConfig,
    spec: &RunSpec,
    wave: Option<(PathBuf, WaveOptions)>,
    json: Option<&Path>,
) -> Result<Executed> {
    if let Some((p, _)) = &wave {
        if crate::wave::gtkw::path_for(p) == *p || crate::wave::sucl::path_for(p) == *p {
            return Err(Error::param(
                "vcd",
                format!(
                    "{}: the GTKWave save file or Surfer command file would overwrite it; name it *.vcd or *.fst",
                    p.display()
                ),
            ));
        }
    }
    let mut writer = match wave {
        Some((p, opts)) => Some(WaveWriter::create(&p, opts)?),
        None => None,
    };
    let started = std::time::Instant::now();
    let probe = writer.as_mut().map(|w| w as &mut dyn Probe);
    let prep = prepare(scene, file, cfg, spec)?;
    let out = simulate_reporting(&prep.input(), &scene.name, cfg, spec, probe, true)?;
    let waveform = match writer {
        Some(w) => {
            let summary = w.finish()?;
            let gtkw = crate::wave::gtkw::path_for(&summary.path);
            // A VCD streamed to a device or FIFO has no directory to put a save file in.
            if crate::output::is_file_path(&summary.path) {
                crate::wave::gtkw::write(&gtkw, &summary)?;
                crate::wave::sucl::write(&crate::wave::sucl::path_for(&summary.path), &summary)?;
            }
            Some(Waveform {
                path: summary.path.clone(),
                signals: summary.signals.len(),
                bytes: summary.bytes,
                gtkw,
            })
        }
        None => None,
    };
    if let Some(out_path) = json {
        #[derive(serde::Serialize)]
        struct Out<'a> {
            config: MachineConfig,
            stats: &'a RunStats,
            /// Host figures: not simulated statistics (see [`Host`]).
            host: Host,
        }
        let host = Host::measure(started.elapsed().as_secs_f64(), &out.stats);
        write_json(
            out_path,
            &Out {
                config: config::resolve(cfg, scene.size())?,
                stats: &out.stats,
                host,
            },
        )?;
    }
    let escaped = (0..out.hits.len() as u32)
        .filter(|&i| out.hits[i as usize].is_none())
        .collect();
    Ok(Executed {
        stats: out.stats,
        waveform,
        escaped,
    })
}

/// How the host ran the simulation, kept apart from the simulated statistics (as gem5 keeps
/// `hostSeconds` apart): it differs from run to run, so goldens and determinism checks leave
/// it out ([`strip_host`]).
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct Host {
    /// Wall-clock seconds of the whole run: partition, records, machine, check.
    pub wall_seconds: f64,
    /// Wall-clock seconds of the machine's simulation alone.
    pub simulation_seconds: f64,
    /// Simulated cycles per wall-clock second of the simulation.
    pub simulated_cycles_per_second: f64,
    /// Peak resident set size of the process in KiB (`VmHWM` of /proc/self/status; `null`
    /// where there is none).
    pub peak_rss_kib: Option<u64>,
}

impl Host {
    /// The figures of a run that took `wall_seconds` and produced `stats`.
    pub fn measure(wall_seconds: f64, stats: &RunStats) -> Self {
        Host {
            wall_seconds,
            simulation_seconds: stats.sim_wall_s,
            simulated_cycles_per_second: stats.sim_rate_hz,
            peak_rss_kib: peak_rss_kib(),
        }
    }
}

/// `VmHWM` (peak resident set) of this process in KiB, from /proc/self/status.
pub fn peak_rss_kib() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

/// A run JSON without its `host` section: what goldens and determinism checks compare.
pub fn strip_host(json: &str) -> String {
    let mut v: serde_json::Value = serde_json::from_str(json).expect("a run JSON");
    if let Some(o) = v.as_object_mut() {
        o.remove("host");
    }
    serde_json::to_string_pretty(&v).expect("serializable")
}
