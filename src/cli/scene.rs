//! `shellsim scene gen|import|info`.

use super::args::CellArg;
use crate::error::Result;
use crate::output::{check_outputs, Output};
use crate::reference::tracer::Tracer;
use crate::scene::{gen, obj, Aabb, Scene};
use clap::Subcommand;
use std::path::{Path, PathBuf};

#[derive(Subcommand, Debug)]
pub enum SceneCmd {
    /// Generate a built-in scene (deterministic for a seed) and write it as JSON.
    Gen {
        /// Which scene.
        #[arg(value_enum)]
        kind: gen::Kind,
        /// Seed of the random parts.
        #[arg(long, default_value_t = gen::DEFAULT_SEED)]
        seed: u64,
        /// Output file (JSON; `-` for standard output).
        #[arg(short, long)]
        out: PathBuf,
    },
    /// Convert a Wavefront OBJ file into a validated JSON scene (faces with more than 4
    /// vertices become triangle fans).
    Import {
        /// The OBJ file.
        file: PathBuf,
        /// Output file (JSON; `-` for standard output).
        #[arg(short, long)]
        out: PathBuf,
        /// Scene bounds as lo_x,lo_y,lo_z,hi_x,hi_y,hi_z (default: the vertices' bounding box).
        #[arg(long, value_parser = parse_bounds)]
        bounds: Option<Aabb>,
        /// Reflectance of faces without a material.
        #[arg(long, default_value_t = 0.5)]
        reflectance: f64,
    },
    /// Validate a scene (JSON or OBJ) and print its statistics.
    Info {
        /// The scene file (.json or .obj).
        file: PathBuf,
        /// The grid for the grid statistics.
        #[command(flatten)]
        grid: CellArg,
    },
}

/// Runs `shellsim scene ...`.
pub fn run(c: SceneCmd) -> Result<()> {
    match c {
        SceneCmd::Info { file, grid } => info(&file, grid),
        SceneCmd::Gen { kind, seed, out } => {
            check_outputs(&[Output::file("--out", &out)])?;
            let scene = gen::generate(kind, seed);
            scene.validate(&out)?;
            scene.save_json(&out)?;
            crate::output::outln!(
                "{}: {} patches (seed {seed}) written to {}",
                kind.name(),
                scene.patches.len(),
                out.display()
            );
            Ok(())
        }
        SceneCmd::Import {
            file,
            out,
            bounds,
            reflectance,
        } => {
            check_outputs(&[Output::file("--out", &out)])?;
            let opts = obj::ImportOptions {
                bounds,
                reflectance,
                ..Default::default()
            };
            let (scene, report) = obj::import(&file, &opts)?;
            for w in &report.warnings {
                eprintln!("warning: {}", crate::error::shown(w));
            }
            scene.save_json(&out)?;
            crate::output::outln!("{}: {}", file.display(), report.summary());
            crate::output::outln!("written to {}", out.display());
            Ok(())
        }
    }
}

/// Parses `lo_x,lo_y,lo_z,hi_x,hi_y,hi_z`.
fn parse_bounds(s: &str) -> std::result::Result<Aabb, String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>().map_err(|e| format!("{x:?}: {e}")))
        .collect::<std::result::Result<_, _>>()?;
    if v.len() != 6 {
        return Err(format!("expected 6 numbers, got {}", v.len()));
    }
    Ok(Aabb {
        lo: glam::DVec3::new(v[0], v[1], v[2]),
        hi: glam::DVec3::new(v[3], v[4], v[5]),
    })
}

fn info(file: &Path, grid: CellArg) -> Result<()> {
    let scene = Scene::load(file)?;
    let tracer = Tracer::new(&scene, grid.for_scene(&scene)).map_err(|e| e.for_scene(file))?;
    let g = &tracer.grid;
    let tris = scene
        .patches
        .iter()
        .filter(|p| p.vertices.len() == 3)
        .count();
    let emitters = scene
        .patches
        .iter()
        .filter(|p| p.emission.is_nonzero())
        .count();
    crate::output::outln!("scene        {}", crate::error::shown(&scene.name));
    crate::output::outln!(
        "bounds       {:?} - {:?}",
        scene.bounds.lo.to_array(),
        scene.bounds.hi.to_array()
    );
    crate::output::outln!(
        "patches      {} ({} triangles, {} quads, {} emitting)",
        scene.patches.len(),
        tris,
        scene.patches.len() - tris,
        emitters
    );
    crate::output::outln!("total area   {:.6}", scene.total_area());
    crate::output::outln!(
        "grid         {}×{}×{} cells of {}, {} nonempty, {} cell entries ({:.2} per patch)",
        g.dims[0],
        g.dims[1],
        g.dims[2],
        g.cell_size,
        g.nonempty_cells(),
        g.entries(),
        g.entries() as f64 / scene.patches.len() as f64
    );
    Ok(())
}
