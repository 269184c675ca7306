//! The partition's chart family: bar charts of workload per ICU, like the paper's
//! Figs 12.8–12.13: for each section (cluster), a filled bar of the actual intersection
//! computations of the high-resolution pass beside a lighter bar of the low-resolution
//! prediction, and a line at the mean actual workload (max over mean is the imbalance).
//!
//! **Invariant:** the SVG depends only on the numbers drawn (no timestamps), so a figure is
//! byte-identical when its run is.

use super::{draw_err, legend, palette, si, Legend, SiStyle};
use crate::error::Result;
use plotters::prelude::*;

/// One panel: a bar pair per ICU.
#[derive(Clone, Debug, PartialEq)]
pub struct Panel {
    pub title: String,
    /// Actual intersections per ICU.
    pub actual: Vec<u64>,
    /// Predicted intersections per ICU.
    pub predicted: Vec<u64>,
}

const ACTUAL: RGBColor = palette::BLUE;
const PREDICTED: RGBColor = palette::LIGHT_BLUE;
const MEAN: RGBColor = palette::RED;

/// A figure of `panels` side by side under `caption`, as SVG text.
pub fn workload_svg(caption: &str, panels: &[Panel]) -> Result<String> {
    let n = panels.len().max(1);
    let (w, h) = ((440 * n as u32).max(680), 420u32);
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        let body = root.titled(caption, ("sans-serif", 17)).map_err(draw_err)?;
        let areas = body.split_evenly((1, n));
        for (area, p) in areas.iter().zip(panels) {
            draw_panel(area, p).map_err(draw_err)?;
        }
        root.present().map_err(draw_err)?;
    }
    Ok(out)
}

fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    p: &Panel,
) -> std::result::Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let n = p.actual.len().max(1);
    let top = p
        .actual
        .iter()
        .chain(&p.predicted)
        .copied()
        .max()
        .unwrap_or(0)
        .max(1) as f64
        // Headroom for the legend above the tallest bar.
        * 1.32;
    let mut chart = ChartBuilder::on(area)
        .caption(&p.title, ("sans-serif", 16))
        .margin(10)
        .x_label_area_size(38)
        .y_label_area_size(62)
        .build_cartesian_2d(-0.5f64..(n as f64 - 0.5), 0f64..top)?;
    chart
        .configure_mesh()
        .disable_x_mesh()
        .bold_line_style(BLACK.mix(0.12))
        .light_line_style(TRANSPARENT)
        .y_labels(6)
        .x_labels(n.min(16))
        .x_label_formatter(&|x| {
            let r = x.round();
            if (x - r).abs() < 1e-6 && r >= 0.0 {
                format!("{}", r as i64 + 1)
            } else {
                String::new()
            }
        })
        .y_label_formatter(&|y| si(*y, SiStyle::WORKLOAD))
        .x_desc("ICU (section)")
        .y_desc("intersection computations")
        .label_style(("sans-serif", 12))
        .axis_desc_style(("sans-serif", 13))
        .draw()?;
    let half = 0.38;
    chart
        .draw_series(p.actual.iter().enumerate().map(|(i, &v)| {
            let x = i as f64;
            Rectangle::new([(x - half, 0.0), (x, v as f64)], ACTUAL.filled())
        }))?
        .label("actual (high resolution)")
        .legend(|(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], ACTUAL.filled()));
    chart
        .draw_series(p.predicted.iter().enumerate().map(|(i, &v)| {
            let x = i as f64;
            Rectangle::new([(x, 0.0), (x + half, v as f64)], PREDICTED.filled())
        }))?
        .label("predicted (low resolution × ratio)")
        .legend(|(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], PREDICTED.filled()));
    let mean = p.actual.iter().sum::<u64>() as f64 / n as f64;
    chart
        .draw_series(std::iter::once(PathElement::new(
            vec![(-0.5, mean), (n as f64 - 0.5, mean)],
            MEAN.stroke_width(1),
        )))?
        .label("mean actual")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 12, y)], MEAN.stroke_width(2)));
    legend(&mut chart, SeriesLabelPosition::UpperRight, Legend::Light)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_svg_with_every_bar() {
        let p = Panel {
            title: "P = 3".into(),
            actual: vec![10, 20, 30],
            predicted: vec![12, 18, 33],
        };
        let a = workload_svg("test", &[p.clone(), p.clone()]).unwrap();
        let b = workload_svg("test", &[p.clone(), p]).unwrap();
        assert_eq!(a, b, "deterministic");
        assert!(a.starts_with("<svg"));
        assert!(a.contains("P = 3") && a.contains("intersection computations"));
        // 2 panels × (3 actual + 3 predicted) bars, plus legend boxes and backgrounds.
        assert!(a.matches("<rect").count() >= 12);
    }
}
