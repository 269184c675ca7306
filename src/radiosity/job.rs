//! `shellsim radiosity`: the matrix (computed, or read from a file), the solution, the
//! per-patch CSV, the picture; with a comparison, both models' solutions, their pictures
//! side by side, the false-colour difference and the figures, also in units of the float
//! estimator's noise.

use crate::error::{Error, Result};
use crate::output::write_json;
use crate::radiosity::compare::{compare, relative, Comparison};
use crate::radiosity::matrix::{self, FormMatrix, MachineTotals, MatrixSpec, Model, Summary};
use crate::radiosity::render::{self, Camera, HitBuffer, Shading};
use crate::radiosity::solve::{self, Energy, Method, Solution, SolveParams, System};
use crate::reference::tracer::Tracer;
use crate::scene::Scene;
use serde::Serialize;
use shellsim_hw::config::MachineConfig;
use std::path::{Path, PathBuf};

/// The picture to make.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct ImageSpec {
    pub camera: Camera,
    pub width: u32,
    pub height: u32,
    pub shading: Shading,
}

/// Everything `shellsim radiosity` does.
#[derive(Clone, Debug)]
pub struct JobSpec {
    /// The matrix to compute (its model is the one solved without a comparison).
    pub matrix: MatrixSpec,
    /// Read the matrix from here instead of computing it.
    pub matrix_file: Option<PathBuf>,
    pub solve: SolveParams,
    pub image: ImageSpec,
    /// Compare the second model's solution against the first's.
    pub compare: Option<(Model, Model)>,
    pub clock_mhz: f64,
}

/// One model's solution with what it was computed from.
#[derive(Clone, Debug, Serialize)]
pub struct Solved {
    pub model: Model,
    #[serde(skip)]
    pub matrix: FormMatrix,
    pub iterations: usize,
    pub residual: f64,
    pub converged: bool,
    pub energy: Energy,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub machine: Option<MachineTotals>,
    #[serde(skip)]
    pub b: Vec<[f64; 3]>,
}

/// The JSON a job writes (solution.json, or compare.json with a comparison).
#[derive(Clone, Debug, Serialize)]
pub struct JobReport {
    pub scene: String,
    pub rays_per_source: usize,
    pub seed: u64,
    pub method: Method,
    pub system: System,
    pub tol: f64,
    pub image: ImageSpec,
    pub solutions: Vec<Solved>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub comparison: Option<Comparison>,
}

/// The scene, the file it was read from, the machine configuration.
#[derive(Clone, Copy)]
pub struct Inputs<'a> {
    pub scene: &'a Scene,
    pub file: &'a Path,
    pub cfg: &'a MachineConfig,
}

/// The matrix of `model` (computed for `spec` with `model`, or read from `file`) and its
/// solution.
pub fn solve_model(
    inputs: Inputs,
    spec: &MatrixSpec,
    model: Model,
    matrix_file: Option<&Path>,
    params: SolveParams,
    clock_mhz: f64,
    progress: bool,
) -> Result<Solved> {
    let Inputs { scene, file, cfg } = inputs;
    let (m, totals) = match matrix_file {
        Some(f) => (matrix::read(f, scene)?, None),
        None => {
            let spec = MatrixSpec {
                model,
                ..spec.clone()
            };
            // The matrix, then the solver's transposed copy and its iterate.
            matrix::check_memory(&spec, scene.patches.len(), 3)?;
            let m = matrix::compute(scene, file, cfg, &spec, progress)?;
            let summary = Summary::new(&m, &spec, cfg, clock_mhz);
            summary.verdict()?;
            (m, summary.machine)
        }
    };
    let Solution {
        iterations,
        residual,
        converged,
        energy,
        b,
        ..
    } = {
        solve::check_solvable(&m, scene, file)?;
        solve::solve(&m, scene, params)?
    };
    Ok(Solved {
        model,
        matrix: m,
        iterations,
        residual,
        converged,
        energy,
        machine: totals,
        b,
    })
}

/// Runs the job, writing into `out`: `radiosity.csv`, `image.png` and `solution.json`; with
/// a comparison `A,B`: `A.csv`, `B.csv`, `A.png`, `B.png`, `compare.png` (A | B),
/// `diff.png` (the relative difference of B against A, false colour, scale bar) and
/// `compare.json`. Everything is computed before anything is written.
pub fn run(
    scene: &Scene,
    file: &Path,
    cfg: &MachineConfig,
    job: &JobSpec,
    out: &Path,
    progress: bool,
) -> Result<JobReport> {
    if out.is_file() {
        return Err(Error::param(
            "out",
            format!("{} is a file; want a directory", out.display()),
        ));
    }
    if !(job.clock_mhz.is_finite() && job.clock_mhz > 0.0) {
        return Err(Error::param(
            "clock_mhz",
            format!("{} must be a finite number above 0", job.clock_mhz),
        ));
    }
    let tracer = Tracer::new(
        scene,
        crate::config::cell_size(cfg.machine.cell_size, scene.size()),
    )?;
    let im = &job.image;
    let hits: HitBuffer = render::cast(&tracer, &im.camera, im.width, im.height);
    let mf = job.matrix_file.as_deref();
    let solve = |model: Model, mf: Option<&Path>, spec: &MatrixSpec| {
        solve_model(
            Inputs { scene, file, cfg },
            spec,
            model,
            mf,
            job.solve,
            job.clock_mhz,
            progress,
        )
    };
    let mut files: Vec<(PathBuf, Output)> = Vec::new();
    let (solutions, comparison) = match job.compare {
        None => {
            let s = solve(job.matrix.model, mf, &job.matrix)?;
            files.push((out.join("radiosity.csv"), Output::Csv(s.b.clone())));
            files.push((
                out.join("image.png"),
                Output::Png(render::picture(scene, &hits, &s.b, im.shading)),
            ));
            (vec![s], None)
        }
        Some((a, b)) => {
            let sa = solve(a, None, &job.matrix)?;
            let sb = solve(b, None, &job.matrix)?;
            // A second float solution from another seed: the estimator's own noise.
            let other = MatrixSpec {
                seed: job.matrix.seed.wrapping_add(1),
                ..job.matrix.clone()
            };
            let noise = solve(Model::Float, None, &other)?;
            let cmp = compare(a.name(), &sa.b, b.name(), &sb.b, &noise.b);
            let pa = render::picture(scene, &hits, &sa.b, im.shading);
            let pb = render::picture(scene, &hits, &sb.b, im.shading);
            let rel = relative(&sa.b, &sb.b);
            let dark: Vec<bool> = sa.b.iter().map(|x| render::luminance(*x) <= 0.0).collect();
            let scale = render::visible_scale(&hits, &rel, &dark, 1e-6);
            files.push((
                out.join(format!("{}.csv", a.name())),
                Output::Csv(sa.b.clone()),
            ));
            files.push((
                out.join(format!("{}.csv", b.name())),
                Output::Csv(sb.b.clone()),
            ));
            files.push((
                out.join("compare.png"),
                Output::Png(render::side_by_side(&pa, a.name(), &pb, b.name())),
            ));
            files.push((
                out.join("diff.png"),
                Output::Png(render::difference_picture(&hits, &rel, &dark, scale)),
            ));
            files.push((out.join(format!("{}.png", a.name())), Output::Png(pa)));
            files.push((out.join(format!("{}.png", b.name())), Output::Png(pb)));
            (vec![sa, sb], Some(cmp))
        }
    };
    let report = JobReport {
        scene: scene.name.clone(),
        rays_per_source: job.matrix.rays,
        seed: job.matrix.seed,
        method: job.solve.method,
        system: job.solve.system,
        tol: job.solve.tol,
        image: job.image,
        solutions,
        comparison,
    };
    for (path, o) in &files {
        match o {
            Output::Csv(b) => solve::write_csv(path, scene, b)?,
            Output::Png(p) => render::write_png(path, p)?,
        }
    }
    let name = if job.compare.is_some() {
        "compare.json"
    } else {
        "solution.json"
    };
    write_json(&out.join(name), &report)?;
    Ok(report)
}

enum Output {
    Csv(Vec<[f64; 3]>),
    Png(render::Picture),
}
