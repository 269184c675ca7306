//! `shellsim sweep bits`: the float reference against the fixed-point model over fractional
//! bit widths — mismatch rate and form-factor error against bits, beside the estimator's own
//! sampling error and a rough hardware cost — as CSV and an SVG chart.

use crate::chart::bits::BitsPoint;
use crate::error::{Error, Result};
use crate::fixed::check::{check, CheckReport};
use crate::fixed::records::HostFixed;
use crate::output::write_atomic;
use crate::reference::rays::{RaySet, RaySpec};
use crate::reference::tracer::Tracer;
use crate::Scene;
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
            .map_err(|e| Error::param("bits", format!("{b}: {}: {}", e.key, e.what)))?;
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

/// The rows as the chart's points.
pub fn chart_points(rows: &[BitsRow]) -> Vec<BitsPoint> {
    rows.iter()
        .map(|r| BitsPoint {
            frac_bits: r.frac_bits,
            mismatch_rate: r.report.mismatches as f64 / r.report.rays as f64,
            ff_err_max: r.report.ff_err_max,
            ff_sampling_err: r.report.ff_sampling_err,
            multiplier_bits: r.cost.multiplier_bits,
            adder_bits: r.cost.adder_bits,
        })
        .collect()
}

/// The chart (see [`crate::chart::bits`]) of the rows.
pub fn svg(rows: &[BitsRow], title: &str) -> Result<String> {
    crate::chart::bits::svg(&chart_points(rows), recommended(rows), title)
}

/// Writes `bits.csv` and `bits.svg` (named after `stem`) into `dir`.
pub fn write(dir: &Path, stem: &str, rows: &[BitsRow], title: &str) -> Result<()> {
    write_atomic(&dir.join(format!("{stem}.csv")), csv(rows).as_bytes())?;
    write_atomic(
        &dir.join(format!("{stem}.svg")),
        svg(rows, title)?.as_bytes(),
    )
}

/// The `sweep bits` job: checks `spec` against `scene` (read from `file`), builds the float
/// tracer on cells of `cell` and sweeps `bits` from the datapath `base`.
pub fn sweep_scene(
    scene: &Scene,
    file: &Path,
    base: DatapathConfig,
    spec: &RaySpec,
    cell: f64,
    bits: std::ops::RangeInclusive<u32>,
) -> Result<Vec<BitsRow>> {
    spec.validate(scene, file)?;
    crate::fixed::check::check_memory(spec)?;
    let tracer = Tracer::new(scene, cell).map_err(|e| e.for_scene(file))?;
    let set = spec.rays(scene);
    let input = SweepInput {
        scene,
        file,
        tracer: &tracer,
        cell,
        set: &set,
        source: spec.source,
    };
    sweep_bits(&input, base, bits)
}

/// The chart's title for a sweep of `spec` on `scene`.
pub fn title(scene: &Scene, spec: &RaySpec) -> String {
    format!(
        "{}: fixed point vs float, {} rays ({}) from patch {}",
        scene.name,
        spec.rays,
        spec.directions.name(),
        spec.source
    )
}
