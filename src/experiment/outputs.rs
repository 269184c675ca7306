//! What an experiment writes: its CSV, its SVG (drawn by [`crate::chart::experiments`]) and
//! a short summary for the terminal, for `shellsim experiment` and `shellsim paper`.

use super::{levels, stem, Point, SpeedupRow, WorkItemRows, Workload};
use crate::chart::experiments as chart;
use crate::error::Result;
use crate::output::write_atomic;
use crate::paper::{
    PAPER_RATIO, RATIOS, SECTIONS, SPEEDUP_CLUSTERS, WORK_ITEMS, WORK_ITEM_CLUSTERS,
};
use std::path::Path;

/// Which experiment.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Which {
    /// Pipeline efficiency with and without balancing: 2/4/8 ICUs × Hi_Low_Ratio 1/10/30.
    Efficiency,
    /// Efficiency and cycles against work-item size (1..128 jobs), 8 ICUs, ratio 10.
    Workitem,
    /// Speedup T(1)/T(P) for P = 1, 2, 4, 8, with and without balancing, ideal and bound.
    Speedup,
    /// The speedup experiment's machines at the queue level against the cycle level: the
    /// queueing network's error and its wall time.
    Levels,
}

impl Which {
    /// The output files' stem prefix.
    pub fn name(self) -> &'static str {
        match self {
            Which::Efficiency => "efficiency",
            Which::Workitem => "workitem",
            Which::Speedup => "speedup",
            Which::Levels => "levels",
        }
    }
}

/// The files one experiment writes, as text.
pub struct Outputs {
    pub stem: String,
    pub csv: String,
    pub svg: String,
    /// A short table for the terminal.
    pub summary: String,
    /// A chart of host figures (wall seconds), written as `stem-wall.svg`: unlike the CSV
    /// and SVG it differs from run to run.
    pub wall_svg: Option<String>,
}

impl Outputs {
    /// Writes `stem.csv` and `stem.svg` into `dir`.
    pub fn write(&self, dir: &Path) -> Result<()> {
        write_atomic(&dir.join(format!("{}.csv", self.stem)), self.csv.as_bytes())?;
        if let Some(w) = &self.wall_svg {
            write_atomic(&dir.join(format!("{}-wall.svg", self.stem)), w.as_bytes())?;
        }
        write_atomic(&dir.join(format!("{}.svg", self.stem)), self.svg.as_bytes())
    }
}

/// Runs experiment `which` on `w` and renders its CSV and SVG.
pub fn experiment(which: Which, w: &Workload) -> Result<Outputs> {
    match which {
        Which::Efficiency => efficiency_outputs(w, &super::efficiency(w, &SECTIONS, &RATIOS)?),
        Which::Workitem => work_item_outputs(
            w,
            &super::work_item(w, WORK_ITEM_CLUSTERS, PAPER_RATIO, &WORK_ITEMS)?,
        ),
        Which::Speedup => speedup_outputs(w, &super::speedup(w, &SPEEDUP_CLUSTERS, PAPER_RATIO)?),
        Which::Levels => {
            levels_outputs(w, &levels::levels(w, &SPEEDUP_CLUSTERS, PAPER_RATIO, true)?)
        }
    }
}

fn stem_of(which: Which, w: &Workload) -> String {
    stem_of_scene(which, w.scene)
}

/// The output files' stem of experiment `which` on `scene`: `WHICH-SCENE`, the scene's
/// name made file-name safe.
pub fn stem_of_scene(which: Which, scene: &crate::scene::Scene) -> String {
    format!("{}-{}", which.name(), stem(&scene.name))
}

/// CSV, SVG and summary of the levels experiment.
pub fn levels_outputs(w: &Workload, rows: &[levels::LevelRow]) -> Result<Outputs> {
    let title = format!(
        "{} from patch {}: the queue level's cycles against the cycle level's",
        w.scene.name, w.source
    );
    Ok(Outputs {
        stem: stem_of(Which::Levels, w),
        csv: levels::csv(rows),
        svg: levels::svg(&title, rows)?,
        summary: levels::summary(rows),
        wall_svg: Some(levels::wall_svg(
            &format!(
                "{} from patch {}: wall seconds per machine against the error in cycles",
                w.scene.name, w.source
            ),
            rows,
        )?),
    })
}

/// CSV, SVG and summary of the efficiency experiment's points.
pub fn efficiency_outputs(w: &Workload, pts: &[Point]) -> Result<Outputs> {
    let mut summary =
        String::from("ratio  ICUs  efficiency off   on    cycles off        on  binds\n");
    for pair in pts.chunks(2) {
        let (off, on) = (&pair[0], &pair[pair.len() - 1]);
        summary.push_str(&format!(
            "{:>5} {:>5} {:>15.3} {:>4.3} {:>12} {:>9}  {}\n",
            off.ratio,
            off.clusters,
            off.pipeline_efficiency,
            on.pipeline_efficiency,
            off.cycles,
            on.cycles,
            on.bound.binding().name()
        ));
    }
    let title = format!(
        "{} from patch {}: pipeline efficiency, static partitioning vs dynamic balancing",
        w.scene.name, w.source
    );
    Ok(Outputs {
        stem: stem_of(Which::Efficiency, w),
        csv: super::points_csv(pts),
        svg: efficiency_svg(&title, pts)?,
        summary,
        wall_svg: None,
    })
}

/// CSV, SVG and summary of the work-item experiment.
pub fn work_item_outputs(w: &Workload, rows: &WorkItemRows) -> Result<Outputs> {
    let mut summary = format!(
        "static: efficiency {:.3}, {} cycles\nwork-item  efficiency    cycles  jobs moved\n",
        rows.off.pipeline_efficiency, rows.off.cycles
    );
    for p in &rows.on {
        summary.push_str(&format!(
            "{:>9} {:>11.3} {:>9} {:>11}\n",
            p.work_item_jobs, p.pipeline_efficiency, p.cycles, p.jobs_moved
        ));
    }
    if !rows.skipped.is_empty() {
        summary.push_str(&format!(
            "left out (larger than the ray buffer): {:?}\n",
            rows.skipped
        ));
    }
    let title = format!(
        "{}: efficiency and cycles vs work-item size ({} ICUs, Hi_Low_Ratio {})",
        w.scene.name, rows.off.clusters, rows.off.ratio
    );
    Ok(Outputs {
        stem: stem_of(Which::Workitem, w),
        csv: super::work_item_csv(rows),
        svg: work_item_svg(&title, rows)?,
        summary,
        wall_svg: None,
    })
}

/// CSV, SVG and summary of the speedup experiment.
pub fn speedup_outputs(w: &Workload, rows: &[SpeedupRow]) -> Result<Outputs> {
    speedup_outputs_of(w, rows, None)
}

/// The speedup experiment's outputs on a machine variant: `variant` is its file-name
/// suffix and its name in the title (`None`: the machine as configured).
pub fn speedup_outputs_of(
    w: &Workload,
    rows: &[SpeedupRow],
    variant: Option<(&str, &str)>,
) -> Result<Outputs> {
    let mut summary =
        String::from("   P  balance   cycles  speedup  same-work  bound(same work)  binds\n");
    for r in rows {
        summary.push_str(&format!(
            "{:>4} {:>8} {:>8} {:>8.2} {:>10.2} {:>17.2}  {}\n",
            r.point.clusters,
            if r.point.balance { "on" } else { "off" },
            r.point.cycles,
            r.speedup,
            r.speedup_same_work,
            r.bound_speedup_same_work,
            r.point.bound.binding().name()
        ));
    }
    let mut title = format!(
        "{}: speedup vs ICUs (Hi_Low_Ratio {})",
        w.scene.name,
        rows.first().map_or(0, |r| r.point.ratio)
    );
    let mut stem = stem_of(Which::Speedup, w);
    if let Some((suffix, name)) = variant {
        title.push_str(&format!(", {name}"));
        stem.push_str(&format!("-{suffix}"));
    }
    Ok(Outputs {
        stem,
        csv: super::speedup_csv(rows),
        svg: speedup_svg(&title, rows)?,
        summary,
        wall_svg: None,
    })
}

/// The efficiency chart of `points` (see [`chart::efficiency_svg`]).
pub fn efficiency_svg(title: &str, points: &[Point]) -> Result<String> {
    chart::efficiency_svg(title, &points.iter().map(Point::chart).collect::<Vec<_>>())
}

/// The work-item chart of `rows` (see [`chart::work_item_svg`]).
pub fn work_item_svg(title: &str, rows: &WorkItemRows) -> Result<String> {
    chart::work_item_svg(title, &rows.chart())
}

/// The speedup chart of `rows` (see [`chart::speedup_svg`]).
pub fn speedup_svg(title: &str, rows: &[SpeedupRow]) -> Result<String> {
    chart::speedup_svg(
        title,
        &rows.iter().map(SpeedupRow::chart).collect::<Vec<_>>(),
    )
}
