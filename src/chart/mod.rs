//! SVG charts (plotters, SVG backend only): the shared pieces — [`si`] for axis labels,
//! the [`palette`], the error mapping [`draw_err`], the [`legend`] — and one file per chart family: the
//! partition's workload per ICU ([`partition`]), the machine experiments
//! ([`experiments`]), the bits sweep ([`bits`]).
//!
//! Charts take plain numbers (their own small structs), never the types of the modules
//! that draw them, so `chart` depends on nothing but [`crate::error`].
//!
//! **Invariant:** an SVG depends only on the numbers drawn (no timestamps), so a figure is
//! byte-identical when its run is.

pub mod bits;
pub mod experiments;
pub mod explore;
pub mod partition;

use crate::error::Error;
use plotters::coord::CoordTranslate;
use plotters::prelude::{
    ChartContext, Color, DrawingAreaErrorKind, DrawingBackend, SeriesLabelPosition, BLACK, WHITE,
};

/// How [`si`] writes a value: decimals per suffix, and whether `.000` is trimmed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SiStyle {
    /// Decimals with the suffix G (≥ 1e9); `None`: no G, such values take M.
    pub giga: Option<usize>,
    /// Decimals with M (≥ 1e6).
    pub mega: usize,
    /// Decimals with k (≥ 1e3).
    pub kilo: usize,
    /// Remove a `.000` (three zero decimals), so 2e6 is "2M" rather than "2.000M".
    pub trim: bool,
}

impl SiStyle {
    /// Workload axes: three decimals (trimmed when zero) up to G: 1500 → "1.500k", 2e6 → "2M".
    pub const WORKLOAD: SiStyle = SiStyle {
        giga: Some(3),
        mega: 3,
        kilo: 3,
        trim: true,
    };
    /// Cycle axes: 1.23M, 45k.
    pub const CYCLES: SiStyle = SiStyle {
        giga: None,
        mega: 2,
        kilo: 0,
        trim: false,
    };
}

/// `v` with an SI suffix in `style`: 1234567 → "1.235M" (WORKLOAD) or "1.23M" (CYCLES);
/// below 1000 without decimals.
pub fn si(v: f64, style: SiStyle) -> String {
    let a = v.abs();
    let s = match style.giga {
        Some(d) if a >= 1e9 => format!("{:.d$}G", v / 1e9),
        _ if a >= 1e6 => format!("{:.d$}M", v / 1e6, d = style.mega),
        _ if a >= 1e3 => format!("{:.d$}k", v / 1e3, d = style.kilo),
        _ => format!("{v:.0}"),
    };
    if style.trim {
        s.replace(".000", "")
    } else {
        s
    }
}

/// How a chart's series legend looks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Legend {
    /// White box, black border, plotters' default font: the full-size charts.
    Boxed,
    /// Translucent box, faint border, 11 px labels: small panels.
    Light,
}

/// Draws `chart`'s series legend at `pos` in the kit's `look`.
pub fn legend<'a, DB, CT>(
    chart: &mut ChartContext<'a, DB, CT>,
    pos: SeriesLabelPosition,
    look: Legend,
) -> std::result::Result<(), DrawingAreaErrorKind<DB::ErrorType>>
where
    DB: DrawingBackend + 'a,
    CT: CoordTranslate,
{
    let mut labels = chart.configure_series_labels();
    labels.position(pos);
    match look {
        Legend::Boxed => labels.background_style(WHITE.mix(0.9)).border_style(BLACK),
        Legend::Light => labels
            .label_font(("sans-serif", 11))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK.mix(0.3)),
    };
    labels.draw()
}

/// A drawing error as the host's error.
pub fn draw_err<E: std::fmt::Debug>(e: E) -> Error {
    Error::Check(format!("drawing a chart: {e:?}"))
}

/// The colours every chart draws with.
pub mod palette {
    use plotters::style::RGBColor;

    /// Blue (tab10): actual work; runs with dynamic balancing.
    pub const BLUE: RGBColor = RGBColor(31, 119, 180);
    /// Light blue (tab20): predicted work.
    pub const LIGHT_BLUE: RGBColor = RGBColor(174, 199, 232);
    /// Orange (tab10): runs with static partitioning.
    pub const ORANGE: RGBColor = RGBColor(255, 127, 14);
    /// Green (tab10): resource bounds.
    pub const GREEN: RGBColor = RGBColor(44, 160, 44);
    /// Red (tab10): means.
    pub const RED: RGBColor = RGBColor(214, 39, 40);
    /// Grey: ideal lines.
    pub const GREY: RGBColor = RGBColor(80, 80, 80);
    /// The bits sweep's pure colours (plotters' named ones), kept so its chart is unchanged.
    pub const PURE_BLUE: RGBColor = plotters::style::colors::BLUE;
    pub const PURE_RED: RGBColor = plotters::style::colors::RED;
    pub const PURE_GREEN: RGBColor = plotters::style::colors::GREEN;
    pub const PURE_MAGENTA: RGBColor = plotters::style::colors::MAGENTA;
    pub const PURE_CYAN: RGBColor = plotters::style::colors::CYAN;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn si_suffixes() {
        let w = SiStyle::WORKLOAD;
        assert_eq!(si(0.0, w), "0");
        assert_eq!(si(999.0, w), "999");
        assert_eq!(si(1500.0, w), "1.500k");
        assert_eq!(si(2_000_000.0, w), "2M");
        let c = SiStyle::CYCLES;
        assert_eq!(si(1500.0, c), "2k");
        assert_eq!(si(1_234_567.0, c), "1.23M");
        assert_eq!(si(2e9, c), "2000.00M");
    }
}
