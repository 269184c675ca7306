//! The stability report's chart family: one small panel per case, the differences of one
//! model per class against fractional bits (log scale), `shellsim stability`.

use super::palette::{BLUE, GREEN, GREY, LIGHT_BLUE, ORANGE, RED};
use super::{draw_err, legend, Legend};
use crate::error::Result;
use plotters::prelude::*;

/// One panel: a title and per class its counts at each width of `bits`.
#[derive(Clone, Debug, PartialEq)]
pub struct ClassPanel {
    pub title: String,
    pub bits: Vec<u32>,
    /// (class name, count per width); classes that are 0 at every width are not drawn.
    pub series: Vec<(String, Vec<u64>)>,
    /// Rays per width (the top of the y axis).
    pub rays: u64,
}

/// The colour of the `k`-th class.
fn colour(k: usize) -> RGBColor {
    const C: [RGBColor; 7] = [
        GREY,
        ORANGE,
        GREEN,
        BLUE,
        LIGHT_BLUE,
        RGBColor(148, 103, 189),
        RED,
    ];
    C[k % C.len()]
}

/// Panels in a grid of `cols` columns under `title`.
pub fn svg(panels: &[ClassPanel], cols: usize, title: &str) -> Result<String> {
    let cols = cols.max(1);
    let rows = panels.len().div_ceil(cols).max(1);
    let (w, h) = (300 * cols as u32, 40 + 240 * rows as u32);
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        let root = root.titled(title, ("sans-serif", 20)).map_err(draw_err)?;
        let areas = root.split_evenly((rows, cols));
        for (p, area) in panels.iter().zip(areas.iter()) {
            let lo = p.bits.first().copied().unwrap_or(8) as f64;
            let hi = p.bits.last().copied().unwrap_or(16) as f64;
            let top = (p.rays.max(1) as f64) * 2.0;
            let mut chart = ChartBuilder::on(area)
                .caption(&p.title, ("sans-serif", 14))
                .margin(6)
                .x_label_area_size(28)
                .y_label_area_size(40)
                .build_cartesian_2d(lo - 0.5..hi + 0.5, (0.5f64..top).log_scale())
                .map_err(draw_err)?;
            chart
                .configure_mesh()
                .x_desc("F")
                .x_labels(p.bits.len().min(10))
                .x_label_formatter(&|x| format!("{x:.0}"))
                .y_label_formatter(&|y| format!("{y:.0}"))
                .label_style(("sans-serif", 10))
                .light_line_style(WHITE)
                .bold_line_style(BLACK.mix(0.15))
                .draw()
                .map_err(draw_err)?;
            let mut drawn = false;
            for (k, (name, counts)) in p.series.iter().enumerate() {
                if counts.iter().all(|&c| c == 0) {
                    continue;
                }
                drawn = true;
                let c = colour(k);
                // A zero is drawn on the axis floor.
                let pts: Vec<(f64, f64)> = p
                    .bits
                    .iter()
                    .zip(counts)
                    .map(|(&b, &n)| (b as f64, (n as f64).max(0.5)))
                    .collect();
                chart
                    .draw_series(LineSeries::new(pts.clone(), c.stroke_width(2)))
                    .map_err(draw_err)?
                    .label(name.as_str())
                    .legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 14, y)], c.stroke_width(2))
                    });
                chart
                    .draw_series(pts.into_iter().map(|q| Circle::new(q, 2, c.filled())))
                    .map_err(draw_err)?;
            }
            if drawn {
                legend(&mut chart, SeriesLabelPosition::UpperRight, Legend::Light)
                    .map_err(draw_err)?;
            }
        }
        root.present().map_err(draw_err)?;
    }
    Ok(out)
}
