//! Cost from synthesis: Yosys's generic `synth` of a unit (cells, flip-flops, and the
//! longest topological path between flip-flops as the frequency proxy) and one FPGA mapping
//! (`synth_ecp5`: LUT4s and 18×18 multipliers), cached by the hash of the package and the
//! sources, beside the bits proxy the model's sweeps use (`Formats::cost`).

use super::layout::{Params, Unit};
use crate::error::{Error, Result};
use std::path::Path;
use std::process::Command;

/// A unit's synthesized cost at one configuration.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SynthCost {
    pub unit: String,
    pub frac_bits: u32,
    pub coord_int_bits: u32,
    pub t_frac_bits: u32,
    pub t_int_bits: u32,
    pub divider_bits_per_stage: u32,
    /// Generic gates and flip-flops (`synth; stat`).
    pub cells: u64,
    pub flip_flops: u64,
    /// Longest path in gates between flip-flops (`ltp -noff`).
    pub depth: u64,
    /// ECP5: LUT4s and MULT18X18D blocks (`synth_ecp5; stat`); `None` when not asked.
    pub luts: Option<u64>,
    pub multipliers: Option<u64>,
    /// The model's proxy: multiplier bits + adder bits of one ICU datapath.
    pub bits_proxy: u64,
}

/// The count in a `stat` report of cells whose type starts with any of `prefixes`.
fn count_cells(stat: &str, prefixes: &[&str]) -> u64 {
    stat.lines()
        .filter_map(|l| {
            let mut w = l.split_whitespace();
            let (name, n) = (w.next()?, w.next()?);
            prefixes
                .iter()
                .any(|p| name.starts_with(p))
                .then(|| n.parse::<u64>().ok())
                .flatten()
        })
        .sum()
}

/// The value after `label` on the last line holding it.
fn number_after(text: &str, label: &str) -> Option<u64> {
    text.lines().rev().find_map(|l| {
        let at = l.find(label)? + label.len();
        l[at..]
            .trim_start_matches([' ', ':', '='])
            .split(|c: char| !c.is_ascii_digit())
            .next()?
            .parse()
            .ok()
    })
}

/// Runs a Yosys script in `dir`; its log's text.
fn yosys(dir: &Path, script: &str) -> Result<String> {
    let path = dir.join("run.ys");
    std::fs::write(&path, script).map_err(|e| Error::io(&path, e))?;
    let out = Command::new("yosys")
        .current_dir(dir)
        .args(["-q", "-l", "run.log", "run.ys"])
        .output()
        .map_err(|e| Error::io(Path::new("yosys"), e))?;
    let log = std::fs::read_to_string(dir.join("run.log")).unwrap_or_default();
    if !out.status.success() {
        let err: Vec<&str> = log
            .lines()
            .filter(|l| l.contains("ERROR"))
            .take(5)
            .collect();
        return Err(Error::Check(format!(
            "yosys failed in {}: {}",
            dir.display(),
            err.join("; ")
        )));
    }
    Ok(log)
}

/// The synthesized cost of `unit` for `p` (with the ECP5 mapping when `fpga`), from the
/// cache when it holds it.
pub fn synth_cost(p: &Params, unit: Unit, fpga: bool) -> Result<SynthCost> {
    if !super::have("yosys") {
        return Err(super::missing_tool("yosys", "yosys"));
    }
    let pkg = super::package_sv(p, "the configuration");
    let src = super::SOURCES
        .iter()
        .find(|(n, _)| *n == format!("{}.sv", unit.module()))
        .map(|(_, t)| *t)
        .expect("every unit has a source");
    let key = super::hash_of(&[&pkg, src, if fpga { "ecp5" } else { "" }, "cost 2"]);
    let cache = super::cache_dir().join(format!("cost-{}-{key}.json", unit.name()));
    if let Some(c) = std::fs::read_to_string(&cache)
        .ok()
        .and_then(|t| serde_json::from_str::<SynthCost>(&t).ok())
    {
        return Ok(c);
    }
    let dir = super::cache_dir().join(format!(
        "synth-{}-{key}.tmp{}",
        unit.name(),
        std::process::id()
    ));
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    for (n, t) in [("shellsim_cfg.sv", pkg.as_str()), ("unit.sv", src)] {
        std::fs::write(dir.join(n), t).map_err(|e| Error::io(&dir.join(n), e))?;
    }
    let top = unit.module();
    let read = "read_verilog -sv shellsim_cfg.sv unit.sv\n";
    let log = yosys(
        &dir,
        &format!(
            "{read}synth -top {top} -flatten\ntee -o stat.txt stat\ntee -o ltp.txt ltp -noff\n"
        ),
    )?;
    let stat = std::fs::read_to_string(dir.join("stat.txt")).unwrap_or(log.clone());
    let ltp = std::fs::read_to_string(dir.join("ltp.txt")).unwrap_or(log);
    let cells = number_after(&stat, "Number of cells")
        .ok_or_else(|| Error::Check(format!("no cell count in {}", dir.display())))?;
    let depth = number_after(&ltp, "(length")
        .ok_or_else(|| Error::Check(format!("no path length in {}", dir.display())))?;
    let (mut luts, mut multipliers) = (None, None);
    if fpga {
        yosys(
            &dir,
            &format!("{read}synth_ecp5 -top {top}\ntee -o ecp5.txt stat\n"),
        )?;
        let e = std::fs::read_to_string(dir.join("ecp5.txt")).unwrap_or_default();
        luts = Some(count_cells(&e, &["LUT4"]));
        multipliers = Some(count_cells(&e, &["MULT18X18D"]));
    }
    let dp = p.f.cost();
    let c = SynthCost {
        unit: unit.name().into(),
        frac_bits: p.f.coord.frac_bits,
        coord_int_bits: p.f.coord.int_bits,
        t_frac_bits: p.f.t.frac_bits,
        t_int_bits: p.f.t.int_bits,
        divider_bits_per_stage: p.div.bits_per_stage,
        cells,
        flip_flops: count_cells(&stat, &["$_DFF", "$_SDFF", "$_DFFE", "$_SDFFE", "$_SDFFCE"]),
        depth,
        luts,
        multipliers,
        bits_proxy: dp.multiplier_bits + dp.adder_bits,
    };
    let _ = std::fs::remove_dir_all(&dir);
    let text = serde_json::to_string_pretty(&c).expect("serializable");
    crate::output::write_atomic(&cache, text.as_bytes())?;
    Ok(c)
}

/// The table `size` reads (hw/rtl/cost.csv, src/size/synth.rs): one CSV line per row.
pub fn csv(rows: &[SynthCost]) -> String {
    let mut s = String::from("unit,frac_bits,coord_int_bits,t_frac_bits,t_int_bits,divider_bits_per_stage,cells,flip_flops,depth,luts,multipliers,bits_proxy\n");
    let opt = |x: Option<u64>| x.map_or(String::new(), |v| v.to_string());
    for r in rows {
        s.push_str(&format!(
            "{},{},{},{},{},{},{},{},{},{},{},{}\n",
            r.unit,
            r.frac_bits,
            r.coord_int_bits,
            r.t_frac_bits,
            r.t_int_bits,
            r.divider_bits_per_stage,
            r.cells,
            r.flip_flops,
            r.depth,
            opt(r.luts),
            opt(r.multipliers),
            if r.unit == "icu" {
                r.bits_proxy.to_string()
            } else {
                String::new()
            }
        ));
    }
    s
}

/// The least-squares line cells ≈ a + b · proxy over `rows`, and its correlation r.
pub fn fit(rows: &[(f64, f64)]) -> (f64, f64, f64) {
    let n = rows.len() as f64;
    let (sx, sy) = rows
        .iter()
        .fold((0.0, 0.0), |(a, b), (x, y)| (a + x, b + y));
    let (mx, my) = (sx / n, sy / n);
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for (x, y) in rows {
        sxx += (x - mx) * (x - mx);
        sxy += (x - mx) * (y - my);
        syy += (y - my) * (y - my);
    }
    let b = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    let r = if sxx > 0.0 && syy > 0.0 {
        sxy / (sxx * syy).sqrt()
    } else {
        0.0
    };
    (my - b * mx, b, r)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stat_and_ltp_reports_are_read() {
        let stat = "=== top ===\n   Number of cells:              65048\n     $_ANDNOT_ 21560\n     $_DFFE_PP_ 1136\n     $_SDFFCE_PN0P_ 192\n     LUT4 3000\n     MULT18X18D 28\n";
        assert_eq!(number_after(stat, "Number of cells"), Some(65048));
        assert_eq!(count_cells(stat, &["$_DFF", "$_SDFF"]), 1328);
        assert_eq!(count_cells(stat, &["MULT18X18D"]), 28);
        let ltp = "Longest topological path in shellsim_icu (length=84):\n";
        assert_eq!(number_after(ltp, "(length"), Some(84));
        let (a, b, r) = fit(&[(1.0, 3.0), (2.0, 5.0), (3.0, 7.0)]);
        assert!((a - 1.0).abs() < 1e-12 && (b - 2.0).abs() < 1e-12 && (r - 1.0).abs() < 1e-12);
    }
}
