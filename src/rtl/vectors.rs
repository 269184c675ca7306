//! Where the co-simulation's vectors come from, and what the model says each one holds in
//! every stage register.
//!
//! ICU jobs (a ray record and a patch record): the real jobs of scenes (each ray against
//! the patches of the cells its walk visits, origins placed as every command places them),
//! every case of `shellsim stability` (each ray against each patch of the case), vectors
//! aimed at the datapath's branches (rays exactly through shared vertices and edges: exact
//! zero edge functions and top-left ties; patches containing the ray: zero denominators;
//! far patches: t at and beyond its format) and seeded random ones. DDA states: every step of
//! those scenes' walks, and random walks in random grids, each with a t to compare.

use super::layout::{Field, Packer, Params, Stage};
use crate::fixed::records::HostFixed;
use crate::reference::rays::{hemisphere_rays, Directions, Origins};
use crate::scene::Scene;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use shellsim_hw::datapath::dda::{DdaRegs, FixedDda};
use shellsim_hw::datapath::divider;
use shellsim_hw::datapath::record::{CellTable, PatchRecord, RayRecord};
use shellsim_hw::datapath::{edges, interpolate, shear, translate, Exceptions};
use std::path::Path;

/// One ICU job.
#[derive(Clone, Copy, Debug)]
pub struct IcuJob {
    pub ray: RayRecord,
    pub patch: PatchRecord,
}

/// One DDA vector: a state and the t it is compared with.
#[derive(Clone, Copy, Debug)]
pub struct DdaJob {
    pub regs: DdaRegs,
    pub t: i64,
}

/// The input bus of an ICU job, into `b` (`ins`: the ICU's input fields).
pub fn icu_inputs(ins: &[Field], j: &IcuJob, b: &mut Packer) {
    let r = &j.ray;
    let quad = (j.patch.n_verts == 4) as i64;
    let scalars = [
        r.kx as i64,
        r.ky as i64,
        r.kz as i64,
        r.sx,
        r.sy,
        r.sz,
        quad,
    ];
    let vals = r.o.iter().chain(&scalars).chain(j.patch.v.iter().flatten());
    let widths = ins
        .iter()
        .flat_map(|f| std::iter::repeat_n(f.width, f.count as usize));
    b.clear();
    for (&v, w) in vals.zip(widths) {
        b.push(v as i128, w);
    }
}

/// The element widths of `stages`' fields, flattened in packing order.
pub fn widths(stages: &[Stage]) -> Vec<u32> {
    stages
        .iter()
        .flat_map(|s| s.fields.iter())
        .flat_map(|f| std::iter::repeat_n(f.width, f.count as usize))
        .collect()
}

/// Every stage register of an ICU job as the model computes it, packed in stage order into
/// `out` (`widths`: [`widths`] of the ICU's stages; `vals` is scratch), and the job's result
/// (t raw or no hit) from the model's stages. Allocates nothing once the buffers are grown.
pub fn icu_expected(
    p: &Params,
    widths: &[u32],
    j: &IcuJob,
    vals: &mut Vec<i128>,
    out: &mut Packer,
) -> Option<i64> {
    let f = &p.f;
    let (r, pt) = (&j.ray, &j.patch);
    let mut exc = Exceptions::default();
    let tr = translate(r, pt, f, &mut exc);
    let sh = shear(r, &tr, f);
    let ed = edges(&sh);
    let ip = interpolate(&sh, &ed);
    let quad = (pt.n_verts == 4) as i128;
    vals.clear();
    // translate
    vals.push(quad);
    vals.extend(tr.p.iter().flatten().map(|&x| x as i128));
    vals.extend([r.kx, r.ky, r.kz].map(|x| x as i128));
    vals.extend([r.sx, r.sy, r.sz].map(|x| x as i128));
    // shear
    vals.push(quad);
    for a in [&sh.x, &sh.y, &sh.z] {
        vals.extend(a.iter().map(|&x| x as i128));
    }
    // edges
    vals.extend([quad, ed.inside as i128, (ed.orient == -1) as i128]);
    vals.extend(sh.z.iter().map(|&x| x as i128));
    vals.extend(ed.e);
    vals.push(ed.diag);
    // interpolate
    vals.extend([ip.valid as i128, ip.num, ip.den]);
    // divide
    let mut last = divider::DividerStage::default();
    divider::for_each_stage(&ip, f, &p.div, |s| {
        vals.extend([
            s.cand as i128,
            s.near_zero as i128,
            s.ovf as i128,
            s.r as i128,
            s.q as i128,
            s.y as i128,
        ]);
        last = *s;
    });
    // result
    let (t, saturated) = divider::result(&last, f);
    vals.extend([
        t.is_some() as i128,
        t.unwrap_or(0) as i128,
        last.near_zero as i128,
        saturated as i128,
    ]);
    debug_assert_eq!(vals.len(), widths.len());
    out.clear();
    for (&v, &w) in vals.iter().zip(widths) {
        out.push(v, w);
    }
    t
}

/// The input bus of a DDA vector.
pub fn dda_inputs(ins: &[Field], j: &DdaJob) -> Packer {
    let r = &j.regs;
    let vals: [Vec<i128>; 10] = [
        r.c.map(|x| x as i128).to_vec(),
        r.dims.map(|x| x as i128).to_vec(),
        r.step.map(|x| x as i128).to_vec(),
        r.n.map(|x| x as i128).to_vec(),
        r.den.map(|x| x as i128).to_vec(),
        vec![r.cell_raw as i128],
        vec![r.entry_num as i128],
        vec![r.entry_den as i128],
        vec![r.pinned as i128],
        vec![j.t as i128],
    ];
    let mut b = Packer::default();
    for (f, v) in ins.iter().zip(vals.iter()) {
        b.field(f, v);
    }
    b
}

/// The DDA's register after the step, as the model computes it.
pub fn dda_expected(p: &Params, stage: &Stage, j: &DdaJob) -> Packer {
    let ft = p.f.t.frac_bits;
    let before = FixedDda::from(j.regs);
    let mut d = before;
    let moved = d.step();
    let r = DdaRegs::from(&d);
    let vals: [Vec<i128>; 9] = [
        vec![moved as i128],
        r.c.map(|x| x as i128).to_vec(),
        r.n.map(|x| x as i128).to_vec(),
        vec![r.entry_num as i128],
        vec![r.entry_den as i128],
        vec![r.pinned as i128],
        vec![before.exit_beyond(j.t, ft) as i128],
        vec![before.entry_beyond(j.t, ft) as i128],
        vec![before.entry_at_or_beyond(j.t, ft) as i128],
    ];
    let mut b = Packer::default();
    for (f, v) in stage.fields.iter().zip(vals.iter()) {
        b.field(f, v);
    }
    b
}

/// True when every field of the job fits the RTL's input widths (records from the host
/// always do; a generator's stray value is dropped, never wrapped).
fn icu_fits(p: &Params, j: &IcuJob) -> bool {
    let c = p.f.coord;
    let s = p.f.shear;
    j.ray.o.iter().all(|&x| c.fits(x as i128))
        && j.patch.v.iter().flatten().all(|&x| c.fits(x as i128))
        && [j.ray.sx, j.ray.sy, j.ray.sz]
            .iter()
            .all(|&x| s.fits(x as i128))
}

fn dda_fits(p: &Params, j: &DdaJob) -> bool {
    let r = &j.regs;
    let nb = |x: i64| x >= -(1 << (p.nbw - 1)) && x < (1 << (p.nbw - 1));
    r.c.iter().chain(&r.dims).all(|&x| (x as u64) < (1 << p.cb))
        && r.n
            .iter()
            .all(|&x| nb(x) && nb(x + r.cell_raw.max(p.overshoot)))
        && r.den
            .iter()
            .chain([&r.entry_den])
            .all(|&x| x >= 0 && x < (1 << p.denw))
        && nb(r.cell_raw)
        && nb(r.entry_num)
        && p.f.t.fits(j.t as i128)
}

/// Counts of vectors by source.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct Sources {
    pub scenes: u64,
    pub stability: u64,
    /// Of those, each stability case's (by name, in report order).
    pub stability_cases: Vec<(String, u64)>,
    pub directed: u64,
    pub random: u64,
}

/// The ICU jobs and DDA vectors of the scene `scene`'s walks: `rays` rays from each of up to
/// `sources` sources (every n-th patch), each ray against the patches in every cell it
/// visits; the DDA's state at every step with t the ray's nearest hit (or the t format's
/// largest value).
pub fn scene_jobs(
    scene: &Scene,
    host: &HostFixed,
    sources: usize,
    rays: usize,
    icu: &mut Vec<IcuJob>,
    dda: &mut Vec<DdaJob>,
) {
    let fs = &host.scene;
    let n = scene.patches.len();
    let every = n.div_ceil(sources.max(1)).max(1);
    for src in (0..n).step_by(every) {
        let set = hemisphere_rays(
            &scene.patches[src],
            rays,
            Directions::Random,
            Origins::Patch,
            src as u64,
        );
        for (i, ray) in set.rays.iter().enumerate() {
            let Some((r, _)) = host.ray_placed(i as u32, ray, src as u32) else {
                continue;
            };
            let Some(mut d) = FixedDda::new(&fs.cells, &r) else {
                continue;
            };
            let mut exc = Exceptions::default();
            let best = fs.nearest_grid(&r, Some(src as u32), &mut exc).0;
            let t = best.map_or(fs.formats.t.max_raw() as i64, |h| h.t);
            let mut steps = 0;
            loop {
                let c = fs.cells.index(d.c);
                for &id in fs.cells.patches_in(c) {
                    icu.push(IcuJob {
                        ray: r,
                        patch: fs.patches[id as usize],
                    });
                }
                dda.push(DdaJob {
                    regs: DdaRegs::from(&d),
                    t,
                });
                steps += 1;
                if !d.step() || steps > 4096 {
                    break;
                }
            }
        }
    }
}

/// The ICU jobs of every stability case: each ray against every patch of its case (at most
/// `per_case` jobs a case).
pub fn stability_jobs(
    p: &Params,
    rays: usize,
    seed: u64,
    per_case: usize,
    icu: &mut Vec<IcuJob>,
) -> Vec<(String, u64)> {
    let mut counts = vec![];
    let mut cfg = shellsim_hw::config::paper();
    cfg.datapath.frac_bits = p.f.coord.frac_bits;
    cfg.datapath.coord_int_bits = p.f.coord.int_bits;
    cfg.datapath.t_frac_bits = p.f.t.frac_bits;
    cfg.datapath.t_int_bits = p.f.t.int_bits;
    for name in crate::stability::all_cases() {
        let Some(case) = crate::stability::cases::generate_case(&name, rays, seed) else {
            continue;
        };
        let cell = case.scene.bounds.scale() / 20.0;
        let Ok(host) = HostFixed::new(&case.scene, Path::new(case.name), cfg.datapath, cell) else {
            continue;
        };
        let mut jobs = vec![];
        'case: for i in 0..case.rays.len() {
            let Some(r) = crate::stability::record(&host, &case, i) else {
                continue;
            };
            for pt in &host.scene.patches {
                jobs.push(IcuJob { ray: r, patch: *pt });
                if jobs.len() >= per_case {
                    break 'case;
                }
            }
        }
        jobs.retain(|j| icu_fits(p, j));
        counts.push((name.clone(), jobs.len() as u64));
        icu.extend(jobs);
    }
    counts
}

/// A random nonzero direction in the direction format, |d| about 1 (raw).
fn direction(rng: &mut Pcg64, p: &Params) -> [i64; 3] {
    let one = (1i64 << p.f.dir.frac_bits) as f64;
    loop {
        let v: [f64; 3] = [
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
        ];
        let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if l > 0.1 && l <= 1.0 {
            let d = v.map(|x| (x / l * one).round() as i64);
            if d != [0, 0, 0] {
                return d;
            }
        }
    }
}

/// The planar quad c ∓ e1 ∓ e2 around `c` (its vertices in order).
fn parallelogram(c: [i64; 3], e1: [i64; 3], e2: [i64; 3]) -> [[i64; 3]; 4] {
    [(-1, -1), (1, -1), (1, 1), (-1, 1)]
        .map(|(a, b)| [0, 1, 2].map(|k| c[k] + a * e1[k] + b * e2[k]))
}

/// Vectors aimed at the datapath's branches and seeded random ones: `n` jobs.
pub fn directed_and_random(p: &Params, n: usize, seed: u64, directed: bool) -> Vec<IcuJob> {
    let mut rng = Pcg64::seed_from_u64(seed ^ if directed { 0xd1ec7ed } else { 0x7a9d0 });
    let f = &p.f;
    let lim = (f.coord.max_raw() as i64) / 2;
    let mut out = Vec::with_capacity(n);
    let pt = |v: [[i64; 3]; 4], quad: bool| PatchRecord {
        id: 0,
        n_verts: if quad { 4 } else { 3 },
        v: if quad { v } else { [v[0], v[1], v[2], v[2]] },
    };
    let mut id = 0u32;
    while out.len() < n {
        id = id.wrapping_add(1);
        let quad = rng.gen_bool(0.5);
        let kind = if directed { rng.gen_range(0..4) } else { 4 };
        // Small integer steps: rays through lattice points are exact lines.
        let step = 1i64 << (f.dir.frac_bits.saturating_sub(3));
        let small = |rng: &mut Pcg64| -> [i64; 3] {
            loop {
                let a = [
                    rng.gen_range(-7..=7),
                    rng.gen_range(-7..=7),
                    rng.gen_range(-7..=7),
                ];
                if a != [0, 0, 0] {
                    return a;
                }
            }
        };
        let pick = |rng: &mut Pcg64, r: i64| -> [i64; 3] {
            [
                rng.gen_range(-r..=r),
                rng.gen_range(-r..=r),
                rng.gen_range(-r..=r),
            ]
        };
        let size = (lim / 4).max(8);
        let job = match kind {
            // Through a vertex or along a shared edge: exact-zero edge functions, top-left
            // ties; the two triangles of a quad on either side of their shared diagonal.
            0 | 1 => {
                let a = small(&mut rng);
                let target = pick(&mut rng, lim / 2);
                let e1 = pick(&mut rng, size);
                let e2 = pick(&mut rng, size);
                let m = rng.gen_range(1..=lim / 16 / 8 + 1) * 8;
                let o = [
                    target[0] - m * a[0] / 8,
                    target[1] - m * a[1] / 8,
                    target[2] - m * a[2] / 8,
                ];
                let d = a.map(|x| x * step);
                let v0 = if kind == 0 {
                    target
                } else {
                    // Midpoint of edge v0–v1 on the target.
                    [target[0] - e1[0], target[1] - e1[1], target[2] - e1[2]]
                };
                let v1 = [v0[0] + 2 * e1[0], v0[1] + 2 * e1[1], v0[2] + 2 * e1[2]];
                let v2 = [v0[0] + e2[0], v0[1] + e2[1], v0[2] + e2[2]];
                let v3 = [v1[0] + e2[0], v1[1] + e2[1], v1[2] + e2[2]];
                let v = if rng.gen_bool(0.5) {
                    [v0, v1, v3, v2]
                } else {
                    [v0, v2, v3, v1]
                };
                IcuJob {
                    ray: RayRecord::new(id, o, d, f),
                    patch: pt(v, quad),
                }
            }
            // A patch containing the ray's line: zero or tiny denominators (grazing).
            2 => {
                let a = small(&mut rng);
                let o = pick(&mut rng, lim / 2);
                let side = pick(&mut rng, size);
                let m = rng.gen_range(1..=8);
                let on = |k: i64| [o[0] + k * a[0], o[1] + k * a[1], o[2] + k * a[2]];
                let (p0, p1) = (on(m), on(2 * m));
                let nudge = rng.gen_range(-1..=1);
                let v2 = [p1[0] + side[0], p1[1] + side[1] + nudge, p1[2] + side[2]];
                let v3 = [p0[0] + side[0], p0[1] + side[1], p0[2] + side[2]];
                IcuJob {
                    ray: RayRecord::new(id, o, a.map(|x| x * step), f),
                    patch: pt([p0, p1, v2, v3], quad),
                }
            }
            // Far patches: t at and beyond the top of its format.
            3 => {
                let d = direction(&mut rng, p);
                let o = pick(&mut rng, lim);
                let tmax = f.t.max_raw() as f64 * f.t.lsb();
                let t = tmax * rng.gen_range(0.9..1.1);
                let one = (1i64 << f.dir.frac_bits) as f64;
                let at = |dt: f64, e: [i64; 3]| -> [i64; 3] {
                    let c = |k: usize| {
                        o[k] + ((d[k] as f64 / one) * (t + dt) / f.coord.lsb()) as i64 + e[k]
                    };
                    [c(0), c(1), c(2)]
                };
                let e1 = pick(&mut rng, size);
                let e2 = pick(&mut rng, size);
                let c = at(0.0, [0; 3]);
                let v = parallelogram(c, e1, e2);
                IcuJob {
                    ray: RayRecord::new(id, o, d, f),
                    patch: pt(v, quad),
                }
            }
            // Random: a ray, and a patch around a point a random distance along it (or
            // anywhere, a third of the time).
            _ => {
                let d = direction(&mut rng, p);
                let o = pick(&mut rng, lim);
                let one = (1i64 << f.dir.frac_bits) as f64;
                let c = if rng.gen_bool(0.33) {
                    pick(&mut rng, lim)
                } else {
                    let s = rng.gen_range(-0.2..2.0) / f.coord.lsb();
                    [0, 1, 2].map(|k| o[k] + (d[k] as f64 / one * s) as i64)
                };
                let sz = rng.gen_range(1..=size);
                let e1 = pick(&mut rng, sz);
                let e2 = pick(&mut rng, sz);
                let v = parallelogram(c, e1, e2);
                IcuJob {
                    ray: RayRecord::new(id, o, d, f),
                    patch: pt(v, quad),
                }
            }
        };
        if icu_fits(p, &job) {
            out.push(job);
        }
    }
    out
}

/// `n` DDA vectors from random walks in random grids (with t near each cell's exit).
pub fn random_dda(p: &Params, n: usize, seed: u64) -> Vec<DdaJob> {
    let mut rng = Pcg64::seed_from_u64(seed ^ 0xdda);
    let f = &p.f;
    let mut out = Vec::with_capacity(n);
    let top = f.coord.max_raw() as i64 / 2;
    while out.len() < n {
        let dims = [
            rng.gen_range(1..=24u32),
            rng.gen_range(1..=24u32),
            rng.gen_range(1..=24u32),
        ];
        let cmax = top / *dims.iter().max().unwrap() as i64;
        let cell = rng.gen_range(p.overshoot.max(4)..=cmax.max(p.overshoot.max(4)));
        let table = CellTable {
            dims,
            cell_raw: cell,
            ..CellTable::default()
        };
        let o = [0, 1, 2].map(|k| rng.gen_range(0..=dims[k] as i64 * cell));
        let mut d = direction(&mut rng, p);
        // Axis-parallel and diagonal directions a quarter of the time: ties and zeros.
        match rng.gen_range(0..8) {
            0 => d = [d[0], 0, 0],
            1 => d = [0, d[1], d[2]],
            2 => d = [d[0], d[0], d[0]],
            _ => {}
        }
        if d == [0, 0, 0] {
            continue;
        }
        let r = RayRecord::new(0, o, d, f);
        let Some(mut dda) = FixedDda::new(&table, &r) else {
            continue;
        };
        for _ in 0..200 {
            let regs = DdaRegs::from(&dda);
            let t = if rng.gen_bool(0.5) {
                rng.gen_range(0..=f.t.max_raw() as i64)
            } else {
                // Near the entry of this cell: t = entry rounded, ± 1.
                let e =
                    ((regs.entry_num as i128) << f.t.frac_bits) / (regs.entry_den.max(1) as i128);
                (e as i64 + rng.gen_range(-1..=1)).clamp(0, f.t.max_raw() as i64)
            };
            let j = DdaJob { regs, t };
            if dda_fits(p, &j) {
                out.push(j);
            }
            if out.len() >= n || !dda.step() {
                break;
            }
        }
    }
    out
}

/// Drops the DDA vectors that do not fit the RTL's widths (none from real walks).
pub fn keep_fitting_dda(p: &Params, v: &mut Vec<DdaJob>) {
    v.retain(|j| dda_fits(p, j));
}

/// Drops the ICU jobs that do not fit the RTL's input widths.
pub fn keep_fitting_icu(p: &Params, v: &mut Vec<IcuJob>) {
    v.retain(|j| icu_fits(p, j));
}
