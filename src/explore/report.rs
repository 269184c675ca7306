//! The outputs of `shellsim explore`: `points.csv` and `points.json` (one row per point in
//! the spec's order), `host.csv` (wall clock), and for a whole run the fronts of error
//! against machine cycles and hardware cost per scene and source (`front.csv`, an SVG each,
//! `report.md` naming each front point and what changing one knob costs), and the
//! host-dependent front of error against wall time (`host-front.csv`, its SVG).

use super::front::front;
use super::spec::Timing;
use super::spec::{knobs_label, Axis};
use super::{AutoSummary, PointFile, PointResult, SpecFile};
use crate::chart::explore::{svg, Dot, FrontChart};
use crate::error::Result;
use crate::output::{file_stem, json_string, write_atomic};
use crate::radiosity::matrix::Model;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::Path;

/// The model levels in the order they are coloured.
const LEVELS: [Model; 3] = [Model::Float, Model::Fixed, Model::Machine];

/// A CSV field, quoted when it must be.
fn field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// An optional number, empty when absent.
fn opt<T: std::fmt::Display>(v: Option<T>) -> String {
    v.map_or(String::new(), |v| v.to_string())
}

/// The header of points.csv.
pub const POINTS_HEADER: &str = "index,scene,source,level,rays,directions,seed,knobs,frac_bits,t_frac_bits,coord_int_bits,t_int_bits,cell,shell_radius,clusters,ctus_per_cluster,ray_buffer,patch_buffer,request_queue,balance,work_item_jobs,ff_err_max,ff_err_rms,sampling_err,err_over_sampling,mismatches_vs_float,mismatches_vs_fixed,cycles,timing,queue_cycles,pipeline_efficiency,bound_cycles,binds,multiplier_bits,adder_bits,sram_bits,memory_words,total_bits,icu_cells,icu_cells_source,datapath_cells";

/// One row of points.csv.
fn point_row(p: &PointResult) -> String {
    let c = p.cost;
    [
        p.index.to_string(),
        field(&p.scene),
        p.source.to_string(),
        p.level.name().into(),
        p.rays.to_string(),
        p.directions.clone(),
        p.seed.to_string(),
        field(&knobs_label(&p.knobs)),
        p.frac_bits.to_string(),
        p.t_frac_bits.to_string(),
        p.coord_int_bits.to_string(),
        p.t_int_bits.to_string(),
        p.cell.to_string(),
        p.shell_radius.to_string(),
        p.clusters.to_string(),
        p.ctus_per_cluster.to_string(),
        p.ray_buffer.to_string(),
        p.patch_buffer.to_string(),
        p.request_queue.to_string(),
        p.balance.to_string(),
        p.work_item_jobs.to_string(),
        format!("{:.6e}", p.ff_err_max),
        format!("{:.6e}", p.ff_err_rms),
        format!("{:.6e}", p.sampling_err),
        format!("{:.4}", p.err_over_sampling),
        p.mismatches_vs_float.to_string(),
        opt(p.mismatches_vs_fixed),
        opt(p.cycles),
        opt(p.timing.map(Timing::name)),
        opt(p.queue_cycles),
        opt(p.pipeline_efficiency.map(|e| format!("{e:.4}"))),
        opt(p.bound_cycles),
        opt(p.binds.clone()),
        opt(c.map(|c| c.multiplier_bits)),
        opt(c.map(|c| c.adder_bits)),
        opt(c.map(|c| c.sram_bits)),
        opt(c.map(|c| c.memory_words)),
        opt(c.map(|c| c.total_bits)),
        opt(c.map(|c| c.icu_cells)),
        opt(c.map(|c| {
            if c.icu_cells_synthesized {
                "yosys"
            } else {
                "fit"
            }
        })),
        opt(c.map(|c| c.datapath_cells)),
    ]
    .join(",")
}

/// points.csv of `files` (in order).
pub fn points_csv(files: &[PointFile]) -> String {
    let mut s = format!("{POINTS_HEADER}\n");
    for f in files {
        s.push_str(&point_row(&f.point));
        s.push('\n');
    }
    s
}

/// host.csv: the simulator's wall time per point.
fn host_csv(files: &[PointFile]) -> String {
    let mut s = String::from("index,scene,source,level,knobs,wall_s,cycles_per_s\n");
    for f in files {
        let p = &f.point;
        let _ = writeln!(
            s,
            "{},{},{},{},{},{:.6},{}",
            p.index,
            field(&p.scene),
            p.source,
            p.level.name(),
            field(&knobs_label(&p.knobs)),
            f.host.wall_s,
            opt(f.host.cycles_per_s.map(|r| format!("{r:.0}")))
        );
    }
    s
}

/// points.json.
#[derive(Serialize)]
struct PointsJson<'a> {
    spec_hash: &'a str,
    points: Vec<&'a PointResult>,
}

/// A front's measure of cost.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Against {
    Cycles,
    Cost,
    /// The ICUs' synthesized cells (size/synth.rs): the cost front on measured hardware.
    Cells,
    Wall,
}

impl Against {
    fn name(self) -> &'static str {
        match self {
            Against::Cycles => "cycles",
            Against::Cost => "cost",
            Against::Cells => "cells",
            Against::Wall => "wall",
        }
    }

    fn desc(self) -> &'static str {
        match self {
            Against::Cycles => "machine cycles",
            Against::Cost => "hardware cost (datapath + SRAM bits)",
            Against::Cells => "synthesized ICU cells, all clusters (Yosys, hw/rtl/cost.csv)",
            Against::Wall => "simulator wall time (s)",
        }
    }

    fn x(self, f: &PointFile) -> Option<f64> {
        match self {
            Against::Cycles => f.point.cycles.map(|c| c as f64),
            Against::Cost => f.point.cost.map(|c| c.total_bits as f64),
            Against::Cells => f.point.cost.map(|c| c.datapath_cells as f64),
            Against::Wall => Some(f.host.wall_s),
        }
    }

    fn show(self, v: f64) -> String {
        match self {
            Against::Wall => format!("{v:.3}"),
            _ => format!("{v:.0}"),
        }
    }
}

/// The points of one scene and source, in index order.
struct Group<'a> {
    scene: &'a str,
    source: u32,
    files: Vec<&'a PointFile>,
}

fn groups(files: &[PointFile]) -> Vec<Group<'_>> {
    let mut out: Vec<Group> = Vec::new();
    for f in files {
        match out
            .iter_mut()
            .find(|g| g.scene == f.point.scene && g.source == f.point.source)
        {
            Some(g) => g.files.push(f),
            None => out.push(Group {
                scene: &f.point.scene,
                source: f.point.source,
                files: vec![f],
            }),
        }
    }
    out
}

/// One front of a group: its points (indices into the group's files), ordered by cost.
fn group_front(g: &Group, a: Against) -> (Vec<usize>, Vec<usize>) {
    let with: Vec<usize> = (0..g.files.len())
        .filter(|&i| a.x(g.files[i]).is_some())
        .collect();
    let pts: Vec<(f64, f64)> = with
        .iter()
        .map(|&i| {
            (
                a.x(g.files[i]).unwrap_or(f64::NAN),
                g.files[i].point.ff_err_max,
            )
        })
        .collect();
    let f = front(&pts).into_iter().map(|k| with[k]).collect();
    (with, f)
}

/// The chart of one front.
fn chart(g: &Group, a: Against, with: &[usize], fr: &[usize]) -> Result<String> {
    let dots: Vec<Dot> = with
        .iter()
        .map(|&i| {
            let p = &g.files[i].point;
            Dot {
                x: a.x(g.files[i]).unwrap_or(f64::NAN),
                y: p.ff_err_max,
                series: LEVELS.iter().position(|&l| l == p.level).unwrap_or(0),
                label: format!("#{}", p.index),
            }
        })
        .collect();
    let front_pos: Vec<usize> = fr
        .iter()
        .map(|i| {
            with.iter()
                .position(|w| w == i)
                .expect("on the front, so drawn")
        })
        .collect();
    let title = format!(
        "{} from patch {}: form-factor error against {}",
        g.scene,
        g.source,
        a.desc()
    );
    let names: Vec<&str> = LEVELS.iter().map(|l| l.name()).collect();
    svg(&FrontChart {
        title: &title,
        x_desc: a.desc(),
        y_desc: "form-factor error vs reference (max over patches)",
        series: &names,
        dots: &dots,
        front: &front_pos,
    })
}

/// The chart's file name.
fn chart_name(g: &Group, a: Against) -> String {
    format!("front-{}-{}-{}.svg", a.name(), file_stem(g.scene), g.source)
}

/// A point's level as the report names it: `machine (queue)` when the queueing network
/// gave its cycles.
fn level_label(p: &PointResult) -> String {
    match p.timing {
        Some(Timing::Queue) => format!("{} (queue)", p.level.name()),
        _ => p.level.name().to_string(),
    }
}

/// The header of front.csv and host-front.csv.
const FRONT_HEADER: &str = "front,scene,source,rank,index,level,knobs,x,ff_err_max,timing\n";

/// The knobs that vary over the study (axes with more than one value).
fn varying(axes: &[Axis]) -> Vec<&Axis> {
    axes.iter().filter(|a| a.values.len() > 1).collect()
}

/// `p`'s knobs that vary, as `key=value`.
fn short_label(p: &PointResult, axes: &[&Axis]) -> String {
    let ks: Vec<_> = p
        .knobs
        .iter()
        .filter(|k| k.key != "scene" && k.key != "level" && axes.iter().any(|a| a.key == k.key))
        .cloned()
        .collect();
    knobs_label(&ks)
}

/// "what changing one knob would cost": for front point `p`, the points of its group that
/// differ from it in one knob only, by the nearest value on either side.
fn one_knob(g: &Group, p: &PointResult, axes: &[&Axis], a: Against) -> Vec<String> {
    let mut out = Vec::new();
    for axis in axes {
        let Some(mine) = p.knobs.iter().find(|k| k.key == axis.key) else {
            continue;
        };
        let at = |v: &str| axis.values.iter().position(|x| x == v);
        let Some(i) = at(&mine.value) else { continue };
        let others: Vec<&PointFile> =
            g.files
                .iter()
                .copied()
                .filter(|f| {
                    let q = &f.point;
                    q.knobs.len() == p.knobs.len()
                        && q.knobs.iter().zip(&p.knobs).all(|(x, y)| {
                            x.key == y.key && (x.value == y.value || x.key == axis.key)
                        })
                        && q.knobs
                            .iter()
                            .any(|k| k.key == axis.key && k.value != mine.value)
                })
                .collect();
        let pos = |f: &PointFile| {
            f.point
                .knobs
                .iter()
                .find(|k| k.key == axis.key)
                .and_then(|k| at(&k.value))
        };
        let below = others
            .iter()
            .filter(|f| pos(f).is_some_and(|j| j < i))
            .max_by_key(|f| pos(f));
        let above = others
            .iter()
            .filter(|f| pos(f).is_some_and(|j| j > i))
            .min_by_key(|f| pos(f));
        for q in below.into_iter().chain(above) {
            let qv = q
                .point
                .knobs
                .iter()
                .find(|k| k.key == axis.key)
                .map_or("", |k| k.value.as_str());
            let e0 = p.ff_err_max;
            let e1 = q.point.ff_err_max;
            let ratio = if e0 > 0.0 {
                format!("×{:.2}", e1 / e0)
            } else {
                "from 0".into()
            };
            let cost = match (
                a.x(g
                    .files
                    .iter()
                    .find(|f| f.point.index == p.index)
                    .expect("in its group")),
                a.x(q),
            ) {
                (Some(x0), Some(x1)) if x0 > 0.0 => format!(
                    ", {} {} → {}{} ({:+.1} %)",
                    a.name(),
                    a.show(x0),
                    a.show(x1),
                    if a == Against::Cycles && q.point.timing == Some(Timing::Queue) {
                        " (queue level)"
                    } else {
                        ""
                    },
                    100.0 * (x1 - x0) / x0
                ),
                (_, None) => format!(", no {} at that level", a.name()),
                _ => String::new(),
            };
            // A change of error within the estimator's sampling error is no effect.
            let sigma = p.sampling_err.max(q.point.sampling_err);
            let noise = if (e1 - e0).abs() <= sigma {
                format!(" (the error's change is within the sampling error {sigma:.1e}: no effect)")
            } else {
                String::new()
            };
            out.push(format!(
                "`{}` {} → {} (#{}): error {:.3e} → {:.3e} ({ratio}){cost}{noise}",
                axis.key, mine.value, qv, q.point.index, e0, e1
            ));
        }
    }
    out
}

/// Writes the tables into `dir`; for a whole run (`whole`) the fronts, charts and report too.
pub fn write_all(
    dir: &Path,
    sf: &SpecFile,
    files: &[PointFile],
    whole: bool,
    auto: Option<&AutoSummary>,
) -> Result<()> {
    write_atomic(&dir.join("points.csv"), points_csv(files).as_bytes())?;
    let pj = PointsJson {
        spec_hash: &sf.spec_hash,
        points: files.iter().map(|f| &f.point).collect(),
    };
    write_atomic(&dir.join("points.json"), json_string(&pj).as_bytes())?;
    write_atomic(&dir.join("host.csv"), host_csv(files).as_bytes())?;
    if !whole {
        return Ok(());
    }
    let axes = varying(&sf.axes);
    let mut front_csv = String::from(FRONT_HEADER);
    let mut host_front = String::from(FRONT_HEADER);
    let queued = files
        .iter()
        .filter(|f| f.point.timing == Some(Timing::Queue))
        .count();
    let mut md = format!(
        "# {}\n\n{} design points (spec hash `{}`). The error of a point is the largest |F − F_ref| over patches, F_ref a float reference of many Malley rays per scene and source; ×σ is that error over the estimator's sampling error at the point's rays (max over patches of √(F(1−F)/N)). Every machine point run at the cycle level equals the untimed fixed-point model ray for ray (0 mismatches, checked){}.\n\nKnobs varied: {}.\n",
        sf.title,
        files.len(),
        sf.spec_hash,
        if queued > 0 {
            format!("; {queued} machine points are timed by the queueing network (`timing` queue: the untimed model's results, estimated cycles; docs/levels/ gives its error)")
        } else {
            String::new()
        },
        if axes.is_empty() {
            "none".to_string()
        } else {
            axes.iter()
                .map(|a| format!("`{}` ({})", a.key, a.values.join(", ")))
                .collect::<Vec<_>>()
                .join("; ")
        }
    );
    if let Some(a) = auto {
        let _ = write!(
            md,
            "\n## Timing levels (`timing = \"auto\"`)\n\nEvery machine point was timed by the queueing network first. The cycle model then ran a check sample ({:.0} % of the machine points, drawn whatever the screen says) and the points that may reach the front of error against cycles in their scene and source — those no other point certainly dominates when each point's true cycles lie within the margin of its estimate — round after round until the margin covered the largest error measured ×1.25. Every point on a front of error against cycles below was run at the cycle level.\n\n| machine points | run at the cycle level | cycle runs saved | rounds | margin (start → end) | queue error, all run: mean | max | check sample: points | mean | max |\n| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n| {} | {} | {} | {} | {:.1} % → {:.1} % | {:.2} % | {:.2} % | {} | {:.2} % | {:.2} % |\n\nA point's `timing` column (points.csv) names the level that gave its cycles; `queue_cycles` is the network's estimate.\n",
            100.0 * a.check_share,
            a.machine_points,
            a.cycle_runs,
            a.machine_points - a.cycle_runs,
            a.rounds,
            100.0 * a.margin_start,
            100.0 * a.margin,
            100.0 * a.err_mean,
            100.0 * a.err_max,
            a.check_points,
            100.0 * a.check_mean,
            100.0 * a.check_max
        );
    }
    for g in groups(files) {
        let count = |l: Model| g.files.iter().filter(|f| f.point.level == l).count();
        let _ = write!(
            md,
            "\n## {} from patch {}\n\n{} points ({} float, {} fixed, {} machine); reference: {} rays.\n",
            g.scene,
            g.source,
            g.files.len(),
            count(Model::Float),
            count(Model::Fixed),
            count(Model::Machine),
            sf.reference_rays
                .get(&format!("{}/{}", g.scene, g.source))
                .copied()
                .unwrap_or(0)
        );
        for a in [
            Against::Cycles,
            Against::Cost,
            Against::Cells,
            Against::Wall,
        ] {
            let (with, fr) = group_front(&g, a);
            if with.is_empty() {
                continue;
            }
            let name = chart_name(&g, a);
            write_atomic(&dir.join(&name), chart(&g, a, &with, &fr)?.as_bytes())?;
            let csv = if a == Against::Wall {
                &mut host_front
            } else {
                &mut front_csv
            };
            for (rank, &i) in fr.iter().enumerate() {
                let f = g.files[i];
                let _ = writeln!(
                    csv,
                    "{},{},{},{},{},{},{},{},{:.6e},{}",
                    a.name(),
                    field(g.scene),
                    g.source,
                    rank,
                    f.point.index,
                    f.point.level.name(),
                    field(&knobs_label(&f.point.knobs)),
                    a.show(a.x(f).unwrap_or(f64::NAN)),
                    f.point.ff_err_max,
                    opt(f.point.timing.map(Timing::name))
                );
            }
            if a == Against::Wall {
                let _ = write!(
                    md,
                    "\n### Error against the simulator's wall time\n\nHost-dependent, so not in this report: [{name}]({name}) and host-front.csv (nothing compares them).\n"
                );
                continue;
            }
            let _ = write!(
                md,
                "\n### Front: error against {}\n\n![{name}]({name})\n\n{} of {} points are on the front:\n\n| # | level | knobs | error | ×σ | {} | binds |\n| --- | --- | --- | --- | --- | --- | --- |\n",
                a.desc(),
                fr.len(),
                with.len(),
                a.name()
            );
            for &i in &fr {
                let p = &g.files[i].point;
                let _ = writeln!(
                    md,
                    "| {} | {} | {} | {:.3e} | {:.2} | {} | {} |",
                    p.index,
                    level_label(p),
                    short_label(p, &axes),
                    p.ff_err_max,
                    p.err_over_sampling,
                    a.show(a.x(g.files[i]).unwrap_or(f64::NAN)),
                    p.binds.as_deref().unwrap_or("")
                );
            }
            md.push_str(
                "\nChanging one knob of a front point (the nearest value either side):\n\n",
            );
            for &i in &fr {
                let p = &g.files[i].point;
                let moves = one_knob(&g, p, &axes, a);
                if moves.is_empty() {
                    let _ = writeln!(
                        md,
                        "- #{}: no point differs from it in one knob only",
                        p.index
                    );
                } else {
                    let _ = writeln!(md, "- #{}: {}", p.index, moves.join("; "));
                }
            }
        }
    }
    write_atomic(&dir.join("front.csv"), front_csv.as_bytes())?;
    write_atomic(&dir.join("host-front.csv"), host_front.as_bytes())?;
    write_atomic(&dir.join("report.md"), md.as_bytes())?;
    Ok(())
}
