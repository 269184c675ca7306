//! The partition's committed figures (`shellsim partition --figures DIR`, and the workload
//! figures of `shellsim paper`): workload per ICU for scene1 and scene2 at the paper's
//! section counts and ratios, and the static imbalance of every committed scene.

use super::{partition, Config, Granularity, Partition};
use crate::chart::partition::{workload_svg, Panel};
use crate::error::{Error, Result};
use crate::output::write_atomic;
use crate::paper::{PAPER_RATIO, RATIOS, SECTIONS};
use crate::reference::tracer::Tracer;
use crate::scene::gen::{self, Kind};
use crate::scene::Scene;
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

/// The granularity's name in captions and tables.
pub fn granularity_name(g: Granularity) -> &'static str {
    match g {
        Granularity::Subregion => "subregion",
        Granularity::Ray => "ray",
    }
}

/// The workload chart of one run (`shellsim partition --svg`): one panel, captioned with
/// the scene, source, ratio and granularity.
pub fn workload_figure(p: &Partition) -> Result<String> {
    let cfg = &p.config;
    let caption = format!(
        "{} from patch {} · Hi_Low_Ratio {} · {} granularity",
        p.scene,
        cfg.source,
        cfg.ratio,
        granularity_name(cfg.granularity)
    );
    workload_svg(&caption, &[panel(p, &format!("P = {}", cfg.sections))])
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
    let mut cfg = Config::paper(kind.default_source() as u32, sections, FIGURE_CTUS, ratio)
        .scaled_to(scene.size());
    cfg.granularity = g;
    partition(scene, tracer, &cfg)
}

/// The float tracer of a committed scene on the built-in configuration's cell size.
fn tracer_of(scene: &Scene) -> Result<Tracer> {
    let m = &crate::config::built_in().machine;
    Tracer::new(scene, crate::config::cell_size(m.cell_size, scene.size()))
}

/// Regenerates the committed figures and the imbalance table into `dir`.
pub fn figures(dir: &Path) -> Result<()> {
    let start = Instant::now();
    for kind in [Kind::Scene1, Kind::Scene2] {
        let scene = gen::generate(kind, gen::DEFAULT_SEED);
        let tracer = tracer_of(&scene)?;
        for ratio in RATIOS {
            let panels: Vec<Panel> = SECTIONS
                .iter()
                .map(|&sections| {
                    let sections = sections as usize;
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
            let svg = workload_svg(&caption, &panels)?;
            let out = dir.join(format!("workload-{}-ratio{ratio}.svg", kind.name()));
            write_atomic(&out, svg.as_bytes())?;
            crate::output::outln!("{}", out.display());
        }
    }
    let table = imbalance_table()?;
    let out = dir.join("imbalance.md");
    write_atomic(&out, table.as_bytes())?;
    crate::output::out!("{table}");
    crate::output::outln!("{} ({:.1} s)", out.display(), start.elapsed().as_secs_f64());
    Ok(())
}

/// The static imbalance of every committed scene from its natural source, both
/// granularities, P = 2, 4, 8, at [`PAPER_RATIO`], as a markdown table.
pub fn imbalance_table() -> Result<String> {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Static imbalance (max over mean of actual intersections per section) of every\n\
         committed scene from its natural source: {FIGURE_CTUS} CTUs per cluster, Hi_Low_Ratio\n\
         {PAPER_RATIO} (9,690 high-resolution rays), the paper's parameters otherwise. The last\n\
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
        let tracer = tracer_of(&scene)?;
        for g in [Granularity::Subregion, Granularity::Ray] {
            let mut cells = Vec::new();
            let mut loads = String::new();
            for sections in SECTIONS.map(|s| s as usize) {
                let p = run_kind(kind, &scene, &tracer, sections, PAPER_RATIO, g);
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
