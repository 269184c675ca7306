//! Form factors by the float reference: cast a ray set from a source patch through the
//! tracer, sum the weights per hit patch, count escapes; results as JSON.

use crate::error::Result;
use crate::progress::Progress;
use crate::reference::rays::{Directions, RaySet, RaySpec};
use crate::reference::tracer::{Hit, TraceCounts, Tracer};
use crate::scene::Scene;
use rayon::prelude::*;
use serde::Serialize;
use std::path::Path;

/// One form factor F(source → patch).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct FormFactor {
    pub patch: u32,
    pub value: f64,
}

/// What a reference run found. `form_factors` lists every patch hit, by id.
#[derive(Clone, Debug, Serialize)]
pub struct ReferenceReport {
    pub scene: String,
    pub source: u32,
    pub rays: usize,
    pub directions: Directions,
    pub seed: u64,
    pub cell_size: f64,
    /// Rays that hit nothing.
    pub escaped: usize,
    /// Their summed weight (the form factor to "outside").
    pub escaped_weight: f64,
    /// Σ form factors + escaped weight (1 up to rounding).
    pub weight_sum: f64,
    /// The part of the form factors that lands on patches' back sides (a back side
    /// neither emits nor reflects; `matrix` files it apart from the row's entries).
    pub back_weight: f64,
    pub form_factors: Vec<FormFactor>,
    /// Grid cells stepped through, over all rays.
    pub cells_visited: u64,
    /// Ray/patch tests, over all rays.
    pub patch_tests: u64,
    /// Timing is for the terminal only: the JSON stays byte-identical between runs.
    #[serde(skip)]
    pub wall_s: f64,
    #[serde(skip)]
    pub rays_per_s: f64,
}

/// Per-ray nearest hits, in ray order, with the work counted: chunks of 4096 rays through
/// [`Tracer::trace_packet`]. Parallel over chunks, but the result does not depend on the
/// thread count.
pub fn cast(
    tracer: &Tracer,
    set: &RaySet,
    source: Option<u32>,
    mut progress: Option<&mut Progress>,
) -> (Vec<Option<Hit>>, TraceCounts64) {
    const CHUNK: usize = 4096;
    let mut hits = Vec::with_capacity(set.len());
    let mut counts = TraceCounts64::default();
    let mut buf = vec![(None, TraceCounts::default()); set.len().min(CHUNK * 16)];
    for block in set.rays.chunks(CHUNK * 16) {
        let part = &mut buf[..block.len()];
        block
            .par_chunks(CHUNK)
            .zip(part.par_chunks_mut(CHUNK))
            .for_each(|(rays, out)| tracer.trace_packet(rays, source, out));
        for &(h, c) in &*part {
            hits.push(h);
            counts.add(c);
        }
        if let Some(p) = progress.as_deref_mut() {
            p.inc(block.len() as u64);
        }
    }
    (hits, counts)
}

/// Work summed over many rays.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TraceCounts64 {
    pub cells: u64,
    pub nonempty_cells: u64,
    pub tests: u64,
}

impl TraceCounts64 {
    fn add(&mut self, c: TraceCounts) {
        self.cells += c.cells as u64;
        self.nonempty_cells += c.nonempty_cells as u64;
        self.tests += c.tests as u64;
    }
}

/// Form factors from per-ray hits: weights summed per patch in ray order (deterministic).
/// Returns the nonzero form factors by id, the escaped count and the escaped weight.
pub fn form_factors(
    hits: &[Option<Hit>],
    weights: &[f64],
    n_patches: usize,
) -> (Vec<FormFactor>, usize, f64) {
    let mut f = vec![0.0f64; n_patches];
    let mut hit = vec![false; n_patches];
    let (mut escaped, mut escaped_w) = (0usize, 0.0f64);
    for (h, w) in hits.iter().zip(weights) {
        match h {
            Some(h) => {
                f[h.patch as usize] += w;
                hit[h.patch as usize] = true;
            }
            None => {
                escaped += 1;
                escaped_w += w;
            }
        }
    }
    let ff = f
        .into_iter()
        .enumerate()
        .filter(|(i, _)| hit[*i])
        .map(|(i, value)| FormFactor {
            patch: i as u32,
            value,
        })
        .collect();
    (ff, escaped, escaped_w)
}

/// Everything a `reference` run needs besides the tracer and rays.
pub struct RunInfo<'a> {
    pub scene: &'a str,
    pub source: u32,
    pub directions: Directions,
    pub seed: u64,
}

/// Casts `set` from `info.source` and reports form factors.
pub fn run(tracer: &Tracer, set: &RaySet, info: &RunInfo, show_progress: bool) -> ReferenceReport {
    let start = std::time::Instant::now();
    let mut progress = show_progress.then(|| Progress::new(set.len() as u64, "rays"));
    let (hits, counts) = cast(tracer, set, Some(info.source), progress.as_mut());
    if let Some(p) = progress {
        p.finish();
    }
    let wall_s = start.elapsed().as_secs_f64();
    let (form_factors, escaped, escaped_weight) =
        form_factors(&hits, &set.weights, tracer.patches.len());
    let weight_sum = form_factors.iter().map(|f| f.value).sum::<f64>() + escaped_weight;
    let back_weight = hits
        .iter()
        .zip(&set.weights)
        .zip(&set.rays)
        .filter_map(|((h, w), r)| {
            h.filter(|h| tracer.patches[h.patch as usize].normal.dot(r.d) > 0.0)
                .map(|_| w)
        })
        .fold(0.0, |a, w| a + w);
    ReferenceReport {
        scene: info.scene.to_string(),
        source: info.source,
        rays: set.len(),
        directions: info.directions,
        seed: info.seed,
        cell_size: tracer.grid().cell_size,
        escaped,
        escaped_weight,
        weight_sum,
        back_weight,
        form_factors,
        cells_visited: counts.cells,
        patch_tests: counts.tests,
        wall_s,
        rays_per_s: set.len() as f64 / wall_s.max(1e-9),
    }
}

/// The `reference` job: checks `spec` against `scene` (read from `file`), builds the tracer
/// on cells of `cell` and casts the rays with a progress bar.
pub fn run_scene(scene: &Scene, file: &Path, spec: &RaySpec, cell: f64) -> Result<ReferenceReport> {
    spec.validate(scene, file)?;
    crate::limits::check_memory(
        "rays",
        &spec.rays.to_string(),
        "the rays and their results",
        spec.rays as u64 * crate::reference::rays::ray_bytes(),
    )?;
    let tracer = Tracer::new(scene, cell).map_err(|e| e.for_scene(file))?;
    let set = spec.rays(scene);
    let info = RunInfo {
        scene: &scene.name,
        source: spec.source,
        directions: spec.directions,
        seed: spec.seed,
    };
    Ok(run(&tracer, &set, &info, true))
}
