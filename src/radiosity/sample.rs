//! Sampled timing of a whole matrix (`matrix --model machine --sample K`): every row's
//! results from the untimed fixed-point model (which the machine equals ray for ray), the
//! machine's cycles from a stratified sample of K rows on the cycle model, and the total
//! cycles estimated with a 95 % interval.
//!
//! The design: the rows sorted by the untimed walk's work (DDA cells plus patch tests over
//! the row's rays, which the machine's CTUs and ICUs spend their cycles on) cut into K/2
//! strata of equal size, two rows drawn from each (seeded). The total is the separate ratio
//! estimate Σ_h X_h · ȳ_h / x̄_h (X_h the stratum's whole work) with variance
//! Σ_h N_h² (1 − 2/N_h) s²_d,h / 2 over the residuals d = y − R_h x (Cochran, *Sampling
//! Techniques*, 6.10); every sampled row's hits are checked against the untimed model's.

use crate::error::{Error, Result};
use crate::radiosity::matrix::{
    leak_check, records, run_row, validate, FormMatrix, MatrixSpec, Model, RowRun, SampledTiming,
    Shared,
};
use crate::scene::Scene;
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rayon::prelude::*;
use shellsim_hw::config::MachineConfig;
use shellsim_hw::Exceptions;
use std::path::Path;

/// The untimed walk's work of source `i`'s row: its run and Σ (cells + patch tests).
fn fixed_row(sh: &Shared, spec: &MatrixSpec, i: u32) -> Result<(RowRun, u64)> {
    let host = sh.host.as_ref().expect("built for the machine model");
    let set = crate::radiosity::matrix::rays_of(sh.scene, spec, i);
    let recs = records(sh, host, &set, i)?;
    let mut work = 0u64;
    let hits = recs
        .iter()
        .map(|r| {
            let mut e = Exceptions::default();
            let (h, c) = host.scene.nearest_grid(r, Some(i), &mut e);
            work += c.cells as u64 + c.tests as u64;
            h.map(|h| h.patch)
        })
        .collect();
    Ok((
        RowRun {
            set,
            hits,
            stats: None,
            queue: None,
        },
        work,
    ))
}

/// Every row of `spec.sources` from the untimed model, the machine's cycles estimated from
/// `k` sampled rows (k even, at least 4, at most the rows) drawn with `sample_seed` (the
/// rays keep `spec.seed`). `spec.model` must be the machine.
pub fn compute_sampled(
    scene: &Scene,
    file: &Path,
    cfg: &MachineConfig,
    spec: &MatrixSpec,
    k: usize,
    sample_seed: u64,
) -> Result<(FormMatrix, SampledTiming)> {
    validate(spec, scene, file)?;
    let rows_n = spec.sources.len();
    if spec.model != Model::Machine || k < 4 || !k.is_multiple_of(2) || k > rows_n {
        return Err(Error::param(
            "sample",
            format!(
                "{k}: want an even number of rows from 4 to the {rows_n} rows, with the machine model"
            ),
        ));
    }
    crate::radiosity::matrix::check_memory(spec, scene.patches.len(), 1)?;
    let sh = Shared::new(scene, file, cfg, Model::Machine)?;
    let ids: Vec<u32> = spec.sources.clone().collect();
    let fixed: Vec<Result<(RowRun, u64)>> =
        ids.par_iter().map(|&i| fixed_row(&sh, spec, i)).collect();
    let mut runs = Vec::with_capacity(rows_n);
    let mut work = Vec::with_capacity(rows_n);
    for (r, &i) in fixed.into_iter().zip(&ids) {
        let (run, w) = r?;
        if sh.closed {
            leak_check(&sh, spec, i, &run)?;
        }
        runs.push(run);
        work.push(w);
    }
    // Strata: the rows in order of work (then id), cut into k/2 runs of equal size.
    let mut order: Vec<usize> = (0..rows_n).collect();
    order.sort_by_key(|&r| (work[r], r));
    let strata = k / 2;
    let mut rng = rand_pcg::Pcg64::seed_from_u64(sample_seed);
    let mut picks: Vec<(usize, Vec<usize>)> = Vec::with_capacity(strata); // (N_h, rows)
    for h in 0..strata {
        let (lo, hi) = (h * rows_n / strata, (h + 1) * rows_n / strata);
        let chosen: Vec<usize> = order[lo..hi]
            .choose_multiple(&mut rng, 2)
            .copied()
            .collect();
        picks.push((hi - lo, chosen));
    }
    let sample: Vec<usize> = picks.iter().flat_map(|p| p.1.iter().copied()).collect();
    let timed: Vec<Result<(usize, u64, u64)>> = sample
        .par_iter()
        .map(|&r| {
            let i = ids[r];
            let run = run_row(&sh, spec, i)?;
            let stats = run.stats.as_ref().expect("the machine's statistics");
            // The machine's hits are the untimed model's, ray for ray.
            let differ = run
                .hits
                .iter()
                .zip(&runs[r].hits)
                .filter(|(a, b)| a != b)
                .count() as u64;
            Ok((r, stats.cycles, stats.mismatches_vs_fixed + differ))
        })
        .collect();
    let mut cycles = vec![0u64; rows_n];
    let mut mismatches = 0;
    for t in timed {
        let (r, c, m) = t?;
        cycles[r] = c;
        mismatches += m;
    }
    // The separate ratio estimator (Cochran 6.10): per stratum, the sampled rows' cycles
    // per unit of work times the stratum's whole work; its variance from the residuals
    // d = y − R_h x of the two rows.
    let (mut total, mut var) = (0.0f64, 0.0f64);
    for (h, (n_h, rows)) in picks.iter().enumerate() {
        let (lo, hi) = (h * rows_n / strata, (h + 1) * rows_n / strata);
        let x_h: f64 = order[lo..hi].iter().map(|&r| work[r] as f64).sum();
        let y: Vec<f64> = rows.iter().map(|&r| cycles[r] as f64).collect();
        let x: Vec<f64> = rows.iter().map(|&r| work[r] as f64).collect();
        let n_h = *n_h as f64;
        let (sy, sx) = (y.iter().sum::<f64>(), x.iter().sum::<f64>());
        let est = if sx > 0.0 {
            x_h * sy / sx
        } else {
            n_h * sy / y.len() as f64
        };
        total += est;
        if y.len() == 2 && n_h > 2.0 {
            let r = if sx > 0.0 { sy / sx } else { 0.0 };
            let s2: f64 = y.iter().zip(&x).map(|(y, x)| (y - r * x).powi(2)).sum();
            var += n_h * n_h * (1.0 - 2.0 / n_h) * s2 / 2.0;
        }
    }
    let mut sample_ids: Vec<u32> = sample.iter().map(|&r| ids[r]).collect();
    sample_ids.sort_unstable();
    let timing = SampledTiming {
        rows: rows_n,
        sampled: sample.len(),
        strata,
        sample: sample_ids,
        cycles_estimate: total,
        cycles_ci95: 1.96 * var.sqrt(),
        sampled_cycles: sample.iter().map(|&r| cycles[r]).sum(),
        mismatches_vs_fixed: mismatches,
    };
    let m = FormMatrix {
        scene: scene.name.clone(),
        n: scene.patches.len(),
        rows: runs
            .iter()
            .zip(&ids)
            .map(|(run, &i)| run.row(scene, i))
            .collect(),
        machine: Vec::new(),
    };
    Ok((m, timing))
}
