//! The experiments' chart family: efficiency bars with and without balancing, efficiency and cycles
//! against work-item size (Fig 12.14), speedup against ICUs beside the ideal and the resource
//! bound (Fig 12.15).
//!
//! **Invariant:** an SVG depends only on the numbers drawn (no timestamps), so a figure is
//! byte-identical when its runs are.

use super::{draw_err, legend, palette, si, Legend, SiStyle};
use crate::error::Result;
use plotters::prelude::*;

const ON: RGBColor = palette::BLUE;
const OFF: RGBColor = palette::ORANGE;
const BOUND: RGBColor = palette::GREEN;
const IDEAL: RGBColor = palette::GREY;

/// One run of the efficiency chart.
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    pub ratio: usize,
    /// Rays of the run (the ratio's caption).
    pub rays: usize,
    pub clusters: u32,
    pub balance: bool,
    pub pipeline_efficiency: f64,
}

/// One run of the work-item chart.
#[derive(Clone, Debug, PartialEq)]
pub struct WorkItemPoint {
    pub work_item_jobs: u32,
    pub pipeline_efficiency: f64,
    pub cycles: u64,
    /// The run's lower bound on cycles and the resource that sets it.
    pub bound_cycles: u64,
    pub binding: &'static str,
}

/// The work-item chart's runs: the static machine and the balanced runs by size.
#[derive(Clone, Debug, PartialEq)]
pub struct WorkItemRows {
    pub off: WorkItemPoint,
    pub on: Vec<WorkItemPoint>,
}

/// One run of the speedup chart.
#[derive(Clone, Debug, PartialEq)]
pub struct SpeedupRow {
    pub clusters: u32,
    pub balance: bool,
    pub speedup: f64,
    pub bound_speedup: f64,
    pub speedup_same_work: f64,
    pub bound_speedup_same_work: f64,
}

/// Pipeline efficiency with balancing off and on: one panel per ratio, a bar pair per
/// cluster count, each bar labelled with its value. `points` as from `experiment::efficiency`.
pub fn efficiency_svg(title: &str, points: &[Point]) -> Result<String> {
    let mut ratios: Vec<usize> = points.iter().map(|p| p.ratio).collect();
    ratios.dedup();
    let n = ratios.len().max(1);
    let mut out = String::new();
    {
        let root =
            SVGBackend::with_string(&mut out, (380 * n as u32 + 40, 460)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        let body = root.titled(title, ("sans-serif", 17)).map_err(draw_err)?;
        for (area, &ratio) in body.split_evenly((1, n)).iter().zip(&ratios) {
            let ps: Vec<&Point> = points.iter().filter(|p| p.ratio == ratio).collect();
            let mut clusters: Vec<u32> = ps.iter().map(|p| p.clusters).collect();
            clusters.dedup();
            let m = clusters.len().max(1);
            let mut chart = ChartBuilder::on(area)
                .caption(
                    format!(
                        "Hi_Low_Ratio {ratio} ({} rays)",
                        ps.first().map_or(0, |p| p.rays)
                    ),
                    ("sans-serif", 15),
                )
                .margin(10)
                .x_label_area_size(36)
                .y_label_area_size(48)
                .build_cartesian_2d(-0.5f64..(m as f64 - 0.5), 0f64..1.18)
                .map_err(draw_err)?;
            let labels = clusters.clone();
            chart
                .configure_mesh()
                .disable_x_mesh()
                .bold_line_style(BLACK.mix(0.12))
                .light_line_style(TRANSPARENT)
                .x_labels(m)
                .x_label_formatter(&|x| {
                    let r = x.round();
                    if (x - r).abs() < 1e-6 && r >= 0.0 && (r as usize) < labels.len() {
                        format!("P = {}", labels[r as usize])
                    } else {
                        String::new()
                    }
                })
                .y_labels(7)
                .y_label_formatter(&|y| {
                    if *y <= 1.0 {
                        format!("{y:.1}")
                    } else {
                        String::new()
                    }
                })
                .x_desc("ICUs (clusters)")
                .y_desc("pipeline efficiency")
                .label_style(("sans-serif", 12))
                .axis_desc_style(("sans-serif", 13))
                .draw()
                .map_err(draw_err)?;
            let half = 0.36;
            for (on, color, name, dx) in [
                (false, OFF, "static partitioning", -half),
                (true, ON, "dynamic balancing", 0.0),
            ] {
                let bars: Vec<(f64, f64)> = clusters
                    .iter()
                    .enumerate()
                    .filter_map(|(i, &c)| {
                        ps.iter()
                            .find(|p| p.clusters == c && p.balance == on)
                            .map(|p| (i as f64 + dx, p.pipeline_efficiency))
                    })
                    .collect();
                chart
                    .draw_series(
                        bars.iter().map(|&(x, v)| {
                            Rectangle::new([(x, 0.0), (x + half, v)], color.filled())
                        }),
                    )
                    .map_err(draw_err)?
                    .label(name)
                    .legend(move |(x, y)| {
                        Rectangle::new([(x, y - 5), (x + 12, y + 5)], color.filled())
                    });
                chart
                    .draw_series(bars.iter().map(|&(x, v)| {
                        Text::new(
                            format!("{v:.2}"),
                            (x + 0.02, v + 0.05),
                            ("sans-serif", 11).into_font(),
                        )
                    }))
                    .map_err(draw_err)?;
            }
            legend(&mut chart, SeriesLabelPosition::UpperRight, Legend::Light).map_err(draw_err)?;
        }
        root.present().map_err(draw_err)?;
    }
    Ok(out)
}

/// A line with dots and a legend entry.
fn line<DB: DrawingBackend, X, Y>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<X, Y>>,
    pts: Vec<(X::ValueType, Y::ValueType)>,
    color: RGBColor,
    name: &str,
    dots: bool,
) -> Result<()>
where
    X: plotters::coord::ranged1d::Ranged,
    Y: plotters::coord::ranged1d::Ranged,
    X::ValueType: Clone + 'static,
    Y::ValueType: Clone + 'static,
{
    chart
        .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))
        .map_err(draw_err)?
        .label(name)
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2)));
    if dots {
        chart
            .draw_series(pts.into_iter().map(|p| Circle::new(p, 3, color.filled())))
            .map_err(draw_err)?;
    }
    Ok(())
}

/// Efficiency (top) and cycles (bottom) against work-item size, balancing on, beside the
/// static machine's values and the resource bound.
pub fn work_item_svg(title: &str, rows: &WorkItemRows) -> Result<String> {
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, (900, 760)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        let body = root.titled(title, ("sans-serif", 17)).map_err(draw_err)?;
        let (top, bottom) = body.split_vertically(360);
        // x: log2 of the size, labelled with the size.
        let lg = |p: &WorkItemPoint| (p.work_item_jobs.max(1) as f64).log2();
        let (lo, hi) = (
            rows.on.first().map_or(0.0, lg) - 0.5,
            rows.on.last().map_or(7.0, lg) + 0.5,
        );
        let size_label = |x: &f64| {
            let r = x.round();
            if (x - r).abs() < 1e-6 && r >= 0.0 {
                format!("{}", 1u64 << (r as u32).min(62))
            } else {
                String::new()
            }
        };
        let ticks = (hi - lo).round() as usize;
        let mut eff = ChartBuilder::on(&top)
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(lo..hi, 0f64..1.0)
            .map_err(draw_err)?;
        eff.configure_mesh()
            .light_line_style(TRANSPARENT)
            .bold_line_style(BLACK.mix(0.12))
            .x_labels(ticks)
            .x_desc("work-item size (jobs)")
            .y_desc("pipeline efficiency")
            .x_label_formatter(&size_label)
            .y_label_formatter(&|y| format!("{y:.1}"))
            .label_style(("sans-serif", 12))
            .draw()
            .map_err(draw_err)?;
        line(
            &mut eff,
            rows.on
                .iter()
                .map(|p| (lg(p), p.pipeline_efficiency))
                .collect(),
            ON,
            "dynamic balancing",
            true,
        )?;
        line(
            &mut eff,
            vec![
                (lo, rows.off.pipeline_efficiency),
                (hi, rows.off.pipeline_efficiency),
            ],
            OFF,
            &format!("static partitioning ({:.3})", rows.off.pipeline_efficiency),
            false,
        )?;
        legend(&mut eff, SeriesLabelPosition::LowerRight, Legend::Boxed).map_err(draw_err)?;
        let ymax = rows
            .on
            .iter()
            .chain(std::iter::once(&rows.off))
            .map(|p| p.cycles)
            .max()
            .unwrap_or(1) as f64
            * 1.15;
        let mut cyc = ChartBuilder::on(&bottom)
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(lo..hi, 0f64..ymax)
            .map_err(draw_err)?;
        cyc.configure_mesh()
            .light_line_style(TRANSPARENT)
            .bold_line_style(BLACK.mix(0.12))
            .x_labels(ticks)
            .x_desc("work-item size (jobs)")
            .y_desc("cycles")
            .x_label_formatter(&size_label)
            .y_label_formatter(&|y| si(*y, SiStyle::CYCLES))
            .label_style(("sans-serif", 12))
            .draw()
            .map_err(draw_err)?;
        line(
            &mut cyc,
            rows.on.iter().map(|p| (lg(p), p.cycles as f64)).collect(),
            ON,
            "dynamic balancing",
            true,
        )?;
        line(
            &mut cyc,
            vec![(lo, rows.off.cycles as f64), (hi, rows.off.cycles as f64)],
            OFF,
            "static partitioning",
            false,
        )?;
        line(
            &mut cyc,
            rows.on
                .iter()
                .map(|p| (lg(p), p.bound_cycles as f64))
                .collect(),
            BOUND,
            &format!(
                "resource bound (binds: {})",
                rows.on.first().map_or("-", |p| p.binding)
            ),
            false,
        )?;
        legend(&mut cyc, SeriesLabelPosition::LowerRight, Legend::Boxed).map_err(draw_err)?;
        root.present().map_err(draw_err)?;
    }
    Ok(out)
}

/// Speedup against ICUs: the whole machine scaled (left) and the same work on P ICUs
/// (right), each with balancing off and on, the ideal line and the resource bound.
pub fn speedup_svg(title: &str, rows: &[SpeedupRow]) -> Result<String> {
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, (1100, 500)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        let body = root.titled(title, ("sans-serif", 17)).map_err(draw_err)?;
        let panels = body.split_evenly((1, 2));
        let pmax = rows.iter().map(|r| r.clusters).max().unwrap_or(1) as f64;
        type Pick = fn(&SpeedupRow) -> f64;
        let specs: [(&str, Pick, Pick); 2] = [
            (
                "whole machine: T(1 cluster) / T(P clusters), K CTUs each",
                |r| r.speedup,
                |r| r.bound_speedup,
            ),
            (
                "same work: T(1 ICU, the same P×K sectors) / T(P)",
                |r| r.speedup_same_work,
                |r| r.bound_speedup_same_work,
            ),
        ];
        for (area, (caption, sp, bound)) in panels.iter().zip(specs) {
            let ymax = rows
                .iter()
                .flat_map(|r| [sp(r), bound(r)])
                .fold(pmax, f64::max)
                * 1.1;
            let mut chart = ChartBuilder::on(area)
                .caption(caption, ("sans-serif", 14))
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(50)
                .build_cartesian_2d(0.5f64..pmax + 0.5, 0f64..ymax)
                .map_err(draw_err)?;
            chart
                .configure_mesh()
                .x_desc("ICUs (clusters) P")
                .y_desc("speedup")
                .x_label_formatter(&|x| format!("{x:.0}"))
                .y_label_formatter(&|y| format!("{y:.0}"))
                .label_style(("sans-serif", 12))
                .draw()
                .map_err(draw_err)?;
            line(
                &mut chart,
                vec![(1.0, 1.0), (pmax, pmax)],
                IDEAL,
                "ideal (P)",
                false,
            )?;
            let on: Vec<&SpeedupRow> = rows.iter().filter(|r| r.balance).collect();
            line(
                &mut chart,
                on.iter().map(|r| (r.clusters as f64, bound(r))).collect(),
                BOUND,
                "resource bound, balancing on",
                true,
            )?;
            line(
                &mut chart,
                on.iter().map(|r| (r.clusters as f64, sp(r))).collect(),
                ON,
                "dynamic balancing",
                true,
            )?;
            line(
                &mut chart,
                rows.iter()
                    .filter(|r| !r.balance)
                    .map(|r| (r.clusters as f64, sp(r)))
                    .collect(),
                OFF,
                "static partitioning",
                true,
            )?;
            legend(&mut chart, SeriesLabelPosition::UpperLeft, Legend::Boxed).map_err(draw_err)?;
        }
        root.present().map_err(draw_err)?;
    }
    Ok(out)
}

/// The queue level's error against the cycle level, one bar per machine (`(label, error)`,
/// error a fraction), with the ±5 % and ±10 % targets drawn.
pub fn levels_svg(title: &str, rows: &[(String, f64)]) -> Result<String> {
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, (900, 480)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        let n = rows.len().max(1);
        let lim = rows
            .iter()
            .map(|r| 100.0 * r.1.abs())
            .fold(12.0f64, f64::max)
            * 1.1;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 16))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(55)
            .build_cartesian_2d(-0.5..n as f64 - 0.5, -lim..lim)
            .map_err(draw_err)?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .y_desc("queue − cycle, % of the cycle level's cycles")
            .x_labels(n)
            .x_label_formatter(&|x| {
                let i = x.round();
                if (x - i).abs() > 1e-6 || i < 0.0 {
                    return String::new();
                }
                rows.get(i as usize).map_or(String::new(), |r| {
                    (r.0.replace(" balance ", " ")).replace(" same work", " same")
                })
            })
            .x_label_style(("sans-serif", 11))
            .y_label_formatter(&|y| format!("{y:+.0}"))
            .label_style(("sans-serif", 12))
            .draw()
            .map_err(draw_err)?;
        for (v, color, name) in [
            (5.0, BOUND, "±5 % (mean target)"),
            (10.0, OFF, "±10 % (max)"),
        ] {
            for s in [v, -v] {
                let series = chart
                    .draw_series(LineSeries::new(
                        [(-0.5, s), (n as f64 - 0.5, s)],
                        color.stroke_width(1),
                    ))
                    .map_err(draw_err)?;
                if s > 0.0 {
                    series.label(name).legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 16, y)], color.stroke_width(2))
                    });
                }
            }
        }
        chart
            .draw_series(rows.iter().enumerate().map(|(i, r)| {
                let e = 100.0 * r.1;
                Rectangle::new(
                    [(i as f64 - 0.35, 0.0), (i as f64 + 0.35, e)],
                    ON.mix(0.8).filled(),
                )
            }))
            .map_err(draw_err)?;
        legend(&mut chart, SeriesLabelPosition::LowerLeft, Legend::Boxed).map_err(draw_err)?;
        root.present().map_err(draw_err)?;
    }
    Ok(out)
}

/// Wall seconds (log) against |Δcycles| in % of the cycle level: one series of marks per
/// timing level (`levels::wall_svg`).
pub fn wall_svg(title: &str, series: &[(&str, Vec<(f64, f64)>)]) -> Result<String> {
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, (900, 520)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        let pts = series.iter().flat_map(|s| &s.1);
        let (lo, hi) = pts.clone().fold((f64::MAX, f64::MIN), |(a, b), p| {
            (a.min(p.0.max(1e-6)), b.max(p.0))
        });
        let (lo, hi) = if lo > hi {
            (1e-3, 1.0)
        } else {
            (lo / 2.0, hi * 2.0)
        };
        let ymax = pts.map(|p| p.1).fold(12.0f64, f64::max) * 1.1;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 16))
            .margin(12)
            .x_label_area_size(45)
            .y_label_area_size(55)
            .build_cartesian_2d((lo..hi).log_scale(), 0.0..ymax)
            .map_err(draw_err)?;
        chart
            .configure_mesh()
            .x_desc("wall seconds per machine (this host; log scale)")
            .y_desc("|cycles − cycle level's|, %")
            .x_label_formatter(&|x| format!("{x:.0e}"))
            .y_label_formatter(&|y| format!("{y:.0}"))
            .label_style(("sans-serif", 12))
            .draw()
            .map_err(draw_err)?;
        let colours = [BOUND, OFF, palette::RED, ON, IDEAL];
        for (i, (name, marks)) in series.iter().enumerate() {
            let c = colours[i % colours.len()];
            // The last series as rings, so marks on the same spot stay visible.
            let last = i + 1 == series.len();
            let style = if last {
                c.stroke_width(2)
            } else {
                c.mix(0.75).filled()
            };
            let r = if last { 7 } else { 4 };
            chart
                .draw_series(
                    marks
                        .iter()
                        .map(|&(x, y)| Circle::new((x.max(lo), y), r, style)),
                )
                .map_err(draw_err)?
                .label(*name)
                .legend(move |(x, y)| Circle::new((x + 8, y), r, style));
        }
        legend(&mut chart, SeriesLabelPosition::UpperRight, Legend::Boxed).map_err(draw_err)?;
        root.present().map_err(draw_err)?;
    }
    Ok(out)
}
