//! `shellsim size`: the smallest machine that meets a form-factor accuracy target on a
//! scene, found by measurement. Each knob has its rule and its evidence:
//!
//! - **fractional bits**: the fewest whose form-factor error stays under the target —
//!   bisection over real runs of the fixed-point model on the machine's own rays (the machine
//!   equals that model bit for bit). The error is measured against the float model on the
//!   same rays (`Against::Float`, the default: what the hardware's number formats add) or
//!   against a high-ray float reference (`Against::Reference`: the total error, which no
//!   format can push below the estimator's own at the machine's ray count);
//! - **integer bits** of coordinates and t: from the analytic range (the scene normalized to
//!   its scale, the grid's diagonal) beside the range the run reached;
//! - **buffers** (ray buffer, patch buffer, request queue): the smallest capacity that keeps
//!   the cycles within [`SizeSpec::tolerance`] of an unbounded machine, by bisection from the
//!   measured peak occupancy, then verified together;
//! - **clusters and CTUs**: the fewest that meet `--max-cycles` when it is given (else the
//!   base configuration's);
//! - **cost**: datapath bits (multiplier and adder bits), SRAM bits of every buffer, and the
//!   global memory's words for the patch records and the cell table.
//!
//! The chosen machine is run at the end: the error, cycles and mismatches the report states
//! are measured, not predicted.

pub mod synth;

use crate::config;
use crate::error::{Error, Result};
use crate::fixed::records::HostFixed;
use crate::machine::run::{run, RunOutput, RunSpec};
use crate::paper::PAPER_RAYS;
use crate::reference::rays::{hemisphere_rays, Directions, Origins, RaySet};
use crate::reference::tracer::Tracer;
use crate::scene::Scene;
use serde::Serialize;
use shellsim_hw::config::{DatapathConfig, MachineConfig};
use shellsim_hw::datapath::record::{RecordSizes, PATCH_ID_BITS, RAY_ID_BITS};
use shellsim_hw::machine::TickOrder;
use shellsim_hw::Exceptions;
use std::path::Path;

/// Fractional bits tried: the bisection's range.
pub const FRAC_BITS: std::ops::RangeInclusive<u32> = 4..=30;

/// Most clusters `--max-cycles` may ask for.
pub const MAX_CLUSTERS: u32 = 64;

/// CTU counts per cluster tried for `--max-cycles`.
pub const CTU_COUNTS: [u32; 3] = [1, 2, 4];

/// Reference rays per machine ray (Malley, an independent seed), and at least this many.
pub const REFERENCE_FACTOR: usize = 16;
pub const REFERENCE_MIN: usize = 100_000;

/// Seed of the reference rays (independent of the machine's ring rays).
pub const REFERENCE_SEED: u64 = 1_000_003;

/// What the form-factor error is measured against.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Against {
    /// The float model on the same rays: the error the fixed-point hardware adds.
    Float,
    /// A float reference with many more rays: the machine's total error.
    Reference,
}

/// What to size for.
#[derive(Clone, Debug, Serialize)]
pub struct SizeSpec {
    pub source: u32,
    /// The form-factor target: the largest |F_machine(j) − F(j)| over patches j, F the float
    /// model on the same rays or the high-ray reference (`against`).
    pub target_error: f64,
    pub against: Against,
    /// Hi_Low_Ratio of the machine's run: 969 × ratio ring rays.
    pub ratio: usize,
    /// The machine must finish within this many cycles (sizes clusters and CTUs).
    pub max_cycles: Option<u64>,
    /// A buffer is big enough when the cycles stay within this fraction of an unbounded
    /// machine's.
    pub tolerance: f64,
    /// The base configuration is the ceiling for what buys cycles (clusters and CTUs, every
    /// buffer) unless this is set. Fractional bits follow the accuracy target, which asks
    /// for them; the report says when they exceed the base's.
    pub allow_larger: bool,
}

/// One evaluated fractional width.
#[derive(Clone, Debug, Serialize)]
pub struct BitsTrial {
    pub frac_bits: u32,
    pub ff_err_max: f64,
    /// Rays the fixed-point model lost where the float reference hit a patch (`check`'s
    /// leaks): a width that loses any does not meet the target, whatever its error.
    #[serde(skip_serializing_if = "is_zero")]
    pub leaks: u64,
    pub meets: bool,
}

fn is_zero(x: &u64) -> bool {
    *x == 0
}

/// An integer-bit decision: analytic bounds beside the measured range.
#[derive(Clone, Debug, Serialize)]
pub struct RangeRow {
    pub value: String,
    pub lower_bound: f64,
    pub measured_min: f64,
    pub measured_max: f64,
    pub upper_bound: f64,
    pub int_bits: u32,
}

/// A buffer decision.
#[derive(Clone, Debug, Serialize)]
pub struct BufferRow {
    pub buffer: String,
    pub peak_occupancy: u64,
    pub capacity: u32,
    /// Cycles with this capacity (the others unbounded), and the unbounded machine's.
    pub cycles: u64,
    pub unbounded_cycles: u64,
    pub base_capacity: u32,
    /// What sets the capacity.
    pub binds: String,
}

/// A machine shape tried for `--max-cycles`.
#[derive(Clone, Debug, Serialize)]
pub struct ShapeTrial {
    pub clusters: u32,
    pub ctus_per_cluster: u32,
    pub cycles: u64,
}

/// What a machine costs.
#[derive(Clone, Copy, Debug, Serialize, serde::Deserialize, PartialEq, Eq)]
pub struct Cost {
    pub multiplier_bits: u64,
    pub adder_bits: u64,
    /// Ray buffers + patch buffers + request queues, all clusters, in bits.
    pub sram_bits: u64,
    /// Global memory words: the patch records and the cell table.
    pub memory_words: u64,
    /// Datapath (multiplier + adder bits, all ICUs) plus SRAM bits.
    pub total_bits: u64,
    /// One ICU's Yosys cells ([`synth::icu_cells`]), and whether synthesized (else fitted).
    #[serde(default)]
    pub icu_cells: u64,
    #[serde(default)]
    pub icu_cells_synthesized: bool,
    /// All ICUs' cells.
    #[serde(default)]
    pub datapath_cells: u64,
}

/// A run of a machine: what it measured.
#[derive(Clone, Debug, Serialize)]
pub struct Measured {
    /// Against what the spec names (the target's measure).
    pub ff_err_max: f64,
    /// Against the float model on the same rays, and against the high-ray reference.
    pub ff_err_vs_float: f64,
    pub ff_err_vs_reference: f64,
    pub cycles: u64,
    pub mismatches_vs_fixed: u64,
    pub exceptions: Exceptions,
    pub cost: Cost,
}

/// The result: the machine, the evidence for every knob, and what it measured against the
/// base configuration.
#[derive(Clone, Debug, Serialize)]
pub struct SizeReport {
    pub scene: String,
    pub spec: SizeSpec,
    pub rays: usize,
    pub reference_rays: usize,
    /// The float estimator's own error at the machine's rays against the high-ray reference
    /// (with `against = reference`, no format can beat it).
    pub float_ff_err_max: f64,
    pub bits: Vec<BitsTrial>,
    pub frac_bits: u32,
    /// The base configuration's fractional bits.
    pub base_frac_bits: u32,
    pub ranges: Vec<RangeRow>,
    pub shapes: Vec<ShapeTrial>,
    pub buffers: Vec<BufferRow>,
    pub machine: MachineConfig,
    pub measured: Measured,
    pub base: Measured,
}

/// Form factors (dense, by patch) of `hits` weighted by `weights`.
fn dense(n: usize, hits: impl Iterator<Item = Option<u32>>, weights: &[f64]) -> Vec<f64> {
    let mut f = vec![0.0; n];
    for (h, w) in hits.zip(weights) {
        if let Some(p) = h {
            f[p as usize] += w;
        }
    }
    f
}

fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
}

/// Everything the search measures against, computed once.
struct Bench<'a> {
    scene: &'a Scene,
    file: &'a Path,
    spec: &'a SizeSpec,
    cell: f64,
    rays: RaySet,
    /// The high-ray reference, and the float model on the machine's rays (and its hits).
    reference: Vec<f64>,
    float: Vec<f64>,
    float_hits: Vec<Option<u32>>,
    /// Machine runs so far, counted on a terminal (`size` runs the machine dozens of times).
    progress: std::cell::RefCell<crate::progress::Progress>,
}

impl Bench<'_> {
    /// The fixed-point model's form-factor error on the machine's rays for `dp`, and the
    /// rays it lost where the float reference hit a patch.
    fn fixed_error(&self, dp: DatapathConfig) -> Result<(f64, u64, HostFixed)> {
        let host = HostFixed::new(self.scene, self.file, dp, self.cell)?;
        let src = self.spec.source;
        let hits: Vec<Option<u32>> = self
            .rays
            .rays
            .iter()
            .enumerate()
            .map(|(i, r)| {
                let rec = host.ray_from(i as u32, r, src)?;
                let mut e = Exceptions::default();
                host.scene
                    .nearest_grid(&rec, Some(src), &mut e)
                    .0
                    .map(|h| h.patch)
            })
            .collect();
        let leaks = hits
            .iter()
            .zip(&self.float_hits)
            .filter(|(x, f)| x.is_none() && f.is_some())
            .count() as u64;
        let f = dense(
            self.scene.patches.len(),
            hits.into_iter(),
            &self.rays.weights,
        );
        Ok((max_abs_diff(&f, self.target()), leaks, host))
    }

    /// What the target is measured against.
    fn target(&self) -> &[f64] {
        match self.spec.against {
            Against::Float => &self.float,
            Against::Reference => &self.reference,
        }
    }

    /// Runs the machine `cfg` (scene units) on the spec's rays.
    fn run(&self, cfg: &MachineConfig) -> Result<RunOutput> {
        let spec = RunSpec {
            source: self.spec.source,
            ratio: self.spec.ratio,
            order: TickOrder::Forward,
        };
        let out = run(self.scene, self.file, cfg, &spec, None);
        self.progress.borrow_mut().inc(1);
        out
    }

    /// A full measurement of `cfg`: its error (from the machine's hits), cycles, mismatches
    /// against the untimed model, exceptions and cost.
    fn measure(&self, cfg: &MachineConfig) -> Result<Measured> {
        let out = self.run(cfg)?;
        let f = dense(
            self.scene.patches.len(),
            out.hits.iter().map(|h| h.map(|h| h.patch)),
            &self.rays.weights,
        );
        Ok(Measured {
            ff_err_max: max_abs_diff(&f, self.target()),
            ff_err_vs_float: max_abs_diff(&f, &self.float),
            ff_err_vs_reference: max_abs_diff(&f, &self.reference),
            cycles: out.stats.cycles,
            mismatches_vs_fixed: out.stats.mismatches_vs_fixed,
            exceptions: out.stats.exceptions,
            cost: cost(cfg, self.scene, self.file, self.cell)?,
        })
    }
}

/// The cost of machine `cfg` on `scene`.
pub fn cost(cfg: &MachineConfig, scene: &Scene, file: &Path, cell: f64) -> Result<Cost> {
    let host = HostFixed::new(scene, file, cfg.datapath, cell)?;
    cost_on(cfg, scene, file, &host)
}

/// The cost of machine `cfg` on `scene` already in hardware form (`host`, built on
/// `cfg.datapath` and the resolved cell size).
pub fn cost_on(cfg: &MachineConfig, scene: &Scene, file: &Path, host: &HostFixed) -> Result<Cost> {
    let f = cfg
        .datapath
        .formats()
        .map_err(|e| Error::input(file, e.key, e.what))?;
    let dp = f.cost();
    let m = &cfg.machine;
    let sizes = RecordSizes::of(&f);
    let clusters = m.clusters as u64;
    let ctus = clusters * m.ctus_per_cluster as u64;
    // A job names its ray, its patch, its CTU and its owner cluster.
    let job_bits = (RAY_ID_BITS + PATCH_ID_BITS + 16 + 16) as u64;
    let sram_bits = clusters * m.ray_buffer_capacity as u64 * job_bits
        + clusters * m.patch_buffer_capacity as u64 * sizes.patch_bits as u64
        + ctus * m.request_queue_capacity as u64 * PATCH_ID_BITS as u64;
    let memory_words =
        scene.patches.len() as u64 * sizes.patch_words as u64 + host.scene.cells.words(f.word_bits);
    let datapath = clusters * (dp.multiplier_bits + dp.adder_bits);
    let (icu_cells, icu_cells_synthesized) = synth::icu_cells(
        &cfg.datapath,
        m.divider_bits_per_stage,
        dp.multiplier_bits + dp.adder_bits,
    );
    Ok(Cost {
        multiplier_bits: dp.multiplier_bits,
        adder_bits: dp.adder_bits,
        sram_bits,
        memory_words,
        total_bits: datapath + sram_bits,
        icu_cells,
        icu_cells_synthesized,
        datapath_cells: clusters * icu_cells,
    })
}

/// Signed integer bits of a format whose largest value must reach `bound`.
fn int_bits_for(bound: f64) -> u32 {
    let mut i = 1;
    while (2f64).powi(i as i32 - 1) <= bound {
        i += 1;
    }
    i
}

/// Sizes the machine for `spec` on `scene` (named `file`), starting from `base` (its timing,
/// balancing and policies are kept).
pub fn size(
    scene: &Scene,
    file: &Path,
    base: &MachineConfig,
    spec: &SizeSpec,
) -> Result<SizeReport> {
    let e = spec.target_error;
    if !(e.is_finite() && e > 0.0) {
        return Err(Error::param(
            "target_error",
            format!("{e} is not a positive form-factor error"),
        ));
    }
    if !(1..=100).contains(&spec.ratio) {
        return Err(Error::param(
            "ratio",
            format!("{} is out of range (1..=100)", spec.ratio),
        ));
    }
    let rays_n = PAPER_RAYS * spec.ratio;
    crate::reference::rays::check_source_and_rays(scene, file, spec.source, rays_n)?;
    let resolved = config::resolve(base, scene.size())?;
    let cell = resolved.machine.cell_size.value();
    let tracer = Tracer::new(scene, cell)?;
    let src = &scene.patches[spec.source as usize];
    // The machine's own rays (the partition's high-resolution pass: rings, seed 2).
    let rays = hemisphere_rays(src, rays_n, Directions::Rings, Origins::Patch, 2);
    let ref_n = (REFERENCE_FACTOR * rays_n).max(REFERENCE_MIN);
    let ref_set = hemisphere_rays(
        src,
        ref_n,
        Directions::Malley,
        Origins::Patch,
        REFERENCE_SEED,
    );
    let n = scene.patches.len();
    let hits_of = |set: &RaySet| -> Vec<Option<u32>> {
        use rayon::prelude::*;
        set.rays
            .par_iter()
            .map(|r| tracer.trace(r, Some(spec.source)).map(|h| h.patch))
            .collect()
    };
    let reference = dense(n, hits_of(&ref_set).into_iter(), &ref_set.weights);
    let float_hits = hits_of(&rays);
    let float = dense(n, float_hits.iter().copied(), &rays.weights);
    let float_err = max_abs_diff(&float, &reference);
    if spec.against == Against::Reference && float_err > e {
        return Err(Error::param(
            "target_error",
            format!(
                "{e:e} is below the float estimator's own error at {rays_n} rays ({float_err:.3e} against {ref_n} reference rays): no number format can meet it; raise --ratio or the target"
            ),
        ));
    }
    let bench = Bench {
        scene,
        file,
        spec,
        cell,
        rays,
        reference,
        float,
        float_hits,
        progress: std::cell::RefCell::new(crate::progress::Progress::counter("machine runs")),
    };

    // 1. Fractional bits: bisection over real runs of the fixed-point model.
    let with_bits = |b: u32| {
        let mut dp = resolved.datapath;
        dp.frac_bits = b;
        dp.t_frac_bits = b;
        dp
    };
    let mut bits = Vec::new();
    let mut try_bits = |b: u32| -> Result<bool> {
        let (err, leaks, _) = bench.fixed_error(with_bits(b))?;
        let meets = err <= e && leaks == 0;
        bits.push(BitsTrial {
            frac_bits: b,
            ff_err_max: err,
            leaks,
            meets,
        });
        Ok(meets)
    };
    let (mut lo, mut hi) = (*FRAC_BITS.start(), *FRAC_BITS.end());
    if !try_bits(hi)? {
        let at = bits.last().map_or(f64::NAN, |t| t.ff_err_max);
        return Err(Error::param(
            "target_error",
            format!(
                "{e:e}: no format up to {hi} fractional bits meets it (at {hi} bits the error is {at:.3e}; the float estimator's own is {float_err:.3e})"
            ),
        ));
    }
    if try_bits(lo)? {
        hi = lo;
    }
    // Invariant: `hi` meets the target, `lo` does not (unless both are the range's start).
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        if try_bits(mid)? {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    let frac_bits = hi;
    bits.sort_by_key(|t| t.frac_bits);
    // 2. Integer bits: the scene normalized to its scale lies in [0, 1]³ (coordinates
    //    relative to the grid origin); t reaches at most the grid's diagonal.
    let (_, _, host) = bench.fixed_error(with_bits(frac_bits))?;
    let f = *host.formats();
    let lsb = f.coord.lsb();
    let (mut cmin, mut cmax) = (f64::INFINITY, f64::NEG_INFINITY);
    for p in &host.scene.patches {
        for v in &p.v[..p.n_verts as usize] {
            for &x in v {
                cmin = cmin.min(x as f64 * lsb);
                cmax = cmax.max(x as f64 * lsb);
            }
        }
    }
    let ext = scene.bounds.extent() / scene.bounds.scale();
    let diag = ext.length();
    let mut tmax = 0.0f64;
    for (i, r) in bench.rays.rays.iter().enumerate() {
        if let Some(rec) = host.ray_from(i as u32, r, spec.source) {
            let mut x = Exceptions::default();
            if let Some(h) = host.scene.nearest_grid(&rec, Some(spec.source), &mut x).0 {
                tmax = tmax.max(f.t.to_f64(h.t as i128));
            }
        }
    }
    let coord_bits = int_bits_for(ext.max_element());
    let t_bits = int_bits_for(diag);
    let ranges = vec![
        RangeRow {
            value: "coordinate (scene over its scale, from the grid origin)".into(),
            lower_bound: 0.0,
            measured_min: cmin,
            measured_max: cmax,
            upper_bound: ext.max_element(),
            int_bits: coord_bits,
        },
        RangeRow {
            value: "t (hit distance over the scale)".into(),
            lower_bound: 0.0,
            measured_min: 0.0,
            measured_max: tmax,
            upper_bound: diag,
            int_bits: t_bits,
        },
    ];
    let mut sized = resolved;
    sized.datapath = with_bits(frac_bits);
    sized.datapath.coord_int_bits = coord_bits;
    sized.datapath.t_int_bits = t_bits;
    // The shell radius must still fit the t format.
    if config::resolve(&sized, scene.size()).is_err() {
        sized.datapath.t_int_bits = resolved.datapath.t_int_bits.max(t_bits);
    }

    // 3. Clusters and CTUs: the fewest that meet --max-cycles.
    let mut shapes = Vec::new();
    if let Some(max) = spec.max_cycles {
        let mut found = None;
        let (max_c, max_k) = if spec.allow_larger {
            (MAX_CLUSTERS, u32::MAX)
        } else {
            (base.machine.clusters, base.machine.ctus_per_cluster)
        };
        'shape: for c in 1..=max_c {
            for k in CTU_COUNTS.into_iter().filter(|&k| k <= max_k) {
                let mut t = sized;
                t.machine.clusters = c;
                t.machine.ctus_per_cluster = k;
                let cycles = bench.run(&t)?.stats.cycles;
                shapes.push(ShapeTrial {
                    clusters: c,
                    ctus_per_cluster: k,
                    cycles,
                });
                if cycles <= max {
                    found = Some((c, k));
                    break 'shape;
                }
            }
        }
        let Some((c, k)) = found else {
            let best = shapes.iter().map(|s| s.cycles).min().unwrap_or(0);
            let what = if spec.allow_larger {
                format!(
                    "no machine up to {MAX_CLUSTERS} clusters × {} CTUs",
                    CTU_COUNTS[CTU_COUNTS.len() - 1]
                )
            } else {
                format!(
                    "no machine up to the base configuration's {max_c} clusters × {max_k} CTUs (the ceiling unless a larger machine is allowed: --allow-larger)"
                )
            };
            return Err(Error::param(
                "max_cycles",
                format!("{max}: {what} meets it (the fastest tried took {best} cycles)"),
            ));
        };
        sized.machine.clusters = c;
        sized.machine.ctus_per_cluster = k;
    }

    // 4. Buffers: unbounded first, then each the smallest within the tolerance.
    let unbounded = |c: &MachineConfig| {
        let mut u = *c;
        u.machine.ray_buffer_capacity = 1 << 20;
        u.machine.patch_buffer_capacity = 1 << 16;
        u.machine.request_queue_capacity = 1 << 16;
        u
    };
    let free = bench.run(&unbounded(&sized))?;
    let unb = free.stats.cycles;
    let bound = (unb as f64 * (1.0 + spec.tolerance)).floor() as u64;
    let peak_ray = free
        .stats
        .clusters
        .iter()
        .map(|c| c.ray_buffer.max_occupancy)
        .max()
        .unwrap_or(1);
    let peak_patch = free
        .stats
        .clusters
        .iter()
        .map(|c| c.patch_buffer.max_occupancy)
        .max()
        .unwrap_or(1);
    type Set = fn(&mut MachineConfig, u32);
    let knobs: [(&str, u64, u32, Set); 3] = [
        (
            "ray buffer (jobs)",
            peak_ray,
            base.machine.ray_buffer_capacity,
            |c, v| c.machine.ray_buffer_capacity = v,
        ),
        (
            "patch buffer (patch records)",
            peak_patch,
            base.machine.patch_buffer_capacity,
            |c, v| c.machine.patch_buffer_capacity = v,
        ),
        (
            "request queue (requests per CTU)",
            base.machine.request_queue_capacity as u64,
            base.machine.request_queue_capacity,
            |c, v| c.machine.request_queue_capacity = v,
        ),
    ];
    let mut buffers = Vec::new();
    let mut chosen = Vec::new();
    for (name, peak, base_cap, set) in knobs {
        // Bisection on [1, top]: `top` (the peak, or twice the base for a queue whose peak
        // is not counted) keeps the cycles within the bound.
        let top = (peak.max(1) as u32).max(if name.starts_with("request") {
            2 * base_cap
        } else {
            1
        });
        let cycles_at = |v: u32| -> Result<u64> {
            let mut t = unbounded(&sized);
            set(&mut t, v);
            Ok(bench.run(&t)?.stats.cycles)
        };
        // The smallest legal capacity: a ray buffer holds at least one work-item.
        let least = if name.starts_with("ray") && sized.balance.enabled {
            sized.balance.work_item_jobs
        } else {
            1
        };
        let top = top.max(least);
        let (mut lo, mut hi) = (least - 1, top);
        let mut hi_cycles = cycles_at(hi)?;
        while hi - lo > 1 {
            let mid = lo + (hi - lo) / 2;
            let c = cycles_at(mid)?;
            if c <= bound {
                hi = mid;
                hi_cycles = c;
            } else {
                lo = mid;
            }
        }
        // The base's capacity is the ceiling: what a larger one would buy is reported.
        let ceiling = if !spec.allow_larger && hi > base_cap.max(least) {
            let at_base = cycles_at(base_cap.max(least))?;
            let (want, want_cycles) = (hi, hi_cycles);
            hi = base_cap.max(least);
            hi_cycles = at_base;
            Some(format!(
                "the base's {hi} is the ceiling: {want} would keep the cycles within the tolerance ({at_base} → {want_cycles}, −{:.1} %; --allow-larger takes it)",
                100.0 * (at_base - want_cycles.min(at_base)) as f64 / at_base.max(1) as f64
            ))
        } else {
            None
        };
        let binds = if let Some(c) = ceiling {
            c
        } else if hi == least && least > 1 {
            format!("balance.work_item_jobs = {least} (a work-item must fit)")
        } else if hi == least {
            "the least legal capacity already keeps the cycles".into()
        } else {
            format!(
                "{} would exceed the cycle tolerance ({:.0} %)",
                hi - 1,
                spec.tolerance * 100.0
            )
        };
        buffers.push(BufferRow {
            buffer: name.into(),
            peak_occupancy: peak,
            capacity: hi,
            cycles: hi_cycles,
            unbounded_cycles: unb,
            base_capacity: base_cap,
            binds,
        });
        chosen.push((set, hi));
    }
    for (set, v) in &chosen {
        set(&mut sized, *v);
    }
    // Verified together: grow all three by a quarter until the bound holds.
    let mut measured = bench.measure(&sized)?;
    for _ in 0..16 {
        if measured.cycles <= bound {
            break;
        }
        let m = &mut sized.machine;
        let grow = |v: u32, cap: u32| {
            let g = v + v.div_ceil(4);
            if spec.allow_larger {
                g
            } else {
                g.min(cap.max(v))
            }
        };
        let b = &base.machine;
        let before = (
            m.ray_buffer_capacity,
            m.patch_buffer_capacity,
            m.request_queue_capacity,
        );
        m.ray_buffer_capacity = grow(m.ray_buffer_capacity, b.ray_buffer_capacity);
        m.patch_buffer_capacity = grow(m.patch_buffer_capacity, b.patch_buffer_capacity);
        m.request_queue_capacity = grow(m.request_queue_capacity, b.request_queue_capacity);
        if before
            == (
                m.ray_buffer_capacity,
                m.patch_buffer_capacity,
                m.request_queue_capacity,
            )
        {
            break; // At the ceiling.
        }
        measured = bench.measure(&sized)?;
    }
    for (row, v) in buffers.iter_mut().zip([
        sized.machine.ray_buffer_capacity,
        sized.machine.patch_buffer_capacity,
        sized.machine.request_queue_capacity,
    ]) {
        row.capacity = v;
    }
    // 5. The measured result, and the base configuration on the same rays.
    if measured.mismatches_vs_fixed != 0 || measured.ff_err_max > e {
        return Err(Error::Check(format!(
            "the sized machine misses its target: error {:.3e} (target {e:.3e}), {} mismatches against the untimed model",
            measured.ff_err_max, measured.mismatches_vs_fixed
        )));
    }
    let base_measured = bench.measure(&resolved)?;
    bench.progress.into_inner().finish();
    Ok(SizeReport {
        scene: scene.name.clone(),
        spec: spec.clone(),
        rays: rays_n,
        reference_rays: ref_n,
        float_ff_err_max: float_err,
        bits,
        frac_bits,
        base_frac_bits: base.datapath.frac_bits,
        ranges,
        shapes,
        buffers,
        machine: sized,
        measured,
        base: base_measured,
    })
}

/// The sized machine as a configuration file (usable with `--hw`).
pub fn toml(r: &SizeReport) -> String {
    let body = toml::to_string(&r.machine).expect("a configuration serializes");
    format!(
        "# The smallest machine found by `shellsim size` for {} from patch {}: form-factor\n\
         # error ≤ {:e} at {} rays (measured {:.3e}), {} cycles, 0 mismatches against the\n\
         # untimed model. Lengths in scene units.\n\n{body}",
        r.scene,
        r.spec.source,
        r.spec.target_error,
        r.rays,
        r.measured.ff_err_max,
        r.measured.cycles
    )
}

/// The report as markdown.
pub fn markdown(r: &SizeReport) -> String {
    let mut s = format!(
        "# Sizing {} from patch {}\n\nTarget: form-factor error ≤ {:e} (max over patches of |F_machine − F| with F {}) at {} ring rays (ratio {}). The float estimator's own error at these rays against {} Malley reference rays: {:.3e}.\n\n",
        r.scene,
        r.spec.source,
        r.spec.target_error,
        match r.spec.against {
            Against::Float => "the float model on the same rays",
            Against::Reference => "the high-ray float reference",
        },
        r.rays,
        r.spec.ratio,
        r.reference_rays,
        r.float_ff_err_max
    );
    s.push_str("## Fractional bits (bisection over fixed-point runs)\n\n| bits | error | meets |\n| --- | --- | --- |\n");
    for b in &r.bits {
        s.push_str(&format!(
            "| {} | {:.3e} | {} |\n",
            b.frac_bits,
            b.ff_err_max,
            if b.meets { "yes" } else { "no" }
        ));
    }
    s.push_str(&format!(
        "\nChosen: **{} fractional bits** — the fewest that meet the target ({} bits miss it){}.\n\n",
        r.frac_bits,
        r.frac_bits.saturating_sub(1),
        match r.frac_bits.cmp(&r.base_frac_bits) {
            std::cmp::Ordering::Greater => format!(
                "; **more than the base configuration's {}**: the target asks for them",
                r.base_frac_bits
            ),
            _ => format!("; the base configuration has {}", r.base_frac_bits),
        }
    ));
    s.push_str("## Integer bits\n\nEach from its analytic upper bound (the scene normalized to its largest extent: coordinates in [0, 1], t up to the grid's diagonal), the measured range beside it.\n\n| value | lower bound | measured min | measured max | upper bound | int bits |\n| --- | --- | --- | --- | --- | --- |\n");
    for g in &r.ranges {
        s.push_str(&format!(
            "| {} | {} | {:.4} | {:.4} | {:.4} | {} |\n",
            g.value, g.lower_bound, g.measured_min, g.measured_max, g.upper_bound, g.int_bits
        ));
    }
    if !r.shapes.is_empty() {
        s.push_str("\n## Clusters and CTUs (fewest that meet --max-cycles)\n\n| clusters | CTUs | cycles |\n| --- | --- | --- |\n");
        for t in &r.shapes {
            s.push_str(&format!(
                "| {} | {} | {} |\n",
                t.clusters, t.ctus_per_cluster, t.cycles
            ));
        }
    }
    s.push_str(&format!(
        "\n## Buffers (smallest within {:.0} % of an unbounded machine's cycles{})\n\n| buffer | peak occupancy | capacity | cycles | unbounded | base capacity | what binds |\n| --- | --- | --- | --- | --- | --- | --- |\n",
        r.spec.tolerance * 100.0,
        if r.spec.allow_larger {
            ""
        } else {
            ", the base's capacity the ceiling"
        }
    ));
    for b in &r.buffers {
        s.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {} |\n",
            b.buffer,
            b.peak_occupancy,
            b.capacity,
            b.cycles,
            b.unbounded_cycles,
            b.base_capacity,
            b.binds
        ));
    }
    let row = |name: &str, m: &Measured| {
        format!(
            "| {name} | {:.3e} | {:.3e} | {:.3e} | {} | {} | {} | {}{} | {} | {} | {} |\n",
            m.ff_err_max,
            m.ff_err_vs_float,
            m.ff_err_vs_reference,
            m.cycles,
            m.mismatches_vs_fixed,
            m.cost.multiplier_bits + m.cost.adder_bits,
            m.cost.icu_cells,
            if m.cost.icu_cells_synthesized {
                ""
            } else {
                " (fit)"
            },
            m.cost.sram_bits,
            m.cost.total_bits,
            m.cost.memory_words
        )
    };
    s.push_str("\n## Measured (the chosen machine run, against the base configuration)\n\n| machine | error (target's measure) | vs float | vs reference | cycles | mismatches | datapath bits / ICU | Yosys cells / ICU | SRAM bits | total bits | memory words |\n| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n");
    s.push_str(&row("sized", &r.measured));
    s.push_str(&row("base", &r.base));
    let m = &r.machine.machine;
    s.push_str(&format!(
        "\nThe sized machine: {} clusters × {} CTUs, coordinates Q{}.{}, t Q{}.{}, ray buffer {}, patch buffer {}, request queue {}, grid cells of {:.6} (scene units: `machine.cell_size`, `auto` sizes the grid to the scene, `--cell` sets it).\n",
        m.clusters,
        m.ctus_per_cluster,
        r.machine.datapath.coord_int_bits,
        r.machine.datapath.frac_bits,
        r.machine.datapath.t_int_bits,
        r.machine.datapath.t_frac_bits,
        m.ray_buffer_capacity,
        m.patch_buffer_capacity,
        m.request_queue_capacity,
        m.cell_size.value()
    ));
    s
}
