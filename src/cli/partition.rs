//! `shellsim partition`: one partition run with its report, chart and schedule, or the
//! committed figures (`--figures DIR`).

use super::args::{load_scene, CellArg, SceneEditArgs};
use crate::error::Result;
use crate::output::{check_outputs, write_atomic, Output};
use crate::paper::PAPER_RAYS;
use crate::partition::angles::parse_subregions;
use crate::partition::figures::{figures, workload_figure};
use crate::partition::report::Report;
use crate::partition::schedule::Schedule;
use crate::partition::shells::ShellParams;
use crate::partition::{partition, Config, Granularity};
use crate::reference::tracer::Tracer;
use crate::scene::PatchRef;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `shellsim partition`.
#[derive(clap::Args, Debug, Clone)]
pub struct PartitionArgs {
    /// The scene file (.json or .obj).
    #[arg(long, required_unless_present = "figures")]
    pub scene: Option<PathBuf>,
    /// The source patch: its id, or the name of its group, object or material (OBJ `g`,
    /// `o`, `usemtl`) when that names one patch.
    #[arg(long, required_unless_present = "figures")]
    pub source: Option<PatchRef>,
    #[command(flatten)]
    pub edit: SceneEditArgs,
    /// Sections P: one per cluster (ICU); any count, not only powers of two.
    #[arg(long, required_unless_present = "figures")]
    pub sections: Option<usize>,
    /// Sectors per section K: one per CTU.
    #[arg(long, required_unless_present = "figures")]
    pub ctus: Option<usize>,
    /// Hi_Low_Ratio R: the high-resolution pass casts R × (low-resolution rays).
    #[arg(long, required_unless_present = "figures")]
    pub ratio: Option<usize>,
    /// Subregions of the low-resolution pass, θ × φ (equal Δθ, equal Δφ).
    #[arg(long, default_value = "5x5", value_parser = parse_subregions)]
    pub subregions: (usize, usize),
    /// Where sections and sectors may be cut: at subregion boundaries, or between any two
    /// low-resolution ray directions.
    #[arg(long, value_enum, default_value_t = Granularity::Subregion)]
    pub granularity: Granularity,
    /// Radius step of the shells about the source patch's centroid, in scene units
    /// (default: the built-in configuration's rule, 0.289 × the scene's largest extent).
    #[arg(long)]
    pub shell_radius: Option<f64>,
    /// Most new active patches per subshell (a shell with more is cut into subshells;
    /// default: the built-in configuration's machine.subshell_max_patches).
    #[arg(long, default_value_t = ShellParams::default().subshell_max)]
    pub subshell_max: usize,
    /// Low-resolution ray count N_low (ring directions).
    #[arg(long, default_value_t = PAPER_RAYS)]
    pub rays: usize,
    /// Seed of the ray origins (the high-resolution pass uses seed + 1).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    #[command(flatten)]
    pub grid: CellArg,
    /// Write the report as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write the bar chart of workload per ICU (SVG) here.
    #[arg(long)]
    pub svg: Option<PathBuf>,
    /// Write the schedule (ids and counts per section, sector and subshell; JSON) here.
    #[arg(long)]
    pub schedule: Option<PathBuf>,
    /// Regenerate the committed figures into DIR instead: workload per ICU for scene1 and
    /// scene2, P = 2, 4, 8, ratio 1, 10, 30, and the static imbalance of every committed
    /// scene (imbalance.md). Takes a minute or two.
    #[arg(long, value_name = "DIR", conflicts_with_all = ["scene", "source", "sections", "ctus", "ratio", "json", "svg", "schedule"])]
    pub figures: Option<PathBuf>,
}

/// Runs `shellsim partition`.
pub fn run(a: &PartitionArgs) -> Result<()> {
    if let Some(dir) = &a.figures {
        check_outputs(&[Output::dir("--figures", dir)])?;
        return figures(dir);
    }
    let outputs: Vec<Output> = [
        ("--json", &a.json),
        ("--svg", &a.svg),
        ("--schedule", &a.schedule),
    ]
    .into_iter()
    .filter_map(|(o, p)| p.as_deref().map(|p| Output::file(o, p)))
    .collect();
    check_outputs(&outputs)?;
    let file = a.scene.as_deref().expect("clap requires --scene");
    let scene = load_scene(file, &a.edit)?;
    let source = a.source.as_ref().expect("clap requires --source");
    let cfg = Config {
        source: source.resolve(&scene, file)?,
        sections: a.sections.expect("clap requires --sections"),
        ctus: a.ctus.expect("clap requires --ctus"),
        ratio: a.ratio.expect("clap requires --ratio"),
        rays_low: a.rays,
        subregions: a.subregions,
        granularity: a.granularity,
        shell_radius: a.shell_radius.unwrap_or_else(|| {
            crate::config::shell_radius(
                crate::config::built_in().machine.shell_radius,
                scene.bounds.scale(),
            )
        }),
        subshell_max: a.subshell_max,
        seed: a.seed,
        cell_size: a.grid.for_scene(&scene),
    };
    cfg.validate(&scene, file)?;
    let tracer = Tracer::new(&scene, cfg.cell_size).map_err(|e| e.for_scene(file))?;
    let start = Instant::now();
    let p = partition(&scene, &tracer, &cfg);
    let wall = start.elapsed().as_secs_f64();
    let report = Report::new(&p);
    report.print();
    crate::output::outln!("({wall:.2} s)");
    if let Some(out) = &a.json {
        write_atomic(out, report.to_json().as_bytes())?;
    }
    if let Some(out) = &a.svg {
        write_atomic(out, workload_figure(&p)?.as_bytes())?;
    }
    if let Some(out) = &a.schedule {
        let text = serde_json::to_string(&Schedule::new(&p)).expect("a schedule serializes");
        write_atomic(out, (text + "\n").as_bytes())?;
    }
    p.verdict()
}
