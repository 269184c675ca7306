//! `shellsim matrix`: the whole form-factor matrix on one model, as Matrix Market plus a
//! JSON summary.

use super::args::{MatrixRaysArgs, SceneFileArg};
use crate::error::Result;
use crate::output::{check_outputs, outln, Output};
use crate::radiosity::matrix::{self, Model, Summary};
use std::path::PathBuf;

/// Arguments of `shellsim matrix`.
#[derive(clap::Args, Debug)]
pub struct MatrixArgs {
    #[command(flatten)]
    pub scene: SceneFileArg,
    /// The model that computes the rows.
    #[arg(long, value_enum)]
    pub model: Model,
    #[command(flatten)]
    pub rays: MatrixRaysArgs,
    /// The matrix (Matrix Market, .mtx); its summary goes beside it as .json.
    #[arg(long)]
    pub out: PathBuf,
}

/// Runs `shellsim matrix`.
pub fn run(a: &MatrixArgs) -> Result<()> {
    check_outputs(&[
        Output::file("--out", &a.out),
        Output::file("--out", &a.out.with_extension("json")),
    ])?;
    let scene = a.scene.load()?;
    let cfg = a.rays.machine.load()?;
    let spec = a.rays.spec(a.model, scene.patches.len())?;
    let start = std::time::Instant::now();
    let m = matrix::compute(&scene, &a.scene.scene, &cfg, &spec, true)?;
    let wall = start.elapsed().as_secs_f64();
    let summary = Summary::new(&m, &spec, &cfg, a.rays.clock_mhz);
    outln!(
        "writing {}: {} nonzeros, about {}",
        a.out.display(),
        summary.nonzeros,
        crate::limits::human(m.matrix_market_estimate())
    );
    matrix::write(&a.out, &m, &summary)?;
    outln!(
        "{}: {} model, {} rows × {} rays, {} nonzeros, max |row sum − 1| {:.3e}, max escaped {:.3e}, {:.2} s wall",
        summary.scene,
        spec.model.name(),
        m.rows.len(),
        spec.rays,
        summary.nonzeros,
        summary.max_row_sum_error,
        summary.max_escaped_weight,
        wall
    );
    if let Some(t) = &summary.machine {
        outln!(
            "machine: {} cycles = {:.4} s at {} MHz, pipeline efficiency {:.3}, {} patch loads, {} mismatches vs fixed",
            t.cycles, t.time_s, t.clock_mhz, t.pipeline_efficiency, t.patch_loads, t.mismatches_vs_fixed
        );
    }
    outln!(
        "wrote {} and {}",
        a.out.display(),
        matrix::summary_path(&a.out).display()
    );
    summary.verdict()
}
