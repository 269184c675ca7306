//! Where a ray leaving a patch starts in fixed point: a lattice point inside the closed
//! scene, clear of every patch by more than the datapath's rounding can move a patch.
//!
//! **Why this is watertight by construction.** The datapath (hw/src/datapath/stages.rs) is
//! exact except at rounding point A, where each translated vertex's ray-space x, y and z are
//! rounded to the coordinate LSB (±½ each). Pulled back to the scene, that moves every vertex
//! by at most √(1² + 1² + ½²) = 1.5 LSB (x and y take up to ½ LSB of their own and ½ LSB of
//! z's error through the shear, |d_kx|, |d_ky| ≤ |d_kz|). The datapath then tests the ray
//! *exactly* against the triangles of the moved vertices (a quad as its two triangles on
//! the diagonal v0–v2, stage 3): edge functions are exact, shared vertices move
//! identically, so a closed mesh stays a closed mesh, and the line x = y = 0 crosses it with
//! a consistent top-left rule. (The CTU's walk goes on past the grid face a ray leaves
//! through, hw/src/datapath/dda.rs, so the cells it visits hold every patch it can meet.) A point farther than 1.5 LSB from every
//! patch keeps its side of every moved patch; if it lies inside the closed scene, the ray's
//! half-line `t ≥ 0` must cross the moved surface — it hits some patch. The source itself
//! is excluded, so the origin also keeps more than 1.5 LSB in front of it and the ray's
//! effective direction (the rounded shear's) rises away from it: the ray never meets the
//! moved source, and the patch it crosses is another one.
//!
//! What the host must therefore guarantee, and [`place`] checks exactly enough (f64 on raw
//! integers, margins far above its rounding): the origin (1) lies at least [`CLEAR_LSB`]
//! (2 LSB) from every patch but the source, (2) lies at least [`CLEAR_LSB`] in front of the
//! source, and (3) is joined to the source's front face by a segment along the normal that
//! crosses no patch from behind — so it lies on the same side of every nearby surface as the
//! source's face, i.e. inside the room. The float origin, sampled on the source, may round
//! to the far side of a slanted wall meeting the source (the leak of cornell's red wall, a
//! quarter LSB out), so it is first moved [`INSET_LSB`] inside the quantized source polygon
//! and lifted [`LIFT_LSB`] off its plane, and moved further inside (doubling) when a check
//! fails. Directions whose rounded shear would run along or behind the source are turned one
//! LSB towards its normal.

use glam::DVec3;
use shellsim_hw::datapath::record::{CellTable, PatchRecord};
use shellsim_hw::FixedScene;

/// Least distance, in coordinate LSBs, from the origin to any patch but the source (and
/// in front of the source): above the 1.5 LSB by which rounding point A can move a patch.
pub const CLEAR_LSB: f64 = 2.0;
/// How far the origin is lifted off the source's plane, in LSBs (after rounding to the
/// lattice, at least 3 − √3/2 > [`CLEAR_LSB`]).
pub const LIFT_LSB: f64 = 3.0;
/// The first distance, in LSBs, the origin is kept inside the source's edges; doubled on
/// each failed attempt.
pub const INSET_LSB: f64 = 4.0;
/// Attempts with a doubled inset before the source's centroid is tried.
const ATTEMPTS: usize = 10;

/// How a ray's origin was placed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Placement {
    /// Inside the scene, clear of every patch: the ray cannot leak from a closed scene.
    Clear,
    /// No lattice point near the sampled origin meets the conditions: a patch other than the
    /// source lies within a few LSBs of the source's face there (a panel set just off it,
    /// or a source too small for the format). The origin is the last one tried.
    Crowded { by: Option<u32> },
}

/// The quantized source polygon in LSB units, with what placement needs of it.
struct Source {
    /// Unit normal of the front side (Newell's, of the quantized vertices).
    n: DVec3,
    /// Inward in-plane unit normal of each edge, with the edge's first vertex (the first
    /// `edges` entries; an edge of zero length has none).
    inward: [(DVec3, DVec3); 4],
    edges: usize,
    centroid: DVec3,
}

fn raw(v: [i64; 3]) -> DVec3 {
    DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64)
}

impl Source {
    /// The source `p`; `fallback` is its normal where its quantized vertices collapse.
    fn new(p: &PatchRecord, fallback: DVec3) -> Option<Source> {
        let v = &p.v.map(raw)[..p.n_verts as usize];
        let [x, y, z] = newell(&p.v[..p.n_verts as usize]).map(|c| c as f64);
        let n = DVec3::new(x, y, z)
            .try_normalize()
            .or(fallback.try_normalize())?;
        let mut inward = [(DVec3::ZERO, DVec3::ZERO); 4];
        let mut edges = 0;
        for k in 0..v.len() {
            if let Some(u) = n.cross(v[(k + 1) % v.len()] - v[k]).try_normalize() {
                inward[edges] = (v[k], u);
                edges += 1;
            }
        }
        let centroid = v.iter().copied().sum::<DVec3>() / v.len() as f64;
        Some(Source {
            n,
            inward,
            edges,
            centroid,
        })
    }

    /// The least in-plane distance from `p` to an edge line (negative outside).
    fn clearance(&self, p: DVec3) -> f64 {
        self.inward[..self.edges]
            .iter()
            .map(|&(a, u)| u.dot(p - a))
            .fold(f64::INFINITY, f64::min)
    }

    /// `p` projected onto the source's plane and pushed at least `inset` inside every edge
    /// (a few sweeps of the edge constraints; for a polygon narrower than 2·inset the point
    /// ends near its middle, and the checks decide).
    fn inset(&self, p: DVec3, inset: f64) -> DVec3 {
        let mut q = p - self.n * self.n.dot(p - self.centroid);
        for _ in 0..4 {
            for &(a, u) in &self.inward[..self.edges] {
                let d = u.dot(q - a);
                if d < inset {
                    q += u * (inset - d);
                }
            }
        }
        q
    }
}

/// The closest point of triangle (a, b, c) to p (Ericson, Real-Time Collision Detection 5.1.5).
fn closest_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let den = 1.0 / (va + vb + vc);
    a + ab * (vb * den) + ac * (vc * den)
}

/// The triangles the datapath tests a record as (a quad splits along v0–v2, as stage 4).
fn triangles(p: &PatchRecord) -> impl Iterator<Item = [DVec3; 3]> + '_ {
    let v = p.v.map(raw);
    let quad = p.n_verts == 4;
    [[v[0], v[1], v[2]], [v[0], v[2], v[3]]]
        .into_iter()
        .take(if quad { 2 } else { 1 })
}

/// Distance from `o` to patch `p`.
fn distance(o: DVec3, p: &PatchRecord) -> f64 {
    triangles(p)
        .map(|[a, b, c]| o.distance(closest_on_triangle(o, a, b, c)))
        .fold(f64::INFINITY, f64::min)
}

/// True when the segment from `o` to `e` meets patch `p` while entering it from behind
/// (the segment's start on the back side of the crossed triangle), or passes within
/// `slack` of it undecidedly; a crossing from the front side is allowed (a tile lying on
/// the source, seen from above).
fn crosses_from_behind(o: DVec3, e: DVec3, p: &PatchRecord, slack: f64) -> bool {
    triangles(p).any(|[a, b, c]| {
        let Some(n) = (b - a).cross(c - a).try_normalize() else {
            return false;
        };
        let (so, se) = (n.dot(o - a), n.dot(e - a));
        if so >= slack {
            return false;
        }
        // The segment's point nearest the plane, and its distance from the triangle.
        let s = if so != se {
            (so / (so - se)).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let x = o + (e - o) * s;
        x.distance(closest_on_triangle(x, a, b, c)) <= slack
    })
}

/// The first patch id listed in the cells that the box `[o − r, o + r]` (LSB units)
/// overlaps for which `f` is true (a patch listed in several cells may be seen again).
fn find_near(cells: &CellTable, o: DVec3, r: f64, mut f: impl FnMut(u32) -> bool) -> Option<u32> {
    let w = cells.cell_raw as f64;
    let mut lo = [0u32; 3];
    let mut hi = [0u32; 3];
    for a in 0..3 {
        let top = cells.dims[a] as f64 - 1.0;
        lo[a] = ((o[a] - r) / w).floor().clamp(0.0, top) as u32;
        hi[a] = ((o[a] + r) / w).floor().clamp(0.0, top) as u32;
    }
    for k in lo[2]..=hi[2] {
        for j in lo[1]..=hi[1] {
            for i in lo[0]..=hi[0] {
                let list = cells.patches_in(cells.index([i, j, k]));
                if let Some(&id) = list.iter().find(|&&id| f(id)) {
                    return Some(id);
                }
            }
        }
    }
    None
}

/// Checks a lattice origin `o` for a ray leaving `source`: `None` when it is clear (the
/// three conditions of the module's comment; the source's twins are passed through like
/// the source), else the patch in the way (or `None` inside
/// `Some` when the source itself is too near).
fn blocker(o: DVec3, src: &Source, source: u32, scene: &FixedScene) -> Option<Option<u32>> {
    let (patches, cells) = (&scene.patches, &scene.cells);
    let twins = scene.twins_of(Some(source));
    // In front of the source's plane and over its face.
    let height = src.n.dot(o - src.centroid);
    let sp = &patches[source as usize];
    if height < CLEAR_LSB || distance(o, sp) < CLEAR_LSB || src.clearance(o) < 1.0 {
        return Some(None);
    }
    for [a, b, c] in triangles(sp) {
        if let Some(n) = (b - a).cross(c - a).try_normalize() {
            if n.dot(src.n) > 0.0 && n.dot(o - a) < CLEAR_LSB {
                return Some(None);
            }
        }
    }
    // Clear of every other patch, and joined to the face without entering one from behind.
    let foot = o - src.n * (height + 1.0);
    let by = find_near(cells, o, height + 1.0 + CLEAR_LSB, |id| {
        if id == source || twins.contains(&id) {
            return false;
        }
        let p = &patches[id as usize];
        // Most listed patches lie beyond the reach of both tests by their boxes alone.
        let reach = height + 1.0 + CLEAR_LSB;
        let far = (0..3).any(|a| {
            let vs = p.v[..p.n_verts as usize].iter().map(|v| v[a] as f64);
            let (lo, hi) = vs.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), x| {
                (l.min(x), h.max(x))
            });
            o[a] < lo - reach || o[a] > hi + reach
        });
        !far && (distance(o, p) < CLEAR_LSB || crosses_from_behind(o, foot, p, 0.25))
    });
    by.map(Some)
}

/// The lattice origin (raw coordinates) of a ray leaving `source` from `o` (LSB units, on
/// the float source), and how it was placed; `fallback` is the source's normal in the
/// scene, for a source whose quantized vertices collapse (it is then always crowded by its
/// neighbours). `None` when not even that gives a normal.
pub fn place(
    o: DVec3,
    source: u32,
    scene: &FixedScene,
    fallback: DVec3,
) -> Option<([i64; 3], Placement)> {
    let src = Source::new(scene.patches.get(source as usize)?, fallback)?;
    let lattice = |p: DVec3| [p.x.round() as i64, p.y.round() as i64, p.z.round() as i64];
    let mut last = None;
    let mut inset = INSET_LSB;
    for k in 0..=ATTEMPTS {
        let base = if k == ATTEMPTS {
            src.centroid
        } else {
            src.inset(o, inset)
        };
        let q = lattice(base + src.n * LIFT_LSB);
        match blocker(raw(q), &src, source, scene) {
            None => return Some((q, Placement::Clear)),
            Some(by) => last = Some((q, Placement::Crowded { by })),
        }
        inset *= 2.0;
    }
    last
}

/// The front-side test of a ray record's effective direction against the source: the
/// rounded shear's direction (sx, sy, 1)·sign(d_kz) in ray-space axes, dotted with the
/// source's Newell normal `n` (exact integers). The ray rises away from the source when
/// this is positive.
pub fn rises(r: &shellsim_hw::RayRecord, n: [i128; 3], shear_one: i128) -> bool {
    let (kx, ky, kz) = (r.kx as usize, r.ky as usize, r.kz as usize);
    let s = n[kx] * r.sx as i128 + n[ky] * r.sy as i128 + n[kz] * shear_one;
    (if r.d[kz] < 0 { -s } else { s }) > 0
}

/// Newell's normal of a quantized polygon (exact): its direction is the front side's.
pub fn newell(v: &[[i64; 3]]) -> [i128; 3] {
    let mut n = [0i128; 3];
    for (k, a) in v.iter().enumerate() {
        let b = v[(k + 1) % v.len()];
        let (a, b) = (a.map(|x| x as i128), b.map(|x| x as i128));
        n[0] += (a[1] - b[1]) * (a[2] + b[2]);
        n[1] += (a[2] - b[2]) * (a[0] + b[0]);
        n[2] += (a[0] - b[0]) * (a[1] + b[1]);
    }
    n
}
