//! `shellsim partition`: its arguments, the job, and the regeneration of the committed
//! workload figures and imbalance table (`--figures DIR`).

use super::chart::{workload_svg, Panel};
use super::report::Report;
use super::schedule::Schedule;
use super::{angles::parse_subregions, partition, Config, Granularity, Partition};
use crate::error::{write_atomic, Error, Result};
use crate::gen::{self, Kind};
use crate::grid::DEFAULT_CELL;
use crate::rays::PAPER_RAYS;
use crate::scene::Scene;
use crate::trace::Tracer;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `shellsim partition`.
#[derive(clap::Args, Debug, Clone)]
pub struct PartitionArgs {
    /// The scene file (.json or .obj).
    #[arg(long, required_unless_present = "figures")]
    pub scene: Option<PathBuf>,
    /// The source patch id.
    #[arg(long, required_unless_present = "figures")]
    pub source: Option<u32>,
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
    /// Radius step of the shells about the source patch's centroid.
    #[arg(long, default_value_t = super::shells::DEFAULT_SHELL_RADIUS)]
    pub shell_radius: f64,
    /// Most new active patches per subshell (a shell with more is cut into subshells).
    #[arg(long, default_value_t = super::shells::DEFAULT_SUBSHELL_MAX)]
    pub subshell_max: usize,
    /// Low-resolution ray count N_low (ring directions).
    #[arg(long, default_value_t = PAPER_RAYS)]
    pub rays: usize,
    /// Seed of the ray origins (the high-resolution pass uses seed + 1).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Grid cell size.
    #[arg(long, default_value_t = DEFAULT_CELL)]
    pub cell: f64,
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
        return figures(dir);
    }
    let file = a.scene.as_deref().expect("clap requires --scene");
    let scene = Scene::load(file)?;
    let cfg = Config {
        source: a.source.expect("clap requires --source"),
        sections: a.sections.expect("clap requires --sections"),
        ctus: a.ctus.expect("clap requires --ctus"),
        ratio: a.ratio.expect("clap requires --ratio"),
        rays_low: a.rays,
        subregions: a.subregions,
        granularity: a.granularity,
        shell_radius: a.shell_radius,
        subshell_max: a.subshell_max,
        seed: a.seed,
        cell_size: a.cell,
    };
    cfg.validate(&scene, file)?;
    let tracer = Tracer::new(&scene, cfg.cell_size)?;
    let start = Instant::now();
    let p = partition(&scene, &tracer, &cfg);
    let wall = start.elapsed().as_secs_f64();
    let report = Report::new(&p);
    report.print();
    println!("({wall:.2} s)");
    if let Some(out) = &a.json {
        write_atomic(out, report.to_json().as_bytes())?;
    }
    if let Some(out) = &a.svg {
        let caption = format!(
            "{} from patch {} · Hi_Low_Ratio {} · {} granularity",
            p.scene,
            cfg.source,
            cfg.ratio,
            granularity_name(cfg.granularity)
        );
        let svg = workload_svg(&caption, &[panel(&p, &format!("P = {}", cfg.sections))])
            .map_err(|e| Error::Check(format!("drawing the chart: {e}")))?;
        write_atomic(out, svg.as_bytes())?;
    }
    if let Some(out) = &a.schedule {
        let text = serde_json::to_string(&Schedule::new(&p)).expect("a schedule serializes");
        write_atomic(out, (text + "\n").as_bytes())?;
    }
    if p.nearest_hit_mismatches > 0 {
        return Err(Error::Check(format!(
            "{} rays got a different nearest hit from their sector's schedule than from the float tracer",
            p.nearest_hit_mismatches
        )));
    }
    Ok(())
}

fn granularity_name(g: Granularity) -> &'static str {
    match g {
        Granularity::Subregion => "subregion",
        Granularity::Ray => "ray",
    }
}

/// The bar pairs of a run, titled with its imbalance.
pub fn panel(p: &Partition, label: &str) -> Panel {
    let work = p.section_work();
    Panel {
        title: format!("{label} · imbalance {:.2}", p.imbalance()),
        actual: work.iter().map(|w| w.intersections).collect(),
        predicted: p
            .predicted_sections
            .iter()
            .map(|w| w.intersections)
            .collect(),
    }
}

/// CTUs per cluster in the committed figures: 8 sections × 2 sectors stay within the 25
/// subregions, so the paper's subregion granularity needs no forced cut.
pub const FIGURE_CTUS: usize = 2;
/// Section counts of the paper's figures.
pub const FIGURE_SECTIONS: [usize; 3] = [2, 4, 8];
/// Hi_Low_Ratios of the paper's figures.
pub const FIGURE_RATIOS: [usize; 3] = [1, 10, 30];
/// The ratio of the imbalance table.
pub const TABLE_RATIO: usize = 10;

/// Runs one committed scene (generated: equal to `scenes/X.json`) with the paper's
/// parameters.
fn run_kind(
    kind: Kind,
    scene: &Scene,
    tracer: &Tracer,
    sections: usize,
    ratio: usize,
    g: Granularity,
) -> Partition {
    let mut cfg = Config::paper(kind.default_source() as u32, sections, FIGURE_CTUS, ratio);
    cfg.granularity = g;
    partition(scene, tracer, &cfg)
}

/// Regenerates the committed figures and the imbalance table into `dir`.
pub fn figures(dir: &Path) -> Result<()> {
    let start = Instant::now();
    for kind in [Kind::Scene1, Kind::Scene2] {
        let scene = gen::generate(kind, gen::DEFAULT_SEED);
        let tracer = Tracer::new(&scene, DEFAULT_CELL)?;
        for ratio in FIGURE_RATIOS {
            let panels: Vec<Panel> = FIGURE_SECTIONS
                .iter()
                .map(|&sections| {
                    let p = run_kind(
                        kind,
                        &scene,
                        &tracer,
                        sections,
                        ratio,
                        Granularity::Subregion,
                    );
                    panel(&p, &format!("P = {sections}"))
                })
                .collect();
            let caption = format!(
                "{} · Hi_Low_Ratio {ratio} · workload per ICU ({} CTUs each, subregion granularity)",
                kind.name(),
                FIGURE_CTUS
            );
            let svg = workload_svg(&caption, &panels)
                .map_err(|e| Error::Check(format!("drawing the chart: {e}")))?;
            let out = dir.join(format!("workload-{}-ratio{ratio}.svg", kind.name()));
            write_atomic(&out, svg.as_bytes())?;
            println!("{}", out.display());
        }
    }
    let table = imbalance_table()?;
    let out = dir.join("imbalance.md");
    write_atomic(&out, table.as_bytes())?;
    print!("{table}");
    println!("{} ({:.1} s)", out.display(), start.elapsed().as_secs_f64());
    Ok(())
}

/// The static imbalance of every committed scene from its natural source, both
/// granularities, P = 2, 4, 8, at [`TABLE_RATIO`], as a markdown table.
pub fn imbalance_table() -> Result<String> {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Static imbalance (max over mean of actual intersections per section) of every\n\
         committed scene from its natural source: {FIGURE_CTUS} CTUs per cluster, Hi_Low_Ratio\n\
         {TABLE_RATIO} (9,690 high-resolution rays), the paper's parameters otherwise. The last\n\
         column is shelling's patch loads over the ray-by-ray baseline's. Written by\n\
         `shellsim partition --figures docs/figures`.\n"
    );
    let _ = writeln!(
        s,
        "| scene | source | patches | granularity | P = 2 | P = 4 | P = 8 | loads / ray-by-ray (P = 4) |"
    );
    let _ = writeln!(s, "| --- | --- | --- | --- | --- | --- | --- | --- |");
    for kind in Kind::ALL {
        let scene = gen::generate(kind, gen::DEFAULT_SEED);
        let tracer = Tracer::new(&scene, DEFAULT_CELL)?;
        for g in [Granularity::Subregion, Granularity::Ray] {
            let mut cells = Vec::new();
            let mut loads = String::new();
            for sections in FIGURE_SECTIONS {
                let p = run_kind(kind, &scene, &tracer, sections, TABLE_RATIO, g);
                if p.nearest_hit_mismatches > 0 {
                    return Err(Error::Check(format!(
                        "{}: {} nearest-hit mismatches",
                        kind.name(),
                        p.nearest_hit_mismatches
                    )));
                }
                cells.push(format!("{:.2}", p.imbalance()));
                if sections == 4 {
                    loads = format!(
                        "{:.3}",
                        p.patch_loads() as f64 / p.patch_loads_baseline.max(1) as f64
                    );
                }
            }
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {loads} |",
                kind.name(),
                kind.default_source(),
                scene.patches.len(),
                granularity_name(g),
                cells.join(" | ")
            );
        }
    }
    Ok(s)
}
