//! `shellsim sweep bits`: the float reference against the fixed-point model over fractional
//! bit widths — mismatch rate and form-factor error against bits, beside the estimator's own
//! sampling error and a rough hardware cost — as CSV and an SVG chart.

use crate::check::{check, CheckReport};
use crate::error::{write_atomic, Error, Result};
use crate::fixed::HostFixed;
use crate::rays::RaySet;
use crate::trace::Tracer;
use crate::Scene;
use plotters::prelude::*;
use shellsim_hw::config::HardwareCost;
use shellsim_hw::DatapathConfig;
use std::path::Path;

/// One format of the sweep.
#[derive(Clone, Debug, serde::Serialize)]
pub struct BitsRow {
    pub frac_bits: u32,
    pub report: CheckReport,
    pub cost: HardwareCost,
}

/// What a sweep runs on: the scene (named `file` in errors), its float tracer, the rays.
pub struct SweepInput<'a> {
    pub scene: &'a Scene,
    pub file: &'a Path,
    pub tracer: &'a Tracer,
    pub cell: f64,
    pub set: &'a RaySet,
    pub source: u32,
}

/// A row's value to plot.
type Metric = fn(&BitsRow) -> f64;
/// A row's cost to plot.
type CostMetric = fn(&BitsRow) -> u64;

/// Runs the check for every fractional width in `bits` (coordinates and t alike).
pub fn sweep_bits(
    input: &SweepInput,
    base: DatapathConfig,
    bits: std::ops::RangeInclusive<u32>,
) -> Result<Vec<BitsRow>> {
    let SweepInput {
        scene,
        file,
        tracer,
        cell,
        set,
        source,
    } = *input;
    let mut rows = Vec::new();
    for b in bits {
        let mut cfg = base;
        cfg.frac_bits = b;
        cfg.t_frac_bits = b;
        let formats = cfg
            .formats()
            .map_err(|e| Error::input(Path::new("--bits"), e.key, e.what))?;
        let host = HostFixed::new(scene, file, cfg, cell)?;
        let report = check(tracer, &host, set, source, Default::default());
        rows.push(BitsRow {
            frac_bits: b,
            report,
            cost: formats.cost(),
        });
    }
    Ok(rows)
}

/// The fewest fractional bits from which on every wider format keeps the form-factor
/// error under the sampling error.
pub fn recommended(rows: &[BitsRow]) -> Option<u32> {
    let mut best = None;
    for r in rows.iter().rev() {
        if r.report.ff_err_max < r.report.ff_sampling_err {
            best = Some(r.frac_bits);
        } else {
            break;
        }
    }
    best
}

/// The rows as CSV.
pub fn csv(rows: &[BitsRow]) -> String {
    let mut s = String::from(
        "frac_bits,rays,mismatches,mismatch_rate,grazing,near_edge,tie,overflow,unexplained,\
         ff_err_max,ff_sampling_err,t_err_rms_lsb,multiplier_bits,adder_bits\n",
    );
    for r in rows {
        let c = &r.report;
        s.push_str(&format!(
            "{},{},{},{:.6e},{},{},{},{},{},{:.6e},{:.6e},{:.3},{},{}\n",
            r.frac_bits,
            c.rays,
            c.mismatches,
            c.mismatches as f64 / c.rays as f64,
            c.classes.grazing,
            c.classes.near_edge,
            c.classes.tie,
            c.classes.overflow,
            c.unexplained_mismatches,
            c.ff_err_max,
            c.ff_sampling_err,
            c.t_err_rms_lsb,
            r.cost.multiplier_bits,
            r.cost.adder_bits
        ));
    }
    s
}

/// The chart: accuracy against bits (log scale) above, hardware cost against bits below.
pub fn svg(rows: &[BitsRow], title: &str) -> String {
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, (900, 800)).into_drawing_area();
        root.fill(&WHITE).expect("svg");
        let (top, bottom) = root.split_vertically(500);
        let lo_b = rows.first().map_or(8, |r| r.frac_bits);
        let hi_b = rows.last().map_or(30, |r| r.frac_bits);
        let floor = 1e-7f64;
        let val = |x: f64| x.max(floor);
        let mut chart = ChartBuilder::on(&top)
            .caption(title, ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(
                lo_b as f64 - 0.5..hi_b as f64 + 0.5,
                (floor..1.0f64).log_scale(),
            )
            .expect("chart");
        chart
            .configure_mesh()
            .x_desc("fractional bits F (LSB = 2^-F)")
            .y_desc("rate / error")
            .y_label_formatter(&|y| format!("{y:.0e}"))
            .draw()
            .expect("mesh");
        let series: [(&str, RGBColor, Metric); 2] = [
            ("mismatch rate (fixed vs float hit)", BLUE, |r| {
                r.report.mismatches as f64 / r.report.rays as f64
            }),
            ("form-factor error, max over patches", RED, |r| {
                r.report.ff_err_max
            }),
        ];
        for (name, color, f) in series {
            let pts: Vec<(f64, f64)> = rows
                .iter()
                .map(|r| (r.frac_bits as f64, val(f(r))))
                .collect();
            chart
                .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))
                .expect("line")
                .label(name)
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
                });
            chart
                .draw_series(pts.into_iter().map(|p| Circle::new(p, 3, color.filled())))
                .expect("points");
        }
        let samp = rows.first().map_or(0.0, |r| r.report.ff_sampling_err);
        chart
            .draw_series(LineSeries::new(
                vec![
                    (lo_b as f64 - 0.5, val(samp)),
                    (hi_b as f64 + 0.5, val(samp)),
                ],
                BLACK.stroke_width(1),
            ))
            .expect("line")
            .label("sampling error of the estimate (binomial, max over patches)")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK));
        if let Some(b) = recommended(rows) {
            chart
                .draw_series(LineSeries::new(
                    vec![(b as f64, floor), (b as f64, 1.0)],
                    GREEN.stroke_width(1),
                ))
                .expect("line")
                .label(format!("fewest bits under the sampling error: {b}"))
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], GREEN));
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .expect("legend");
        let max_cost = rows
            .iter()
            .map(|r| r.cost.multiplier_bits.max(r.cost.adder_bits))
            .max()
            .unwrap_or(1) as f64;
        let mut cost = ChartBuilder::on(&bottom)
            .caption("rough ICU datapath cost", ("sans-serif", 16))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(lo_b as f64 - 0.5..hi_b as f64 + 0.5, 0.0..max_cost * 1.05)
            .expect("chart");
        cost.configure_mesh()
            .x_desc("fractional bits F")
            .y_desc("bits")
            .draw()
            .expect("mesh");
        let costs: [(&str, RGBColor, CostMetric); 2] = [
            ("multiplier bit-products (Σ a·b)", MAGENTA, |r| {
                r.cost.multiplier_bits
            }),
            ("adder bits (Σ width)", CYAN, |r| r.cost.adder_bits),
        ];
        for (name, color, f) in costs {
            cost.draw_series(LineSeries::new(
                rows.iter().map(|r| (r.frac_bits as f64, f(r) as f64)),
                color.stroke_width(2),
            ))
            .expect("line")
            .label(name)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
            });
        }
        cost.configure_series_labels()
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperLeft)
            .draw()
            .expect("legend");
        root.present().expect("svg");
    }
    out
}

/// Writes `bits.csv` and `bits.svg` (named after `stem`) into `dir`.
pub fn write(dir: &Path, stem: &str, rows: &[BitsRow], title: &str) -> Result<()> {
    write_atomic(&dir.join(format!("{stem}.csv")), csv(rows).as_bytes())?;
    write_atomic(
        &dir.join(format!("{stem}.svg")),
        svg(rows, title).as_bytes(),
    )
}
