//! The design-space sweep's chart family (`shellsim explore`): every point's error against
//! one cost (machine cycles, hardware bits, wall time), both axes logarithmic, coloured by
//! series (the model level), the non-dominated front drawn as a staircase and its points
//! labelled.

use super::palette::{BLUE, GREEN, GREY, ORANGE, RED};
use super::{draw_err, legend, Legend};
use crate::error::Result;
use plotters::prelude::*;

/// One point as drawn.
#[derive(Clone, Debug, PartialEq)]
pub struct Dot {
    pub x: f64,
    pub y: f64,
    /// Index into [`FrontChart::series`].
    pub series: usize,
    /// Written beside the point when it is on the front.
    pub label: String,
}

/// A chart: the dots, which of them form the front (ordered by x), the names of the series.
pub struct FrontChart<'a> {
    pub title: &'a str,
    pub x_desc: &'a str,
    pub y_desc: &'a str,
    pub series: &'a [&'a str],
    pub dots: &'a [Dot],
    pub front: &'a [usize],
}

/// The series' colours, in order.
const COLOURS: [RGBColor; 4] = [BLUE, ORANGE, GREEN, GREY];

/// The chart as SVG text.
pub fn svg(c: &FrontChart) -> Result<String> {
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, (900, 600)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        let pos = |v: f64| v.is_finite() && v > 0.0;
        let xs: Vec<f64> = c.dots.iter().map(|d| d.x).filter(|&v| pos(v)).collect();
        let ys: Vec<f64> = c.dots.iter().map(|d| d.y).filter(|&v| pos(v)).collect();
        let span = |v: &[f64], lo_default: f64| {
            let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = v.iter().copied().fold(0.0f64, f64::max);
            if lo.is_finite() && hi > 0.0 {
                (lo / 1.5, hi * 1.5)
            } else {
                (lo_default, lo_default * 10.0)
            }
        };
        let (x0, x1) = span(&xs, 1.0);
        let (y0, y1) = span(&ys, 1e-6);
        // A zero error is drawn on the floor.
        let clamp = |v: f64, lo: f64| if pos(v) { v } else { lo };
        let mut chart = ChartBuilder::on(&root)
            .caption(c.title, ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .map_err(draw_err)?;
        chart
            .configure_mesh()
            .x_desc(c.x_desc)
            .y_desc(c.y_desc)
            .x_label_formatter(&|x| format!("{x:.1e}"))
            .y_label_formatter(&|y| format!("{y:.0e}"))
            .draw()
            .map_err(draw_err)?;
        for (s, name) in c.series.iter().enumerate() {
            let colour = COLOURS[s % COLOURS.len()];
            let pts: Vec<(f64, f64)> = c
                .dots
                .iter()
                .filter(|d| d.series == s && d.x.is_finite())
                .map(|d| (clamp(d.x, x0), clamp(d.y, y0)))
                .collect();
            if pts.is_empty() {
                continue;
            }
            chart
                .draw_series(pts.into_iter().map(|p| Circle::new(p, 3, colour.filled())))
                .map_err(draw_err)?
                .label(*name)
                .legend(move |(x, y)| Circle::new((x + 10, y), 3, colour.filled()));
        }
        // The front: a staircase through its points (the best error reached so far).
        let fp: Vec<(f64, f64)> = c
            .front
            .iter()
            .map(|&i| (clamp(c.dots[i].x, x0), clamp(c.dots[i].y, y0)))
            .collect();
        let mut stairs = Vec::new();
        for (k, &p) in fp.iter().enumerate() {
            if k > 0 {
                stairs.push((p.0, fp[k - 1].1));
            }
            stairs.push(p);
        }
        if let Some(&last) = fp.last() {
            stairs.push((x1, last.1));
        }
        chart
            .draw_series(LineSeries::new(stairs, RED.stroke_width(2)))
            .map_err(draw_err)?
            .label("non-dominated front")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED.stroke_width(2)));
        chart
            .draw_series(fp.iter().map(|&p| Circle::new(p, 5, RED.stroke_width(2))))
            .map_err(draw_err)?;
        chart
            .draw_series(c.front.iter().zip(&fp).map(|(&i, &p)| {
                Text::new(c.dots[i].label.clone(), p, ("sans-serif", 11).into_font())
            }))
            .map_err(draw_err)?;
        legend(&mut chart, SeriesLabelPosition::UpperRight, Legend::Boxed).map_err(draw_err)?;
        root.present().map_err(draw_err)?;
    }
    Ok(out)
}
