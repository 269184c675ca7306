//! Command-line interface: argument types (clap) and the jobs they run.

use crate::error::{write_json, Error, Result};
use crate::grid::DEFAULT_CELL;
use crate::rays::{hemisphere_rays, Directions, Origins, PAPER_RAYS};
use crate::reference::{self, ReferenceReport, RunInfo};
use crate::scene::Scene;
use crate::trace::Tracer;
use clap::{Parser, Subcommand};
use std::path::{Path, PathBuf};

/// Most rays one run may cast.
pub const MAX_RAYS: usize = 100_000_000;

/// Cycle-level model of the shelling ray-casting machine (Shen, Laarakker & Deprettere, 1992)
/// for radiosity form factors. With no subcommand: the default job on built-in inputs.
#[derive(Parser, Debug)]
#[command(name = "shellsim", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Generate, inspect or import scenes.
    #[command(subcommand)]
    Scene(SceneCmd),
    /// Form factors from one source patch by the float reference tracer.
    Reference(ReferenceArgs),
    /// The float reference against the untimed fixed-point model on the same rays.
    Check(CheckArgs),
    /// Partition, simulate the cycle-level machine, check against the fixed-point model.
    Run(RunArgs),
    /// Sweep a model parameter and chart accuracy against cost.
    #[command(subcommand)]
    Sweep(SweepCmd),
    /// The shelling partition: low-resolution pass, sections and sectors, shells and
    /// subshells, workloads predicted against actual, patch loads, schedule.
    Partition(crate::partition::PartitionArgs),
    /// The paper's experiments on the machine: pipeline efficiency with and without
    /// balancing, efficiency against work-item size, speedup against ICUs (CSV + SVG).
    Experiment(crate::experiment::cli::ExperimentArgs),
    /// Regenerate every figure of the paper and a report (report.md) in one command.
    Paper(crate::experiment::cli::PaperArgs),
}

#[derive(Subcommand, Debug)]
pub enum SceneCmd {
    /// Generate a built-in scene (deterministic for a seed) and write it as JSON.
    Gen {
        /// Which scene.
        #[arg(value_enum)]
        kind: crate::gen::Kind,
        /// Seed of the random parts.
        #[arg(long, default_value_t = crate::gen::DEFAULT_SEED)]
        seed: u64,
        /// Output file (JSON).
        #[arg(short, long)]
        out: PathBuf,
    },
    /// Convert a Wavefront OBJ file into a validated JSON scene (faces with more than 4
    /// vertices become triangle fans).
    Import {
        /// The OBJ file.
        file: PathBuf,
        /// Output file (JSON).
        #[arg(short, long)]
        out: PathBuf,
        /// Scene bounds as lo_x,lo_y,lo_z,hi_x,hi_y,hi_z (default: the vertices' bounding box).
        #[arg(long, value_parser = parse_bounds)]
        bounds: Option<crate::scene::Aabb>,
        /// Reflectance of faces without a material.
        #[arg(long, default_value_t = 0.5)]
        reflectance: f64,
    },
    /// Validate a scene (JSON or OBJ) and print its statistics.
    Info {
        /// The scene file (.json or .obj).
        file: PathBuf,
        /// Grid cell size for the grid statistics.
        #[arg(long, default_value_t = DEFAULT_CELL)]
        cell: f64,
    },
}

/// Arguments of `shellsim reference`.
#[derive(clap::Args, Debug)]
pub struct ReferenceArgs {
    /// The scene file (.json or .obj).
    #[arg(long)]
    pub scene: PathBuf,
    /// The source patch id.
    #[arg(long)]
    pub source: u32,
    /// Number of rays.
    #[arg(long, default_value_t = PAPER_RAYS)]
    pub rays: usize,
    /// Direction set.
    #[arg(long, value_enum, default_value_t = Directions::Rings)]
    pub directions: Directions,
    /// Seed of the origins (and of Malley/random directions).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Grid cell size.
    #[arg(long, default_value_t = DEFAULT_CELL)]
    pub cell: f64,
    /// Write the full result as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
}

#[derive(Subcommand, Debug)]
pub enum SweepCmd {
    /// Mismatch rate and form-factor error against fractional bits (CSV + SVG).
    Bits {
        /// The scene file (.json or .obj).
        #[arg(long)]
        scene: PathBuf,
        /// The source patch id.
        #[arg(long, default_value_t = 0)]
        source: u32,
        /// Number of rays (default: the paper's 969 × its largest Hi_Low_Ratio, 30).
        #[arg(long, default_value_t = 29070)]
        rays: usize,
        /// Direction set.
        #[arg(long, value_enum, default_value_t = Directions::Malley)]
        directions: Directions,
        /// Seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Fewest fractional bits.
        #[arg(long, default_value_t = 8)]
        from: u32,
        /// Most fractional bits.
        #[arg(long, default_value_t = 30)]
        to: u32,
        /// Output directory: bits-<scene>.csv and bits-<scene>.svg.
        #[arg(long, default_value = "out")]
        out: PathBuf,
        #[command(flatten)]
        datapath: DatapathArgs,
    },
}

/// Arguments of `shellsim run`.
#[derive(clap::Args, Debug)]
pub struct RunArgs {
    /// The scene file (.json or .obj).
    #[arg(long)]
    pub scene: PathBuf,
    /// Machine configuration (TOML); default hw/configs/paper.toml (built in).
    #[arg(long)]
    pub hw: Option<PathBuf>,
    /// The source patch id.
    #[arg(long, default_value_t = 0)]
    pub source: u32,
    /// Hi_Low_Ratio: the machine casts ratio × 969 rays.
    #[arg(long, default_value_t = 10)]
    pub ratio: usize,
    /// Write the statistics (and the resolved configuration) as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Dynamic workload balancing: overrides the configuration's [balance] enabled.
    #[arg(long, value_enum)]
    pub balance: Option<OnOff>,
    /// Write the machine's waveform as a VCD here, and a GTKWave save file (signals grouped
    /// per unit and formatted) beside it with the same stem and extension .gtkw.
    #[arg(long, value_name = "OUT")]
    pub vcd: Option<PathBuf>,
    /// Only cycles FROM..=TO in the VCD (either side may be left empty); the values holding
    /// at FROM are dumped in full.
    #[arg(long, value_name = "FROM:TO", requires = "vcd", value_parser = crate::vcd_out::Window::parse)]
    pub vcd_window: Option<crate::vcd_out::Window>,
    /// Only signals whose dotted scope matches PATTERN: a glob with * and ? on the whole
    /// scope (e.g. 'machine.cluster_0.*'), else a substring (e.g. 'icu').
    #[arg(long, value_name = "PATTERN", requires = "vcd")]
    pub vcd_scope: Option<String>,
}

/// On or off.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum OnOff {
    On,
    Off,
}

/// Reads a machine configuration (the built-in paper.toml when `path` is None).
pub fn machine_config(path: Option<&Path>) -> Result<shellsim_hw::machine_config::MachineConfig> {
    let (text, file) = match path {
        Some(p) => (
            std::fs::read_to_string(p).map_err(|e| Error::unreadable(p, e))?,
            p.to_path_buf(),
        ),
        None => (
            PAPER_TOML.to_string(),
            PathBuf::from("<built-in hw/configs/paper.toml>"),
        ),
    };
    shellsim_hw::machine_config::MachineConfig::from_toml_str(&text)
        .map_err(|e| Error::input(&file, e.key, e.what))
}

/// Arguments of `shellsim check`.
#[derive(clap::Args, Debug)]
pub struct CheckArgs {
    #[command(flatten)]
    pub rays: ReferenceArgs,
    #[command(flatten)]
    pub datapath: DatapathArgs,
}

/// Which datapath formats to use.
#[derive(clap::Args, Debug, Clone)]
pub struct DatapathArgs {
    /// A machine configuration (TOML with a [datapath] table); default hw/configs/paper.toml
    /// (built in).
    #[arg(long)]
    pub hw: Option<PathBuf>,
    /// A named configuration: hw/configs/NAME.toml.
    #[arg(long, conflicts_with = "hw")]
    pub format: Option<String>,
    /// Override the fractional bits of coordinates, directions and t.
    #[arg(long)]
    pub frac_bits: Option<u32>,
}

use shellsim_hw::config::PAPER_TOML;

impl DatapathArgs {
    /// The resolved datapath configuration.
    pub fn resolve(&self) -> Result<shellsim_hw::DatapathConfig> {
        let (text, file) = match (&self.hw, &self.format) {
            (Some(p), _) => (
                std::fs::read_to_string(p).map_err(|e| Error::unreadable(p, e))?,
                p.clone(),
            ),
            (None, Some(name)) => {
                let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
                    .join("hw/configs")
                    .join(format!("{name}.toml"));
                (
                    std::fs::read_to_string(&p).map_err(|e| Error::unreadable(&p, e))?,
                    p,
                )
            }
            (None, None) => (
                PAPER_TOML.to_string(),
                PathBuf::from("<built-in hw/configs/paper.toml>"),
            ),
        };
        let mut cfg = shellsim_hw::DatapathConfig::from_toml_str(&text)
            .map_err(|e| Error::input(&file, e.key, e.what))?;
        if let Some(b) = self.frac_bits {
            cfg.frac_bits = b;
            cfg.t_frac_bits = b;
            cfg.formats()
                .map_err(|e| Error::input(Path::new("--frac-bits"), e.key, e.what))?;
        }
        Ok(cfg)
    }
}

/// Runs the job the command line asks for.
pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Some(Command::Scene(SceneCmd::Info { file, cell })) => scene_info(&file, cell),
        Some(Command::Scene(SceneCmd::Gen { kind, seed, out })) => {
            let scene = crate::gen::generate(kind, seed);
            scene.validate(&out)?;
            scene.save_json(&out)?;
            println!(
                "{}: {} patches (seed {seed}) written to {}",
                kind.name(),
                scene.patches.len(),
                out.display()
            );
            Ok(())
        }
        Some(Command::Scene(SceneCmd::Import {
            file,
            out,
            bounds,
            reflectance,
        })) => {
            let opts = crate::obj::ImportOptions {
                bounds,
                reflectance,
                ..Default::default()
            };
            let (scene, report) = crate::obj::import(&file, &opts)?;
            for w in &report.warnings {
                eprintln!("warning: {w}");
            }
            scene.save_json(&out)?;
            println!("{}: {}", file.display(), report.summary());
            println!("written to {}", out.display());
            Ok(())
        }
        Some(Command::Reference(a)) => {
            let scene = Scene::load(&a.scene)?;
            let report = reference_job(&scene, &a)?;
            print_reference(&report, &scene);
            if let Some(out) = &a.json {
                write_json(out, &report)?;
            }
            Ok(())
        }
        Some(Command::Check(a)) => {
            let scene = Scene::load(&a.rays.scene)?;
            let cfg = a.datapath.resolve()?;
            let r = &a.rays;
            check_source_and_rays(&scene, &r.scene, r.source, r.rays)?;
            let tracer = Tracer::new(&scene, r.cell)?;
            let host = crate::fixed::HostFixed::new(&scene, &r.scene, cfg, r.cell)?;
            let set = hemisphere_rays(
                &scene.patches[r.source as usize],
                r.rays,
                r.directions,
                Origins::Patch,
                r.seed,
            );
            let report = crate::check::check(&tracer, &host, &set, r.source, Default::default());
            print_check(&report);
            if let Some(out) = &r.json {
                #[derive(serde::Serialize)]
                struct Out<'a> {
                    datapath: shellsim_hw::DatapathConfig,
                    #[serde(flatten)]
                    report: &'a crate::check::CheckReport,
                }
                write_json(
                    out,
                    &Out {
                        datapath: cfg,
                        report: &report,
                    },
                )?;
            }
            if report.unexplained_mismatches > 0 {
                return Err(Error::Check(format!(
                    "{} unexplained mismatches (listed in the JSON report)",
                    report.unexplained_mismatches
                )));
            }
            Ok(())
        }
        Some(Command::Sweep(SweepCmd::Bits {
            scene: file,
            source,
            rays,
            directions,
            seed,
            from,
            to,
            out,
            datapath,
        })) => {
            let scene = Scene::load(&file)?;
            check_source_and_rays(&scene, &file, source, rays)?;
            if from > to {
                return Err(Error::Usage(format!("--from {from} is above --to {to}")));
            }
            let base = datapath.resolve()?;
            let tracer = Tracer::new(&scene, DEFAULT_CELL)?;
            let set = hemisphere_rays(
                &scene.patches[source as usize],
                rays,
                directions,
                Origins::Patch,
                seed,
            );
            let input = crate::sweep::SweepInput {
                scene: &scene,
                file: &file,
                tracer: &tracer,
                cell: DEFAULT_CELL,
                set: &set,
                source,
            };
            let rows = crate::sweep::sweep_bits(&input, base, from..=to)?;
            println!(
                "{:>4} {:>10} {:>12} {:>12} {:>11} {:>8}",
                "F", "mismatches", "ff_err_max", "sampling", "mult bits", "unexpl."
            );
            for r in &rows {
                println!(
                    "{:>4} {:>10} {:>12.3e} {:>12.3e} {:>11} {:>8}",
                    r.frac_bits,
                    r.report.mismatches,
                    r.report.ff_err_max,
                    r.report.ff_sampling_err,
                    r.cost.multiplier_bits,
                    r.report.unexplained_mismatches
                );
            }
            match crate::sweep::recommended(&rows) {
                Some(b) => println!(
                    "fewest bits whose form-factor error stays under the sampling error: {b}"
                ),
                None => println!(
                    "no width in the sweep keeps the form-factor error under the sampling error"
                ),
            }
            let stem = format!("bits-{}", scene.name);
            let title = format!(
                "{}: fixed point vs float, {} {:?} rays from patch {}",
                scene.name, rays, directions, source
            );
            crate::sweep::write(&out, &stem, &rows, &title)?;
            println!("wrote {}/{stem}.csv and .svg", out.display());
            Ok(())
        }
        Some(Command::Partition(a)) => crate::partition::cli::run(&a),
        Some(Command::Experiment(a)) => crate::experiment::cli::run_experiment(&a),
        Some(Command::Paper(a)) => crate::experiment::cli::run_paper(&a),
        Some(Command::Run(a)) => {
            let scene = Scene::load(&a.scene)?;
            let mut cfg = machine_config(a.hw.as_deref())?;
            if let Some(b) = a.balance {
                cfg.balance.enabled = b == OnOff::On;
            }
            let spec = crate::run::RunSpec {
                source: a.source,
                ratio: a.ratio,
                cell: DEFAULT_CELL,
                order: shellsim_hw::machine::TickOrder::Forward,
            };
            let vcd = a.vcd.as_ref().map(|p| {
                (
                    p.clone(),
                    crate::vcd_out::VcdOptions {
                        window: a.vcd_window.unwrap_or(crate::vcd_out::Window::ALL),
                        scope: a.vcd_scope.as_deref().map(crate::vcd_out::ScopeFilter::new),
                    },
                )
            });
            let s = machine_job(&scene, &a.scene, &cfg, &spec, vcd, a.json.as_deref())?;
            println!(
                "{}: {} rays, {} cycles, pipeline efficiency {:.3}, {} patch loads, {} jobs, {} mismatches vs fixed, {:.2} M cycles/s",
                s.scene, s.rays, s.cycles, s.pipeline_efficiency, s.patch_loads, s.jobs, s.mismatches_vs_fixed, s.sim_rate_hz / 1e6
            );
            if s.mismatches_vs_fixed > 0 {
                return Err(Error::Check(format!(
                    "{} rays differ from the fixed-point model",
                    s.mismatches_vs_fixed
                )));
            }
            Ok(())
        }
        None => default_job(),
    }
}

/// Parses `lo_x,lo_y,lo_z,hi_x,hi_y,hi_z`.
fn parse_bounds(s: &str) -> std::result::Result<crate::scene::Aabb, String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>().map_err(|e| format!("{x:?}: {e}")))
        .collect::<std::result::Result<_, _>>()?;
    if v.len() != 6 {
        return Err(format!("expected 6 numbers, got {}", v.len()));
    }
    Ok(crate::scene::Aabb {
        lo: glam::DVec3::new(v[0], v[1], v[2]),
        hi: glam::DVec3::new(v[3], v[4], v[5]),
    })
}

/// Checks a source id and a ray count against the scene.
pub fn check_source_and_rays(scene: &Scene, file: &Path, source: u32, rays: usize) -> Result<()> {
    if source as usize >= scene.patches.len() {
        return Err(Error::input(
            file,
            "--source",
            format!(
                "source patch {source} does not exist (the scene has patches 0..{})",
                scene.patches.len() - 1
            ),
        ));
    }
    if rays == 0 || rays > MAX_RAYS {
        return Err(Error::Usage(format!(
            "--rays {rays} is out of range (1..={MAX_RAYS})"
        )));
    }
    Ok(())
}

fn reference_job(scene: &Scene, a: &ReferenceArgs) -> Result<ReferenceReport> {
    check_source_and_rays(scene, &a.scene, a.source, a.rays)?;
    let tracer = Tracer::new(scene, a.cell)?;
    let src = &scene.patches[a.source as usize];
    let set = hemisphere_rays(src, a.rays, a.directions, Origins::Patch, a.seed);
    let info = RunInfo {
        scene: &scene.name,
        source: a.source,
        directions: a.directions,
        seed: a.seed,
    };
    Ok(reference::run(&tracer, &set, &info, true))
}

fn print_reference(r: &ReferenceReport, scene: &Scene) {
    println!(
        "{} from patch {}: {} {:?} rays, {} escaped, ΣF = {:.12}",
        r.scene, r.source, r.rays, r.directions, r.escaped, r.weight_sum
    );
    println!(
        "{:.3} s, {:.3} M rays/s, {:.1} cells and {:.1} patch tests per ray",
        r.wall_s,
        r.rays_per_s / 1e6,
        r.cells_visited as f64 / r.rays as f64,
        r.patch_tests as f64 / r.rays as f64
    );
    let mut top = r.form_factors.clone();
    top.sort_by(|a, b| b.value.total_cmp(&a.value).then(a.patch.cmp(&b.patch)));
    println!("{:>8}  {:>12}  {:>10}", "patch", "F", "area");
    for f in top.iter().take(10) {
        println!(
            "{:>8}  {:>12.8}  {:>10.6}",
            f.patch,
            f.value,
            scene.patches[f.patch as usize].area()
        );
    }
    if top.len() > 10 {
        println!("{:>8}  ({} more patches hit)", "…", top.len() - 10);
    }
}

/// Runs the machine, writing the VCD (+ .gtkw) and the JSON (configuration + statistics)
/// when asked. The VCD streams into a temporary file; an error drops the writer, which
/// removes it, so a failed run leaves no waveform behind.
pub fn machine_job(
    scene: &Scene,
    file: &Path,
    cfg: &shellsim_hw::machine_config::MachineConfig,
    spec: &crate::run::RunSpec,
    vcd: Option<(PathBuf, crate::vcd_out::VcdOptions)>,
    json: Option<&Path>,
) -> Result<crate::run::RunStats> {
    if let Some((p, _)) = &vcd {
        if crate::gtkw::path_for(p) == *p {
            return Err(Error::Usage(format!(
                "--vcd {}: the GTKWave save file would overwrite it; name it *.vcd",
                p.display()
            )));
        }
    }
    let mut writer = match vcd {
        Some((p, opts)) => Some(crate::vcd_out::VcdWriter::create(&p, opts)?),
        None => None,
    };
    let probe = writer
        .as_mut()
        .map(|w| w as &mut dyn shellsim_hw::trace::Probe);
    let out = crate::run::run(scene, file, cfg, spec, probe)?;
    if let Some(w) = writer {
        let summary = w.finish()?;
        let gtkw = crate::gtkw::path_for(&summary.path);
        crate::gtkw::write(&gtkw, &summary)?;
        println!(
            "waveform: {} ({} signals, {} bytes) and {}",
            summary.path.display(),
            summary.signals.len(),
            summary.bytes,
            gtkw.display()
        );
    }
    if let Some(out_path) = json {
        #[derive(serde::Serialize)]
        struct Out<'a> {
            config: shellsim_hw::machine_config::MachineConfig,
            stats: &'a crate::run::RunStats,
        }
        write_json(
            out_path,
            &Out {
                config: *cfg,
                stats: &out.stats,
            },
        )?;
    }
    Ok(out.stats)
}

/// The paper's test scene 2, built in so the default job needs no files.
const BUILTIN_SCENE2: &str = include_str!("../scenes/scene2.json");

/// The default job (`shellsim` with no arguments): the paper's 969 ring rays from a floor
/// tile of scene 2 through the float reference, checked against brute force and the
/// analytic values, with a summary table.
fn default_job() -> Result<()> {
    let path = Path::new("<built-in scenes/scene2.json>");
    let scene = Scene::from_json_str(BUILTIN_SCENE2, path)?;
    let source = crate::gen::Kind::Scene2.default_source() as u32;
    let cfg = machine_config(None)?;
    // 1. The cycle-level machine (paper.toml) with its waveform and statistics in waves/.
    let spec = crate::run::RunSpec {
        source,
        ratio: 1,
        cell: DEFAULT_CELL,
        order: shellsim_hw::machine::TickOrder::Forward,
    };
    let vcd = (
        PathBuf::from("waves/default.vcd"),
        crate::vcd_out::VcdOptions {
            window: crate::vcd_out::Window::ALL,
            scope: None,
        },
    );
    let m = machine_job(
        &scene,
        path,
        &cfg,
        &spec,
        Some(vcd),
        Some(Path::new("waves/default.json")),
    )?;
    // 2. The float reference on the paper's 969 ring rays: enclosure and form factors.
    let args = ReferenceArgs {
        scene: path.to_path_buf(),
        source,
        rays: PAPER_RAYS,
        directions: Directions::Rings,
        seed: 1,
        cell: DEFAULT_CELL,
        json: None,
    };
    let report = reference_job(&scene, &args)?;
    // 3. Grid traversal against brute force, and the fixed-point model against the float
    //    reference, on the same rays.
    let tracer = Tracer::new(&scene, DEFAULT_CELL)?;
    let set = hemisphere_rays(
        &scene.patches[source as usize],
        PAPER_RAYS,
        Directions::Rings,
        Origins::Patch,
        1,
    );
    let mismatches = set
        .rays
        .iter()
        .filter(|r| tracer.trace(r, Some(source)) != tracer.trace_brute(r, Some(source)))
        .count();
    let host = crate::fixed::HostFixed::new(&scene, path, cfg.datapath, DEFAULT_CELL)?;
    let fixed = crate::check::check(&tracer, &host, &set, source, Default::default());
    // 4. The tracer against Lambert's formula, floor centre → ceiling of the unit cube.
    let (f, truth, sigma) = analytic_check();
    println!("shellsim: scene2 (808 patches) from patch {source}, machine hw/configs/paper.toml");
    println!();
    println!("{:<46} {:>16} {:>8}", "check", "value", "verdict");
    let verdict = |ok: bool| if ok { "ok" } else { "FAILED" };
    let row = |name: &str, value: String, ok: Option<bool>| {
        println!("{:<46} {:>16} {:>8}", name, value, ok.map_or("", verdict));
    };
    row("machine: rays", m.rays.to_string(), None);
    row("machine: cycles", m.cycles.to_string(), None);
    row(
        "machine: pipeline efficiency",
        format!("{:.3}", m.pipeline_efficiency),
        None,
    );
    row(
        "machine: patch loads / jobs",
        format!("{} / {}", m.patch_loads, m.jobs),
        None,
    );
    row(
        "machine: memory utilization",
        format!("{:.3}", m.memory_utilization),
        None,
    );
    row(
        "machine: work-items moved (balancing)",
        m.balancer.work_items.to_string(),
        None,
    );
    row(
        "machine vs untimed fixed-point model",
        format!("{} differ", m.mismatches_vs_fixed),
        Some(m.mismatches_vs_fixed == 0),
    );
    row(
        "fixed point vs float: mismatches",
        fixed.mismatches.to_string(),
        None,
    );
    row(
        "fixed point vs float: unexplained",
        fixed.unexplained_mismatches.to_string(),
        Some(fixed.unexplained_mismatches == 0),
    );
    row(
        "float: rays escaped (enclosure)",
        report.escaped.to_string(),
        Some(report.escaped == 0),
    );
    row(
        "float: sum of form factors",
        format!("{:.12}", report.weight_sum),
        Some((report.weight_sum - 1.0).abs() < 1e-9),
    );
    row(
        "float: grid vs brute-force mismatches",
        mismatches.to_string(),
        Some(mismatches == 0),
    );
    row(
        &format!("float: F(floor centre->ceiling), ±{:.0e}", 3.0 * sigma),
        format!("{f:.10}"),
        Some((f - truth).abs() <= 3.0 * sigma),
    );
    row("  analytic (Lambert)", format!("{truth:.10}"), None);
    println!();
    println!(
        "waveform: gtkwave waves/default.vcd waves/default.gtkw; statistics: waves/default.json ({:.2} M simulated cycles/s)",
        m.sim_rate_hz / 1e6
    );
    let ok = m.mismatches_vs_fixed == 0
        && fixed.unexplained_mismatches == 0
        && report.escaped == 0
        && mismatches == 0
        && (f - truth).abs() <= 3.0 * sigma;
    if !ok {
        return Err(Error::Check(
            "the default run disagrees with its references".into(),
        ));
    }
    Ok(())
}

/// Floor centre → ceiling of the unit cube by 10⁵ Malley rays: (estimate, analytic, σ).
fn analytic_check() -> (f64, f64, f64) {
    use glam::DVec3;
    let cube = crate::gen::unit_cube();
    let tracer = Tracer::new(&cube, DEFAULT_CELL).expect("the unit cube builds");
    let centre = DVec3::new(0.5, 0.5, 0.0);
    let n = 100_000;
    let set = hemisphere_rays(
        &cube.patches[0],
        n,
        Directions::Malley,
        Origins::Point(centre),
        1,
    );
    let (hits, _) = reference::cast(&tracer, &set, Some(0), None);
    let (ff, _, _) = reference::form_factors(&hits, &set.weights, cube.patches.len());
    let f = ff.iter().find(|x| x.patch == 1).map_or(0.0, |x| x.value);
    let truth = crate::analytic::point_to_polygon(centre, DVec3::Z, &cube.patches[1].vertices);
    // Stratified error model of tests/convergence.rs.
    (f, truth, 0.7 * (n as f64).powf(-0.75))
}

fn print_check(r: &crate::check::CheckReport) {
    println!("{}: {} rays, {} mismatches", r.format, r.rays, r.mismatches);
    println!(
        "  explained: {} overflow, {} near the origin, {} grazing, {} near an edge or vertex, {} tie in t; unexplained: {}",
        r.classes.overflow, r.classes.near_origin, r.classes.grazing, r.classes.near_edge, r.classes.tie, r.unexplained_mismatches
    );
    println!(
        "  t error: max {:.2} LSB, rms {:.2} LSB; form factors: max error {:.2e} (sampling error {:.2e})",
        r.t_err_max_lsb, r.t_err_rms_lsb, r.ff_err_max, r.ff_sampling_err
    );
    let e = &r.exceptions;
    println!(
        "  exceptions: {} overflow, {} near-zero denominators, {} t saturated",
        e.overflow, e.near_zero_denominator, e.t_saturated
    );
}

fn scene_info(file: &Path, cell: f64) -> Result<()> {
    let scene = Scene::load(file)?;
    let tracer = Tracer::new(&scene, cell)?;
    let g = &tracer.grid;
    let tris = scene
        .patches
        .iter()
        .filter(|p| p.vertices.len() == 3)
        .count();
    let emitters = scene
        .patches
        .iter()
        .filter(|p| p.emission.is_nonzero())
        .count();
    println!("scene        {}", scene.name);
    println!(
        "bounds       {:?} - {:?}",
        scene.bounds.lo.to_array(),
        scene.bounds.hi.to_array()
    );
    println!(
        "patches      {} ({} triangles, {} quads, {} emitting)",
        scene.patches.len(),
        tris,
        scene.patches.len() - tris,
        emitters
    );
    println!("total area   {:.6}", scene.total_area());
    println!(
        "grid         {}×{}×{} cells of {}, {} nonempty, {} cell entries ({:.2} per patch)",
        g.dims[0],
        g.dims[1],
        g.dims[2],
        g.cell_size,
        g.nonempty_cells(),
        g.entries(),
        g.entries() as f64 / scene.patches.len() as f64
    );
    Ok(())
}
