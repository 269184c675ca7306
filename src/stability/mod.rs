//! `shellsim stability`: where each method fails. The adversarial cases of [`cases`] run on
//! the float reference, the untimed fixed-point model at every width of a range, and the
//! cycle machine (the configuration's buffers and the smallest it allows); per case, model
//! and width: differences from the exact answer (the analytic construction) or else from
//! the float reference, each in its class (`check`'s classes plus `coplanar_source`, a hit
//! on a patch the source lies on), leaks and double hits on watertight surfaces, overflow and
//! saturation counts, DDA walks that skip or repeat a cell, the machine against the untimed
//! model and its deadlocks. The report (CSV, markdown, SVG) is in [`report`].

pub mod cases;
pub mod report;

use crate::config;
use crate::error::{Error, Result};
use crate::fixed::check::{classify, Tolerances};
use crate::fixed::records::HostFixed;
use crate::machine::run::{simulate, MachineInput, RunSpec};
use crate::reference::tracer::{Dda, Hit, PreparedRay, Ray, Tracer};
use cases::Case;
use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;
use shellsim_hw::config::MachineConfig;
use shellsim_hw::datapath::dda::FixedDda;
use shellsim_hw::datapath::intersect;
use shellsim_hw::machine::TickOrder;
use shellsim_hw::{Exceptions, FixedHit, RayRecord};
use std::cmp::Ordering;
use std::path::Path;

/// What to run.
#[derive(Clone, Debug)]
pub struct Options {
    /// Case names, in the order of [`cases::CASES`].
    pub cases: Vec<String>,
    /// Rays per case.
    pub rays: usize,
    pub seed: u64,
    /// Fractional widths of the fixed-point model (coordinates, directions and t alike).
    pub bits: std::ops::RangeInclusive<u32>,
    /// The machine configuration (its datapath is the default format).
    pub config: MachineConfig,
}

/// The models.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Model {
    Float,
    Fixed,
    /// The cycle machine on the configuration's buffers.
    Machine,
    /// The cycle machine with every buffer and queue at 1, balancing on, work-items of 1.
    MachineMin,
}

impl Model {
    pub fn name(self) -> &'static str {
        match self {
            Model::Float => "float",
            Model::Fixed => "fixed",
            Model::Machine => "machine",
            Model::MachineMin => "machine-min",
        }
    }
}

/// Differences per class; `unexplained` is what no class covers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct ClassCounts {
    pub overflow: u64,
    pub near_origin: u64,
    pub grazing: u64,
    pub near_edge: u64,
    pub tie: u64,
    /// A hit on a patch the source lies on (coplanar and overlapping; `Scene::lying_on`).
    pub coplanar_source: u64,
    pub unexplained: u64,
}

impl ClassCounts {
    /// The classes' names and counts, in column order.
    pub fn named(&self) -> [(&'static str, u64); 7] {
        [
            ("overflow", self.overflow),
            ("near_origin", self.near_origin),
            ("grazing", self.grazing),
            ("near_edge", self.near_edge),
            ("tie", self.tie),
            ("coplanar_source", self.coplanar_source),
            ("unexplained", self.unexplained),
        ]
    }

    fn add(&mut self, c: Verdict) {
        match c {
            Verdict::Class(name) => match name {
                "overflow" => self.overflow += 1,
                "near_origin" => self.near_origin += 1,
                "grazing" => self.grazing += 1,
                "near_edge" => self.near_edge += 1,
                _ => self.tie += 1,
            },
            Verdict::CoplanarSource => self.coplanar_source += 1,
            Verdict::Unexplained => self.unexplained += 1,
        }
    }
}

/// One model's counts on one case at one width. `None`: does not apply to the model.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Counts {
    pub rays: u64,
    /// Hits differing from the exact answer, or from the float reference without one.
    pub differ: u64,
    pub classes: ClassCounts,
    /// Rays through a watertight surface hitting none of its patches.
    pub leaks: Option<u64>,
    /// Rays hitting two patches of a watertight surface.
    pub double_hits: Option<u64>,
    /// Values outside their format: rays with no record, datapath overflows.
    pub overflow: Option<u64>,
    /// Quotients beyond the t format.
    pub saturated: Option<u64>,
    /// DDA steps that jumped a cell (or visited one the ray does not pass through).
    pub dda_skipped: Option<u64>,
    /// DDA steps that stood still or went back.
    pub dda_repeated: Option<u64>,
    /// Rays whose machine hit differs from the untimed model's.
    pub machine_mismatches: Option<u64>,
    pub deadlocks: Option<u64>,
}

/// An unexplained difference with the ray that reproduces it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Repro {
    pub ray: usize,
    pub origin: [f64; 3],
    pub direction: [f64; 3],
    pub expected: String,
    pub got: Option<u32>,
}

/// One row of the report.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    pub case: String,
    pub model: Model,
    /// The fixed-point width (`None` for the float reference).
    pub frac_bits: Option<u32>,
    pub counts: Counts,
    pub unexplained: Vec<Repro>,
}

/// One case's rows and what it is.
#[derive(Clone, Debug, Serialize)]
pub struct CaseReport {
    pub name: String,
    pub about: String,
    pub why: String,
    pub patches: usize,
    /// Validation warnings (a source lying on another patch), naming both patches.
    pub warnings: Vec<String>,
    pub rows: Vec<Row>,
}

/// The whole report.
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    pub rays: usize,
    pub seed: u64,
    /// Every width run, ascending.
    pub bits: Vec<u32>,
    /// The configuration's width (the default format).
    pub default_bits: u32,
    pub cases: Vec<CaseReport>,
}

/// How a difference is explained.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Verdict {
    Class(&'static str),
    CoplanarSource,
    Unexplained,
}

/// Unexplained differences kept per row.
const REPROS: usize = 10;

/// The validation warnings of `case`: the patches its source lies on.
pub fn warnings(case: &Case) -> Vec<String> {
    case.scene
        .lying_on(case.source)
        .iter()
        .map(|p| {
            format!(
                "{}: patch {} (the source) lies on patch {p}: coplanar and overlapping, rays leaving it start an LSB above its plane, so patch {p} lies behind them; at few bits the answer can still turn on rounding",
                case.name, case.source
            )
        })
        .collect()
}

/// Everything the models share on one case.
struct Ctx<'a> {
    case: &'a Case,
    tracer: Tracer,
    lying: Vec<u32>,
    /// The float reference's hits.
    float: Vec<Option<Hit>>,
    cell: f64,
    tol: Tolerances,
}

impl Ctx<'_> {
    /// The expected hit of ray `i` as a float hit (t at the patch's plane), if known.
    fn expected(&self, i: usize) -> Option<Hit> {
        let e = &self.case.expect[i];
        let id = match e.exact {
            Some(x) => x,
            None if !e.around.is_empty() => Some(e.around[0]),
            None => return self.float[i],
        };
        id.map(|patch| Hit {
            patch,
            t: self.tracer.patches[patch as usize].plane_t(&PreparedRay::new(&self.case.rays[i])),
        })
    }

    /// Whether `got` is right for ray `i`.
    fn right(&self, i: usize, got: Option<u32>) -> bool {
        let e = &self.case.expect[i];
        match e.exact {
            Some(x) => got == x,
            None if !e.around.is_empty() => got.is_some_and(|p| e.around.contains(&p)),
            None => got == self.float[i].map(|h| h.patch),
        }
    }

    /// The verdict on a wrong answer `got` for ray `i`, with `host`'s LSBs.
    fn judge(&self, host: &HostFixed, i: usize, got: Option<Hit>, overflow: bool) -> Verdict {
        let want = self.expected(i);
        let on_source =
            |h: Option<Hit>| h.is_some_and(|h| self.lying.binary_search(&h.patch).is_ok());
        if !overflow && (on_source(got) || on_source(want)) {
            return Verdict::CoplanarSource;
        }
        let ray = &self.case.rays[i];
        let shift = record(host, self.case, i).map_or(0.0, |r| host.ray_back(&r).o.distance(ray.o));
        match classify(
            &self.tracer,
            host,
            ray,
            want,
            got,
            overflow,
            shift,
            self.tol,
        ) {
            Some(c) => Verdict::Class(c.name()),
            None => Verdict::Unexplained,
        }
    }

    fn repro(&self, i: usize, got: Option<u32>) -> Repro {
        let e = &self.case.expect[i];
        let r = &self.case.rays[i];
        let expected = match (&e.exact, e.around.is_empty()) {
            (Some(Some(p)), _) => format!("patch {p}"),
            (Some(None), _) => "a miss".into(),
            (None, false) => format!("one of {:?}", e.around),
            (None, true) => match self.float[i] {
                Some(h) => format!("patch {} (float)", h.patch),
                None => "a miss (float)".into(),
            },
        };
        Repro {
            ray: i,
            origin: r.o.to_array(),
            direction: r.d.to_array(),
            expected,
            got,
        }
    }
}

/// Per-ray outcome of one model.
#[derive(Clone, Copy, Default)]
struct RayOutcome {
    got: Option<u32>,
    /// `Some` when the answer is wrong.
    verdict: Option<Verdict>,
    leak: bool,
    double: bool,
    overflow: u64,
    saturated: u64,
    skipped: u64,
    repeated: u64,
}

/// Sums per-ray outcomes into a row.
fn row(ctx: &Ctx, model: Model, bits: Option<u32>, out: &[(usize, RayOutcome)]) -> Row {
    let mut c = Counts {
        rays: out.len() as u64,
        ..Counts::default()
    };
    let mut unexplained = Vec::new();
    let (mut leaks, mut dbl, mut ovf, mut sat, mut skip, mut rep) = (0, 0, 0, 0, 0, 0);
    for &(i, o) in out {
        if let Some(v) = o.verdict {
            c.differ += 1;
            c.classes.add(v);
            if v == Verdict::Unexplained && unexplained.len() < REPROS {
                unexplained.push(ctx.repro(i, o.got));
            }
        }
        leaks += o.leak as u64;
        dbl += o.double as u64;
        ovf += o.overflow;
        sat += o.saturated;
        skip += o.skipped;
        rep += o.repeated;
    }
    let machine = matches!(model, Model::Machine | Model::MachineMin);
    if !machine {
        c.leaks = Some(leaks);
        c.double_hits = Some(dbl);
        c.dda_skipped = Some(skip);
        c.dda_repeated = Some(rep);
    }
    if model == Model::Fixed {
        c.overflow = Some(ovf);
        c.saturated = Some(sat);
    }
    Row {
        case: ctx.case.name.into(),
        model,
        frac_bits: bits,
        counts: c,
        unexplained,
    }
}

/// The float DDA's faults on `ray`: (skipped, repeated). Each step must move one cell along
/// one axis, in the direction's sign, into a cell the ray passes through (the middle of its
/// t span inside the cell's box).
fn float_dda_faults(tracer: &Tracer, ray: &Ray) -> (u64, u64) {
    // The walk and the cell boxes are in the tracer's frame, so the ray is too.
    let grid = tracer.grid();
    let ray = &tracer.to_local(ray);
    let Some(mut dda) = Dda::new(grid, ray) else {
        return (0, 0);
    };
    let tol = 1e-9 * grid.aabb().extent().max_element();
    let d = ray.d.to_array();
    let on_ray = |dda: &Dda| {
        let t = 0.5 * (dda.t_enter() + dda.t_exit());
        let p = ray.o + ray.d * t;
        let b = grid.cell_box(dda.coords());
        (p.cmpge(b.lo - tol).all() && p.cmple(b.hi + tol).all()) || !t.is_finite()
    };
    let first = on_ray(&dda);
    let sign = d.map(|x| x.partial_cmp(&0.0).unwrap_or(Ordering::Equal));
    let limit = grid.dims.iter().sum::<usize>();
    walk_faults(dda.coords().map(|x| x as i64), first, sign, limit, || {
        dda.step()
            .then(|| (dda.coords().map(|x| x as i64), on_ray(&dda)))
    })
}

/// The fixed-point DDA's faults on record `r`: (skipped, repeated); the first cell must
/// hold the origin, each step as for the float DDA.
fn fixed_dda_faults(host: &HostFixed, r: &RayRecord) -> (u64, u64) {
    let cells = &host.scene.cells;
    let Some(mut dda) = FixedDda::new(cells, r) else {
        return (0, 0);
    };
    let cr = cells.cell_raw;
    let holds = (0..3).all(|a| {
        let c = dda.c[a] as i64;
        c * cr <= r.o[a] && (r.o[a] < (c + 1) * cr || c + 1 == cells.dims[a] as i64)
    });
    let sign = r.d.map(|x| x.cmp(&0));
    let limit = cells.dims.iter().sum::<u32>() as usize;
    walk_faults(dda.c.map(i64::from), holds, sign, limit, || {
        dda.step().then(|| (dda.c.map(i64::from), true))
    })
}

/// Counts a walk's faults: (skipped, repeated). It starts in `start` (`first_ok`: the right
/// cell); `next` steps and gives the new cell and whether the ray passes through it, or
/// `None` at the end. A step must move one cell along one axis in that axis's `sign`; more
/// is a skip, none or backwards a repeat, and a walk longer than `limit` steps (the grid's
/// dimensions summed) repeats.
fn walk_faults(
    start: [i64; 3],
    first_ok: bool,
    sign: [Ordering; 3],
    limit: usize,
    mut next: impl FnMut() -> Option<([i64; 3], bool)>,
) -> (u64, u64) {
    let (mut skipped, mut repeated) = (u64::from(!first_ok), 0);
    let mut prev = start;
    let mut steps = 0;
    while let Some((c, on_ray)) = next() {
        let mut moved = 0;
        let mut backwards = false;
        for k in 0..3 {
            let m = c[k] - prev[k];
            moved += m.abs();
            let want = match sign[k] {
                Ordering::Greater => 1,
                Ordering::Less => -1,
                Ordering::Equal => 0,
            };
            backwards |= m != 0 && m.signum() != want;
        }
        skipped += u64::from(moved > 1 || !on_ray);
        repeated += u64::from(moved == 0 || backwards);
        prev = c;
        steps += 1;
        if steps > limit {
            repeated += 1;
            break;
        }
    }
    (skipped, repeated)
}

/// The host for `bits` fractional bits of the configuration's datapath.
fn host_at(case: &Case, cfg: &MachineConfig, bits: u32, cell: f64) -> Result<HostFixed> {
    let dp = config::with_frac_bits(cfg.datapath, bits)?;
    HostFixed::new(&case.scene, Path::new(case.name), dp, cell)
}

/// The float reference's row.
fn float_row(ctx: &Ctx, host30: &HostFixed) -> Row {
    let case = ctx.case;
    let out: Vec<(usize, RayOutcome)> = (0..case.rays.len())
        .into_par_iter()
        .map(|i| {
            let ray = &case.rays[i];
            let h = ctx.float[i];
            let got = h.map(|h| h.patch);
            let e = &case.expect[i];
            let right = (e.exact.is_none() && e.around.is_empty()) || ctx.right(i, got);
            let crossings = if e.surface.is_empty() {
                1
            } else {
                ctx.tracer
                    .hits_all(ray)
                    .iter()
                    .filter(|x| e.surface.contains(&x.patch))
                    .count()
            };
            let (skipped, repeated) = float_dda_faults(&ctx.tracer, ray);
            let verdict = (!right).then(|| ctx.judge(host30, i, h, false));
            (
                i,
                RayOutcome {
                    got,
                    verdict,
                    leak: crossings == 0,
                    double: crossings > 1,
                    skipped,
                    repeated,
                    ..Default::default()
                },
            )
        })
        .collect();
    row(ctx, Model::Float, None, &out)
}

/// The fixed-point record of ray `i` of `case`: a ray that starts on the case's source is
/// converted as `run`, `matrix`, `check` and `size` convert it (`HostFixed::ray_from`: an
/// LSB inside the source's bounds and off its plane, to the front), any other by rounding
/// alone (`HostFixed::ray`).
pub fn record(host: &HostFixed, case: &Case, i: usize) -> Option<RayRecord> {
    let ray = &case.rays[i];
    let p = &case.scene.patches[case.source as usize];
    let on_plane = p.normal().dot(ray.o - p.vertices[0]).abs() <= 1e-12 * case.scene.bounds.scale();
    let lo = p.vertices.iter().fold(DVec3::INFINITY, |a, &v| a.min(v));
    let hi = p
        .vertices
        .iter()
        .fold(DVec3::NEG_INFINITY, |a, &v| a.max(v));
    let inside = ray.o.cmpge(lo).all() && ray.o.cmple(hi).all();
    if on_plane && inside {
        host.ray_from(i as u32, ray, case.source)
    } else {
        host.ray(i as u32, ray)
    }
}

/// The untimed fixed-point model's row at `bits`, with the records the machine runs
/// (`(ray index, record)` for every ray that has one).
fn fixed_row(ctx: &Ctx, host: &HostFixed, bits: u32) -> (Row, Vec<(usize, RayRecord)>) {
    let case = ctx.case;
    let src = Some(case.source);
    let per: Vec<((usize, RayOutcome), Option<RayRecord>)> = (0..case.rays.len())
        .into_par_iter()
        .map(|i| {
            let rec = record(host, case, i);
            let mut exc = Exceptions::default();
            let (hit, faults) = match &rec {
                Some(r) => (
                    host.scene.nearest_grid(r, src, &mut exc).0,
                    fixed_dda_faults(host, r),
                ),
                None => {
                    exc.overflow += 1;
                    (None, (0, 0))
                }
            };
            let e = &case.expect[i];
            let crossings = match &rec {
                Some(r) if !e.surface.is_empty() => {
                    let mut x = Exceptions::default();
                    e.surface
                        .clone()
                        .filter(|&p| {
                            intersect(
                                r,
                                &host.scene.patches[p as usize],
                                &host.scene.formats,
                                &mut x,
                            )
                            .is_some()
                        })
                        .count()
                }
                _ => 1,
            };
            let o = outcome(ctx, host, i, hit, &exc);
            let o = RayOutcome {
                leak: crossings == 0,
                double: crossings > 1,
                skipped: faults.0,
                repeated: faults.1,
                ..o
            };
            ((i, o), rec)
        })
        .collect();
    let recs = per
        .iter()
        .filter_map(|((i, _), r)| r.map(|r| (*i, r)))
        .collect();
    let out: Vec<(usize, RayOutcome)> = per.into_iter().map(|(o, _)| o).collect();
    (row(ctx, Model::Fixed, Some(bits), &out), recs)
}

/// A fixed-point answer's outcome for ray `i` (right or its verdict, a leak, exceptions).
fn outcome(
    ctx: &Ctx,
    host: &HostFixed,
    i: usize,
    hit: Option<FixedHit>,
    exc: &Exceptions,
) -> RayOutcome {
    let got = hit.map(|h| h.patch);
    let right = ctx.right(i, got);
    let overflow = exc.overflow > 0 || exc.t_saturated > 0;
    let as_float = hit.map(|h| Hit {
        patch: h.patch,
        t: host.t_f64(h.t),
    });
    RayOutcome {
        got,
        verdict: (!right).then(|| ctx.judge(host, i, as_float, overflow)),
        overflow: exc.overflow,
        saturated: exc.t_saturated,
        ..Default::default()
    }
}

/// `cfg` with every buffer and queue at its smallest (1), subshells of one patch, and
/// balancing on with work-items of one job.
pub fn smallest_buffers(cfg: &MachineConfig) -> MachineConfig {
    let mut c = *cfg;
    c.machine.ray_buffer_capacity = 1;
    c.machine.patch_buffer_capacity = 1;
    c.machine.request_queue_capacity = 1;
    c.machine.subshell_max_patches = 1;
    c.balance.enabled = true;
    c.balance.work_item_jobs = 1;
    c
}

/// The machine's row on `recs` (`(ray index, record)`) at `bits`.
fn machine_row(
    ctx: &Ctx,
    host: &HostFixed,
    cfg: &MachineConfig,
    model: Model,
    bits: u32,
    recs: &[(usize, RayRecord)],
) -> Result<Row> {
    let case = ctx.case;
    let mut cfg = *cfg;
    cfg.datapath = host.config;
    let records: Vec<RayRecord> = recs
        .iter()
        .enumerate()
        .map(|(k, (_, r))| RayRecord { id: k as u32, ..*r })
        .collect();
    let (nc, nk) = (
        cfg.machine.clusters as usize,
        cfg.machine.ctus_per_cluster as usize,
    );
    let sectors_n = nc * nk;
    let mut sectors = vec![vec![Vec::new(); nk]; nc];
    for k in 0..records.len() {
        let s = k * sectors_n / records.len().max(1);
        sectors[s / nk][s % nk].push(k as u32);
    }
    let input = MachineInput {
        host,
        records: &records,
        sectors: &sectors,
    };
    let spec = RunSpec {
        source: case.source,
        ratio: 1,
        order: TickOrder::Forward,
    };
    let (hits, mismatches, deadlocks) = match simulate(&input, case.name, &cfg, &spec, None) {
        Ok(o) => (o.hits, o.stats.mismatches_vs_fixed, 0),
        Err(Error::Check(_)) => (vec![None; records.len()], 0, 1),
        Err(e) => return Err(e),
    };
    let out: Vec<(usize, RayOutcome)> = recs
        .par_iter()
        .zip(hits.par_iter())
        .map(|(&(i, _), &h)| {
            // The datapath's exceptions are the untimed model's (equal hits); not recounted.
            (i, outcome(ctx, host, i, h, &Exceptions::default()))
        })
        .collect();
    let mut r = row(ctx, model, Some(bits), &out);
    r.counts.machine_mismatches = Some(mismatches);
    r.counts.deadlocks = Some(deadlocks);
    Ok(r)
}

/// Runs one case on every model and width.
pub fn run_case(case: &Case, opts: &Options, bits: &[u32]) -> Result<CaseReport> {
    let cfg = config::resolve(&opts.config, case.scene.size())?;
    let cell = cfg.machine.cell_size.value();
    let tracer = Tracer::new(&case.scene, cell).map_err(|e| e.for_scene(Path::new(case.name)))?;
    let float: Vec<Option<Hit>> = case
        .rays
        .par_iter()
        .map(|r| tracer.trace(r, Some(case.source)))
        .collect();
    let mut lying = case.scene.lying_on(case.source);
    lying.sort_unstable();
    let ctx = Ctx {
        case,
        tracer,
        lying,
        float,
        cell,
        tol: Tolerances::default(),
    };
    // The float reference's differences are classed on a 30-bit grid of LSBs.
    let host30 = host_at(case, &cfg, 30, ctx.cell)?;
    let mut rows = vec![float_row(&ctx, &host30)];
    let small = smallest_buffers(&cfg);
    for &b in bits {
        let host = host_at(case, &cfg, b, ctx.cell)?;
        let (fixed, recs) = fixed_row(&ctx, &host, b);
        rows.push(fixed);
        rows.push(machine_row(&ctx, &host, &cfg, Model::Machine, b, &recs)?);
        rows.push(machine_row(
            &ctx,
            &host,
            &small,
            Model::MachineMin,
            b,
            &recs,
        )?);
    }
    Ok(CaseReport {
        name: case.name.into(),
        about: case.about.into(),
        why: case.why.into(),
        patches: case.scene.patches.len(),
        warnings: warnings(case),
        rows,
    })
}

/// The widths a run covers: `bits` and the configuration's own, ascending.
pub fn widths(opts: &Options) -> Vec<u32> {
    let mut v: Vec<u32> = opts.bits.clone().collect();
    v.push(opts.config.datapath.frac_bits);
    v.sort_unstable();
    v.dedup();
    v
}

/// Checks the options (case names, rays, widths) before any work.
pub fn validate(opts: &Options) -> Result<()> {
    for c in &opts.cases {
        if !cases::CASES.iter().any(|(n, _)| n == c) {
            let known: Vec<&str> = cases::CASES.iter().map(|(n, _)| *n).collect();
            return Err(Error::param(
                "cases",
                format!("{c:?} is not a case; the cases are {}", known.join(", ")),
            ));
        }
    }
    if opts.rays == 0 || opts.rays > 1_000_000 {
        return Err(Error::param(
            "rays",
            format!("{} is out of range (1..=1000000)", opts.rays),
        ));
    }
    if opts.bits.is_empty() {
        return Err(Error::param(
            "frac_bits",
            format!("{}..={} is empty", opts.bits.start(), opts.bits.end()),
        ));
    }
    for b in widths(opts) {
        config::with_frac_bits(opts.config.datapath, b)?;
    }
    Ok(())
}

/// Runs every case of `opts` (in the order of [`cases::CASES`]).
pub fn run(opts: &Options) -> Result<Report> {
    validate(opts)?;
    let bits = widths(opts);
    let mut out = Vec::new();
    for (name, _) in cases::CASES {
        if !opts.cases.iter().any(|c| c == name) {
            continue;
        }
        let case = cases::generate_case(name, opts.rays, opts.seed).expect("a known case");
        out.push(run_case(&case, opts, &bits)?);
    }
    Ok(Report {
        rays: opts.rays,
        seed: opts.seed,
        bits,
        default_bits: opts.config.datapath.frac_bits,
        cases: out,
    })
}

/// Every case's name.
pub fn all_cases() -> Vec<String> {
    cases::CASES.iter().map(|(n, _)| n.to_string()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The walk check sees a jump, a standstill, a step back and a cell off the ray.
    #[test]
    fn walk_faults_sees_every_kind_of_bad_step() {
        let up = [Ordering::Greater, Ordering::Greater, Ordering::Equal];
        let run = |cells: &[([i64; 3], bool)]| {
            let mut it = cells.iter().copied();
            walk_faults([0, 0, 0], true, up, 10, || it.next())
        };
        assert_eq!(run(&[([1, 0, 0], true), ([1, 1, 0], true)]), (0, 0));
        assert_eq!(run(&[([1, 1, 0], true)]), (1, 0), "diagonal jump");
        assert_eq!(run(&[([0, 0, 0], true)]), (0, 1), "standstill");
        assert_eq!(run(&[([1, 0, 0], true), ([0, 0, 0], true)]), (0, 1), "back");
        assert_eq!(run(&[([0, 0, 1], true)]), (0, 1), "along a zero component");
        assert_eq!(run(&[([1, 0, 0], false)]), (1, 0), "off the ray");
        let mut n = 0;
        let endless = walk_faults([0, 0, 0], true, up, 10, || {
            n += 1;
            Some(([n, 0, 0], true))
        });
        assert_eq!(endless, (0, 1), "a walk past the grid's length");
    }
}
