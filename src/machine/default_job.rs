//! The default job's computation (`shellsim` with no arguments): the paper's test scene 2,
//! built in, from a floor tile — the cycle-level machine (paper.toml) with its waveform and
//! statistics in `waves/`, the float reference on the paper's 969 ring rays, grid
//! traversal against brute force, the fixed-point model against the float reference, and
//! the tracer against Lambert's formula. The CLI prints the table.

use crate::error::Result;
use crate::fixed::check::{check, CheckReport};
use crate::fixed::records::HostFixed;
use crate::machine::run::{execute, RunSpec, RunStats, Waveform};
use crate::paper::PAPER_RAYS;
use crate::reference::cast::{self, ReferenceReport};
use crate::reference::rays::{hemisphere_rays, Directions, Origins, RaySpec};
use crate::reference::tracer::Tracer;
use crate::scene::gen::Kind;
use crate::scene::Scene;
use crate::wave::{WaveOptions, Window};
use std::path::{Path, PathBuf};

/// The paper's test scene 2, built in so the default job needs no files.
const BUILTIN_SCENE2: &str = include_str!("../../scenes/scene2.json");

/// The name the built-in scene goes by in messages.
pub const BUILTIN_SCENE2_NAME: &str = "<built-in scenes/scene2.json>";

/// Where the default job writes the machine's waveform and statistics.
pub const WAVES_VCD: &str = "waves/default.vcd";
/// Where the default job writes the machine's configuration and statistics.
pub const WAVES_JSON: &str = "waves/default.json";

/// The tracer against Lambert's formula: floor centre → ceiling of the unit cube.
#[derive(Clone, Copy, Debug)]
pub struct AnalyticCheck {
    /// The tracer's estimate.
    pub estimate: f64,
    /// Lambert's value.
    pub truth: f64,
    /// The estimate's standard error (the stratified error model of tests/it/convergence.rs).
    pub sigma: f64,
}

impl AnalyticCheck {
    /// Within 3σ.
    pub fn ok(&self) -> bool {
        (self.estimate - self.truth).abs() <= 3.0 * self.sigma
    }
}

/// Everything the default job measured.
#[derive(Clone, Debug)]
pub struct DefaultJob {
    /// The source patch (scene 2's floor tile).
    pub source: u32,
    /// The machine's statistics.
    pub machine: RunStats,
    /// The machine's waveform ([`WAVES_VCD`] and its .gtkw).
    pub waveform: Option<Waveform>,
    /// The float reference on the paper's 969 ring rays.
    pub reference: ReferenceReport,
    /// Rays whose grid traversal differs from brute force.
    pub grid_mismatches: usize,
    /// The fixed-point model against the float reference on the same rays.
    pub fixed: CheckReport,
    pub analytic: AnalyticCheck,
}

impl DefaultJob {
    /// True when every check passed.
    pub fn ok(&self) -> bool {
        self.machine.mismatches_vs_fixed == 0
            && self.fixed.verdict(None).is_ok()
            && self.reference.escaped == 0
            && self.grid_mismatches == 0
            && self.analytic.ok()
    }
}

/// Runs the default job (writing [`WAVES_VCD`], its .gtkw and [`WAVES_JSON`]).
pub fn default_job() -> Result<DefaultJob> {
    let path = Path::new(BUILTIN_SCENE2_NAME);
    let scene = Scene::from_json_str(BUILTIN_SCENE2, path)?;
    let source = Kind::Scene2.default_source() as u32;
    let cfg = *crate::config::built_in();
    // 1. The cycle-level machine (paper.toml) with its waveform and statistics in waves/.
    let spec = RunSpec {
        source,
        ratio: 1,
        order: shellsim_hw::machine::TickOrder::Forward,
    };
    let vcd = (
        PathBuf::from(WAVES_VCD),
        WaveOptions {
            window: Window::ALL,
            scope: None,
            ..Default::default()
        },
    );
    let m = execute(
        &scene,
        path,
        &cfg,
        &spec,
        Some(vcd),
        Some(Path::new(WAVES_JSON)),
    )?;
    // 2. The float reference on the paper's 969 ring rays: enclosure and form factors.
    let rays = RaySpec {
        source,
        rays: PAPER_RAYS,
        directions: Directions::Rings,
        seed: 1,
    };
    let cell = crate::config::cell_size(cfg.machine.cell_size, scene.size());
    let reference = cast::run_scene(&scene, path, &rays, cell)?;
    // 3. Grid traversal against brute force, and the fixed-point model against the float
    //    reference, on the same rays.
    let tracer = Tracer::new(&scene, cell)?;
    let set = rays.rays(&scene);
    let grid_mismatches = set
        .rays
        .iter()
        .filter(|r| tracer.trace(r, Some(source)) != tracer.trace_brute(r, Some(source)))
        .count();
    let host = HostFixed::new(&scene, path, cfg.datapath, cell)?;
    let fixed = check(&tracer, &host, &set, source, Default::default());
    // 4. The tracer against Lambert's formula, floor centre → ceiling of the unit cube.
    Ok(DefaultJob {
        source,
        machine: m.stats,
        waveform: m.waveform,
        reference,
        grid_mismatches,
        fixed,
        analytic: analytic_check(),
    })
}

/// Floor centre → ceiling of the unit cube by 10⁵ Malley rays.
fn analytic_check() -> AnalyticCheck {
    use glam::DVec3;
    let cube = crate::scene::gen::unit_cube();
    let cell = crate::config::cell_size(
        crate::config::built_in().machine.cell_size,
        crate::config::SceneSize::of_scale(1.0),
    );
    let tracer = Tracer::new(&cube, cell).expect("the unit cube builds");
    let centre = DVec3::new(0.5, 0.5, 0.0);
    let n = 100_000;
    let set = hemisphere_rays(
        &cube.patches[0],
        n,
        Directions::Malley,
        Origins::Point(centre),
        1,
    );
    let (hits, _) = cast::cast(&tracer, &set, Some(0), None);
    let (ff, _, _) = cast::form_factors(&hits, &set.weights, cube.patches.len());
    let estimate = ff.iter().find(|x| x.patch == 1).map_or(0.0, |x| x.value);
    let truth =
        crate::reference::analytic::point_to_polygon(centre, DVec3::Z, &cube.patches[1].vertices);
    // Stratified error model of tests/it/convergence.rs.
    AnalyticCheck {
        estimate,
        truth,
        sigma: 0.7 * (n as f64).powf(-0.75),
    }
}
