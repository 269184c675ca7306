//! The ICU's synthesized cost for a configuration: Yosys's generic cell count from the
//! committed table hw/rtl/cost.csv (`shellsim rtl cost --sweep 8..16 --csv hw/rtl/cost.csv`,
//! the RTL in hw/rtl/), exact where the table holds the configuration's formats, otherwise
//! from the table's least-squares line of cells against the bits proxy (r = 0.994 over
//! F = 8–16). The proxy stays the sweeps' fast measure; this column is what it stands for.

use shellsim_hw::config::DatapathConfig;
use std::sync::OnceLock;

/// The committed synthesis table.
const TABLE: &str = include_str!("../../hw/rtl/cost.csv");

/// One ICU row: (frac_bits, coord_int_bits, t_frac_bits, t_int_bits, divider bits per
/// stage) → (cells, bits proxy).
type Row = ([u32; 5], u64, u64);

fn rows() -> &'static [Row] {
    static ROWS: OnceLock<Vec<Row>> = OnceLock::new();
    ROWS.get_or_init(|| {
        TABLE
            .lines()
            .skip(1)
            .filter_map(|l| {
                let c: Vec<&str> = l.split(',').collect();
                if c.first() != Some(&"icu") || c.len() < 12 {
                    return None;
                }
                let n = |i: usize| c[i].parse::<u64>().ok();
                let key = [n(1)?, n(2)?, n(3)?, n(4)?, n(5)?].map(|x| x as u32);
                Some((key, n(6)?, n(11)?))
            })
            .collect()
    })
}

/// The line cells = a + b · proxy through the table's ICU rows.
pub fn fit() -> (f64, f64) {
    static FIT: OnceLock<(f64, f64)> = OnceLock::new();
    *FIT.get_or_init(|| {
        let r = rows();
        let n = r.len().max(1) as f64;
        let mx = r.iter().map(|x| x.2 as f64).sum::<f64>() / n;
        let my = r.iter().map(|x| x.1 as f64).sum::<f64>() / n;
        let sxx: f64 = r.iter().map(|x| (x.2 as f64 - mx).powi(2)).sum();
        let sxy: f64 = r
            .iter()
            .map(|x| (x.2 as f64 - mx) * (x.1 as f64 - my))
            .sum();
        let b = if sxx > 0.0 { sxy / sxx } else { 0.0 };
        (my - b * mx, b)
    })
}

/// One ICU's cells for `dp` with `div_bits` quotient bits per divider stage and bits proxy
/// `proxy`; true when synthesized (a row of the table), false when from the fit.
pub fn icu_cells(dp: &DatapathConfig, div_bits: u32, proxy: u64) -> (u64, bool) {
    let key = [
        dp.frac_bits,
        dp.coord_int_bits,
        dp.t_frac_bits,
        dp.t_int_bits,
        div_bits,
    ];
    match rows().iter().find(|r| r.0 == key) {
        Some(r) => (r.1, true),
        None => {
            let (a, b) = fit();
            ((a + b * proxy as f64).round().max(0.0) as u64, false)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_is_read_and_its_fit_passes_near_its_rows() {
        assert_eq!(rows().len(), 9, "F = 8..16");
        let mut dp = shellsim_hw::config::paper().datapath;
        let f = dp.formats().unwrap().cost();
        let (cells, exact) = icu_cells(&dp, 4, f.multiplier_bits + f.adder_bits);
        assert!(exact && cells > 10_000, "{cells}");
        // Off the table (5 integer bits of t): the fit, within 15 % of a neighbour's size.
        dp.t_int_bits = 5;
        let g = dp.formats().unwrap().cost();
        let (fitted, exact) = icu_cells(&dp, 4, g.multiplier_bits + g.adder_bits);
        assert!(!exact);
        assert!(
            (fitted as f64 / cells as f64 - 1.0).abs() < 0.15,
            "{fitted} vs {cells}"
        );
    }
}
