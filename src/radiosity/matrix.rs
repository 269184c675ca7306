//! The whole form-factor matrix (`shellsim matrix`): every source patch's row on one of the
//! three models — the float tracer, the untimed fixed-point model, or the cycle-level
//! machine (checked ray for ray against the untimed model) — in parallel over sources with
//! the result independent of the thread count; written as Matrix Market (sprs) plus a JSON
//! summary, and read back with its checks.

use crate::error::{Error, Result};
use crate::fixed::origin::Placement;
use crate::fixed::records::HostFixed;
use crate::machine::run::{simulate, MachineInput, RunSpec};
use crate::output::{json_string, write_atomic, write_atomic_with};
use crate::partition::{self, Config as PartitionConfig};
use crate::progress::Progress;
use crate::reference::rays::{check_source_and_rays, hemisphere_rays, Directions, Origins, RaySet};
use crate::reference::tracer::Tracer;
use crate::scene::Scene;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use shellsim_hw::config::MachineConfig;
use shellsim_hw::machine::TickOrder;
use shellsim_hw::{Exceptions, RayRecord};
use std::ops::Range;
use std::path::{Path, PathBuf};

/// Which model computes the rows.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Model {
    /// The float reference tracer (f64, 3D-DDA).
    Float,
    /// The untimed fixed-point model (`FixedScene::nearest_grid`).
    Fixed,
    /// The cycle-level machine, every ray checked against the untimed model.
    Machine,
}

impl Model {
    /// Its name on the command line and in file names.
    pub fn name(self) -> &'static str {
        match self {
            Model::Float => "float",
            Model::Fixed => "fixed",
            Model::Machine => "machine",
        }
    }

    /// Parses `float`, `fixed` or `machine`.
    pub fn parse(s: &str) -> Option<Model> {
        match s {
            "float" => Some(Model::Float),
            "fixed" => Some(Model::Fixed),
            "machine" => Some(Model::Machine),
            _ => None,
        }
    }
}

/// What a matrix job casts: `rays` rays of `directions` from every source in `sources`,
/// origins stratified over the patch, seeded by `seed` (the same set for every model, so
/// the models differ only in how they find the nearest hit).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MatrixSpec {
    pub model: Model,
    pub rays: usize,
    pub directions: Directions,
    pub seed: u64,
    pub sources: Range<u32>,
}

/// One row: F(source → j) for the patches whose front side is hit, by id; the weight that
/// escaped; the weight that hit some patch's back side (blocked: a back side neither emits
/// nor reflects, e.g. the ceiling's rays on the back of the Cornell box's light).
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    pub source: u32,
    pub entries: Vec<(u32, f64)>,
    pub escaped: f64,
    pub back: f64,
}

impl Row {
    /// The row as a dense vector over `n` patches.
    pub fn dense(&self, n: usize) -> Vec<f64> {
        let mut v = vec![0.0; n];
        for &(j, f) in &self.entries {
            v[j as usize] = f;
        }
        v
    }

    /// Σ_j F_ij + escaped + back weight, summed in id order (1 up to rounding).
    pub fn sum(&self) -> f64 {
        self.entries.iter().map(|e| e.1).sum::<f64>() + self.escaped + self.back
    }
}

/// The machine's figures for one source.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct MachineRow {
    pub cycles: u64,
    pub pipeline_efficiency: f64,
    pub patch_loads: u64,
    pub jobs: u64,
    /// Rays whose hit differs from the untimed model's (must be 0).
    pub mismatches_vs_fixed: u64,
}

/// The rows of a matrix over `n` patches (rows for `spec.sources`, in source order).
#[derive(Clone, Debug)]
pub struct FormMatrix {
    pub scene: String,
    pub n: usize,
    pub rows: Vec<Row>,
    /// Per row, for the machine model.
    pub machine: Vec<MachineRow>,
}

impl FormMatrix {
    /// True when it holds every row of the scene, in order.
    pub fn is_full(&self) -> bool {
        self.rows.len() == self.n
            && self
                .rows
                .iter()
                .enumerate()
                .all(|(i, r)| r.source as usize == i)
    }

    /// Every row as a dense vector (for small scenes and tests).
    pub fn dense(&self) -> Vec<Vec<f64>> {
        self.rows.iter().map(|r| r.dense(self.n)).collect()
    }

    /// Entries in row-major order (row, column, value), 0-based.
    pub fn triplets(&self) -> impl Iterator<Item = (usize, usize, f64)> + '_ {
        self.rows.iter().flat_map(|r| {
            r.entries
                .iter()
                .map(move |&(j, f)| (r.source as usize, j as usize, f))
        })
    }

    /// Nonzero entries.
    pub fn nnz(&self) -> usize {
        self.rows.iter().map(|r| r.entries.len()).sum()
    }

    /// Writes the Matrix Market text (coordinate, real, general; 1-based) through sprs's
    /// writer, from the rows as they are (no copy of the entries); `rows_done` is called
    /// after each row.
    pub fn write_matrix_market(
        &self,
        w: &mut dyn std::io::Write,
        rows_done: &mut dyn FnMut(u64),
    ) -> std::io::Result<()> {
        let done = std::cell::Cell::new(0u64);
        let view = View {
            m: self,
            done: &done,
        };
        let mut w = Ticking {
            w,
            done: &done,
            seen: 0,
            rows_done,
        };
        sprs::io::write_matrix_market_to_bufwrite(&mut w, view)
    }

    /// The Matrix Market text in memory (tests and small matrices).
    pub fn matrix_market(&self) -> Vec<u8> {
        let mut out = Vec::new();
        self.write_matrix_market(&mut out, &mut |_| {})
            .expect("writing to memory does not fail");
        out
    }

    /// Bytes of the Matrix Market file, estimated from the nonzeros (the file is written
    /// after every row is known, so this is announced before it is written): each line
    /// holds two 1-based ids and a value printed at full precision (about 20 characters).
    pub fn matrix_market_estimate(&self) -> u64 {
        let id = (self.n.max(1) as f64).log10().floor() as u64 + 1;
        80 + self.nnz() as u64 * (2 * id + 2 + 21)
    }
}

/// A matrix as sprs's writer sees it: borrowed rows, counting rows as their entries go by.
struct View<'a> {
    m: &'a FormMatrix,
    done: &'a std::cell::Cell<u64>,
}

impl sprs::SparseMat for View<'_> {
    fn rows(&self) -> usize {
        self.m.n
    }
    fn cols(&self) -> usize {
        self.m.n
    }
    fn nnz(&self) -> usize {
        self.m.nnz()
    }
}

impl<'a> IntoIterator for View<'a> {
    type Item = (&'a f64, (usize, usize));
    type IntoIter = Box<dyn Iterator<Item = Self::Item> + 'a>;
    fn into_iter(self) -> Self::IntoIter {
        let done = self.done;
        Box::new(self.m.rows.iter().flat_map(move |r| {
            done.set(done.get() + 1);
            r.entries
                .iter()
                .map(move |(j, f)| (f, (r.source as usize, *j as usize)))
        }))
    }
}

/// A writer that reports rows done (from [`View`]'s count) as the text goes out.
struct Ticking<'a, 'b> {
    w: &'a mut dyn std::io::Write,
    done: &'b std::cell::Cell<u64>,
    seen: u64,
    rows_done: &'b mut dyn FnMut(u64),
}

impl std::io::Write for Ticking<'_, '_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let d = self.done.get();
        if d > self.seen {
            (self.rows_done)(d - self.seen);
            self.seen = d;
        }
        self.w.write(buf)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.w.flush()
    }
}

/// Everything a matrix job is built on, made once for all sources: the float tracer, the
/// fixed-point scene (one cell table for every source) and the machine configuration.
pub struct Shared<'a> {
    pub scene: &'a Scene,
    pub file: &'a Path,
    pub cfg: &'a MachineConfig,
    pub tracer: Tracer,
    pub host: Option<HostFixed>,
    /// The resolved cell size and shell radius (scene units; `config::resolve`).
    pub cell: f64,
    pub shell_radius: f64,
    /// For the fixed and machine models: the float reference's closure probe found no
    /// escape (`reference::orient::closure`), so a ray they lose is a leak.
    pub closed: bool,
    /// The machine model's timing level: the cycle model, or the queueing network over the
    /// untimed model's results (`--timing queue`).
    pub queue_timing: bool,
}

impl<'a> Shared<'a> {
    /// Builds the tracer (and, for the fixed and machine models, the fixed-point scene) on
    /// the configuration's cell size.
    pub fn new(
        scene: &'a Scene,
        file: &'a Path,
        cfg: &'a MachineConfig,
        model: Model,
    ) -> Result<Self> {
        let resolved = crate::config::resolve(cfg, scene.size())?;
        let cell = resolved.machine.cell_size.value();
        let shell_radius = resolved.machine.shell_radius.value();
        let tracer = Tracer::new(scene, cell)?;
        let host = match model {
            Model::Float => None,
            _ => Some(HostFixed::new(scene, file, cfg.datapath, cell)?),
        };
        let closed =
            model != Model::Float && crate::reference::orient::closure(scene, &tracer).closed();
        Ok(Shared {
            scene,
            file,
            cfg,
            tracer,
            host,
            cell,
            shell_radius,
            closed,
            queue_timing: false,
        })
    }
}

/// Checks `spec` against `scene` (read from `file`): the sources exist and are not empty,
/// the ray count is in range.
pub fn validate(spec: &MatrixSpec, scene: &Scene, file: &Path) -> Result<()> {
    let n = scene.patches.len() as u32;
    if spec.sources.start >= spec.sources.end || spec.sources.end > n {
        return Err(Error::param(
            "sources",
            format!(
                "{}..{} (TO excluded) is not a nonempty range of the scene's patches 0..={}",
                spec.sources.start,
                spec.sources.end,
                n.saturating_sub(1)
            ),
        ));
    }
    check_source_and_rays(scene, file, spec.sources.start, spec.rays)?;
    if spec.model == Model::Machine && spec.rays > partition::MAX_PASS_RAYS {
        return Err(Error::param(
            "rays",
            format!(
                "{} is out of range for the machine (1..={})",
                spec.rays,
                partition::MAX_PASS_RAYS
            ),
        ));
    }
    Ok(())
}

/// The ray set of source `i`.
pub fn rays_of(scene: &Scene, spec: &MatrixSpec, i: u32) -> RaySet {
    hemisphere_rays(
        &scene.patches[i as usize],
        spec.rays,
        spec.directions,
        Origins::Patch,
        spec.seed,
    )
}

/// Sums per-ray hits into a row (weights in ray order, entries by id).
fn row_of(
    source: u32,
    scene: &Scene,
    set: &RaySet,
    hits: impl Iterator<Item = Option<u32>>,
) -> Row {
    let n = scene.patches.len();
    let mut f = vec![0.0f64; n];
    let mut hit = vec![false; n];
    let mut escaped = 0.0;
    let mut back = 0.0;
    for ((h, w), ray) in hits.zip(&set.weights).zip(&set.rays) {
        match h {
            Some(p) if scene.patches[p as usize].area_vector().dot(ray.d) > 0.0 => back += w,
            Some(p) => {
                f[p as usize] += w;
                hit[p as usize] = true;
            }
            None => escaped += w,
        }
    }
    let entries = f
        .into_iter()
        .enumerate()
        .filter(|(i, _)| hit[*i])
        .map(|(i, v)| (i as u32, v))
        .collect();
    Row {
        source,
        entries,
        escaped,
        back,
    }
}

/// The fixed-point ray records of `set` (a ray that does not fit the formats is bad input).
pub(crate) fn records(
    sh: &Shared,
    host: &HostFixed,
    set: &RaySet,
    source: u32,
) -> Result<Vec<RayRecord>> {
    set.rays
        .iter()
        .enumerate()
        .map(|(k, r)| {
            host.ray_from(k as u32, r, source).ok_or_else(|| {
                Error::input(
                    sh.file,
                    format!("source {source}, ray {k}"),
                    "does not fit the datapath's formats",
                )
            })
        })
        .collect()
}

/// One source's rays on one model: the ray set, each ray's nearest patch, and for the
/// machine its whole run's statistics.
pub struct RowRun {
    pub set: RaySet,
    pub hits: Vec<Option<u32>>,
    pub stats: Option<crate::machine::run::RunStats>,
    /// The machine's figures from the queueing network (`--timing queue`).
    pub queue: Option<MachineRow>,
}

impl RowRun {
    /// The row these hits make.
    pub fn row(&self, scene: &Scene, source: u32) -> Row {
        row_of(source, scene, &self.set, self.hits.iter().copied())
    }
}

/// Casts source `i`'s rays of `spec` on `spec.model` (the machine's run checked ray by ray
/// against the untimed model).
pub fn run_row(sh: &Shared, spec: &MatrixSpec, i: u32) -> Result<RowRun> {
    let set = rays_of(sh.scene, spec, i);
    let (hits, stats) = match spec.model {
        Model::Float => (
            set.rays
                .iter()
                .map(|r| sh.tracer.trace(r, Some(i)).map(|h| h.patch))
                .collect(),
            None,
        ),
        Model::Fixed => {
            let host = sh.host.as_ref().expect("built for the fixed model");
            let recs = records(sh, host, &set, i)?;
            let hits = recs
                .iter()
                .map(|r| {
                    let mut e = Exceptions::default();
                    host.scene
                        .nearest_grid(r, Some(i), &mut e)
                        .0
                        .map(|h| h.patch)
                })
                .collect();
            (hits, None)
        }
        Model::Machine => {
            let host = sh.host.as_ref().expect("built for the machine model");
            let recs = records(sh, host, &set, i)?;
            let m = &sh.cfg.machine;
            let mut pcfg =
                PartitionConfig::paper(i, m.clusters as usize, m.ctus_per_cluster as usize, 1);
            pcfg.shell_radius = sh.shell_radius;
            pcfg.subshell_max = m.subshell_max_patches as usize;
            pcfg.cell_size = sh.cell;
            pcfg.granularity = m.partition_granularity.into();
            pcfg.seed = spec.seed;
            pcfg.validate(sh.scene, sh.file)?;
            let sectors = partition::sectors_for(sh.scene, &sh.tracer, &pcfg, &set);
            let input = MachineInput {
                host,
                records: &recs,
                sectors: &sectors,
            };
            let run = RunSpec {
                source: i,
                ratio: 1,
                order: TickOrder::Forward,
            };
            if sh.queue_timing {
                let q =
                    crate::machine::queue::estimate(&input, &sh.scene.name, sh.cfg, &run, None)?;
                let hits = q.hits.iter().map(|h| h.map(|h| h.patch)).collect();
                let e = &q.estimate;
                let queue = MachineRow {
                    cycles: e.cycles,
                    pipeline_efficiency: q.pipeline_efficiency,
                    patch_loads: e.patch_loads,
                    jobs: e.jobs,
                    mismatches_vs_fixed: 0,
                };
                return Ok(RowRun {
                    set,
                    hits,
                    stats: None,
                    queue: Some(queue),
                });
            }
            let out = simulate(&input, &sh.scene.name, sh.cfg, &run, None)?;
            let hits = out.hits.iter().map(|h| h.map(|h| h.patch)).collect();
            (hits, Some(out.stats))
        }
    };
    Ok(RowRun {
        set,
        hits,
        stats,
        queue: None,
    })
}

/// `Err(Error::Check)` naming the source, the ray and where it left when the fixed-point
/// model or the machine lost a ray of `run` that the float reference traces to a patch in
/// a closed scene — a leak, which the origin placement (`crate::fixed::origin`) rules out.
/// Only the rays that escaped are traced again.
pub(crate) fn leak_check(sh: &Shared, spec: &MatrixSpec, i: u32, run: &RowRun) -> Result<()> {
    let escaped = run.hits.iter().filter(|h| h.is_none()).count();
    for (k, _) in run.hits.iter().enumerate().filter(|(_, h)| h.is_none()) {
        let ray = &run.set.rays[k];
        if let Some(h) = sh.tracer.trace(ray, Some(i)) {
            let p = ray.o + ray.d * h.t;
            let why = crowded_hint(sh, ray, i);
            return Err(Error::Check(format!(
                "source {i}: the {} model lost {escaped} rays; ray {k} from ({:.6}, {:.6}, {:.6}) along \
                 ({:.6}, {:.6}, {:.6}) left the scene where the float reference meets patch {} at \
                 ({:.6}, {:.6}, {:.6}){why}",
                spec.model.name(),
                ray.o.x, ray.o.y, ray.o.z, ray.d.x, ray.d.y, ray.d.z,
                h.patch, p.x, p.y, p.z
            )));
        }
    }
    Ok(())
}

/// Why a leak could happen, when the origin placement says so: no lattice point near the
/// ray's origin lies 2 LSB clear of every patch (`Placement::Crowded`).
fn crowded_hint(sh: &Shared, ray: &crate::reference::tracer::Ray, source: u32) -> String {
    let placed = sh.host.as_ref().and_then(|h| h.ray_placed(0, ray, source));
    match placed {
        Some((_, Placement::Crowded { by })) => format!(
            ": no origin 2 LSB clear of every patch exists there{} — the datapath is too \
             narrow for the scene (more fractional bits)",
            by.map_or(String::new(), |p| format!(" (patch {p} is in the way)"))
        ),
        _ => String::new(),
    }
}

/// One source's row on `spec.model` (the machine's figures too, for the machine).
pub fn compute_row(sh: &Shared, spec: &MatrixSpec, i: u32) -> Result<(Row, Option<MachineRow>)> {
    let run = run_row(sh, spec, i)?;
    if sh.closed {
        leak_check(sh, spec, i, &run)?;
    }
    let mr = run.queue.or_else(|| {
        run.stats.as_ref().map(|s| MachineRow {
            cycles: s.cycles,
            pipeline_efficiency: s.pipeline_efficiency,
            patch_loads: s.patch_loads,
            jobs: s.jobs,
            mismatches_vs_fixed: s.mismatches_vs_fixed,
        })
    });
    Ok((run.row(sh.scene, i), mr))
}

/// Bytes a matrix job holds at its peak, estimated before anything is allocated: the rays
/// of the rows in flight (one row per thread) with their prepared forms, fixed-point
/// records and hits, and the rows kept — at most min(rays, n) entries of 16 bytes each —
/// `copies` times (a solver keeps its own transposed copy).
pub fn memory_estimate(spec: &MatrixSpec, n: usize, copies: u64) -> (u64, u64) {
    let mut per_ray = crate::reference::rays::ray_bytes();
    if spec.model != Model::Float {
        per_ray += std::mem::size_of::<RayRecord>() as u64
            + 2 * std::mem::size_of::<Option<shellsim_hw::FixedHit>>() as u64
            + 64;
    }
    let rows = spec.sources.len() as u64;
    let threads = (rayon::current_num_threads() as u64).min(rows);
    let rays = threads * spec.rays as u64 * per_ray;
    let entries = rows * spec.rays.min(n) as u64;
    let matrix = copies
        * (rows * std::mem::size_of::<Row>() as u64
            + entries * std::mem::size_of::<(u32, f64)>() as u64);
    (rays, matrix)
}

/// Refuses a matrix job whose [`memory_estimate`] is past the memory limit, naming what
/// dominates it: the rays per source, or the rows.
pub fn check_memory(spec: &MatrixSpec, n: usize, copies: u64) -> Result<()> {
    let (rays, matrix) = memory_estimate(spec, n, copies);
    let (key, value, what) = if rays >= matrix {
        (
            "rays",
            spec.rays.to_string(),
            match rayon::current_num_threads().min(spec.sources.len()) {
                1 => "the rays of a row and the matrix".to_string(),
                k => format!("the rays of {k} rows at once (one per thread) and the matrix"),
            },
        )
    } else {
        (
            "sources",
            format!("{}..{}", spec.sources.start, spec.sources.end),
            format!(
                "{} rows of up to {} entries each",
                spec.sources.len(),
                spec.rays.min(n)
            ),
        )
    };
    crate::limits::check_memory(key, &value, &what, rays + matrix)
}

/// Every row of `spec.sources`, in parallel over sources (rayon), collected in source
/// order: the result does not depend on the thread count. A progress bar with ETA on a
/// terminal.
pub fn compute(
    scene: &Scene,
    file: &Path,
    cfg: &MachineConfig,
    spec: &MatrixSpec,
    show_progress: bool,
) -> Result<FormMatrix> {
    compute_timed(scene, file, cfg, spec, show_progress, false)
}

/// [`compute`], the machine model timed by the queueing network when `queue_timing` (its
/// rows are the untimed model's, which the machine equals ray for ray).
pub fn compute_timed(
    scene: &Scene,
    file: &Path,
    cfg: &MachineConfig,
    spec: &MatrixSpec,
    show_progress: bool,
    queue_timing: bool,
) -> Result<FormMatrix> {
    validate(spec, scene, file)?;
    check_memory(spec, scene.patches.len(), 1)?;
    let mut sh = Shared::new(scene, file, cfg, spec.model)?;
    sh.queue_timing = queue_timing;
    let ids: Vec<u32> = spec.sources.clone().collect();
    let mut progress = show_progress.then(|| Progress::new(ids.len() as u64, "sources"));
    let mut rows = Vec::with_capacity(ids.len());
    let mut machine = Vec::new();
    // Blocks of sources in parallel, so the bar moves; order kept within and across blocks.
    let block = (4 * rayon::current_num_threads()).max(8);
    for chunk in ids.chunks(block) {
        let part: Vec<Result<(Row, Option<MachineRow>)>> = chunk
            .par_iter()
            .map(|&i| compute_row(&sh, spec, i))
            .collect();
        for r in part {
            let (row, m) = r?;
            rows.push(row);
            machine.extend(m);
        }
        if let Some(p) = progress.as_mut() {
            p.inc(chunk.len() as u64);
        }
    }
    if let Some(p) = progress {
        p.finish();
    }
    Ok(FormMatrix {
        scene: scene.name.clone(),
        n: scene.patches.len(),
        rows,
        machine,
    })
}

/// One row's line of the summary.
#[derive(Clone, Debug, Serialize)]
pub struct RowSummary {
    pub source: u32,
    pub nonzeros: usize,
    pub escaped_weight: f64,
    /// Weight on patches' back sides.
    pub back_weight: f64,
    pub row_sum: f64,
    #[serde(flatten, skip_serializing_if = "Option::is_none")]
    pub machine: Option<MachineRow>,
}

/// The machine's totals over the rows.
#[derive(Clone, Debug, Serialize)]
pub struct MachineTotals {
    pub cycles: u64,
    pub clock_mhz: f64,
    /// cycles / clock: the machine's time for these rows.
    pub time_s: f64,
    pub patch_loads: u64,
    pub jobs: u64,
    /// Σ busy over Σ stage-cycles, weighted by each row's cycles.
    pub pipeline_efficiency: f64,
    pub mismatches_vs_fixed: u64,
}

/// The JSON summary written beside the matrix.
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    pub scene: String,
    pub patches: usize,
    pub model: Model,
    pub rays_per_source: usize,
    pub directions: Directions,
    pub seed: u64,
    pub sources: [u32; 2],
    pub nonzeros: usize,
    pub max_row_sum_error: f64,
    pub max_escaped_weight: f64,
    /// The configuration the fixed and machine models ran on.
    pub config: Option<MachineConfig>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub machine: Option<MachineTotals>,
    /// The machine's time estimated from a sample of rows (`--sample`); the rows are the
    /// untimed model's.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sampled: Option<SampledTiming>,
    /// `"queue"` when the machine's figures are the queueing network's (`--timing queue`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub timing: Option<&'static str>,
    pub rows: Vec<RowSummary>,
}

impl Summary {
    /// The summary of `m` computed for `spec` on `cfg`, the machine's time at `clock_mhz`.
    pub fn new(m: &FormMatrix, spec: &MatrixSpec, cfg: &MachineConfig, clock_mhz: f64) -> Summary {
        let rows: Vec<RowSummary> = m
            .rows
            .iter()
            .enumerate()
            .map(|(k, r)| RowSummary {
                source: r.source,
                nonzeros: r.entries.len(),
                escaped_weight: r.escaped,
                back_weight: r.back,
                row_sum: r.sum(),
                machine: m.machine.get(k).copied(),
            })
            .collect();
        let machine = (spec.model == Model::Machine && !m.machine.is_empty()).then(|| {
            let cycles: u64 = m.machine.iter().map(|x| x.cycles).sum();
            let busy: f64 = m
                .machine
                .iter()
                .map(|x| x.pipeline_efficiency * x.cycles as f64)
                .sum();
            MachineTotals {
                cycles,
                clock_mhz,
                time_s: cycles as f64 / (clock_mhz * 1e6),
                patch_loads: m.machine.iter().map(|x| x.patch_loads).sum(),
                jobs: m.machine.iter().map(|x| x.jobs).sum(),
                pipeline_efficiency: if cycles > 0 {
                    busy / cycles as f64
                } else {
                    0.0
                },
                mismatches_vs_fixed: m.machine.iter().map(|x| x.mismatches_vs_fixed).sum(),
            }
        });
        Summary {
            scene: m.scene.clone(),
            patches: m.n,
            model: spec.model,
            rays_per_source: spec.rays,
            directions: spec.directions,
            seed: spec.seed,
            sources: [spec.sources.start, spec.sources.end],
            nonzeros: m.nnz(),
            max_row_sum_error: rows
                .iter()
                .fold(0.0f64, |a, r| a.max((r.row_sum - 1.0).abs())),
            max_escaped_weight: rows.iter().fold(0.0f64, |a, r| a.max(r.escaped_weight)),
            config: (spec.model != Model::Float).then_some(*cfg),
            machine,
            sampled: None,
            timing: None,
            rows,
        }
    }

    /// `Err(Error::Check)` when some row of the machine differs from the untimed model.
    pub fn verdict(&self) -> Result<()> {
        let bad: Vec<u32> = self
            .rows
            .iter()
            .filter(|r| r.machine.is_some_and(|m| m.mismatches_vs_fixed > 0))
            .map(|r| r.source)
            .collect();
        if !bad.is_empty() {
            return Err(Error::Check(format!(
                "the machine differs from the fixed-point model in rows {bad:?}"
            )));
        }
        if let Some(t) = self.sampled.as_ref().filter(|t| t.mismatches_vs_fixed > 0) {
            return Err(Error::Check(format!(
                "the machine differs from the fixed-point model on {} rays of the sampled rows",
                t.mismatches_vs_fixed
            )));
        }
        Ok(())
    }
}

/// The summary's path beside a matrix file: the same stem, extension `.json`.
pub fn summary_path(matrix: &Path) -> PathBuf {
    matrix.with_extension("json")
}

/// Writes the matrix (Matrix Market) to `path` and its summary beside it, atomically.
/// A matrix path whose summary would be itself is `Error::Param` `out`.
pub fn write(path: &Path, m: &FormMatrix, summary: &Summary) -> Result<()> {
    let sp = summary_path(path);
    if sp == path {
        return Err(Error::param(
            "out",
            format!(
                "{}: the summary would overwrite it; name it *.mtx",
                path.display()
            ),
        ));
    }
    let mut bar = Progress::new(m.rows.len() as u64, "writing");
    write_atomic_with(path, |w| {
        m.write_matrix_market(w, &mut |rows| bar.inc(rows))
    })?;
    bar.finish();
    write_atomic(&sp, json_string(summary).as_bytes())
}

/// Reads a full matrix of `scene` from a Matrix Market file: it must be n × n for the
/// scene's n patches, every entry finite and in [0, 1], every row sum at most 1 (+1e-9);
/// when its summary lies beside it, it must name the same scene. The escaped weight of a
/// row is 1 − its sum (the file does not tell escaped from back-side weight). The file is
/// read through the input limit ([`crate::limits::read_input`]). Bad files are
/// `Error::Input` naming the file, the line and what is wrong.
pub fn read(path: &Path, scene: &Scene) -> Result<FormMatrix> {
    let bytes = crate::limits::read_input(path)?;
    let m = from_bytes(&bytes, path, scene)?;
    let sp = summary_path(path);
    if std::fs::metadata(&sp).is_ok_and(|m| m.is_file()) {
        let s = crate::limits::utf8(&sp, crate::limits::read_regular(&sp)?)?;
        #[derive(Deserialize)]
        struct Head {
            scene: String,
        }
        let head: Head = serde_json::from_str(&s)
            .map_err(|e| Error::input(&sp, "file", format!("not a matrix summary: {e}")))?;
        if head.scene != scene.name {
            return Err(Error::input(
                path,
                "scene",
                format!(
                    "computed for scene {} (see {}), not {}",
                    crate::error::shown(&head.scene),
                    sp.display(),
                    scene.name
                ),
            ));
        }
    }
    Ok(m)
}

/// A token of a file as a message shows it: control characters escaped, at most 40
/// characters (a 300-digit number is cut, with `…`).
fn token(t: &str) -> String {
    let s = crate::error::shown(t);
    match s.char_indices().nth(40) {
        Some((i, _)) => format!("{}…", &s[..i]),
        None => s,
    }
}

/// Parses a Matrix Market file's text (`coordinate real general`, 1-based, as `shellsim
/// matrix` writes it) into its entries, 0-based, for an `n` × `n` matrix. Strict: the
/// header line, then `%` comments, then the size line `rows cols entries`, which must be
/// `n n k` with `k` at most n²; then exactly `k` entry lines `i j value`, each index in
/// 1..=n. Nothing is allocated from the declared count: entries are collected as they are
/// read. Errors are `Error::Input` on `path` naming the line.
pub fn parse_matrix_market(
    bytes: &[u8],
    path: &Path,
    n: usize,
) -> Result<Vec<(usize, usize, f64)>> {
    let at = |line: usize, what: String| Error::input(path, format!("line {line}"), what);
    let text = std::str::from_utf8(bytes).map_err(|e| {
        let line = bytes[..e.valid_up_to()]
            .iter()
            .filter(|&&b| b == b'\n')
            .count()
            + 1;
        at(line, "not UTF-8 text".into())
    })?;
    let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l));
    let Some((_, head)) = lines.next() else {
        return Err(at(
            1,
            "empty: not a Matrix Market file (no %%MatrixMarket header)".into(),
        ));
    };
    let words: Vec<String> = head
        .split_whitespace()
        .map(|w| w.to_ascii_lowercase())
        .collect();
    let words: Vec<&str> = words.iter().map(|w| w.as_str()).collect();
    match words.as_slice() {
        ["%%matrixmarket", "matrix", "coordinate", "real" | "integer" | "double", "general"] => {}
        ["%%matrixmarket", ..] => {
            return Err(at(
                1,
                format!(
                    "header {:?}: only `%%MatrixMarket matrix coordinate real general` is read",
                    token(head)
                ),
            ))
        }
        _ => {
            return Err(at(
                1,
                format!(
                    "{:?} is not a Matrix Market header (`%%MatrixMarket matrix coordinate real general`)",
                    token(head)
                ),
            ))
        }
    }
    // The size line: the first line that is not a comment.
    let (size_line, size) = loop {
        match lines.next() {
            None => {
                return Err(at(
                    text.lines().count().max(1),
                    "ends before the size line (rows columns entries)".into(),
                ))
            }
            Some((_, l)) if l.trim_start().starts_with('%') => {}
            Some((i, l)) if l.trim().is_empty() => {
                return Err(at(
                    i,
                    "an empty line where the size line (rows columns entries) belongs".into(),
                ))
            }
            Some(x) => break x,
        }
    };
    let parse_count = |w: &str, what: &str| -> Result<u64> {
        w.parse::<u64>().map_err(|_| {
            at(
                size_line,
                format!("size line: {:?} is not a count of {what}", token(w)),
            )
        })
    };
    let f: Vec<&str> = size.split_whitespace().collect();
    let [r, c, k] = f.as_slice() else {
        return Err(at(
            size_line,
            format!(
                "size line {:?}: want three counts, rows columns entries",
                token(size)
            ),
        ));
    };
    let (rows, cols, k) = (
        parse_count(r, "rows")?,
        parse_count(c, "columns")?,
        parse_count(k, "entries")?,
    );
    if rows != n as u64 || cols != n as u64 {
        return Err(at(
            size_line,
            format!(
                "a {}×{} matrix does not fit the scene's {n} patches (a matrix of another scene?)",
                token(r),
                token(c)
            ),
        ));
    }
    let most = (n as u64).saturating_mul(n as u64);
    if k > most {
        return Err(at(
            size_line,
            format!(
                "declares {} entries, more than a {n}×{n} matrix holds ({most})",
                token(&k.to_string())
            ),
        ));
    }
    let mut out = Vec::new();
    let mut last = size_line;
    for (i, l) in lines {
        last = i;
        let t = l.trim();
        if t.is_empty() || t.starts_with('%') {
            continue;
        }
        if out.len() as u64 == k {
            return Err(at(
                i,
                format!("an entry past the {k} the size line (line {size_line}) declares"),
            ));
        }
        let f: Vec<&str> = t.split_whitespace().collect();
        let [a, b, v] = f.as_slice() else {
            return Err(at(
                i,
                format!("{:?}: want an entry `row column value`", token(t)),
            ));
        };
        let index = |w: &str, what: &str| -> Result<usize> {
            match w.parse::<u64>() {
                Ok(x) if (1..=n as u64).contains(&x) => Ok(x as usize - 1),
                Ok(_) => Err(at(
                    i,
                    format!("{what} {} is out of range (1..={n})", token(w)),
                )),
                Err(_) => Err(at(i, format!("{what} {:?} is not an index", token(w)))),
            }
        };
        let (a, b) = (index(a, "row")?, index(b, "column")?);
        let v: f64 = v
            .parse()
            .map_err(|_| at(i, format!("value {:?} is not a number", token(v))))?;
        if !v.is_finite() || !(0.0..=1.0).contains(&v) {
            return Err(at(
                i,
                format!(
                    "entry ({}, {}) = {} is not a form factor (finite, in [0, 1])",
                    a + 1,
                    b + 1,
                    crate::error::short(v)
                ),
            ));
        }
        out.push((a, b, v));
    }
    if (out.len() as u64) < k {
        return Err(at(
            last,
            format!(
                "the size line (line {size_line}) declares {k} entries, the file ends after {}",
                out.len()
            ),
        ));
    }
    Ok(out)
}

/// [`read`] on a file's bytes, without its summary: the matrix of `scene` in `path`.
pub fn from_bytes(bytes: &[u8], path: &Path, scene: &Scene) -> Result<FormMatrix> {
    let n = scene.patches.len();
    let entries = parse_matrix_market(bytes, path, n)?;
    let mut dense: Vec<Vec<(u32, f64)>> = vec![Vec::new(); n];
    for (i, j, v) in entries {
        dense[i].push((j as u32, v));
    }
    let mut rows = Vec::with_capacity(n);
    for (i, mut e) in dense.into_iter().enumerate() {
        e.sort_by_key(|x| x.0);
        if e.windows(2).any(|w| w[0].0 == w[1].0) {
            return Err(Error::input(
                path,
                format!("row {}", i + 1),
                "an entry is listed twice",
            ));
        }
        let s: f64 = e.iter().map(|x| x.1).sum();
        if s > 1.0 + 1e-9 {
            return Err(Error::input(
                path,
                format!("row {}", i + 1),
                format!("sums to {}, above 1", crate::error::short(s)),
            ));
        }
        rows.push(Row {
            source: i as u32,
            entries: e,
            escaped: (1.0 - s).max(0.0),
            back: 0.0,
        });
    }
    Ok(FormMatrix {
        scene: scene.name.clone(),
        n,
        rows,
        machine: Vec::new(),
    })
}
/// The sampled estimate of a matrix's machine time (`sample.rs` makes it).
#[derive(Clone, Debug, Serialize)]
pub struct SampledTiming {
    /// Rows of the matrix and rows run on the cycle model.
    pub rows: usize,
    pub sampled: usize,
    pub strata: usize,
    /// The sampled rows' ids, ascending.
    pub sample: Vec<u32>,
    /// The estimated total cycles and the half-width of its 95 % interval.
    pub cycles_estimate: f64,
    pub cycles_ci95: f64,
    /// Cycles of the sampled rows, summed.
    pub sampled_cycles: u64,
    /// Rays whose machine hit differs from the untimed model's, over the sample (must be 0).
    pub mismatches_vs_fixed: u64,
}
