//! `shellsim sweep bits`: mismatch rate and form-factor error against fractional bits.

use super::args::{DatapathArgs, SceneSourceArgs};
use crate::error::{Error, Result};
use crate::fixed::sweep;
use crate::output::{check_outputs, file_stem, Output};
use crate::reference::rays::{Directions, RaySpec};
use clap::Subcommand;
use std::path::PathBuf;

#[derive(Subcommand, Debug)]
pub enum SweepCmd {
    /// Mismatch rate and form-factor error against fractional bits (CSV + SVG).
    Bits(BitsArgs),
}

/// Arguments of `shellsim sweep bits`.
#[derive(clap::Args, Debug)]
pub struct BitsArgs {
    #[command(flatten)]
    pub input: SceneSourceArgs,
    /// Number of rays (default: the paper's 969 × its largest Hi_Low_Ratio, 30).
    #[arg(long, default_value_t = 29070)]
    pub rays: usize,
    /// Direction set.
    #[arg(long, value_enum, default_value_t = Directions::Malley)]
    pub directions: Directions,
    /// Seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Fewest fractional bits.
    #[arg(long, default_value_t = 8)]
    pub from: u32,
    /// Most fractional bits.
    #[arg(long, default_value_t = 30)]
    pub to: u32,
    /// Output directory: bits-<scene>.csv and bits-<scene>.svg.
    #[arg(long, default_value = "out")]
    pub out: PathBuf,
    #[command(flatten)]
    pub datapath: DatapathArgs,
}

/// Runs `shellsim sweep ...`.
pub fn run(c: &SweepCmd) -> Result<()> {
    let SweepCmd::Bits(a) = c;
    let file = a.input.path();
    let (scene, source) = a.input.load()?;
    let spec = RaySpec {
        source,
        rays: a.rays,
        directions: a.directions,
        seed: a.seed,
    };
    spec.validate(&scene, file)?;
    if a.from > a.to {
        return Err(Error::Usage(format!(
            "--from {} is above --to {}",
            a.from, a.to
        )));
    }
    let stem = format!("bits-{}", file_stem(&scene.name));
    check_outputs(&[
        Output::dir("--out", &a.out),
        Output::file("--out", &a.out.join(format!("{stem}.csv"))),
        Output::file("--out", &a.out.join(format!("{stem}.svg"))),
    ])?;
    let cfg = a.datapath.resolve_config()?;
    // Every width of the sweep must make a datapath; the error names the flag that asked
    // for the width (--from for the first, --to for a wider one).
    for b in a.from..=a.to {
        let mut d = cfg.datapath;
        d.frac_bits = b;
        d.t_frac_bits = b;
        if let Err(e) = d.formats() {
            let (flag, v) = if b == a.from {
                ("--from", a.from)
            } else {
                ("--to", a.to)
            };
            return Err(Error::Usage(format!(
                "{flag} {v}: {b} fractional bits make no datapath: {}: {}",
                e.key, e.what
            )));
        }
    }
    let rows = sweep::sweep_scene(
        &scene,
        file,
        cfg.datapath,
        &spec,
        crate::config::cell_size(cfg.machine.cell_size, scene.size()),
        a.from..=a.to,
    )?;
    crate::output::outln!(
        "{:>4} {:>10} {:>12} {:>12} {:>11} {:>8}",
        "F",
        "mismatches",
        "ff_err_max",
        "sampling",
        "mult bits",
        "unexpl."
    );
    for r in &rows {
        crate::output::outln!(
            "{:>4} {:>10} {:>12.3e} {:>12.3e} {:>11} {:>8}",
            r.frac_bits,
            r.report.mismatches,
            r.report.ff_err_max,
            r.report.ff_sampling_err,
            r.cost.multiplier_bits,
            r.report.unexplained_mismatches
        );
    }
    match sweep::recommended(&rows) {
        Some(b) => {
            crate::output::outln!(
                "fewest bits whose form-factor error stays under the sampling error: {b}"
            )
        }
        None => {
            crate::output::outln!(
                "no width in the sweep keeps the form-factor error under the sampling error"
            )
        }
    }
    sweep::write(&a.out, &stem, &rows, &sweep::title(&scene, &spec))?;
    crate::output::outln!("wrote {}/{stem}.csv and .svg", a.out.display());
    Ok(())
}
