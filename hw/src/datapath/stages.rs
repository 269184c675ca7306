//! The fixed-point intersection datapath, as the named stages the ICU pipeline registers
//! between: translate → shear → edges → interpolate → divide → compare.
//!
//! It is Woop, Benthin & Wald's watertight test (JCGT 2013) in integers. The ray-space frame
//! makes the ray the +z axis, so the inside test is a sign test of 2D edge functions at the
//! origin, and t follows from the same edge functions as barycentric weights.
//!
//! **Rounding points** (everything else is exact integer arithmetic):
//! - A, `shear`: the products sx·p_z, sy·p_z, sz·p_z (2F fractional bits) are rounded to F
//!   bits, half up. This keeps the edge multipliers F-bit wide. Both patches that share a
//!   vertex round it identically, which is all watertightness needs.
//! - B, `divide`: the quotient is rounded to the t format, to nearest.
//!
//! **Watertight by construction:** the edge functions are exact 2×2 determinants of the
//! rounded ray-space vertices. A shared edge therefore has the same function in both patches
//! (negated exactly when it runs the other way), and an exact zero goes to one side only by
//! the top-left rule. A ray through a shared edge or vertex of a tessellated surface hits
//! exactly one patch.
//!
//! Stage costs (cycles each stands for) are set by the ICU's configuration (a later issue).
//! The divider is a radix-2 restoring divider: one quotient bit per cycle, pipelined.

use crate::datapath::format::{round_div, round_shift};
use crate::datapath::format::{Fault, Formats};
use crate::datapath::record::{PatchRecord, RayRecord};

/// Exceptions counted by the datapath, never silent.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct Exceptions {
    /// A value outside its declared format (possible only if a record breaks its format).
    pub overflow: u64,
    /// Hits whose interpolation denominator is below 2^F LSBs: nearly edge-on (grazing). The
    /// quotient is still rounded exactly, but the numerator's rounding is magnified.
    pub near_zero_denominator: u64,
    /// Quotients beyond the t format (the plane is hit outside the grid): counted, no hit.
    pub t_saturated: u64,
}

impl Exceptions {
    /// Adds another set of counts.
    pub fn add(&mut self, o: &Exceptions) {
        self.overflow += o.overflow;
        self.near_zero_denominator += o.near_zero_denominator;
        self.t_saturated += o.t_saturated;
    }
}

/// Stage 1 output: vertices relative to the ray origin.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Translated {
    pub n: u8,
    pub p: [[i64; 3]; 4],
}

/// Stage 2 output: vertices in ray space (x, y in the plane normal to the ray, z the
/// distance along it).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RaySpace {
    pub n: u8,
    pub x: [i64; 4],
    pub y: [i64; 4],
    pub z: [i64; 4],
}

/// Stage 3 output: edge functions, the quad's diagonal, and the inside decision.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Edges {
    /// e_k = x_k·y_(k+1) − y_k·x_(k+1) (exact, 2F fractional bits).
    pub e: [i128; 4],
    /// The quad's diagonal v0 → v2 (0 for triangles).
    pub diag: i128,
    pub inside: bool,
    /// +1 when the triangle holding the ray (of a quad: of its two on the diagonal v0–v2)
    /// is seen counter-clockwise in ray space, −1 clockwise.
    pub orient: i8,
}

/// Stage 4 output: t as a fraction, num/den with den > 0 (den: 2F, num: 3F fractional bits).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Interpolated {
    pub valid: bool,
    pub num: i128,
    pub den: i128,
}

/// A hit in fixed point: the patch and t (raw, t format).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct FixedHit {
    pub patch: u32,
    pub t: i64,
}

impl FixedHit {
    /// The tie rule: smaller t, then smaller id.
    #[inline]
    pub fn beats(&self, o: &FixedHit) -> bool {
        self.t < o.t || (self.t == o.t && self.patch < o.patch)
    }
}

/// Stage 1, translate: p_i = v_i − o (exact).
#[inline(always)]
pub fn translate(r: &RayRecord, p: &PatchRecord, f: &Formats, exc: &mut Exceptions) -> Translated {
    let mut t = Translated {
        n: p.n_verts,
        p: [[0; 3]; 4],
    };
    for i in 0..p.n_verts as usize {
        for a in 0..3 {
            let d = p.v[i][a] - r.o[a];
            if !f.translated.fits(d as i128) {
                exc.overflow += 1;
            }
            t.p[i][a] = d;
        }
    }
    t
}

/// Stage 2, shear into ray space; rounding point A.
#[inline(always)]
pub fn shear(r: &RayRecord, t: &Translated, f: &Formats) -> RaySpace {
    let fs = f.shear.frac_bits;
    let (kx, ky, kz) = (r.kx as usize, r.ky as usize, r.kz as usize);
    let mut s = RaySpace {
        n: t.n,
        ..Default::default()
    };
    for i in 0..t.n as usize {
        let p = t.p[i];
        let pz = p[kz] as i128;
        s.x[i] = p[kx] - round_shift(r.sx as i128 * pz, fs) as i64;
        s.y[i] = p[ky] - round_shift(r.sy as i128 * pz, fs) as i64;
        s.z[i] = round_shift(r.sz as i128 * pz, fs) as i64;
    }
    if f.fault == Fault::ShearLaneTruncates && t.n == 4 {
        // The mutant: lane 3 truncates (rounds towards −∞) instead of rounding half up.
        let p = t.p[3];
        let pz = p[kz] as i128;
        s.x[3] = p[kx] - ((r.sx as i128 * pz) >> fs) as i64;
        s.y[3] = p[ky] - ((r.sy as i128 * pz) >> fs) as i64;
        s.z[3] = ((r.sz as i128 * pz) >> fs) as i64;
    }
    s
}

/// Top-left fill rule for an edge running (dx, dy) with the polygon on its left.
#[inline]
fn top_left(dx: i64, dy: i64) -> bool {
    dy > 0 || (dy == 0 && dx < 0)
}

/// Stage 3, edge functions (exact) and the inside test, per triangle: a quad is the two
/// triangles (v0, v2, v3) and (v0, v1, v2) on its diagonal v0–v2, each inside when its three
/// edge functions are of one sign, exact zeros kept only on top-left edges (an edge that
/// projects to a point bounds nothing). Why not the quad's outline: seen edge-on, a quad's
/// rounded ray-space image (rounding point A) may be non-convex, and the outline test then
/// leaves a crack inside it; triangles are never non-convex, and the diagonal is shared
/// exactly. For a convex image the two tests agree ray for ray.
#[inline(always)]
pub fn edges(s: &RaySpace) -> Edges {
    let n = s.n as usize;
    let cross = |a: usize, b: usize| -> i128 {
        s.x[a] as i128 * s.y[b] as i128 - s.y[a] as i128 * s.x[b] as i128
    };
    let mut out = Edges::default();
    for k in 0..n {
        out.e[k] = cross(k, (k + 1) % n);
    }
    if n == 4 {
        out.diag = cross(0, 2);
    }
    // One triangle: its edge functions with their edges (a → b); its orientation if inside.
    let tri = |es: [(i128, usize, usize); 3]| -> Option<i8> {
        let pos = es.iter().any(|e| e.0 > 0);
        let neg = es.iter().any(|e| e.0 < 0);
        if pos == neg {
            return None;
        }
        let o: i64 = if pos { 1 } else { -1 };
        for &(e, a, b) in &es {
            let (dx, dy) = (s.x[b] - s.x[a], s.y[b] - s.y[a]);
            if e == 0 && (dx, dy) != (0, 0) && !top_left(o * dx, o * dy) {
                return None;
            }
        }
        Some(o as i8)
    };
    let e = out.e;
    let hit = if n == 3 {
        tri([(e[0], 0, 1), (e[1], 1, 2), (e[2], 2, 0)])
    } else {
        tri([(out.diag, 0, 2), (e[2], 2, 3), (e[3], 3, 0)])
            .or_else(|| tri([(e[0], 0, 1), (e[1], 1, 2), (-out.diag, 2, 0)]))
    };
    if let Some(o) = hit {
        out.inside = true;
        out.orient = o;
    }
    out
}

/// Stage 4, interpolate: the barycentric weights of the triangle holding the ray (a quad
/// picks (v0,v1,v2) or (v0,v2,v3) by the sign of its diagonal) against the vertices' z —
/// the scaled plane distance num/den, exact.
#[inline(always)]
pub fn interpolate(s: &RaySpace, e: &Edges) -> Interpolated {
    if !e.inside {
        return Interpolated::default();
    }
    let (w, v) = if s.n == 3 {
        ([e.e[1], e.e[2], e.e[0]], [0, 1, 2])
    } else if e.orient as i128 * e.diag >= 0 {
        ([e.e[2], e.e[3], e.diag], [0, 2, 3])
    } else {
        ([e.e[1], -e.diag, e.e[0]], [0, 1, 2])
    };
    let mut den = w[0] + w[1] + w[2];
    let mut num = w[0] * s.z[v[0]] as i128 + w[1] * s.z[v[1]] as i128 + w[2] * s.z[v[2]] as i128;
    if den < 0 {
        den = -den;
        num = -num;
    }
    Interpolated {
        valid: den != 0,
        num,
        den,
    }
}

/// Stage 5, divide: t = num/den rounded to the t format (rounding point B). `None` for no
/// hit: t < 0 (behind the origin) or beyond the t format (counted as saturated). A patch
/// through the origin (t = 0) is hit: the host starts a ray off its source's plane
/// (`ray_from`), so what lies there is a patch stacked on the source within an LSB — the
/// back of cornell's light, under the ceiling — which the float tracer meets too.
#[inline(always)]
pub fn divide(q: &Interpolated, f: &Formats, exc: &mut Exceptions) -> Option<i64> {
    if !q.valid || q.num < 0 {
        return None;
    }
    if q.den < (1i128 << f.coord.frac_bits) {
        exc.near_zero_denominator += 1;
    }
    let ff = f.coord.frac_bits;
    let ft = f.t.frac_bits;
    // num/den carries F fractional bits; scale to the t format.
    let t = if ft >= ff {
        round_div(q.num << (ft - ff), q.den)
    } else {
        round_div(q.num, q.den << (ff - ft))
    };
    if t > f.t.max_raw() {
        exc.t_saturated += 1;
        return None;
    }
    Some(t as i64)
}

/// Stage 6, compare: the new hit replaces the best when nearer by (t, id).
#[inline]
pub fn compare(best: &mut Option<FixedHit>, h: FixedHit) {
    if best.is_none_or(|b| h.beats(&b)) {
        *best = Some(h);
    }
}

/// All stages for one (ray, patch) job: the hit, if any.
#[inline]
pub fn intersect(
    r: &RayRecord,
    p: &PatchRecord,
    f: &Formats,
    exc: &mut Exceptions,
) -> Option<FixedHit> {
    let mut at_divide = Exceptions::default();
    let t = intersect_t(r, p, f, exc, &mut at_divide);
    exc.add(&at_divide);
    t.map(|t| FixedHit { patch: p.id, t })
}

/// All stages for one job, as the ICU evaluates it on entry: t raw (or no hit), with the
/// exceptions of translate counted in `at_translate` and those of divide in `at_divide`
/// (the pipeline counts each when the job passes that stage).
#[inline]
pub fn intersect_t(
    r: &RayRecord,
    p: &PatchRecord,
    f: &Formats,
    at_translate: &mut Exceptions,
    at_divide: &mut Exceptions,
) -> Option<i64> {
    let t = translate(r, p, f, at_translate);
    let s = shear(r, &t, f);
    let e = edges(&s);
    let q = interpolate(&s, &e);
    divide(&q, f, at_divide)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn q(f: &Formats, x: f64) -> i64 {
        f.coord.quantize(x).unwrap()
    }

    fn square(f: &Formats, id: u32, z: f64, x0: f64, x1: f64) -> PatchRecord {
        let v = |x: f64, y: f64| [q(f, x), q(f, y), q(f, z)];
        PatchRecord {
            id,
            n_verts: 4,
            v: [v(x0, 0.1), v(x1, 0.1), v(x1, 0.9), v(x0, 0.9)],
        }
    }

    #[test]
    fn a_vertical_ray_hits_a_square_at_the_right_t() {
        let f = crate::config::paper().datapath.formats().unwrap();
        let one = 1i64 << f.dir.frac_bits;
        let p = square(&f, 3, 0.5, 0.1, 0.9);
        let r = RayRecord::new(0, [q(&f, 0.3), q(&f, 0.4), q(&f, 0.25)], [0, 0, one], &f);
        let mut exc = Exceptions::default();
        let h = intersect(&r, &p, &f, &mut exc).unwrap();
        assert_eq!(h.patch, 3);
        assert_eq!(h.t, f.t.quantize(0.25).unwrap());
        let down = RayRecord::new(0, r.o, [0, 0, -one], &f);
        assert_eq!(
            intersect(&down, &p, &f, &mut exc),
            None,
            "behind the origin"
        );
        assert_eq!(exc, Exceptions::default());
    }

    #[test]
    fn a_ray_exactly_through_a_shared_edge_hits_one_of_the_two() {
        let f = crate::config::paper().datapath.formats().unwrap();
        let one = 1i64 << f.dir.frac_bits;
        let a = square(&f, 0, 0.5, 0.1, 0.5);
        let b = square(&f, 1, 0.5, 0.5, 0.9);
        let mut exc = Exceptions::default();
        for d in [
            [0, 0, one],
            [one / 4, 0, one],
            [0, -one / 3, one],
            [one / 8, one / 8, one],
        ] {
            // A ray aimed at (0.5, 0.5, 0.5) exactly (through the shared edge x = 0.5).
            let o = [
                q(&f, 0.5) - d[0] / 4,
                q(&f, 0.5) - d[1] / 4,
                q(&f, 0.5) - d[2] / 4,
            ];
            let r = RayRecord::new(0, o, d, &f);
            let n = [a, b]
                .iter()
                .filter(|p| intersect(&r, p, &f, &mut exc).is_some())
                .count();
            assert_eq!(n, 1, "direction {d:?}");
        }
    }

    #[test]
    fn a_non_convex_quad_image_has_no_crack() {
        // A quad whose ray-space image is non-convex (an arrowhead with its reflex vertex
        // at v2), as rounding point A can make of a planar quad seen edge-on; the ray (the
        // origin) lies inside it, in triangle (v0, v2, v3), but beyond the line of edge
        // v1 → v2: the outline's edge functions disagree in sign there.
        let s = RaySpace {
            n: 4,
            x: [5, 11, 5, -1],
            y: [-11, 1, -3, 1],
            z: [10, 10, 10, 10],
        };
        let e = edges(&s);
        assert!(e.e.iter().any(|&x| x > 0) && e.e.iter().any(|&x| x < 0));
        assert!(e.inside, "the triangles cover the ray: {e:?}");
        let q = interpolate(&s, &e);
        assert!(q.valid && q.num == 10 * q.den, "{q:?}");
    }

    #[test]
    fn a_record_outside_its_format_is_reported() {
        let f = crate::config::paper().datapath.formats().unwrap();
        let mut p = square(&f, 0, 0.5, 0.1, 0.9);
        p.v[0][0] = f.coord.max_raw() as i64 * 4;
        let r = RayRecord::new(0, [0; 3], [0, 0, 1 << f.dir.frac_bits], &f);
        let mut exc = Exceptions::default();
        let _ = intersect(&r, &p, &f, &mut exc);
        assert_eq!(exc.overflow, 1);
    }
}
