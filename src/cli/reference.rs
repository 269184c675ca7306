//! `shellsim reference`: form factors from one source patch by the float reference tracer.

use super::args::{CellArg, SceneFileArg};
use crate::error::Result;
use crate::output::{check_outputs, write_json, Output};
use crate::paper::PAPER_RAYS;
use crate::reference::cast::{self, ReferenceReport};
use crate::reference::rays::{Directions, RaySpec};
use crate::scene::{PatchRef, Scene};
use std::path::PathBuf;

/// Arguments of `shellsim reference` (and the rays of `shellsim check`).
#[derive(clap::Args, Debug)]
pub struct ReferenceArgs {
    #[command(flatten)]
    pub input: SceneFileArg,
    /// The source patch: its id, or the name of its group, object or material (OBJ `g`,
    /// `o`, `usemtl`) when that names one patch.
    #[arg(long)]
    pub source: PatchRef,
    /// Number of rays.
    #[arg(long, default_value_t = PAPER_RAYS)]
    pub rays: usize,
    /// Direction set.
    #[arg(long, value_enum, default_value_t = Directions::Rings)]
    pub directions: Directions,
    /// Seed of the origins (and of Malley/random directions).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    #[command(flatten)]
    pub grid: CellArg,
    /// Write the full result as JSON here (`-`: standard output).
    #[arg(long)]
    pub json: Option<PathBuf>,
}

impl ReferenceArgs {
    /// The outputs asked for, for the check before any work.
    pub fn outputs(&self) -> Vec<Output> {
        self.json
            .iter()
            .map(|p| Output::file("--json", p))
            .collect()
    }

    /// Loads the scene and resolves `--source`: the scene and the rays asked for.
    pub fn load(&self) -> Result<(Scene, RaySpec)> {
        let scene = self.input.load()?;
        let source = self.source.resolve(&scene, &self.input.scene)?;
        Ok((scene, self.spec(source)))
    }

    /// The rays asked for, from patch `source`.
    pub fn spec(&self, source: u32) -> RaySpec {
        RaySpec {
            source,
            rays: self.rays,
            directions: self.directions,
            seed: self.seed,
        }
    }
}

/// Runs `shellsim reference`.
pub fn run(a: &ReferenceArgs) -> Result<()> {
    check_outputs(&a.outputs())?;
    let (scene, spec) = a.load()?;
    let report = cast::run_scene(&scene, &a.input.scene, &spec, a.grid.for_scene(&scene))?;
    print_reference(&report, &scene);
    if let Some(out) = &a.json {
        write_json(out, &report)?;
    }
    Ok(())
}

fn print_reference(r: &ReferenceReport, scene: &Scene) {
    crate::output::outln!(
        "{} from patch {}: {} rays ({}), {} escaped",
        r.scene,
        r.source,
        r.rays,
        r.directions.name(),
        r.escaped,
    );
    crate::output::outln!(
        "ΣF over patches {:.6} (on back sides {:.6}), escaped {:.6}: {:.12} in all",
        r.weight_sum - r.escaped_weight,
        r.back_weight,
        r.escaped_weight,
        r.weight_sum
    );
    crate::output::outln!(
        "{:.3} s, {:.3} M rays/s, {:.1} cells and {:.1} patch tests per ray",
        r.wall_s,
        r.rays_per_s / 1e6,
        r.cells_visited as f64 / r.rays as f64,
        r.patch_tests as f64 / r.rays as f64
    );
    let mut top = r.form_factors.clone();
    top.sort_by(|a, b| b.value.total_cmp(&a.value).then(a.patch.cmp(&b.patch)));
    crate::output::outln!("{:>8}  {:>12}  {:>10}", "patch", "F", "area");
    for f in top.iter().take(10) {
        crate::output::outln!(
            "{:>8}  {:>12.8}  {:>10.6}",
            f.patch,
            f.value,
            scene.patches[f.patch as usize].area()
        );
    }
    if top.len() > 10 {
        crate::output::outln!("{:>8}  ({} more patches hit)", "…", top.len() - 10);
    }
}
