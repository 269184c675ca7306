//! `shellsim explore`: a design-space sweep. A spec ([`spec`]) expands to design points;
//! each point is measured ([`evaluate`]) — accuracy against a high-ray float reference
//! (computed once per scene and source and cached in the output directory), mismatches
//! against the float model on the same rays and, for the machine, against the untimed
//! model (must be 0), the machine's cycles, efficiency and resource bound, the hardware
//! cost of `shellsim size`'s model, and the simulator's own wall time — and the
//! non-dominated fronts of error against cycles, cost and wall time are drawn and reported
//! ([`front`], [`report`]).
//!
//! Scale-out: a run may compute one shard (`K/N`: the points whose index is K mod N); every
//! point is written on its own, atomically, to `DIR/points/NNNNNN.json` as soon as it is
//! measured, so an interrupted run resumes where it stopped and [`merge`] joins shards into
//! the unsharded run's result, byte for byte. [`slurm`] writes the job-array scripts.
//!
//! **Invariant:** `points.csv`, `points.json`, `front.csv`, the charts of error against
//! cycles and cost and `report.md` depend only on the spec: not on the thread count, the
//! sharding or resumption. Wall-clock figures live in `host.csv`, `host-front.csv` and the
//! wall-time chart, which nothing compares.

pub mod auto;
pub mod front;
pub mod report;
pub mod slurm;
pub mod spec;

use crate::error::{Error, Result};
use crate::experiment::Bound;
use crate::output::{self, Output};
use crate::radiosity::matrix::{run_row, Model, Shared};
use crate::reference::rays::Directions;
use crate::size::{self, Cost};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use spec::{Axis, Knob, Point, Spec, Timing};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Version of the output directory's layout.
pub const FORMAT: u32 = 1;

/// One shard of a run: the points whose index is `k` mod `n`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    pub k: usize,
    pub n: usize,
}

impl Shard {
    /// Parses `K/N` (K in 0..N).
    pub fn parse(s: &str) -> std::result::Result<Shard, String> {
        let (k, n) = s
            .split_once('/')
            .ok_or_else(|| format!("{s:?} is not K/N"))?;
        let num = |x: &str| {
            x.trim()
                .parse::<usize>()
                .map_err(|_| format!("{x:?} in {s:?} is not a number"))
        };
        Shard::new(num(k)?, num(n)?)
    }

    /// Shard `k` of `n`, checked.
    pub fn new(k: usize, n: usize) -> std::result::Result<Shard, String> {
        if n == 0 || k >= n {
            return Err(format!("shard {k}/{n}: K must be in 0..N and N at least 1"));
        }
        Ok(Shard { k, n })
    }

    /// The shard a Slurm array task computes: `SLURM_ARRAY_TASK_ID` less
    /// `SLURM_ARRAY_TASK_MIN` (0 when unset) of `SLURM_ARRAY_TASK_COUNT`; `None` outside an
    /// array job.
    pub fn from_slurm() -> std::result::Result<Option<Shard>, String> {
        let var = |k: &str| std::env::var(k).ok();
        let (Some(id), Some(count)) = (var("SLURM_ARRAY_TASK_ID"), var("SLURM_ARRAY_TASK_COUNT"))
        else {
            return Ok(None);
        };
        let num = |name: &str, v: &str| {
            v.trim()
                .parse::<usize>()
                .map_err(|_| format!("{name}={v:?} is not a number"))
        };
        let id = num("SLURM_ARRAY_TASK_ID", &id)?;
        let min = match var("SLURM_ARRAY_TASK_MIN") {
            Some(m) => num("SLURM_ARRAY_TASK_MIN", &m)?,
            None => 0,
        };
        let n = num("SLURM_ARRAY_TASK_COUNT", &count)?;
        let k = id.checked_sub(min).ok_or_else(|| {
            format!("SLURM_ARRAY_TASK_ID {id} is below SLURM_ARRAY_TASK_MIN {min}")
        })?;
        Shard::new(k, n).map(Some)
    }

    /// Whether point `i` is in this shard.
    pub fn holds(&self, i: usize) -> bool {
        i % self.n == self.k
    }
}

/// What one design point measured (every figure deterministic).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PointResult {
    pub index: usize,
    pub scene: String,
    pub source: u32,
    pub level: Model,
    pub rays: usize,
    pub directions: String,
    pub seed: u64,
    /// The spec's keys for this point.
    pub knobs: Vec<Knob>,
    /// The resolved configuration's main knobs.
    pub frac_bits: u32,
    pub t_frac_bits: u32,
    pub coord_int_bits: u32,
    pub t_int_bits: u32,
    pub cell: f64,
    pub shell_radius: f64,
    pub clusters: u32,
    pub ctus_per_cluster: u32,
    pub ray_buffer: u32,
    pub patch_buffer: u32,
    pub request_queue: u32,
    pub balance: bool,
    pub work_item_jobs: u32,
    /// Form-factor error against the high-ray float reference: max over patches, RMS over
    /// patches, and the max over the estimator's sampling error at this point's rays
    /// (max over patches of √(F(1−F)/N), F the reference).
    pub ff_err_max: f64,
    pub ff_err_rms: f64,
    pub sampling_err: f64,
    pub err_over_sampling: f64,
    /// Rays whose nearest patch differs from the float model's on the same rays.
    pub mismatches_vs_float: u64,
    /// The machine: rays that differ from the untimed model (0), cycles, pipeline
    /// efficiency, the resource bound on cycles and the resource that sets it.
    pub mismatches_vs_fixed: Option<u64>,
    pub cycles: Option<u64>,
    pub pipeline_efficiency: Option<f64>,
    pub bound_cycles: Option<u64>,
    pub binds: Option<String>,
    /// The machine: the level that gave `cycles` (`cycle` or `queue`), and the queueing
    /// network's estimate when it ran (`timing = "queue"` or `"auto"`).
    #[serde(default)]
    pub timing: Option<Timing>,
    #[serde(default)]
    pub queue_cycles: Option<u64>,
    /// The hardware cost (fixed and machine levels): `shellsim size`'s model.
    pub cost: Option<Cost>,
}

/// What a point cost the simulator (not deterministic; host.csv only).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct HostFigures {
    pub wall_s: f64,
    /// Simulated cycles per second of the machine's run.
    pub cycles_per_s: Option<f64>,
}

/// One point's file, `DIR/points/NNNNNN.json`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PointFile {
    pub spec_hash: String,
    pub point: PointResult,
    pub host: HostFigures,
}

/// `DIR/spec.json`: which spec (by hash) and shard a directory holds, and what the report
/// needs of the spec.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SpecFile {
    pub format: u32,
    pub spec_hash: String,
    pub title: String,
    pub points: usize,
    pub axes: Vec<Axis>,
    /// Reference rays per scene and source (`scene/source` → rays).
    pub reference_rays: BTreeMap<String, usize>,
    pub shard: Option<Shard>,
}

/// The files of an output directory.
pub const FILES: [&str; 6] = [
    "spec.json",
    "points.csv",
    "points.json",
    "host.csv",
    "front.csv",
    "report.md",
];

/// Every output of a run or merge into `dir`, for `output::check_outputs`.
pub fn outputs(option: &str, dir: &Path) -> Vec<Output> {
    let mut o = vec![
        Output::dir(option, dir),
        Output::dir(option, &dir.join("points")),
    ];
    o.extend(FILES.iter().map(|f| Output::file(option, &dir.join(f))));
    o
}

/// A point's file name.
pub fn point_file(dir: &Path, i: usize) -> PathBuf {
    dir.join("points").join(format!("{i:06}.json"))
}

/// `scene/source`, the key of a reference.
fn group_key(scene: &str, source: u32) -> String {
    format!("{scene}/{source}")
}

/// The reference rays for each scene and source: the spec's `reference_rays`, else
/// [`size::REFERENCE_FACTOR`] × the most rays any point casts there, at least
/// [`size::REFERENCE_MIN`].
pub fn reference_rays(spec: &Spec) -> BTreeMap<String, usize> {
    let mut m: BTreeMap<String, usize> = BTreeMap::new();
    for p in &spec.points {
        let k = group_key(&spec.scenes[p.scene].scene.name, p.source);
        let n = spec
            .reference_rays
            .unwrap_or((size::REFERENCE_FACTOR * p.rays).max(size::REFERENCE_MIN));
        let e = m.entry(k).or_insert(n);
        *e = (*e).max(n);
    }
    m
}

/// The spec's description as written into `DIR/spec.json`.
pub fn spec_file(spec: &Spec, shard: Option<Shard>) -> SpecFile {
    SpecFile {
        format: FORMAT,
        spec_hash: spec.hash.clone(),
        title: spec.title.clone(),
        points: spec.points.len(),
        axes: spec.axes.clone(),
        reference_rays: reference_rays(spec),
        shard,
    }
}

/// A cached reference, `DIR/reference/SCENE-SOURCE-KEY.json`: KEY is [`reference_key`],
/// a hash of the scene's content and the reference's parameters, so that two scenes that
/// share a name (every seed of a `scene gen` kind does) never share a reference.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct ReferenceFile {
    scene: String,
    /// [`reference_key`], in hex.
    key: String,
    source: u32,
    rays: usize,
    directions: String,
    seed: u64,
    /// F(source → j) by patch.
    ff: Vec<f64>,
}

/// The cache key of a reference: FNV-1a of the scene's content (its patches, bounds and
/// name as JSON) and the reference's parameters (source, rays, directions, seed).
fn reference_key(scene: &crate::scene::Scene, source: u32, rays: usize) -> String {
    let h = spec::fnv1a(scene.to_json_string().as_bytes(), spec::FNV_START);
    let params = format!("{source}/{rays}/malley/{}", size::REFERENCE_SEED);
    format!("{:016x}", spec::fnv1a(params.as_bytes(), h))
}

/// The high-ray float reference of `scene` from `source` (Malley directions, the sizing's
/// reference seed), read from `dir`'s cache or computed and cached.
fn reference(spec: &Spec, scene: usize, source: u32, rays: usize, dir: &Path) -> Result<Vec<f64>> {
    let sc = &spec.scenes[scene];
    let key = reference_key(&sc.scene, source, rays);
    let path = dir.join("reference").join(format!(
        "{}-{source}-{key}.json",
        output::file_stem(&sc.scene.name)
    ));
    if std::fs::symlink_metadata(&path).is_ok_and(|m| m.is_file()) {
        let text = crate::limits::read_own(&path)?;
        if let Ok(r) = serde_json::from_slice::<ReferenceFile>(&text) {
            if r.key == key
                && r.source == source
                && r.rays == rays
                && r.seed == size::REFERENCE_SEED
                && r.ff.len() == sc.scene.patches.len()
            {
                return Ok(r.ff);
            }
        }
    }
    let cfg = crate::config::built_in();
    let ms = crate::radiosity::matrix::MatrixSpec {
        model: Model::Float,
        rays,
        directions: Directions::Malley,
        seed: size::REFERENCE_SEED,
        sources: source..source + 1,
    };
    // Refused before the tracer is built or a ray is cast when it cannot fit.
    crate::radiosity::matrix::check_memory(&ms, sc.scene.patches.len(), 1).map_err(
        |e| match e {
            Error::Param { what, .. } => Error::input(&spec.file, "reference_rays", what),
            e => e,
        },
    )?;
    let sh = Shared::new(&sc.scene, &sc.path, cfg, Model::Float)?;
    let ff = run_row(&sh, &ms, source)?
        .row(&sc.scene, source)
        .dense(sc.scene.patches.len());
    output::write_json(
        &path,
        &ReferenceFile {
            scene: sc.scene.name.clone(),
            key,
            source,
            rays,
            directions: "malley".into(),
            seed: size::REFERENCE_SEED,
            ff: ff.clone(),
        },
    )?;
    Ok(ff)
}

/// Checks every point of `spec` against its scene before the first one runs: the source
/// exists, the rays are in range for the level, the configuration resolves on the scene's
/// size, the grid can be built on that cell size and (fixed and machine levels) the scene
/// fits the datapath. Each grid and fixed-point scene is built once per distinct scene,
/// cell size and datapath. An error names the spec's file and the point.
pub fn check_points(spec: &Spec) -> Result<()> {
    use std::collections::BTreeSet;
    let mut grids: BTreeSet<(usize, u64)> = BTreeSet::new();
    let mut fixed: BTreeSet<(usize, u64, String)> = BTreeSet::new();
    for pt in &spec.points {
        let sc = &spec.scenes[pt.scene];
        let at = |e: Error| {
            let what = match e {
                Error::Input { file, place, what } => {
                    format!("{}: {place}: {what}", file.display())
                }
                e => e.to_string(),
            };
            Error::input(
                &spec.file,
                format!("point {}", pt.index),
                format!("{}: {what}", pt.label()),
            )
        };
        crate::radiosity::matrix::validate(&pt.matrix_spec(pt.level), &sc.scene, &sc.path)
            .map_err(at)?;
        let resolved = crate::config::resolve(&pt.config, sc.scene.size()).map_err(at)?;
        let cell = resolved.machine.cell_size.value();
        if grids.insert((pt.scene, cell.to_bits())) {
            crate::reference::tracer::Tracer::new(&sc.scene, cell)
                .map_err(|e| at(e.for_scene(&sc.path)))?;
        }
        if pt.level != Model::Float
            && fixed.insert((
                pt.scene,
                cell.to_bits(),
                format!("{:?}", pt.config.datapath),
            ))
        {
            crate::fixed::records::HostFixed::new(&sc.scene, &sc.path, pt.config.datapath, cell)
                .map_err(at)?;
        }
    }
    Ok(())
}

/// Measures point `pt` against `reference` (by patch); a machine point is timed at `timing`
/// (the cycle model, or the queueing network over the untimed model's results).
pub fn evaluate(
    spec: &Spec,
    pt: &Point,
    reference: &[f64],
    timing: Timing,
) -> Result<(PointResult, HostFigures)> {
    let start = std::time::Instant::now();
    let sc = &spec.scenes[pt.scene];
    let scene = &sc.scene;
    let n = scene.patches.len();
    let mut sh = Shared::new(scene, &sc.path, &pt.config, pt.level)?;
    sh.queue_timing = timing == Timing::Queue;
    let run = run_row(&sh, &pt.matrix_spec(pt.level), pt.source)?;
    let mismatches_vs_float = if pt.level == Model::Float {
        0
    } else {
        let float = run_row(&sh, &pt.matrix_spec(Model::Float), pt.source)?;
        float
            .hits
            .iter()
            .zip(&run.hits)
            .filter(|(a, b)| a != b)
            .count() as u64
    };
    let f = run.row(scene, pt.source).dense(n);
    let (mut max, mut sq, mut samp) = (0.0f64, 0.0f64, 0.0f64);
    for (a, r) in f.iter().zip(reference) {
        let d = (a - r).abs();
        max = max.max(d);
        sq += d * d;
        samp = samp.max((r * (1.0 - r) / pt.rays as f64).max(0.0).sqrt());
    }
    let resolved = crate::config::resolve(&pt.config, scene.size())?;
    let cost = match &sh.host {
        Some(host) => Some(size::cost_on(&resolved, scene, &sc.path, host)?),
        None => None,
    };
    let d = &resolved.datapath;
    let m = &resolved.machine;
    let mut result = PointResult {
        index: pt.index,
        scene: scene.name.clone(),
        source: pt.source,
        level: pt.level,
        rays: pt.rays,
        directions: format!("{:?}", pt.directions).to_lowercase(),
        seed: pt.seed,
        knobs: pt.knobs.clone(),
        frac_bits: d.frac_bits,
        t_frac_bits: d.t_frac_bits,
        coord_int_bits: d.coord_int_bits,
        t_int_bits: d.t_int_bits,
        cell: m.cell_size.value(),
        shell_radius: m.shell_radius.value(),
        clusters: m.clusters,
        ctus_per_cluster: m.ctus_per_cluster,
        ray_buffer: m.ray_buffer_capacity,
        patch_buffer: m.patch_buffer_capacity,
        request_queue: m.request_queue_capacity,
        balance: resolved.balance.enabled,
        work_item_jobs: resolved.balance.work_item_jobs,
        ff_err_max: max,
        ff_err_rms: (sq / n.max(1) as f64).sqrt(),
        sampling_err: samp,
        err_over_sampling: if samp > 0.0 { max / samp } else { 0.0 },
        mismatches_vs_float,
        mismatches_vs_fixed: None,
        cycles: None,
        pipeline_efficiency: None,
        bound_cycles: None,
        binds: None,
        timing: None,
        queue_cycles: None,
        cost,
    };
    let mut cycles_per_s = None;
    if let Some(s) = run.stats.as_ref() {
        cycles_per_s = Some(s.sim_rate_hz);
        cycle_figures(&mut result, pt, s, &resolved)?;
    } else if let Some(q) = run.queue.as_ref() {
        result.cycles = Some(q.cycles);
        result.pipeline_efficiency = Some(q.pipeline_efficiency);
        result.timing = Some(Timing::Queue);
        result.queue_cycles = Some(q.cycles);
    }
    let host = HostFigures {
        wall_s: start.elapsed().as_secs_f64(),
        cycles_per_s,
    };
    Ok((result, host))
}

/// Sets `p`'s machine figures from a cycle-level run's statistics, refusing a run that
/// differs from the untimed model.
fn cycle_figures(
    p: &mut PointResult,
    pt: &Point,
    s: &crate::machine::run::RunStats,
    resolved: &shellsim_hw::config::MachineConfig,
) -> Result<()> {
    if s.mismatches_vs_fixed != 0 {
        return Err(Error::Check(format!(
            "point {} ({}): the machine differs from the untimed model on {} rays",
            pt.index,
            pt.label(),
            s.mismatches_vs_fixed
        )));
    }
    let bound = Bound::of(s, resolved);
    p.mismatches_vs_fixed = Some(s.mismatches_vs_fixed);
    p.cycles = Some(s.cycles);
    p.pipeline_efficiency = Some(s.pipeline_efficiency);
    p.bound_cycles = Some(bound.cycles());
    p.binds = Some(bound.binding().name().to_string());
    p.timing = Some(Timing::Cycle);
    Ok(())
}

/// Runs queue-timed machine point `f` at the cycle level: its cycles, efficiency and bound
/// from the cycle model (checked ray for ray against the untimed model, whose results — and
/// so the point's errors — it keeps), its queue estimate kept beside them.
pub fn time_at_cycle(spec: &Spec, pt: &Point, f: &PointFile) -> Result<PointFile> {
    let start = std::time::Instant::now();
    let sc = &spec.scenes[pt.scene];
    let sh = Shared::new(&sc.scene, &sc.path, &pt.config, Model::Machine)?;
    let run = run_row(&sh, &pt.matrix_spec(Model::Machine), pt.source)?;
    let s = run.stats.as_ref().expect("the cycle model's statistics");
    let resolved = crate::config::resolve(&pt.config, sc.scene.size())?;
    let mut point = f.point.clone();
    cycle_figures(&mut point, pt, s, &resolved)?;
    Ok(PointFile {
        spec_hash: f.spec_hash.clone(),
        point,
        host: HostFigures {
            wall_s: f.host.wall_s + start.elapsed().as_secs_f64(),
            cycles_per_s: Some(s.sim_rate_hz),
        },
    })
}

/// What `timing = "auto"` did: the margins, how many machine points the cycle model ran,
/// and the queue level's measured error on them (every figure deterministic).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AutoSummary {
    pub margin_start: f64,
    /// The margin the screen ended with: the start, or 1.25 × the largest error measured.
    pub margin: f64,
    pub rounds: usize,
    pub machine_points: usize,
    pub cycle_runs: usize,
    /// |queue − cycle| / cycle over the points run at both levels.
    pub err_mean: f64,
    pub err_max: f64,
    /// The check sample (`auto_check` of the machine points, whatever the screen): its
    /// size and the queue level's error on it.
    pub check_share: f64,
    pub check_points: usize,
    pub check_mean: f64,
    pub check_max: f64,
}

/// The relative error of the queue level on a point timed at both levels.
fn queue_error(p: &PointResult) -> Option<f64> {
    match (p.timing, p.queue_cycles, p.cycles) {
        (Some(Timing::Cycle), Some(q), Some(c)) => {
            Some((q as f64 - c as f64).abs() / (c as f64).max(1.0))
        }
        _ => None,
    }
}

/// `timing = "auto"`: screens the queue-timed machine points of `files` (every one carries
/// its queue estimate) and runs at the cycle level, round by round, the points that may
/// reach the front of error against cycles in their scene and source ([`auto::candidates`]),
/// until the margin covers every error measured. The rounds are replayed from the queue
/// estimates, so a resumed run — whose files may already hold some rounds' cycle runs —
/// picks the same points.
fn auto_rounds(
    spec: &Spec,
    dir: &Path,
    files: &mut BTreeMap<usize, PointFile>,
    progress: bool,
) -> Result<AutoSummary> {
    let machine: Vec<usize> = files
        .values()
        .filter(|f| f.point.queue_cycles.is_some())
        .map(|f| f.point.index)
        .collect();
    // Groups as the report draws them: by scene name and source.
    let mut groups: BTreeMap<(String, u32), Vec<usize>> = BTreeMap::new();
    for &i in &machine {
        let p = &files[&i].point;
        groups
            .entry((p.scene.clone(), p.source))
            .or_default()
            .push(i);
    }
    // The check sample: a share of the machine points, drawn by a hash of the spec and the
    // point (so the same whatever the screen), run at both levels in the first round.
    let check: Vec<usize> = machine
        .iter()
        .copied()
        .filter(|&i| {
            let h = spec::fnv1a(
                &(i as u64).to_le_bytes(),
                spec::fnv1a(spec.hash.as_bytes(), spec::FNV_START),
            );
            ((h % 1_000_000) as f64) < spec.auto_check * 1e6
        })
        .collect();
    let mut exact: std::collections::BTreeSet<usize> = Default::default();
    let mut margin = spec.auto_margin;
    let mut rounds = 0;
    loop {
        rounds += 1;
        let mut picked: Vec<usize> = if rounds == 1 {
            check.clone()
        } else {
            Vec::new()
        };
        for members in groups.values() {
            let pts: Vec<auto::Screened> = members
                .iter()
                .map(|i| {
                    let p = &files[i].point;
                    let (lo, hi) = if exact.contains(i) {
                        let c = p.cycles.expect("timed") as f64;
                        (c, c)
                    } else {
                        auto::interval(p.queue_cycles.expect("screened") as f64, margin)
                    };
                    auto::Screened {
                        err: p.ff_err_max,
                        lo,
                        hi,
                    }
                })
                .collect();
            let c = auto::candidates(&pts);
            picked.extend(
                members
                    .iter()
                    .zip(&c)
                    .filter(|(i, &c)| c && !exact.contains(i))
                    .map(|(&i, _)| i),
            );
        }
        picked.sort_unstable();
        picked.dedup();
        let run: Vec<usize> = picked
            .iter()
            .copied()
            .filter(|i| files[i].point.timing != Some(Timing::Cycle))
            .collect();
        let show = progress && !run.is_empty();
        let timed = measure(&run, show, "points at the cycle level", dir, |&i| {
            time_at_cycle(spec, &spec.points[i], &files[&i])
        })?;
        files.extend(timed);
        exact.extend(picked.iter().copied());
        let worst = exact
            .iter()
            .filter_map(|i| queue_error(&files[i].point))
            .fold(0.0f64, f64::max);
        let next = spec.auto_margin.max(1.25 * worst);
        if picked.is_empty() && next <= margin {
            break;
        }
        margin = margin.max(next);
    }
    let errs = |set: &mut dyn Iterator<Item = &usize>| -> (usize, f64, f64) {
        let e: Vec<f64> = set.filter_map(|i| queue_error(&files[i].point)).collect();
        (
            e.len(),
            e.iter().sum::<f64>() / e.len().max(1) as f64,
            e.iter().fold(0.0, |a: f64, &b| a.max(b)),
        )
    };
    let (_, err_mean, err_max) = errs(&mut exact.iter());
    let (check_points, check_mean, check_max) = errs(&mut check.iter());
    Ok(AutoSummary {
        margin_start: spec.auto_margin,
        margin,
        rounds,
        machine_points: machine.len(),
        cycle_runs: exact.len(),
        err_mean,
        err_max,
        check_share: spec.auto_check,
        check_points,
        check_mean,
        check_max,
    })
}

/// Measures `items` in parallel blocks (with a progress bar labelled `label` when `show`),
/// writing each point's file into `dir` as it is measured; the files by index.
fn measure<T: Sync>(
    items: &[T],
    show: bool,
    label: &str,
    dir: &Path,
    f: impl Fn(&T) -> Result<PointFile> + Sync,
) -> Result<BTreeMap<usize, PointFile>> {
    let mut out = BTreeMap::new();
    let mut bar = show.then(|| crate::progress::Progress::new(items.len() as u64, label));
    let block = (4 * rayon::current_num_threads()).max(8);
    for chunk in items.chunks(block) {
        let part: Vec<Result<PointFile>> = chunk
            .par_iter()
            .map(|x| {
                let pf = f(x)?;
                output::write_json(&point_file(dir, pf.point.index), &pf)?;
                Ok(pf)
            })
            .collect();
        for pf in part {
            let pf = pf?;
            out.insert(pf.point.index, pf);
        }
        if let Some(b) = bar.as_mut() {
            b.inc(chunk.len() as u64);
        }
    }
    if let Some(b) = bar {
        b.finish();
    }
    Ok(out)
}

/// How a run went.
#[derive(Clone, Debug)]
pub struct RunSummary {
    pub points: usize,
    pub computed: usize,
    pub resumed: usize,
    pub shard: Option<Shard>,
}

/// Reads `dir/spec.json`, if there is one.
fn read_spec_file(dir: &Path) -> Result<Option<SpecFile>> {
    let path = dir.join("spec.json");
    match std::fs::metadata(&path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(Error::unreadable(&path, e)),
        Ok(_) => {
            let sf: SpecFile = serde_json::from_slice(&crate::limits::read_own(&path)?)
                .map_err(|e| Error::input(&path, format!("line {}", e.line()), e.to_string()))?;
            if sf.spec_hash.len() != 16 || !sf.spec_hash.bytes().all(|b| b.is_ascii_hexdigit()) {
                return Err(Error::input(
                    &path,
                    "spec_hash",
                    format!(
                        "{:?} is not a spec's hash (16 hexadecimal digits)",
                        crate::error::shown(&sf.spec_hash)
                    ),
                ));
            }
            if !(1..=spec::MAX_POINTS).contains(&sf.points) {
                return Err(Error::input(
                    &path,
                    "points",
                    format!(
                        "{} points: a spec expands to 1..={}",
                        sf.points,
                        spec::MAX_POINTS
                    ),
                ));
            }
            Ok(Some(sf))
        }
    }
}

/// A point's file in `dir`, when it holds a point of the spec `hash`; `None` when there is
/// none, or (unless `strict`) it is not one (it is measured again). A FIFO, device or
/// directory there, or a file past the input limit, is refused (bad input); so is, when
/// `strict` (`merge`), a file that is not a point file or holds another point or spec.
fn read_point(dir: &Path, i: usize, hash: &str, strict: bool) -> Result<Option<PointFile>> {
    let path = point_file(dir, i);
    if std::fs::symlink_metadata(&path).is_err() {
        return Ok(None);
    }
    let bytes = crate::limits::read_own(&path)?;
    match serde_json::from_slice::<PointFile>(&bytes) {
        Ok(f) if f.spec_hash == hash && f.point.index == i => Ok(Some(f)),
        Ok(f) if strict && f.point.index != i => Err(Error::input(
            &path,
            "index",
            format!("holds point {}, not point {i}", f.point.index),
        )),
        Ok(f) if strict => Err(Error::input(
            &path,
            "spec_hash",
            format!(
                "a point of another spec (hash {}) than {} (hash {hash})",
                crate::error::shown(&f.spec_hash),
                dir.join("spec.json").display()
            ),
        )),
        Err(e) if strict => Err(Error::input(
            &path,
            format!("line {}", e.line()),
            format!("not a point file: {e}"),
        )),
        _ => Ok(None),
    }
}

/// The indices below `points` of the point files in `dir/points` (names `NNNNNN.json`),
/// from the directory's listing, so that nothing is tried for a point with no file.
fn point_indices(dir: &Path, points: usize) -> Result<Vec<usize>> {
    let pd = dir.join("points");
    let list = match std::fs::read_dir(&pd) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(Error::unreadable(&pd, e)),
        Ok(l) => l,
    };
    let mut v = Vec::new();
    for e in list {
        let e = e.map_err(|e| Error::unreadable(&pd, e))?;
        let name = e.file_name();
        let Some(stem) = name.to_str().and_then(|n| n.strip_suffix(".json")) else {
            continue;
        };
        if stem.len() < 6 || !stem.bytes().all(|b| b.is_ascii_digit()) {
            continue;
        }
        if let Ok(i) = stem.parse::<usize>() {
            if i < points && point_file(dir, i) == e.path() {
                v.push(i);
            }
        }
    }
    v.sort_unstable();
    Ok(v)
}

/// Claims `dir` for `sf`'s run: `dir/spec.json` is created complete and atomically (a
/// temporary file hard-linked into place, which fails when the name exists), so that of
/// two runs started at once on one directory exactly one writes it; the other — and a
/// later run — finds it and is refused unless it holds the same spec and shard.
fn claim(dir: &Path, sf: &SpecFile) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let path = dir.join("spec.json");
    let (tmp, mut f) = output::TempFile::create(&dir.join(".spec.json.claim"))?;
    use std::io::Write;
    f.write_all(output::json_string(sf).as_bytes())
        .and_then(|_| f.sync_all())
        .map_err(|e| Error::io(&path, e))?;
    drop(f);
    let exists = |e: &std::io::Error| e.kind() == std::io::ErrorKind::AlreadyExists;
    match std::fs::hard_link(tmp.tmp_path(), &path) {
        Ok(()) => Ok(()),
        Err(e) if exists(&e) => check_same_spec(dir, sf),
        // A file system without hard links: created exclusively, written in place.
        Err(_) => match std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&path)
        {
            Ok(mut f) => f
                .write_all(output::json_string(sf).as_bytes())
                .and_then(|_| f.sync_all())
                .map_err(|e| Error::io(&path, e)),
            Err(e) if exists(&e) => check_same_spec(dir, sf),
            Err(e) => Err(Error::io(&path, e)),
        },
    }
    // `tmp` is dropped here: the temporary name is removed, spec.json stays.
}

/// Runs `spec` (or one shard of it) into `dir`: points already there are kept, the others
/// measured in parallel (each written as it finishes), then the tables — and for a whole
/// run the fronts, charts and report — written.
pub fn run(
    spec: &Spec,
    dir: &Path,
    shard: Option<Shard>,
    show_progress: bool,
) -> Result<RunSummary> {
    let shard = shard.filter(|s| s.n > 1);
    if spec.timing == Timing::Auto && shard.is_some() {
        return Err(Error::Usage(
            "timing = \"auto\" screens each scene's machine points together, so it runs unsharded: drop --shard (and the Slurm array) or use timing = \"cycle\" or \"queue\"".into(),
        ));
    }
    let sf = spec_file(spec, shard);
    let mine: Vec<&Point> = spec
        .points
        .iter()
        .filter(|p| shard.is_none_or(|s| s.holds(p.index)))
        .collect();
    check_points(spec)?;
    claim(dir, &sf)?;
    let mut done: BTreeMap<usize, PointFile> = BTreeMap::new();
    for p in &mine {
        if let Some(f) = read_point(dir, p.index, &spec.hash, false)? {
            done.insert(p.index, f);
        }
    }
    let resumed = done.len();
    let pending: Vec<&Point> = mine
        .iter()
        .copied()
        .filter(|p| !done.contains_key(&p.index))
        .collect();
    // The references the pending points need, each once.
    let mut groups: Vec<(usize, u32)> = pending.iter().map(|p| (p.scene, p.source)).collect();
    groups.sort_unstable();
    groups.dedup();
    let rays = &sf.reference_rays;
    let refs: Vec<((usize, u32), Vec<f64>)> = groups
        .par_iter()
        .map(|&(s, src)| {
            let n = rays[&group_key(&spec.scenes[s].scene.name, src)];
            reference(spec, s, src, n, dir).map(|r| ((s, src), r))
        })
        .collect::<Result<_>>()?;
    let refs: BTreeMap<(usize, u32), Vec<f64>> = refs.into_iter().collect();
    let timing = match spec.timing {
        Timing::Cycle => Timing::Cycle,
        Timing::Queue | Timing::Auto => Timing::Queue,
    };
    done.extend(measure(&pending, show_progress, "points", dir, |p| {
        let (point, host) = evaluate(spec, p, &refs[&(p.scene, p.source)], timing)?;
        Ok(PointFile {
            spec_hash: spec.hash.clone(),
            point,
            host,
        })
    })?);
    let auto = match spec.timing {
        Timing::Auto => Some(auto_rounds(spec, dir, &mut done, show_progress)?),
        _ => None,
    };
    let files: Vec<PointFile> = done.into_values().collect();
    report::write_all(dir, &sf, &files, shard.is_none(), auto.as_ref())?;
    Ok(RunSummary {
        points: files.len(),
        computed: pending.len(),
        resumed,
        shard,
    })
}

/// Refuses to write `sf`'s results into `dir` when it holds another spec's or shard's.
fn check_same_spec(dir: &Path, sf: &SpecFile) -> Result<()> {
    if let Some(old) = read_spec_file(dir)? {
        if old.spec_hash != sf.spec_hash || old.shard != sf.shard {
            return Err(Error::input(
                &dir.join("spec.json"),
                "spec_hash",
                format!(
                    "this directory holds a run of another spec or shard (hash {}, shard {}); this one is hash {}, shard {}: write into another directory or remove it",
                    old.spec_hash,
                    shard_name(old.shard),
                    sf.spec_hash,
                    shard_name(sf.shard)
                ),
            ));
        }
    }
    Ok(())
}

/// `K/N`, or `none`.
fn shard_name(s: Option<Shard>) -> String {
    s.map_or("none".into(), |s| format!("{}/{}", s.k, s.n))
}

/// Joins the shard directories `shards` into `out`: the same files an unsharded run writes.
/// Shards of different specs, or a point no shard holds, are refused (bad input).
pub fn merge(out: &Path, shards: &[PathBuf]) -> Result<usize> {
    let Some(first) = shards.first() else {
        return Err(Error::Usage(
            "explore merge: name at least one shard directory".into(),
        ));
    };
    let mut sf: Option<(SpecFile, &PathBuf)> = None;
    for d in shards {
        let Some(s) = read_spec_file(d)? else {
            return Err(Error::input(
                &d.join("spec.json"),
                "file",
                "missing: not an `explore run` output directory",
            ));
        };
        match &sf {
            None => sf = Some((s, d)),
            Some((f, fd)) => {
                if s.spec_hash != f.spec_hash {
                    return Err(Error::input(
                        &d.join("spec.json"),
                        "spec_hash",
                        format!(
                            "{} is a shard of another spec than {} (hash {} against {}): merge only shards of one spec",
                            s.spec_hash,
                            fd.display(),
                            s.spec_hash,
                            f.spec_hash
                        ),
                    ));
                }
            }
        }
    }
    let (mut whole, _) = sf.expect("at least one shard");
    // The point files present, from the directories' listings: a spec.json whose `points`
    // is larger than the files there is refused before any point is read.
    let mut present: Vec<(usize, &PathBuf)> = Vec::new();
    for d in shards {
        present.extend(point_indices(d, whole.points)?.into_iter().map(|i| (i, d)));
    }
    let mut have: Vec<usize> = present.iter().map(|p| p.0).collect();
    have.sort_unstable();
    have.dedup();
    if have.len() < whole.points {
        let mut missing = Vec::new();
        let mut k = 0;
        for i in 0..whole.points {
            if k < have.len() && have[k] == i {
                k += 1;
            } else if missing.len() < 10 {
                missing.push(i);
            } else {
                break;
            }
        }
        let shown: Vec<String> = missing.iter().map(|i| i.to_string()).collect();
        return Err(Error::input(
            &first.join("spec.json"),
            "points",
            format!(
                "{} of {} points are in no shard (points {}{}): a shard has not finished",
                whole.points - have.len(),
                whole.points,
                shown.join(", "),
                if whole.points - have.len() > 10 {
                    ", …"
                } else {
                    ""
                }
            ),
        ));
    }
    let mut files: BTreeMap<usize, PointFile> = BTreeMap::new();
    for (i, d) in present {
        if files.contains_key(&i) {
            continue;
        }
        if let Some(f) = read_point(d, i, &whole.spec_hash, true)? {
            files.insert(i, f);
        }
    }
    let missing: Vec<usize> = (0..whole.points)
        .filter(|i| !files.contains_key(i))
        .collect();
    if !missing.is_empty() {
        let shown: Vec<String> = missing.iter().take(10).map(|i| i.to_string()).collect();
        return Err(Error::input(
            &first.join("spec.json"),
            "points",
            format!(
                "{} of {} points are in no shard (points {}{}): a shard has not finished",
                missing.len(),
                whole.points,
                shown.join(", "),
                if missing.len() > 10 { ", …" } else { "" }
            ),
        ));
    }
    whole.shard = None;
    check_same_spec(out, &whole)?;
    output::write_json(&out.join("spec.json"), &whole)?;
    for f in files.values() {
        output::write_json(&point_file(out, f.point.index), f)?;
    }
    let files: Vec<PointFile> = files.into_values().collect();
    report::write_all(out, &whole, &files, true, None)?;
    Ok(files.len())
}
