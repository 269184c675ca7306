//! The bits sweep's chart family: accuracy against fractional bits (log scale) above,
//! hardware cost against bits below (`shellsim sweep bits`).

use super::palette::{PURE_BLUE, PURE_CYAN, PURE_GREEN, PURE_MAGENTA, PURE_RED};
use super::{draw_err, legend, Legend};
use crate::error::Result;
use plotters::prelude::*;

/// One format of the sweep, as drawn.
#[derive(Clone, Debug, PartialEq)]
pub struct BitsPoint {
    pub frac_bits: u32,
    /// Mismatches over rays.
    pub mismatch_rate: f64,
    /// Form-factor error, max over patches.
    pub ff_err_max: f64,
    /// The estimator's sampling error (the first point's is drawn).
    pub ff_sampling_err: f64,
    pub multiplier_bits: u64,
    pub adder_bits: u64,
}

/// A point's value to plot.
type Metric = fn(&BitsPoint) -> f64;
/// A point's cost to plot.
type CostMetric = fn(&BitsPoint) -> u64;

/// The chart: accuracy against bits (log scale) above, hardware cost against bits below.
pub fn svg(rows: &[BitsPoint], recommended: Option<u32>, title: &str) -> Result<String> {
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, (900, 800)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
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
            .map_err(draw_err)?;
        chart
            .configure_mesh()
            .x_desc("fractional bits F (LSB = 2^-F)")
            .y_desc("rate / error")
            .y_label_formatter(&|y| format!("{y:.0e}"))
            .draw()
            .map_err(draw_err)?;
        let series: [(&str, RGBColor, Metric); 2] = [
            ("mismatch rate (fixed vs float hit)", PURE_BLUE, |r| {
                r.mismatch_rate
            }),
            ("form-factor error, max over patches", PURE_RED, |r| {
                r.ff_err_max
            }),
        ];
        for (name, color, f) in series {
            let pts: Vec<(f64, f64)> = rows
                .iter()
                .map(|r| (r.frac_bits as f64, val(f(r))))
                .collect();
            chart
                .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))
                .map_err(draw_err)?
                .label(name)
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
                });
            chart
                .draw_series(pts.into_iter().map(|p| Circle::new(p, 3, color.filled())))
                .map_err(draw_err)?;
        }
        let samp = rows.first().map_or(0.0, |r| r.ff_sampling_err);
        chart
            .draw_series(LineSeries::new(
                vec![
                    (lo_b as f64 - 0.5, val(samp)),
                    (hi_b as f64 + 0.5, val(samp)),
                ],
                BLACK.stroke_width(1),
            ))
            .map_err(draw_err)?
            .label("sampling error of the estimate (binomial, max over patches)")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK));
        if let Some(b) = recommended {
            chart
                .draw_series(LineSeries::new(
                    vec![(b as f64, floor), (b as f64, 1.0)],
                    PURE_GREEN.stroke_width(1),
                ))
                .map_err(draw_err)?
                .label(format!("fewest bits under the sampling error: {b}"))
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], PURE_GREEN));
        }
        legend(&mut chart, SeriesLabelPosition::UpperRight, Legend::Boxed).map_err(draw_err)?;
        let max_cost = rows
            .iter()
            .map(|r| r.multiplier_bits.max(r.adder_bits))
            .max()
            .unwrap_or(1) as f64;
        let mut cost = ChartBuilder::on(&bottom)
            .caption("rough ICU datapath cost", ("sans-serif", 16))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(lo_b as f64 - 0.5..hi_b as f64 + 0.5, 0.0..max_cost * 1.05)
            .map_err(draw_err)?;
        cost.configure_mesh()
            .x_desc("fractional bits F")
            .y_desc("bits")
            .draw()
            .map_err(draw_err)?;
        let costs: [(&str, RGBColor, CostMetric); 2] = [
            ("multiplier bit-products (Σ a·b)", PURE_MAGENTA, |r| {
                r.multiplier_bits
            }),
            ("adder bits (Σ width)", PURE_CYAN, |r| r.adder_bits),
        ];
        for (name, color, f) in costs {
            cost.draw_series(LineSeries::new(
                rows.iter().map(|r| (r.frac_bits as f64, f(r) as f64)),
                color.stroke_width(2),
            ))
            .map_err(draw_err)?
            .label(name)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
            });
        }
        legend(&mut cost, SeriesLabelPosition::UpperLeft, Legend::Boxed).map_err(draw_err)?;
        root.present().map_err(draw_err)?;
    }
    Ok(out)
}
