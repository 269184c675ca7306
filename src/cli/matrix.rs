//! `shellsim matrix`: the whole form-factor matrix on one model, as Matrix Market plus a
//! JSON summary.

use super::args::{parse_range, MatrixRaysArgs, SceneFileArg};
use super::run::Level;
use crate::error::Result;
use crate::limits::human;
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
    /// Only these rows (sources), FROM..TO, TO excluded; default all.
    #[arg(long, value_name = "FROM..TO", value_parser = parse_range)]
    pub sources: Option<(u32, u32)>,
    /// With the machine model: run only K rows (even, at least 4) on the cycle model, a
    /// sample stratified by the untimed walk's work, and estimate the total cycles with a
    /// 95 % interval; every row's form factors come from the untimed model, which the
    /// machine equals ray for ray.
    #[arg(long, value_name = "K")]
    pub sample: Option<usize>,
    /// Seed of the sample's draw (the rays keep --seed).
    #[arg(long, default_value_t = 1, requires = "sample")]
    pub sample_seed: u64,
    /// With the machine model: time every row with the queueing network (`queue`: rows from
    /// the untimed model, cycles estimated; `docs/levels/` gives its error) instead of the
    /// cycle model (`cycle`, the default).
    #[arg(long, value_enum, default_value_t = Level::Cycle, conflicts_with = "sample")]
    pub timing: Level,
    /// The matrix (Matrix Market, .mtx); its summary goes beside it as .json.
    #[arg(long)]
    pub out: PathBuf,
}

/// Runs `shellsim matrix`.
pub fn run(a: &MatrixArgs) -> Result<()> {
    let queue = a.timing == Level::Queue;
    if queue && a.model != Model::Machine {
        return Err(crate::error::Error::Usage(format!(
            "--timing queue times the machine model; --model {} has no timing",
            a.model.name()
        )));
    }
    check_outputs(&[
        Output::file("--out", &a.out),
        Output::file("--out", &a.out.with_extension("json")),
    ])?;
    let scene = a.scene.load()?;
    let cfg = a.rays.machine.load()?;
    let spec = a.rays.spec(a.model, a.sources, scene.patches.len())?;
    let (rays_bytes, rows_bytes) = matrix::memory_estimate(&spec, scene.patches.len(), 1);
    matrix::check_memory(&spec, scene.patches.len(), 1)?;
    outln!(
        "memory: about {} planned (rays in flight {}, rows {}) of the {} limit",
        human(rays_bytes + rows_bytes),
        human(rays_bytes),
        human(rows_bytes),
        human(crate::limits::max_memory()?)
    );
    let start = std::time::Instant::now();
    let (m, sampled) = match a.sample {
        Some(k) => {
            let (m, t) = crate::radiosity::sample::compute_sampled(
                &scene,
                &a.scene.scene,
                &cfg,
                &spec,
                k,
                a.sample_seed,
            )?;
            (m, Some(t))
        }
        None => (
            matrix::compute_timed(&scene, &a.scene.scene, &cfg, &spec, true, queue)?,
            None,
        ),
    };
    let wall = start.elapsed().as_secs_f64();
    let mut summary = Summary::new(&m, &spec, &cfg, a.rays.clock_mhz);
    summary.sampled = sampled;
    summary.timing = queue.then_some("queue");
    let on_patches = |r: &matrix::RowSummary| r.row_sum - r.escaped_weight - r.back_weight;
    let (lo, hi) = summary
        .rows
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), r| {
            (lo.min(on_patches(r)), hi.max(on_patches(r)))
        });
    let back = summary
        .rows
        .iter()
        .fold(0.0f64, |a, r| a.max(r.back_weight));
    outln!(
        "{}: {} model, {} rows × {} rays, {} nonzeros, {:.2} s wall",
        summary.scene,
        spec.model.name(),
        m.rows.len(),
        spec.rays,
        summary.nonzeros,
        wall
    );
    outln!(
        "per row: ΣF over patches {lo:.6} to {hi:.6}, escaped up to {:.3e}, on back sides up to {back:.3e}; |ΣF + escaped + back − 1| up to {:.3e}",
        summary.max_escaped_weight,
        summary.max_row_sum_error,
    );
    if let Some(t) = &summary.sampled {
        outln!(
            "machine, sampled ({} of {} rows in {} strata by the untimed walk's work): {:.0} ± {:.0} cycles (95 %), {:.4} s at {} MHz; {} mismatches vs fixed on the sample",
            t.sampled,
            t.rows,
            t.strata,
            t.cycles_estimate,
            t.cycles_ci95,
            t.cycles_estimate / (a.rays.clock_mhz * 1e6),
            a.rays.clock_mhz,
            t.mismatches_vs_fixed
        );
    }
    if let Some(t) = &summary.machine {
        outln!(
            "machine{}: {} cycles = {:.4} s at {} MHz, pipeline efficiency {:.3}, {} patch loads, {} mismatches vs fixed",
            if summary.timing.is_some() { " (queue level: rows from the untimed model)" } else { "" },
            t.cycles, t.time_s, t.clock_mhz, t.pipeline_efficiency, t.patch_loads, t.mismatches_vs_fixed
        );
    }
    outln!(
        "writing {}: {} nonzeros, about {}",
        a.out.display(),
        summary.nonzeros,
        human(m.matrix_market_estimate())
    );
    matrix::write(&a.out, &m, &summary)?;
    outln!(
        "wrote {} and {}",
        a.out.display(),
        matrix::summary_path(&a.out).display()
    );
    summary.verdict()
}
