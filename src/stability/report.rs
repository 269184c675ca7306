//! The stability report's outputs: `stability.csv` (every row), `stability.md` (the table at
//! the default format, the differences against bit width, one sentence per case, warnings,
//! unexplained differences with their rays) and `stability.svg` (classes against bits).
//! Every figure is a count: the outputs depend only on the options.

use super::{CaseReport, Counts, Model, Report, Row};
use crate::chart::stability::ClassPanel;
use crate::error::{Error, Result};
use crate::output::write_atomic;
use std::fmt::Write;
use std::path::{Path, PathBuf};

/// The files a report writes into its directory.
pub const FILES: [&str; 3] = ["stability.csv", "stability.md", "stability.svg"];

/// The output paths in `dir`.
pub fn paths(dir: &Path) -> Vec<PathBuf> {
    FILES.iter().map(|f| dir.join(f)).collect()
}

fn opt(v: Option<u64>) -> String {
    v.map_or(String::new(), |x| x.to_string())
}

fn dash(v: Option<u64>) -> String {
    v.map_or("–".into(), |x| x.to_string())
}

/// Every row as CSV.
pub fn csv(r: &Report) -> String {
    let mut s = String::from(
        "case,model,frac_bits,rays,differ,overflow_class,near_origin,grazing,near_edge,tie,\
         coplanar_source,unexplained,leaks,double_hits,overflow,saturated,dda_skipped,\
         dda_repeated,machine_mismatches,deadlocks\n",
    );
    for c in &r.cases {
        for row in &c.rows {
            let k = &row.counts;
            let cl = k.classes.named().map(|(_, n)| n.to_string()).join(",");
            let _ = writeln!(
                s,
                "{},{},{},{},{},{cl},{},{},{},{},{},{},{},{}",
                row.case,
                row.model.name(),
                row.frac_bits.map_or(String::new(), |b| b.to_string()),
                k.rays,
                k.differ,
                opt(k.leaks),
                opt(k.double_hits),
                opt(k.overflow),
                opt(k.saturated),
                opt(k.dda_skipped),
                opt(k.dda_repeated),
                opt(k.machine_mismatches),
                opt(k.deadlocks)
            );
        }
    }
    s
}

/// The row of `model` at `bits` (the float reference has one, at every width).
pub fn find(c: &CaseReport, model: Model, bits: u32) -> Option<&Row> {
    c.rows
        .iter()
        .find(|r| r.model == model && (model == Model::Float || r.frac_bits == Some(bits)))
}

/// "3 near_edge, 1 tie" — the nonzero classes.
fn classes_text(k: &Counts) -> String {
    let v: Vec<String> = k
        .classes
        .named()
        .iter()
        .filter(|(_, n)| *n > 0)
        .map(|(name, n)| format!("{n} {}", name.replace('_', " ")))
        .collect();
    v.join(", ")
}

/// The sentence on one case: which model fails, how, from which width it stops failing.
fn sentence(c: &CaseReport, r: &Report) -> String {
    let mut s = format!("**{}** — {}. ", c.name, c.about);
    let float = find(c, Model::Float, 0).map(|x| &x.counts);
    if let Some(k) = float {
        if k.differ == 0 {
            s.push_str("The float reference never fails here");
        } else {
            let _ = write!(
                s,
                "The float reference differs on {} of {} rays ({})",
                k.differ,
                k.rays,
                classes_text(k)
            );
        }
        let _ = write!(
            s,
            " (leaks: {}, double hits: {}); ",
            k.leaks.unwrap_or(0),
            k.double_hits.unwrap_or(0)
        );
    }
    let failing: Vec<u32> = r
        .bits
        .iter()
        .copied()
        .filter(|&b| find(c, Model::Fixed, b).is_some_and(|x| x.counts.differ > 0))
        .collect();
    let (lo, hi) = (r.bits[0], *r.bits.last().unwrap());
    let at_default = find(c, Model::Fixed, r.default_bits).map(|x| &x.counts);
    match failing.last() {
        None => {
            let _ = write!(s, "the fixed-point model never fails from F = {lo} to {hi}");
        }
        Some(&last) => {
            let first = failing[0];
            let what = match at_default {
                Some(k) if k.differ > 0 => format!(
                    "at the default F = {}: {} of {} rays, {}",
                    r.default_bits,
                    k.differ,
                    k.rays,
                    classes_text(k)
                ),
                _ => format!("none at the default F = {}", r.default_bits),
            };
            if last == hi {
                let _ = write!(
                    s,
                    "the fixed-point model differs from F = {first} and still at F = {hi} ({what})"
                );
            } else {
                let span = if first == last {
                    format!("at F = {first} only")
                } else {
                    format!("from F = {first} up to F = {last}")
                };
                let _ = write!(
                    s,
                    "the fixed-point model differs {span} ({what}) and stops failing from F = {} on",
                    last + 1
                );
            }
        }
    }
    let leaks: u64 = r
        .bits
        .iter()
        .filter_map(|&b| find(c, Model::Fixed, b))
        .map(|x| x.counts.leaks.unwrap_or(0))
        .sum();
    let _ = write!(s, " (leaks over all widths: {leaks}); ");
    let bad: u64 = c
        .rows
        .iter()
        .filter(|x| matches!(x.model, Model::Machine | Model::MachineMin))
        .map(|x| x.counts.machine_mismatches.unwrap_or(0) + x.counts.deadlocks.unwrap_or(0))
        .sum();
    if bad == 0 {
        s.push_str("the machine equals the untimed model at every width, with the configuration's buffers and with the smallest, and never deadlocks. ");
    } else {
        let _ = write!(
            s,
            "the machine differs from the untimed model or deadlocks {bad} times. "
        );
    }
    let _ = write!(s, "Why: {}.", c.why);
    s
}

/// The markdown report; `command` is the one that regenerates it.
pub fn markdown(r: &Report, command: &str) -> String {
    let mut s = String::new();
    let (lo, hi) = (r.bits[0], *r.bits.last().unwrap());
    let _ = writeln!(s, "# Stability: where each method fails\n");
    let _ = writeln!(
        s,
        "Generated by `{command}` — {} rays per case, seed {}, fixed point at F = {lo}..={hi} \
         fractional bits (coordinates, directions and t alike; the default format has \
         F = {}). Regenerate rather than edit: the command rewrites this file, \
         stability.csv and stability.svg byte for byte.\n",
        r.rays, r.seed, r.default_bits
    );
    s.push_str(
        "Each case (src/stability/cases.rs) is a seeded generator of a scene, a source patch \
         and rays whose answer the construction knows: the patch hit (a ray aimed well \
         inside it), or the patches of a watertight surface around the point a ray crosses \
         it (a shared edge or vertex: hitting none of them is a *leak*, two a *double hit*); \
         without either, the float reference is the answer. Models: `float` (the f64 \
         reference tracer), `fixed` (the untimed fixed-point model, `nearest_grid`), \
         `machine` (the cycle machine on the configuration) and `machine-min` (every buffer \
         and queue at 1, subshells of one patch, balancing with work-items of one job); the \
         machine runs the rays the format can hold and its leaks, double hits, exceptions \
         and DDA walks are the untimed model's (equal hits), so they are not recounted. A \
         difference is put in the first class that explains it — `check`'s overflow, \
         near origin, grazing, near edge, tie — after `coplanar source` (a hit on a patch the \
         source lies on); *unexplained* is what none covers. The float reference's \
         differences are classed with LSBs of 2^-30. Overflow counts rays the format cannot \
         hold and datapath overflows; saturated, quotients beyond the t format. DDA skipped \
         and repeated: steps that jumped a cell, left the ray, stood still or went back.\n\n",
    );
    let _ = writeln!(s, "## At the default format (F = {})\n", r.default_bits);
    s.push_str(
        "| case | model | rays | differ | overflow | near origin | grazing | near edge | tie | coplanar source | unexplained | leaks | double hits | overflow / saturated | DDA skipped / repeated | machine ≠ untimed | deadlocks |\n\
         | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n",
    );
    for c in &r.cases {
        for m in [
            Model::Float,
            Model::Fixed,
            Model::Machine,
            Model::MachineMin,
        ] {
            let Some(row) = find(c, m, r.default_bits) else {
                continue;
            };
            let k = &row.counts;
            let cl: Vec<String> = k
                .classes
                .named()
                .iter()
                .map(|(_, n)| n.to_string())
                .collect();
            let pair = |a: Option<u64>, b: Option<u64>| match (a, b) {
                (Some(a), Some(b)) => format!("{a} / {b}"),
                _ => "–".into(),
            };
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
                c.name,
                m.name(),
                k.rays,
                k.differ,
                cl.join(" | "),
                dash(k.leaks),
                dash(k.double_hits),
                pair(k.overflow, k.saturated),
                pair(k.dda_skipped, k.dda_repeated),
                dash(k.machine_mismatches),
                dash(k.deadlocks)
            );
        }
    }
    let _ = writeln!(s, "\n## Against bit width\n");
    s.push_str(
        "![the fixed-point model's differences per class against fractional bits, per case](stability.svg)\n\n\
         The fixed-point model's differences (unexplained in brackets when there are any) per case \
         and width; the float reference's do not depend on the width.\n\n",
    );
    let _ = write!(s, "| case | float |");
    for b in &r.bits {
        let _ = write!(s, " F = {b} |");
    }
    s.push_str("\n| --- | ---: |");
    for _ in &r.bits {
        s.push_str(" ---: |");
    }
    s.push('\n');
    for c in &r.cases {
        let f = find(c, Model::Float, 0).map_or(0, |x| x.counts.differ);
        let _ = write!(s, "| {} | {f} |", c.name);
        for &b in &r.bits {
            let cell = find(c, Model::Fixed, b).map_or("–".into(), |x| {
                let k = &x.counts;
                if k.classes.unexplained > 0 {
                    format!("{} ({})", k.differ, k.classes.unexplained)
                } else {
                    k.differ.to_string()
                }
            });
            let _ = write!(s, " {cell} |");
        }
        s.push('\n');
    }
    let _ = writeln!(s, "\n## Per case\n");
    for c in &r.cases {
        let _ = writeln!(s, "- {}", sentence(c, r));
    }
    let warnings: Vec<&String> = r.cases.iter().flat_map(|c| &c.warnings).collect();
    if !warnings.is_empty() {
        let _ = writeln!(s, "\n## Warnings\n");
        for w in warnings {
            let _ = writeln!(s, "- {w}");
        }
    }
    let _ = writeln!(s, "\n## Unexplained differences\n");
    let mut any = false;
    for c in &r.cases {
        for row in &c.rows {
            for u in &row.unexplained {
                any = true;
                let _ = writeln!(
                    s,
                    "- {} {}{} ray {}: origin {:?}, direction {:?}: expected {}, got {}",
                    c.name,
                    row.model.name(),
                    row.frac_bits.map_or(String::new(), |b| format!(" F = {b}")),
                    u.ray,
                    u.origin,
                    u.direction,
                    u.expected,
                    u.got.map_or("a miss".into(), |p| format!("patch {p}"))
                );
            }
        }
    }
    if !any {
        s.push_str("None.\n");
    }
    s
}

/// The chart: per case the fixed-point model's classes against bits.
pub fn svg(r: &Report) -> Result<String> {
    let panels: Vec<ClassPanel> = r
        .cases
        .iter()
        .map(|c| {
            let rows: Vec<&Row> = r
                .bits
                .iter()
                .filter_map(|&b| find(c, Model::Fixed, b))
                .collect();
            let names = Counts::default().classes.named();
            let series = names
                .iter()
                .enumerate()
                .map(|(k, (name, _))| {
                    (
                        name.replace('_', " "),
                        rows.iter().map(|x| x.counts.classes.named()[k].1).collect(),
                    )
                })
                .collect();
            ClassPanel {
                title: c.name.clone(),
                bits: r.bits.clone(),
                series,
                rays: rows.first().map_or(1, |x| x.counts.rays),
            }
        })
        .collect();
    crate::chart::stability::svg(
        &panels,
        4,
        "fixed point against the exact answer (or the float reference): differences per class against fractional bits",
    )
}

/// Writes the three files into `dir`.
pub fn write(dir: &Path, r: &Report, command: &str) -> Result<()> {
    let p = paths(dir);
    write_atomic(&p[0], csv(r).as_bytes())?;
    write_atomic(&p[1], markdown(r, command).as_bytes())?;
    write_atomic(&p[2], svg(r)?.as_bytes())
}

/// `Err(Error::Check)` when the machine differs from the untimed model or deadlocks
/// anywhere, or the fixed-point model has unexplained differences or leaks at the default
/// format.
pub fn verdict(r: &Report) -> Result<()> {
    let mut bad = Vec::new();
    for c in &r.cases {
        for row in &c.rows {
            let k = &row.counts;
            let m = k.machine_mismatches.unwrap_or(0);
            let d = k.deadlocks.unwrap_or(0);
            if m + d > 0 {
                bad.push(format!(
                    "{} {} F = {:?}: {m} mismatches against the untimed model, {d} deadlocks",
                    c.name,
                    row.model.name(),
                    row.frac_bits
                ));
            }
            let at_default = row.frac_bits == Some(r.default_bits) && row.model == Model::Fixed;
            let leaks = k.leaks.unwrap_or(0);
            if at_default && (k.classes.unexplained > 0 || leaks > 0) {
                bad.push(format!(
                    "{} fixed F = {}: {} unexplained differences, {leaks} leaks",
                    c.name, r.default_bits, k.classes.unexplained
                ));
            }
        }
    }
    if bad.is_empty() {
        Ok(())
    } else {
        Err(Error::Check(bad.join("; ")))
    }
}
