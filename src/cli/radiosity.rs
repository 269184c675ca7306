//! `shellsim radiosity`: solve B = E + ρ F B on one model's matrix (computed, or read with
//! `--matrix`), write the per-patch CSV and a picture; `--compare A,B` compares two models.

use super::args::{MatrixRaysArgs, SceneFileArg};
use crate::error::{Error, Result};
use crate::output::{check_outputs, outln, Output};
use crate::radiosity::job::{self, ImageSpec, JobSpec};
use crate::radiosity::matrix::Model;
use crate::radiosity::render::{up_axis, Camera, Shading};
use crate::radiosity::solve::{Method, SolveParams, System};
use std::path::PathBuf;

/// Arguments of `shellsim radiosity`.
#[derive(clap::Args, Debug)]
pub struct RadiosityArgs {
    #[command(flatten)]
    pub scene: SceneFileArg,
    /// The model whose matrix is solved.
    #[arg(long, value_enum, default_value_t = Model::Float)]
    pub model: Model,
    /// Read the matrix (Matrix Market, from `shellsim matrix`) instead of computing it.
    #[arg(long, conflicts_with = "compare")]
    pub matrix: Option<PathBuf>,
    #[command(flatten)]
    pub rays: MatrixRaysArgs,
    /// The solver: Gauss-Seidel, or progressive refinement by Southwell shooting.
    #[arg(long, value_enum, default_value_t = Method::Gs)]
    pub method: Method,
    /// The system: `gather` is B = E + ρFB (exact in energy only for a reciprocal matrix),
    /// `power` spreads each patch's power along its own row (energy conserved exactly).
    #[arg(long, value_enum, default_value_t = System::Gather)]
    pub system: System,
    /// Stop when the residual max |E + ρH − B| / max E is at most this.
    #[arg(long, default_value = "1e-12")]
    pub tol: f64,
    /// Most Gauss-Seidel sweeps (shooting: this × patches shots).
    #[arg(long, default_value_t = SolveParams::default().max_iter)]
    pub max_iter: usize,
    /// The camera: eye x,y,z, look-at x,y,z, up x,y,z, vertical fov in degrees (default:
    /// from the scene's bounds, inside the room looking at the back wall).
    #[arg(long, value_name = "EYE,LOOK,UP,FOV", allow_hyphen_values = true)]
    pub camera: Option<String>,
    /// Picture size, WIDTHxHEIGHT pixels.
    #[arg(long, default_value = "512x512", value_parser = parse_size)]
    pub size: (u32, u32),
    /// Flat patches, or smooth by vertex averaging.
    #[arg(long, value_enum, default_value_t = Shading::Flat)]
    pub shading: Shading,
    /// Compare two models, e.g. float,machine: both solutions, side-by-side pictures, the
    /// false-colour difference of the second against the first.
    #[arg(long, value_name = "A,B")]
    pub compare: Option<String>,
    /// Output directory.
    #[arg(long)]
    pub out: PathBuf,
}

fn parse_size(s: &str) -> std::result::Result<(u32, u32), String> {
    let (w, h) = s
        .split_once('x')
        .ok_or_else(|| format!("{s:?} is not WIDTHxHEIGHT"))?;
    let p = |x: &str| match x.parse::<u32>() {
        Ok(v) if (1..=8192).contains(&v) => Ok(v),
        _ => Err(format!("{x:?} in {s:?} is not a size in 1..=8192")),
    };
    Ok((p(w)?, p(h)?))
}

/// Parses `--compare A,B`.
fn parse_compare(s: &str) -> Result<(Model, Model)> {
    let bad = || {
        Error::Usage(format!(
            "--compare {s:?}: want two of float, fixed, machine, e.g. float,machine"
        ))
    };
    let (a, b) = s.split_once(',').ok_or_else(bad)?;
    let (a, b) = (
        Model::parse(a.trim()).ok_or_else(bad)?,
        Model::parse(b.trim()).ok_or_else(bad)?,
    );
    if a == b {
        return Err(Error::Usage(format!(
            "--compare {s:?}: the two models must differ"
        )));
    }
    Ok((a, b))
}

/// Nothing in the scene emits: the solution would be 0 everywhere and the picture black.
/// The error names `--emitter` and the names the file gives its patches.
fn no_emitter(scene: &crate::scene::Scene, file: &std::path::Path) -> Error {
    let mut names: Vec<&str> = scene
        .patches
        .iter()
        .flat_map(|p| [p.name.as_deref(), p.material.as_deref()])
        .flatten()
        .collect();
    names.sort_unstable();
    names.dedup();
    let hint = if names.is_empty() {
        "the file names no groups or materials: give emission in the scene file".to_string()
    } else {
        let shown: Vec<&str> = names.iter().take(12).copied().collect();
        format!(
            "make a group or material emit with --emitter NAME (this file's names: {}{})",
            shown.join(", "),
            if names.len() > shown.len() {
                ", …"
            } else {
                ""
            }
        )
    };
    Error::input(
        file,
        "emission",
        format!("no patch emits light, so the radiosity would be 0 everywhere and the picture black; {hint}"),
    )
}

/// Runs `shellsim radiosity`.
pub fn run(a: &RadiosityArgs) -> Result<()> {
    check_outputs(&[Output::dir("--out", &a.out)])?;
    let scene = a.scene.load()?;
    if !scene.patches.iter().any(|p| p.emission.is_nonzero()) {
        return Err(no_emitter(&scene, &a.scene.scene));
    }
    let camera = match &a.camera {
        Some(s) => Camera::parse(s).map_err(|w| Error::Usage(format!("--camera {s:?}: {w}")))?,
        None => Camera::default_for(&scene, up_axis(&scene, &a.scene.scene).0),
    };
    let compare = a.compare.as_deref().map(parse_compare).transpose()?;
    let cfg = a.rays.machine.load()?;
    let spec = a.rays.spec(a.model, None, scene.patches.len())?;
    let job = JobSpec {
        matrix: spec,
        matrix_file: a.matrix.clone(),
        solve: SolveParams {
            method: a.method,
            system: a.system,
            tol: a.tol,
            max_iter: a.max_iter,
        },
        image: ImageSpec {
            camera,
            width: a.size.0,
            height: a.size.1,
            shading: a.shading,
        },
        compare,
        clock_mhz: a.rays.clock_mhz,
    };
    let r = job::run(&scene, &a.scene.scene, &cfg, &job, &a.out, true)?;
    for s in &r.solutions {
        let e = &s.energy;
        outln!(
            "{}: {} model, {} ({}), {} iterations, residual {:.2e}; energy: emitted {:.6}, absorbed {:.6}, escaped {:.6}, on back sides {:.6}, imbalance {:+.3e}",
            r.scene, s.model.name(), r.method.describe(), r.system.describe(), s.iterations, s.residual, e.emitted, e.absorbed, e.escaped, e.back, e.imbalance
        );
        if let Some(t) = &s.machine {
            outln!(
                "  machine: {} cycles for the whole matrix = {:.4} s at {} MHz",
                t.cycles,
                t.time_s,
                t.clock_mhz
            );
        }
    }
    if let Some(c) = &r.comparison {
        outln!(
            "{} vs {}: max relative difference {:.3e} (patch {}), RMS {:.3e}; float noise (RMS) {:.3e}: max {:.3} and RMS {:.3} noise units",
            c.model, c.reference, c.max_rel, c.max_rel_patch, c.rms_rel, c.noise_rms_rel, c.max_in_noise_units, c.rms_in_noise_units
        );
    }
    outln!("wrote {}", a.out.display());
    if let Some(c) = &r.comparison {
        c.verdict()?;
    }
    if let Some(s) = r.solutions.iter().find(|s| !s.converged) {
        return Err(Error::Check(format!(
            "{} did not converge to {} in {} iterations (residual {:.3e})",
            s.model.name(),
            a.tol,
            s.iterations,
            s.residual
        )));
    }
    Ok(())
}
