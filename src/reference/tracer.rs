//! The float reference tracer (f64): a watertight ray/polygon test, nearest hit by brute
//! force or by 3D-DDA over the uniform grid (Amanatides & Woo), both giving identical results.
//!
//! **Invariant:** the nearest hit is the least `(t, patch id)` over all patches with `t > 0`,
//! the excluded (source) patch left out — ties in `t` go to the smaller id. Grid traversal
//! and brute force run the same test (`Tracer::test`, which answers exactly as
//! [`PatchGeom::intersect_if_nearer`]), so they return identical ids and identical bits of `t`.
//!
//! Speed without changing a result: a per-ray mailbox skips repeat tests of a patch listed
//! in several cells; a crossing behind the origin or certainly beyond the nearest hit is
//! rejected before the division (`Nearest`); plane and corner data are laid out apart so
//! that rejections touch little memory; the edge signs are computed branch-free and only
//! undecided ones take the exact path; the DDA steps on constant axis indices with its
//! crossings read in order from the boundary table.
//!
//! **Invariant (watertight):** the inside test evaluates edge functions in a ray-space frame
//! (Woop, Benthin & Wald 2013, as in pbrt-v4), their signs decided exactly (a filtered
//! determinant with an FMA fallback), and an edge the ray passes exactly through belongs to
//! one side only (a top-left fill rule). A ray through an edge or vertex shared by patches
//! that tile a surface therefore hits exactly one of them: no leaks, no double hits.
//!
//! **Invariant (frame):** the tracer works in the scene's own frame, world coordinates minus
//! the bounds' low corner ([`Tracer::frame`]). Every patch and the grid are translated once,
//! when the tracer is built, and every world-space [`Ray`] a public method takes has its
//! origin translated the same way (one subtraction per coordinate) before it is prepared;
//! t is unchanged by a translation, so callers pass world-space rays and get world-space t.
//! Working near the origin keeps the arithmetic's rounding relative to the scene's extent
//! rather than to its distance from the world origin: in world coordinates a scene 10⁶
//! extents away rounds every plane offset, cell bound and overlap test at 2⁻³² of its
//! extent, below the tolerances those tests allow, and patches fall out of the grid. (A
//! scene whose low corner is the origin is traced bit for bit as before: subtracting 0 is
//! exact.)
//!
//! **Invariant (bundles):** [`Tracer::trace_packet`] traces a bundle of rays (one source's
//! hemisphere, say) and answers for each exactly what [`Tracer::trace_counted`] answers —
//! the same patch, the same bits of t, the same cell, nonempty-cell and test counts —
//! because each ray runs the one-ray walk's operations in the one-ray walk's order. It is
//! the bulk entry point (`cast` goes through it), tested equal to the one-ray path on every
//! committed scene and stability case (tests/it/grid_vs_brute.rs). Each ray still walks on its
//! own: issue 36 measured the packet forms against it on one thread (the Cornell box and the
//! Cornell room at 1,183 and 21,175 patches, 969 rays from 50 sources) and all were slower —
//! four rays' walks interleaved in lanes by 38–57 %, the DDA step on selects instead of the
//! branch on the axis (what lanes need) by 28–47 %, rays regrouped by origin cell by 5–20 %,
//! an exact jump over empty cells (a Chebyshev distance field; the counts kept by counting
//! the crossings jumped) by 11–22 % — and the bundle's rays share little to vectorize over:
//! ring neighbours are 4.5° apart and leave their first cell apart, and only 11–18 % of the
//! tests are in a ray's first cell. BENCHMARKS.md has the figures against Embree.

use crate::reference::grid::Grid;
use crate::scene::{Patch, Scene};
use glam::DVec3;

/// A ray `o + t·d`, `t > 0`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub o: DVec3,
    pub d: DVec3,
}

/// A ray prepared for the watertight test: the axis permutation and shear that map the ray
/// onto +z of ray space.
#[derive(Clone, Copy, Debug)]
pub struct PreparedRay {
    pub o: DVec3,
    pub d: DVec3,
    kx: usize,
    ky: usize,
    kz: usize,
    sx: f64,
    sy: f64,
    /// The origin's permuted coordinates `o[kx], o[ky], o[kz]`.
    okx: f64,
    oky: f64,
    okz: f64,
}

impl PreparedRay {
    /// Prepares `ray` (its direction must be finite and nonzero).
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        let d = ray.d;
        let a = d.abs();
        // Ray-space z is the direction's largest component; swapping x and y when it is
        // negative keeps the winding of projected polygons.
        let kz = if a.x > a.y {
            if a.x > a.z {
                0
            } else {
                2
            }
        } else if a.y > a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        let (da, oa) = (d.to_array(), ray.o.to_array());
        if da[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        PreparedRay {
            o: ray.o,
            d,
            kx,
            ky,
            kz,
            sx: da[kx] / da[kz],
            sy: da[ky] / da[kz],
            okx: oa[kx],
            oky: oa[ky],
            okz: oa[kz],
        }
    }

    /// Corners in ray space (2D: the ray itself is the origin), from their coordinate rows:
    /// `p = v − o`, then `(p[kx] − sx·p[kz], p[ky] − sy·p[kz])`.
    #[inline(always)]
    fn project(&self, rows: &[[f64; 4]; 3]) -> ([f64; 4], [f64; 4]) {
        let (vx, vy, vz) = (&rows[self.kx], &rows[self.ky], &rows[self.kz]);
        let mut px = [0.0; 4];
        let mut py = [0.0; 4];
        for i in 0..4 {
            let pz = vz[i] - self.okz;
            px[i] = (vx[i] - self.okx) - self.sx * pz;
            py[i] = (vy[i] - self.oky) - self.sy * pz;
        }
        (px, py)
    }
}

/// A hit: the patch and the ray parameter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub patch: u32,
    pub t: f64,
}

impl Hit {
    /// True when `self` is nearer than `other` by the tie rule: smaller t, then smaller id.
    #[inline]
    pub fn beats(&self, other: &Hit) -> bool {
        self.t < other.t || (self.t == other.t && self.patch < other.patch)
    }
}

/// A patch prepared for intersection: vertices (a triangle repeats none), plane.
#[derive(Clone, Copy, Debug)]
pub struct PatchGeom {
    pub v: [DVec3; 4],
    pub n_verts: u8,
    /// Unit normal (front side) and plane offset: `normal · x = offset` on the plane.
    pub normal: DVec3,
    pub offset: f64,
}

/// Shewchuk's orient2d error bound (3u + 16u²) rounded up: `|p − q|` above this times
/// `|p| + |q|` has the sign of the exact `p − q`.
const DET2_BOUND: f64 = 3.330_669_073_875_472e-16;

/// The sign of `ax·by − ay·bx`, exact: a filtered product difference, with Kahan's FMA
/// algorithm (error under 2 ulp, so its sign is right and it is zero only when exact zero)
/// when the filter cannot decide.
#[inline]
fn det2_sign(ax: f64, ay: f64, bx: f64, by: f64) -> f64 {
    let p = ax * by;
    let q = ay * bx;
    let e = p - q;
    let bound = DET2_BOUND * (p.abs() + q.abs());
    if e.abs() > bound {
        return e;
    }
    let err = (-ay).mul_add(bx, q);
    let f = ax.mul_add(by, -q);
    f + err
}

/// Top-left fill rule for an edge running `(dx, dy)` in ray space with the polygon on its
/// left: exactly one of a direction and its reverse is top-left.
#[inline]
fn top_left(dx: f64, dy: f64) -> bool {
    dy > 0.0 || (dy == 0.0 && dx < 0.0)
}

/// Watertight inside test on ray-space corners `(px[k], py[k])` of a polygon of `n` (3 or 4)
/// vertices — a triangle's corner 3 repeats corner 0.
#[inline(always)]
fn inside_projected(px: &[f64; 4], py: &[f64; 4], n: usize) -> bool {
    // Edge functions e_k = p_k × p_{k+1} over four edges, and their filter bounds,
    // branch-free. (A triangle's edge 2 runs 2 → 3 = 0; its edge 3, the point 0 → 0, is left
    // out below.)
    let mut e = [0.0f64; 4];
    let mut certain = [false; 4];
    for k in 0..4 {
        let j = (k + 1) % 4;
        let p = px[k] * py[j];
        let q = py[k] * px[j];
        e[k] = p - q;
        certain[k] = e[k].abs() > DET2_BOUND * (p.abs() + q.abs());
    }
    // Fast path: every sign certain (so none zero), as det2_sign would return them.
    let tri = n == 3;
    if certain[0] & certain[1] & certain[2] & (tri | certain[3]) {
        let pos = (e[0] > 0.0) & (e[1] > 0.0) & (e[2] > 0.0) & (tri | (e[3] > 0.0));
        let neg = (e[0] < 0.0) & (e[1] < 0.0) & (e[2] < 0.0) & (tri | (e[3] < 0.0));
        return pos | neg;
    }
    inside_exact(px, py, n)
}

/// The inside test with every sign exact and the fill rule on zero edges: the general path
/// of [`inside_projected`], taken when the filter cannot decide some edge.
#[cold]
#[inline(never)]
fn inside_exact(px: &[f64; 4], py: &[f64; 4], n: usize) -> bool {
    // Edge functions: e_k > 0 when the ray lies left of edge k → k+1.
    let mut e = [0.0f64; 4];
    let (mut pos, mut neg) = (false, false);
    for k in 0..n {
        let j = (k + 1) % n;
        e[k] = det2_sign(px[k], py[k], px[j], py[j]);
        pos |= e[k] > 0.0;
        neg |= e[k] < 0.0;
    }
    if pos == neg {
        // Both signs (outside) or all zero (edge-on).
        return false;
    }
    let orient = if pos { 1.0 } else { -1.0 };
    for k in 0..n {
        if e[k] == 0.0 {
            let j = (k + 1) % n;
            let (dx, dy) = (px[j] - px[k], py[j] - py[k]);
            if dx == 0.0 && dy == 0.0 {
                // The edge projects to a point: it bounds nothing.
                continue;
            }
            if !top_left(orient * dx, orient * dy) {
                return false;
            }
        }
    }
    true
}

impl PatchGeom {
    /// Prepares a validated patch.
    pub fn new(p: &Patch) -> Self {
        let mut v = [p.vertices[0]; 4];
        for (k, x) in p.vertices.iter().enumerate() {
            v[k] = *x;
        }
        let normal = p.normal();
        PatchGeom {
            v,
            n_verts: p.vertices.len() as u8,
            normal,
            offset: normal.dot(p.centroid()),
        }
    }

    /// Ray parameter of the plane crossing; NaN or ±inf for a ray parallel to the plane.
    #[inline]
    pub fn plane_t(&self, r: &PreparedRay) -> f64 {
        (self.offset - self.normal.dot(r.o)) / self.normal.dot(r.d)
    }

    /// Watertight inside test: does the ray's line pass through the polygon?
    #[inline]
    pub fn inside(&self, r: &PreparedRay) -> bool {
        // Corners in ray space, as `PreparedRay::project` (a triangle's corner 3 is corner 0).
        let n = if self.n_verts == 3 { 3 } else { 4 };
        let mut px = [0.0; 4];
        let mut py = [0.0; 4];
        for i in 0..4 {
            let v = self.v[if i < n { i } else { 0 }].to_array();
            let pz = v[r.kz] - r.okz;
            px[i] = (v[r.kx] - r.okx) - r.sx * pz;
            py[i] = (v[r.ky] - r.oky) - r.sy * pz;
        }
        inside_projected(&px, &py, n)
    }

    /// The hit of `r` on this patch if it is nearer than `best` (tie rule of [`Hit::beats`]).
    #[inline]
    pub fn intersect_if_nearer(&self, r: &PreparedRay, id: u32, best: &Option<Hit>) -> Option<Hit> {
        // The plane crossing, as `plane_t`; t > 0 needs num and den nonzero and of one sign,
        // decided before dividing.
        let num = self.offset - self.normal.dot(r.o);
        let den = self.normal.dot(r.d);
        if !((num > 0.0 && den > 0.0) || (num < 0.0 && den < 0.0)) {
            return None;
        }
        let t = num / den;
        // Positive and finite (the quotient may underflow or overflow).
        if !(t > 0.0 && t.is_finite()) {
            return None;
        }
        let h = Hit { patch: id, t };
        if let Some(b) = best {
            if !h.beats(b) {
                return None;
            }
        }
        if self.inside(r) {
            Some(h)
        } else {
            None
        }
    }

    /// The hit of `r` on this patch, if any.
    #[inline]
    pub fn intersect(&self, r: &PreparedRay, id: u32) -> Option<Hit> {
        self.intersect_if_nearer(r, id, &None)
    }
}

/// A patch's plane, all that most tests read: 32 bytes, one per cache-line quarter.
#[derive(Clone, Copy, Debug)]
#[repr(align(32))]
struct Plane {
    normal: DVec3,
    offset: f64,
}

/// A patch's corners as coordinate rows (x, y, z of corners 0..3; a triangle's corner 3
/// repeats corner 0), for the inside test.
#[derive(Clone, Copy, Debug)]
struct Corners {
    rows: [[f64; 4]; 3],
    n: usize,
}

impl Corners {
    #[inline(always)]
    fn new(p: &PatchGeom) -> Self {
        let n = if p.n_verts == 3 { 3 } else { 4 };
        let v = [p.v[0], p.v[1], p.v[2], if n == 3 { p.v[0] } else { p.v[3] }];
        Corners {
            rows: [0, 1, 2].map(|a| v.map(|x| x[a])),
            n,
        }
    }
}

/// Work done by one traversal, as the machine would count it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TraceCounts {
    /// Cells stepped through (the CTU's DDA steps).
    pub cells: u32,
    /// Of those, cells holding patches.
    pub nonempty_cells: u32,
    /// Ray/patch tests done (the ICU's jobs; a patch in several cells is tested in each).
    pub tests: u32,
}

/// No patch: patch ids are below [`crate::scene::MAX_PATCHES`].
const NO_PATCH: u32 = u32::MAX;

/// The nearest hit so far, and a bound for rejecting crossings without dividing.
///
/// With `num, den > 0` (signs flipped together) and the nearest hit at a normal `T`: if
/// `num / den >= T (1 + 2^-52)` the exact quotient lies above the midpoint of `T` and its
/// successor, so `t = fl(num / den) > T` and the crossing cannot beat the hit. `far =
/// fl(T (1 + 2^-50))` absorbs two roundings: when `den · far` is normal, `num > fl(den · far)`
/// implies that inequality; when it is subnormal it is below [`Nearest::TINY`], so
/// `num > max(fl(den · far), TINY)` implies `t > T` in every case. `far` is +inf until there
/// is a hit (and while T is subnormal): nothing is rejected on that ground.
struct Nearest {
    hit: Hit,
    far: f64,
}

impl Nearest {
    /// Margin of `far` over the nearest t: 1 + 2^-50.
    const FAR: f64 = 1.0 + 1.0 / (1u64 << 50) as f64;
    /// Floor of the rejection bound: any value above the subnormal range (2^-1022) will do.
    const TINY: f64 = 1.0e-300;

    #[inline(always)]
    fn new() -> Self {
        Nearest {
            hit: Hit {
                patch: NO_PATCH,
                t: f64::INFINITY,
            },
            far: f64::INFINITY,
        }
    }

    #[inline(always)]
    fn set(&mut self, h: Hit) {
        self.hit = h;
        self.far = if h.t >= f64::MIN_POSITIVE {
            h.t * Self::FAR
        } else {
            f64::INFINITY
        };
    }

    #[inline(always)]
    fn get(&self) -> Option<Hit> {
        (self.hit.patch != NO_PATCH).then_some(self.hit)
    }
}

/// A per-ray filter of patches already tested (mailboxing): a patch listed in several cells
/// would be tested again with the same ray, giving the same t and the same answer, and a
/// best hit that can only have improved since — so skipping the repeat changes nothing.
/// Direct-mapped on the low bits of the id; a collision only evicts, costing a repeat test.
struct Mailbox([u32; Mailbox::SLOTS]);

impl Mailbox {
    const SLOTS: usize = 32;

    #[inline]
    fn new() -> Self {
        Mailbox([NO_PATCH; Self::SLOTS])
    }

    /// True if `id` was tested already on this ray; records it otherwise.
    #[inline]
    fn seen(&mut self, id: u32) -> bool {
        let slot = &mut self.0[id as usize % Self::SLOTS];
        let hit = *slot == id;
        *slot = id;
        hit
    }
}

/// A ray prepared by [`Tracer::prepare`]: translated into the tracer's frame, so that only
/// the tracer's own methods take it (a [`PreparedRay`] made from a world-space ray would
/// mix frames).
#[derive(Clone, Copy, Debug)]
pub struct LocalRay(PreparedRay);

/// The float reference tracer: prepared patches and the grid.
#[derive(Clone, Debug)]
pub struct Tracer {
    /// The prepared patches in world space, for callers that measure against world-space
    /// points and rays (the tracer itself tests translated copies, made by `new`: changing
    /// these afterwards does not change what it traces).
    pub patches: Vec<PatchGeom>,
    /// The grid, in the tracer's frame (see [`Tracer::grid`]).
    grid: Grid,
    /// The frame's origin in world space: the scene bounds' low corner.
    frame: DVec3,
    /// Per patch, in the tracer's frame: its plane, and its corners (split so that
    /// rejections touch little memory).
    planes: Vec<Plane>,
    corners: Vec<Corners>,
    /// Slack of the stopping rule, in units of length (see `trace_counted`).
    slack_len: f64,
    /// Per patch, its coplanar twins (`Scene::twins`): excluded with it as the source.
    twins: Vec<Vec<u32>>,
}

impl Tracer {
    /// Prepares `scene` with cells of `cell_size`: translated into its own frame (its
    /// bounds' low corner at the origin, see the module's frame invariant).
    pub fn new(scene: &Scene, cell_size: f64) -> crate::Result<Tracer> {
        let frame = scene.bounds.lo;
        let local = translated(scene, frame);
        let grid = Grid::build(&local, cell_size)?;
        let diag = grid.aabb().extent().length();
        let local_geoms: Vec<PatchGeom> = local.patches.iter().map(PatchGeom::new).collect();
        Ok(Tracer {
            planes: local_geoms
                .iter()
                .map(|p| Plane {
                    normal: p.normal,
                    offset: p.offset,
                })
                .collect(),
            corners: local_geoms.iter().map(Corners::new).collect(),
            patches: scene.patches.iter().map(PatchGeom::new).collect(),
            grid,
            frame,
            slack_len: 1e-9 * diag,
            twins: scene.twins(),
        })
    }

    /// The grid, in the tracer's frame: its box and cell bounds are world coordinates minus
    /// [`Tracer::frame`]. Walk it with [`Tracer::dda`] (or [`Dda::new`] on a ray from
    /// [`Tracer::to_local`]), never with a world-space ray.
    #[inline]
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// The origin of the tracer's frame in world space: the scene bounds' low corner.
    #[inline]
    pub fn frame(&self) -> DVec3 {
        self.frame
    }

    /// `ray` (world space) in the tracer's frame: its origin translated, its direction and
    /// so its t unchanged.
    #[inline(always)]
    pub fn to_local(&self, ray: &Ray) -> Ray {
        Ray {
            o: ray.o - self.frame,
            d: ray.d,
        }
    }

    /// `ray` (world space) translated and prepared for [`Tracer::hit_if_nearer`].
    #[inline]
    pub fn prepare(&self, ray: &Ray) -> LocalRay {
        LocalRay(PreparedRay::new(&self.to_local(ray)))
    }

    /// The grid walk of `ray` (world space), in the tracer's frame; `None` if it misses the
    /// grid. Its t are world-space t.
    #[inline]
    pub fn dda(&self, ray: &Ray) -> Option<Dda<'_>> {
        Dda::new(&self.grid, &self.to_local(ray))
    }

    /// The hit of `r` on patch `id` if it is nearer than `best` (tie rule of [`Hit::beats`]):
    /// [`PatchGeom::intersect_if_nearer`] on the patch in the tracer's frame.
    #[inline]
    pub fn hit_if_nearer(&self, r: &LocalRay, id: u32, best: &Option<Hit>) -> Option<Hit> {
        let mut near = Nearest::new();
        if let Some(b) = best {
            near.set(*b);
        }
        self.test(&r.0, id, &mut near);
        let h = near.get();
        (h != *best).then_some(h).flatten()
    }

    /// Tests patch `id` against `r` and makes it the nearest hit if it is nearer: the same t
    /// and the same answer as [`PatchGeom::intersect_if_nearer`], with the division left for
    /// crossings that may be hits.
    #[inline(always)]
    fn test(&self, r: &PreparedRay, id: u32, near: &mut Nearest) {
        // Plane crossing t = num / den, the operations of `plane_t`.
        let pl = &self.planes[id as usize];
        let num = pl.offset - pl.normal.dot(r.o);
        let den = pl.normal.dot(r.d);
        // Without dividing, reject a crossing behind the origin (num, den not both nonzero
        // of one sign: t <= 0 or NaN) or certainly beyond the nearest hit (see `Nearest`).
        let ahead = (num > 0.0 && den > 0.0) || (num < 0.0 && den < 0.0);
        if !ahead || num.abs() > (den.abs() * near.far).max(Nearest::TINY) {
            return;
        }
        // The exact t: positive and finite (the quotient may underflow or overflow), nearer
        // than the nearest hit by the tie rule.
        let h = Hit {
            patch: id,
            t: num / den,
        };
        if !(h.t > 0.0 && h.t < f64::INFINITY && h.beats(&near.hit)) {
            return;
        }
        // Watertight inside test on the corners in ray space.
        let c = &self.corners[id as usize];
        let (px, py) = r.project(&c.rows);
        if inside_projected(&px, &py, c.n) {
            near.set(h);
        }
    }

    /// The coplanar twins of `source` (`Scene::twins`), which its rays pass through.
    pub fn twins_of(&self, source: Option<u32>) -> &[u32] {
        source
            .and_then(|s| self.twins.get(s as usize))
            .map_or(&[], Vec::as_slice)
    }

    /// Nearest hit by testing every patch (except `exclude` and its coplanar twins).
    pub fn trace_brute(&self, ray: &Ray, exclude: Option<u32>) -> Option<Hit> {
        let r = PreparedRay::new(&self.to_local(ray));
        let twins = self.twins_of(exclude);
        let exclude = exclude.unwrap_or(NO_PATCH);
        let mut near = Nearest::new();
        for id in 0..self.planes.len() as u32 {
            if id != exclude && !twins.contains(&id) {
                self.test(&r, id, &mut near);
            }
        }
        near.get()
    }

    /// Every patch the ray's half-line `t > 0` hits, sorted by (t, id): for watertightness checks.
    pub fn hits_all(&self, ray: &Ray) -> Vec<Hit> {
        let r = PreparedRay::new(&self.to_local(ray));
        let mut v: Vec<Hit> = (0..self.planes.len() as u32)
            .filter_map(|id| {
                let mut near = Nearest::new();
                self.test(&r, id, &mut near);
                near.get()
            })
            .collect();
        v.sort_by(|a, b| a.t.total_cmp(&b.t).then(a.patch.cmp(&b.patch)));
        v
    }

    /// Nearest hit by grid traversal; equal to [`Tracer::trace_brute`].
    #[inline]
    pub fn trace(&self, ray: &Ray, exclude: Option<u32>) -> Option<Hit> {
        self.walk::<false>(ray, exclude).0
    }

    /// Nearest hit by grid traversal, with the work it took.
    pub fn trace_counted(&self, ray: &Ray, exclude: Option<u32>) -> (Option<Hit>, TraceCounts) {
        self.walk::<true>(ray, exclude)
    }

    /// Nearest hits of a bundle of rays (one source's rays, say), with the work each took:
    /// `out[i]` is `trace_counted(&rays[i], exclude)`, bit for bit — the bulk entry point
    /// (`reference::cast::cast` traces through it). Each ray walks on its own (see
    /// the module's note on bundles).
    pub fn trace_packet(
        &self,
        rays: &[Ray],
        exclude: Option<u32>,
        out: &mut [(Option<Hit>, TraceCounts)],
    ) {
        assert_eq!(rays.len(), out.len(), "one result per ray");
        for (r, o) in rays.iter().zip(out) {
            *o = self.walk::<true>(r, exclude);
        }
    }

    /// Nearest hit by 3D-DDA: tests each cell's patches in order of increasing t (each patch
    /// once, see [`Mailbox`]) and stops once the next cell starts beyond the best hit plus a
    /// slack of 1e-9 of the grid's diagonal — so a hit computed a hair beyond its cell can
    /// never hide a nearer one in the next cell — or when the ray leaves the grid.
    fn walk<const COUNT: bool>(
        &self,
        ray: &Ray,
        exclude: Option<u32>,
    ) -> (Option<Hit>, TraceCounts) {
        let mut counts = TraceCounts::default();
        let ray = &self.to_local(ray);
        let Some(mut dda) = Dda::new(&self.grid, ray) else {
            return (None, counts);
        };
        let r = PreparedRay::new(ray);
        let slack_t = self.slack_len / ray.d.length();
        let twins = self.twins_of(exclude);
        let exclude = exclude.unwrap_or(NO_PATCH);
        let mut mailbox = Mailbox::new();
        let mut near = Nearest::new();
        loop {
            // Test the cell's patches (counted as the machine would, repeats included).
            let list = self.grid.patches_in(dda.cell());
            if COUNT {
                counts.cells += 1;
                counts.nonempty_cells += (!list.is_empty()) as u32;
            }
            for &id in list {
                if id == exclude || (!twins.is_empty() && twins.contains(&id)) {
                    continue;
                }
                if COUNT {
                    counts.tests += 1;
                }
                if !mailbox.seen(id) {
                    self.test(&r, id, &mut near);
                }
            }
            // Step on unless the next cell starts beyond the nearest hit and its slack.
            let t_stop = if near.hit.patch != NO_PATCH {
                near.hit.t + slack_t
            } else {
                f64::INFINITY
            };
            if !dda.step_unless_beyond(t_stop) {
                break;
            }
        }
        (near.get(), counts)
    }

    /// Calls `f(cell, t_enter, t_exit)` for every cell the ray passes through, in order,
    /// until the cell that contains `t_limit` (inclusive) or the grid's end. The same
    /// stepping as [`Tracer::trace`].
    pub fn cells_along(&self, ray: &Ray, t_limit: f64, mut f: impl FnMut(usize, f64, f64)) {
        let Some(mut dda) = self.dda(ray) else {
            return;
        };
        loop {
            f(dda.cell(), dda.t_enter(), dda.t_exit());
            if dda.t_exit() >= t_limit || !dda.step() {
                break;
            }
        }
    }
}

/// `scene` with every vertex and its bounds translated by `−by`: one subtraction per
/// coordinate, exact when `by` is zero.
fn translated(scene: &Scene, by: DVec3) -> Scene {
    let mut s = scene.clone();
    s.bounds.lo -= by;
    s.bounds.hi -= by;
    for p in &mut s.patches {
        for v in &mut p.vertices {
            *v -= by;
        }
    }
    s
}

/// The 3D-DDA stepper (Amanatides & Woo) over a [`Grid`]: the current cell and the t at
/// which the ray leaves it. Zero direction components never step (their t_max is +inf);
/// ties between axes step the lowest axis first; every step moves one cell along one axis,
/// so a walk takes at most `nx + ny + nz` steps and always ends. Boundary crossings are
/// computed from the boundary table, not accumulated, so no error builds up.
///
/// Each axis holds the boundaries it has still to cross after its next one, in crossing
/// order: a step takes the first, and an axis with none left is at the grid's last cell.
#[derive(Clone, Debug)]
pub struct Dda<'g> {
    o: [f64; 3],
    inv: [f64; 3],
    c: [usize; 3],
    /// The current cell's linear index, kept in step with `c`.
    idx: usize,
    /// Per axis: the linear-index change of one step (0 for a zero component).
    stride: [isize; 3],
    /// Per axis: the boundaries beyond the next crossing, in crossing order.
    ahead: [&'g [f64]; 3],
    /// Per axis: t of the next crossing.
    t_max: [f64; 3],
    t_enter: f64,
    /// Where the ray leaves the grid's box.
    t_end: f64,
}

impl<'g> Dda<'g> {
    /// Starts the walk where the ray (t >= 0) enters the grid; `None` if it misses the grid.
    /// The ray must be in the grid's frame: a tracer's grid takes [`Tracer::to_local`] rays
    /// (or use [`Tracer::dda`]).
    #[inline(always)]
    pub fn new(grid: &'g Grid, ray: &Ray) -> Option<Self> {
        let (o, d) = (ray.o.to_array(), ray.d.to_array());
        let inv = d.map(|x| 1.0 / x);
        // Clip the ray to the grid box (slab test; a zero component only checks the slab).
        let bx = grid.aabb();
        let (lo, hi) = (bx.lo.to_array(), bx.hi.to_array());
        let mut t0 = 0.0f64;
        let mut t1 = f64::INFINITY;
        let mut outside = false;
        for a in 0..3 {
            if d[a] == 0.0 {
                outside |= o[a] < lo[a] || o[a] > hi[a];
                continue;
            }
            let ta = (lo[a] - o[a]) * inv[a];
            let tb = (hi[a] - o[a]) * inv[a];
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
        }
        if outside || t0 > t1 || t0.is_nan() || t1.is_nan() {
            return None;
        }
        // The entry cell; per axis the stride, the next crossing and the boundaries beyond.
        let start = if t0 > 0.0 {
            [0, 1, 2].map(|a| o[a] + d[a] * t0)
        } else {
            o
        };
        let dims = grid.dims;
        let axis_stride = [1, dims[0] as isize, (dims[0] * dims[1]) as isize];
        let mut c = [0usize; 3];
        let mut stride = [0isize; 3];
        let mut ahead: [&[f64]; 3] = [&[]; 3];
        let mut t_max = [f64::INFINITY; 3];
        for a in 0..3 {
            c[a] = grid.coord(a, start[a]);
            if d[a] != 0.0 {
                // Stepping up, the next crossing is boundary c + 1; stepping down, c (which
                // is `dims − c` counted from the top).
                let up = d[a] > 0.0;
                let b = grid.boundaries_along(a, up);
                let next = if up { c[a] + 1 } else { dims[a] - c[a] };
                stride[a] = if up { axis_stride[a] } else { -axis_stride[a] };
                t_max[a] = (b[next] - o[a]) * inv[a];
                ahead[a] = &b[next + 1..];
            }
        }
        Some(Dda {
            o,
            inv,
            c,
            idx: grid.index(c),
            stride,
            ahead,
            t_max,
            t_enter: t0,
            t_end: t1,
        })
    }

    /// The current cell's linear index.
    #[inline]
    pub fn cell(&self) -> usize {
        self.idx
    }

    /// The current cell's coordinates.
    #[inline]
    pub fn coords(&self) -> [usize; 3] {
        self.c
    }

    /// The t at which the ray entered the current cell.
    #[inline]
    pub fn t_enter(&self) -> f64 {
        self.t_enter
    }

    /// The t at which the ray leaves the current cell (at most the grid's exit).
    #[inline]
    pub fn t_exit(&self) -> f64 {
        let t = self.t_max[self.next_axis()];
        t.min(self.t_end)
    }

    /// The axis of the next step: the smallest t_max, ties to the lowest axis.
    #[inline(always)]
    fn next_axis(&self) -> usize {
        let mut a = 0;
        if self.t_max[1] < self.t_max[a] {
            a = 1;
        }
        if self.t_max[2] < self.t_max[a] {
            a = 2;
        }
        a
    }

    /// Steps into the next cell; false when the ray leaves the grid.
    #[inline(always)]
    pub fn step(&mut self) -> bool {
        self.step_unless_beyond(f64::INFINITY)
    }

    /// Steps into the next cell unless the current one ends beyond `t_stop` (its t_exit is
    /// greater) or the ray leaves the grid; false then.
    #[inline(always)]
    fn step_unless_beyond(&mut self, t_stop: f64) -> bool {
        // One code path per axis: every index is a constant, so the state stays in registers.
        match self.next_axis() {
            0 => self.step_axis::<0>(t_stop),
            1 => self.step_axis::<1>(t_stop),
            _ => self.step_axis::<2>(t_stop),
        }
    }

    /// Steps along axis `A` (the next axis), as [`Dda::step_unless_beyond`].
    #[inline(always)]
    fn step_axis<const A: usize>(&mut self, t_stop: f64) -> bool {
        let t_next = self.t_max[A];
        // The stopping rule on the current cell's exit, min(t_next, t_end) > t_stop (t_end
        // is never NaN; a NaN t_next leaves t_end).
        if (t_next > t_stop || t_next.is_nan()) & (self.t_end > t_stop) {
            return false;
        }
        // Leaving the box, or no axis left to step (every component zero).
        if t_next > self.t_end || t_next == f64::INFINITY {
            return false;
        }
        // Leaving the grid through its last cell on this axis: no boundary beyond.
        let Some((&b, ahead)) = self.ahead[A].split_first() else {
            return false;
        };
        // Move one cell; the axis's next crossing is the boundary beyond.
        self.ahead[A] = ahead;
        self.c[A] = self.c[A].wrapping_add_signed(self.stride[A].signum());
        self.idx = self.idx.wrapping_add_signed(self.stride[A]);
        self.t_enter = t_next;
        self.t_max[A] = (b - self.o[A]) * self.inv[A];
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Aabb;

    fn quad(v: [[f64; 3]; 4]) -> Patch {
        Patch::new(v.iter().map(|a| DVec3::from_array(*a)).collect(), 0.0, 0.5)
    }

    fn two_squares_sharing_an_edge() -> Scene {
        Scene {
            name: "pair".into(),
            bounds: Aabb {
                lo: DVec3::ZERO,
                hi: DVec3::ONE,
            },
            patches: vec![
                quad([
                    [0.1, 0.1, 0.5],
                    [0.5, 0.1, 0.5],
                    [0.5, 0.9, 0.5],
                    [0.1, 0.9, 0.5],
                ]),
                quad([
                    [0.5, 0.1, 0.5],
                    [0.9, 0.1, 0.5],
                    [0.9, 0.9, 0.5],
                    [0.5, 0.9, 0.5],
                ]),
            ],
        }
    }

    #[test]
    fn a_ray_through_a_shared_edge_hits_exactly_one() {
        let s = two_squares_sharing_an_edge();
        let tr = Tracer::new(&s, 0.05).unwrap();
        for (o, d) in [
            ([0.5, 0.5, 0.0], [0.0, 0.0, 1.0]),
            ([0.5, 0.5, 1.0], [0.0, 0.0, -1.0]),
            ([0.3, 0.2, 0.1], [0.2, 0.3, 0.4]),
            ([0.5, 0.3, 0.0], [0.0, 0.1, 1.0]),
        ] {
            let ray = Ray {
                o: DVec3::from_array(o),
                d: DVec3::from_array(d),
            };
            assert_eq!(tr.hits_all(&ray).len(), 1, "{ray:?}");
            assert_eq!(tr.trace(&ray, None), tr.trace_brute(&ray, None));
        }
    }

    #[test]
    fn misses_and_source_exclusion() {
        let s = two_squares_sharing_an_edge();
        let tr = Tracer::new(&s, 0.05).unwrap();
        let up = Ray {
            o: DVec3::new(0.3, 0.5, 0.2),
            d: DVec3::Z,
        };
        assert_eq!(tr.trace(&up, None).unwrap().patch, 0);
        assert_eq!(tr.trace(&up, Some(0)), None);
        let away = Ray {
            o: DVec3::new(0.3, 0.5, 0.6),
            d: DVec3::Z,
        };
        assert_eq!(tr.trace(&away, None), None);
        let parallel = Ray {
            o: DVec3::new(0.0, 0.5, 0.5),
            d: DVec3::X,
        };
        assert_eq!(tr.trace(&parallel, None), None);
        assert_eq!(tr.trace_brute(&parallel, None), None);
    }

    #[test]
    fn exact_sign_where_the_filter_cannot_decide() {
        // 0.1*0.3 - 0.3*0.1 is exactly zero in exact arithmetic of the doubles given.
        assert_eq!(det2_sign(0.1, 0.3, 0.1, 0.3), 0.0);
        let tiny = f64::EPSILON;
        assert!(det2_sign(1.0 + tiny, 1.0, 1.0, 1.0) > 0.0);
        assert!(det2_sign(1.0, 1.0 + tiny, 1.0, 1.0) < 0.0);
    }

    /// The division-free rejection never drops a crossing whose t would not exceed the
    /// nearest hit's, over ordinary, tiny (subnormal products) and huge magnitudes.
    #[test]
    fn the_far_bound_rejects_only_crossings_beyond_the_hit() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(3);
        let (mut near_misses, mut rejections) = (0, 0);
        for i in 0..200_000 {
            let t_hit: f64 = 10f64.powf(rng.gen_range(-300.0..300.0));
            let mut near = Nearest::new();
            near.set(Hit { patch: 0, t: t_hit });
            let den: f64 = 10f64.powf(rng.gen_range(-320.0..300.0));
            // Numerators around t_hit·den, a few ulps either side (or anywhere, sometimes).
            let num = if i % 4 == 0 {
                10f64.powf(rng.gen_range(-320.0..300.0))
            } else {
                let x = t_hit * den;
                let ulps = rng.gen_range(-4i64..=4);
                f64::from_bits((x.to_bits() as i64 + ulps).max(1) as u64)
            };
            if !(num.is_finite() && num > 0.0 && den > 0.0) {
                continue;
            }
            let rejected = num > (den * near.far).max(Nearest::TINY);
            if rejected {
                assert!(num / den > t_hit, "num {num:e} den {den:e} t {t_hit:e}");
                rejections += 1;
            } else {
                near_misses += (num / den > t_hit) as u32;
            }
        }
        // Both ways taken: crossings just beyond the hit are kept (and rejected after the
        // division).
        assert!(
            rejections > 10_000 && near_misses > 1000,
            "{rejections} {near_misses}"
        );
    }

    /// The stepper against a plain Amanatides & Woo walk (indices recomputed each step from
    /// the boundary table): the same cells and the same bits of t, adversarial rays included.
    #[test]
    fn dda_matches_a_plain_walk() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(5);
        let g = Grid::empty(
            Aabb {
                lo: DVec3::new(-0.2, 0.0, 0.1),
                hi: DVec3::new(0.9, 0.7, 1.0),
            },
            0.07,
        )
        .unwrap();
        let b = &g.boundaries;
        for i in 0..20_000 {
            let mut o = DVec3::new(
                rng.gen_range(-0.5..1.2),
                rng.gen_range(-0.3..1.0),
                rng.gen_range(-0.2..1.3),
            );
            let mut d = DVec3::new(
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
            );
            if i % 3 == 0 {
                d[rng.gen_range(0..3)] = 0.0;
            }
            if i % 5 == 0 {
                for a in 0..3 {
                    o[a] = b[a][rng.gen_range(0..b[a].len())];
                }
                d = DVec3::new(1.0, -1.0, 1.0) * d.signum();
            }
            if d == DVec3::ZERO {
                d = DVec3::X;
            }
            let ray = Ray { o, d };
            let mut got = Vec::new();
            if let Some(mut dda) = Dda::new(&g, &ray) {
                loop {
                    got.push((dda.coords(), dda.cell(), dda.t_enter().to_bits()));
                    if !dda.step() {
                        break;
                    }
                }
            }
            assert_eq!(got, plain_walk(&g, &ray), "ray {ray:?}");
        }
    }

    /// Amanatides & Woo as first written: clip, bin the entry point, then per step the axis
    /// of the least t_max (ties to the lowest) and its next crossing from the table.
    fn plain_walk(g: &Grid, ray: &Ray) -> Vec<([usize; 3], usize, u64)> {
        let inv = DVec3::ONE / ray.d;
        let bx = g.aabb();
        let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
        for a in 0..3 {
            if ray.d[a] == 0.0 {
                if ray.o[a] < bx.lo[a] || ray.o[a] > bx.hi[a] {
                    return Vec::new();
                }
                continue;
            }
            let ta = (bx.lo[a] - ray.o[a]) * inv[a];
            let tb = (bx.hi[a] - ray.o[a]) * inv[a];
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
        }
        if t0 > t1 || t0.is_nan() || t1.is_nan() {
            return Vec::new();
        }
        let start = if t0 > 0.0 { ray.o + ray.d * t0 } else { ray.o };
        let mut c = [0usize; 3];
        let mut t_max = [f64::INFINITY; 3];
        let crossing = |a: usize, c: usize| {
            let k = if ray.d[a] > 0.0 { c + 1 } else { c };
            (g.boundaries[a][k] - ray.o[a]) * inv[a]
        };
        for a in 0..3 {
            c[a] = g.coord(a, start[a]);
            if ray.d[a] != 0.0 {
                t_max[a] = crossing(a, c[a]);
            }
        }
        let mut t_enter = t0;
        let mut out = Vec::new();
        loop {
            out.push((c, g.index(c), t_enter.to_bits()));
            let mut a = 0;
            for k in 1..3 {
                if t_max[k] < t_max[a] {
                    a = k;
                }
            }
            let t = t_max[a];
            if t > t1 || t == f64::INFINITY {
                return out;
            }
            let ni = c[a] as isize + if ray.d[a] > 0.0 { 1 } else { -1 };
            if ni < 0 || ni >= g.dims[a] as isize {
                return out;
            }
            c[a] = ni as usize;
            t_enter = t;
            t_max[a] = crossing(a, c[a]);
        }
    }

    /// The tracer's test and `PatchGeom::intersect` find the same hits with the same bits of
    /// t, triangles and rays through shared edges and vertices included.
    #[test]
    fn tracer_test_equals_patch_intersect() {
        use crate::scene::gen::{generate, Kind, DEFAULT_SEED};
        use rand::{Rng, SeedableRng};
        let scene = generate(Kind::StressEdges, DEFAULT_SEED);
        let tr = Tracer::new(&scene, 0.05).unwrap();
        let mut rng = rand_pcg::Pcg64::seed_from_u64(9);
        for i in 0..2_000 {
            let p = &scene.patches[rng.gen_range(0..scene.patches.len())];
            // Aim at a vertex (every other ray) or a random point of the patch.
            let target = if i % 2 == 0 {
                p.vertices[rng.gen_range(0..p.vertices.len())]
            } else {
                p.centroid() + (p.vertices[0] - p.centroid()) * rng.gen::<f64>()
            };
            let o = DVec3::new(rng.gen(), rng.gen(), rng.gen());
            let ray = Ray { o, d: target - o };
            let r = PreparedRay::new(&ray);
            let by_geom: Vec<(u32, u64)> = (0..tr.patches.len() as u32)
                .filter_map(|id| tr.patches[id as usize].intersect(&r, id))
                .map(|h| (h.patch, h.t.to_bits()))
                .collect();
            let mut by_tracer: Vec<(u32, u64)> = tr
                .hits_all(&ray)
                .iter()
                .map(|h| (h.patch, h.t.to_bits()))
                .collect();
            by_tracer.sort_unstable();
            assert_eq!(by_geom, by_tracer, "ray {ray:?}");
        }
    }
}
