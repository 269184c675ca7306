//! The scene model: planar convex patches (triangles and quads) with emission and
//! reflectance, the scene, its JSON form, and validation with errors that name the file and
//! the patch. The polygon geometry is checked by [`super::polygon`].

use super::polygon::{self, MAX_COORD};
use crate::error::{short, Error, Result};
use crate::output::write_atomic;
use glam::DVec3;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Most patches a scene may hold: patch ids are 24-bit in the hardware's records.
pub const MAX_PATCHES: usize = 1 << 24;

/// A grey value or an RGB triple; grey `g` means `[g, g, g]`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Spectrum {
    Grey(f64),
    Rgb([f64; 3]),
}

impl Spectrum {
    /// The three channels.
    pub fn rgb(self) -> [f64; 3] {
        match self {
            Spectrum::Grey(g) => [g; 3],
            Spectrum::Rgb(c) => c,
        }
    }
    /// True when some channel is above zero.
    pub fn is_nonzero(self) -> bool {
        self.rgb().iter().any(|&c| c > 0.0)
    }
}

impl Default for Spectrum {
    fn default() -> Self {
        Spectrum::Grey(0.0)
    }
}

/// One patch: a planar convex polygon of 3 or 4 vertices. The front side is the one from
/// which the vertices are seen counter-clockwise; its id is its index in the scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Patch {
    #[serde(with = "vec3_list")]
    pub vertices: Vec<DVec3>,
    #[serde(default)]
    pub emission: Spectrum,
    #[serde(default = "default_reflectance")]
    pub reflectance: Spectrum,
    /// The group or object it came from (OBJ `g`/`o`), if named; absent from the JSON when
    /// `None`, so scenes without names serialize as before.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Its material's name (OBJ `usemtl`), if any; absent from the JSON when `None`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub material: Option<String>,
}

fn default_reflectance() -> Spectrum {
    Spectrum::Grey(0.5)
}

/// An axis-aligned box `[lo, hi]` (closed).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub lo: DVec3,
    pub hi: DVec3,
}

impl Aabb {
    /// True when `p` lies in the closed box.
    pub fn contains(&self, p: DVec3) -> bool {
        p.cmpge(self.lo).all() && p.cmple(self.hi).all()
    }
    /// The box's size along each axis.
    pub fn extent(&self) -> DVec3 {
        self.hi - self.lo
    }

    /// The scene's length scale: its largest extent (1 for the unit cube). The hardware
    /// works in units of it (coordinates relative to `lo`, divided by the scale), so a scene
    /// scaled by any factor gives the hardware the same numbers.
    pub fn scale(&self) -> f64 {
        let e = self.extent();
        e.x.max(e.y).max(e.z)
    }
}

/// How far from the world origin a scene may reach, in units of its largest extent: 2^22.
///
/// An f64 coordinate of magnitude below 2^22·E has an ulp of at most E·2^-30, so every
/// coordinate of the scene holds at least 30 bits of its extent E. The tracers need that
/// much: the float tracer works relative to the bounds' low corner, but the input itself
/// (vertices, bounds, ray origins drawn on a patch in world space) is rounded at the ulp of
/// its magnitude, and its tolerances are about that size relative to the extent — the
/// stopping slack 1e-9 of the grid's diagonal (≈ 2^-30 E), the overlap slack 1e-9 of a cell
/// (≈ 2^-34 E), the origins' pull of 1e-6 of a patch off its edges. Rounding coarser than
/// that moves a ray's origin or a wall's vertex by more than the slacks absorb, and rays
/// escape (a unit box 10^8 away loses every ray). Scenes beyond the bound are refused rather
/// than traced wrongly; [`MAX_COORD`] still bounds the magnitude itself.
pub const MAX_OFFSET_EXTENTS: f64 = (1u64 << 22) as f64;

/// A scene: a name, the bounds every patch lies in, and the patches.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    pub name: String,
    pub bounds: Aabb,
    pub patches: Vec<Patch>,
}

impl Patch {
    /// A grey patch with the given vertices.
    pub fn new(vertices: Vec<DVec3>, emission: f64, reflectance: f64) -> Self {
        Patch {
            vertices,
            emission: Spectrum::Grey(emission),
            reflectance: Spectrum::Grey(reflectance),
            name: None,
            material: None,
        }
    }

    /// True when `name` is this patch's group/object name or its material's name.
    pub fn is_named(&self, name: &str) -> bool {
        self.name.as_deref() == Some(name) || self.material.as_deref() == Some(name)
    }

    /// The name to show for the patch: its group/object name, else its material's.
    pub fn label(&self) -> Option<&str> {
        self.name.as_deref().or(self.material.as_deref())
    }

    /// The same patch seen from the other side: the vertex order reversed (the first vertex
    /// kept), so the front side and the normal flip.
    pub fn flip(&mut self) {
        self.vertices[1..].reverse();
    }

    /// Newell's normal: twice the vector area; its length is twice the polygon's area and it
    /// points to the front side (counter-clockwise vertices).
    pub fn area_vector(&self) -> DVec3 {
        polygon::area_vector(&self.vertices)
    }

    /// The unit normal of the front side.
    pub fn normal(&self) -> DVec3 {
        self.area_vector().normalize()
    }

    /// The patch's area.
    pub fn area(&self) -> f64 {
        0.5 * self.area_vector().length()
    }

    /// The vertex average (inside, since the patch is convex).
    pub fn centroid(&self) -> DVec3 {
        self.vertices.iter().copied().sum::<DVec3>() / self.vertices.len() as f64
    }

    /// The longest distance between two vertices.
    pub fn diameter(&self) -> f64 {
        polygon::diameter(&self.vertices)
    }

    /// Checks the patch: 3 or 4 vertices, finite and in range ([`polygon::check_points`]),
    /// emission and reflectance, then the shape ([`polygon::check_shape`]: planar, convex,
    /// nonzero area). `Err` holds what is wrong (without file or id).
    pub fn check(&self) -> std::result::Result<(), String> {
        let v = &self.vertices;
        if v.len() < 3 {
            return Err(format!(
                "has {} vertices; a patch needs 3 (triangle) or 4 (quad)",
                v.len()
            ));
        }
        if v.len() > 4 {
            return Err(format!(
                "has {} vertices; a patch is a triangle or a quad (split it, or import it from OBJ, which splits larger faces)",
                v.len()
            ));
        }
        polygon::check_points(v)?;
        for (what, s) in [
            ("emission", self.emission),
            ("reflectance", self.reflectance),
        ] {
            for c in s.rgb() {
                if !c.is_finite() || c < 0.0 {
                    return Err(format!(
                        "{what} {} is out of range (must be finite and >= 0)",
                        short(c)
                    ));
                }
            }
        }
        if self.reflectance.rgb().iter().any(|&c| c > 1.0) {
            return Err(format!(
                "reflectance {:?} is out of range (must be at most 1)",
                self.reflectance.rgb()
            ));
        }
        polygon::check_shape(v)
    }
}

impl Scene {
    /// What the configuration's `auto` lengths are derived from: the largest extent and
    /// the patch count.
    pub fn size(&self) -> crate::config::SceneSize {
        crate::config::SceneSize {
            scale: self.bounds.scale(),
            patches: self.patches.len(),
        }
    }

    /// Checks the bounds and every patch; the error names `file` and the patch.
    pub fn validate(&self, file: &Path) -> Result<()> {
        let b = self.bounds;
        let huge = b.lo.abs().max_element().max(b.hi.abs().max_element()) > MAX_COORD;
        if !b.lo.is_finite() || !b.hi.is_finite() || !b.lo.cmplt(b.hi).all() || huge {
            return Err(Error::input(
                file,
                "bounds",
                format!(
                    "bounds {:?} - {:?} must be finite, at most {MAX_COORD:e} in magnitude, with lo < hi on every axis",
                    b.lo.to_array(),
                    b.hi.to_array()
                ),
            ));
        }
        let far = b.lo.abs().max_element().max(b.hi.abs().max_element());
        let scale = b.scale();
        if far > MAX_OFFSET_EXTENTS * scale {
            return Err(Error::input(
                file,
                "bounds",
                format!(
                    "bounds {:?} - {:?} reach {} from the origin, more than 2^22 = {} times their largest extent {}: coordinates that far out keep fewer than 30 bits of the scene's extent (a coordinate's ulp must be at most extent·2^-30); move the scene nearer the origin",
                    b.lo.to_array(),
                    b.hi.to_array(),
                    short(far),
                    MAX_OFFSET_EXTENTS,
                    short(scale)
                ),
            ));
        }
        if self.patches.is_empty() {
            return Err(Error::input(file, "patches", "the scene has no patches"));
        }
        if self.patches.len() > MAX_PATCHES {
            return Err(Error::input(
                file,
                "patches",
                format!(
                    "{} patches is more than the {MAX_PATCHES} a scene may hold",
                    self.patches.len()
                ),
            ));
        }
        for (id, p) in self.patches.iter().enumerate() {
            p.check()
                .map_err(|what| Error::input(file, format!("patch {id}"), what))?;
            for (k, v) in p.vertices.iter().enumerate() {
                if !b.contains(*v) {
                    return Err(Error::input(
                        file,
                        format!("patch {id}"),
                        format!(
                            "vertex {k} [{}, {}, {}] lies outside the bounds {:?} - {:?}",
                            short(v.x),
                            short(v.y),
                            short(v.z),
                            b.lo.to_array(),
                            b.hi.to_array()
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    /// Reads and validates a JSON scene.
    pub fn load_json(path: &Path) -> Result<Scene> {
        let text = crate::limits::read_input_string(path)?;
        Scene::from_json_str(&text, path)
    }

    /// Parses and validates JSON scene text; `path` is only used to name the file in errors.
    pub fn from_json_str(text: &str, path: &Path) -> Result<Scene> {
        let value: serde_json::Value = serde_json::from_str(text).map_err(|e| {
            Error::input(
                path,
                format!("line {} column {}", e.line(), e.column()),
                format!("not valid JSON: {e}"),
            )
        })?;
        let top: SceneFile = serde_json::from_value(value)
            .map_err(|e| Error::input(path, "top level", e.to_string()))?;
        let mut patches = Vec::with_capacity(top.patches.len());
        for (id, pv) in top.patches.into_iter().enumerate() {
            let p: Patch = serde_json::from_value(pv)
                .map_err(|e| Error::input(path, format!("patch {id}"), e.to_string()))?;
            patches.push(p);
        }
        let scene = Scene {
            name: top.name,
            bounds: Aabb {
                lo: DVec3::from_array(top.bounds[0]),
                hi: DVec3::from_array(top.bounds[1]),
            },
            patches,
        };
        scene.validate(path)?;
        Ok(scene)
    }

    /// The scene as JSON text (the schema in docs/manual/scenes.md), one patch per line.
    pub fn to_json_string(&self) -> String {
        let mut s = String::new();
        s.push_str("{\n  \"name\": ");
        s.push_str(&serde_json::to_string(&self.name).expect("a string serializes"));
        s.push_str(",\n  \"bounds\": ");
        let bounds = [self.bounds.lo.to_array(), self.bounds.hi.to_array()];
        s.push_str(&serde_json::to_string(&bounds).expect("numbers serialize"));
        s.push_str(",\n  \"patches\": [\n");
        for (i, p) in self.patches.iter().enumerate() {
            s.push_str("    ");
            s.push_str(&serde_json::to_string(p).expect("a patch serializes"));
            if i + 1 < self.patches.len() {
                s.push(',');
            }
            s.push('\n');
        }
        s.push_str("  ]\n}\n");
        s
    }

    /// Writes the scene as JSON, atomically.
    pub fn save_json(&self, path: &Path) -> Result<()> {
        write_atomic(path, self.to_json_string().as_bytes())
    }

    /// The total area of all patches.
    pub fn total_area(&self) -> f64 {
        self.patches.iter().map(Patch::area).sum()
    }

    /// Coplanar twins: per patch, the other patches that lie in its plane within
    /// [`TWIN_TOL`] of the scene's scale (every vertex, whichever way they face) and overlap
    /// it with positive area — a coincident duplicate, a tile lying on a floor. **The one rule of all three models:** rays leaving a patch
    /// pass through its twins (the float reference, the untimed fixed-point model and the
    /// machine exclude them with the source), so that no model's answer turns on how the
    /// rounding orders two surfaces closer than the datapath can tell apart. Ascending ids;
    /// symmetric.
    pub fn twins(&self) -> Vec<Vec<u32>> {
        let n = self.patches.len();
        let tol = TWIN_TOL * self.bounds.scale();
        // Candidates share a bucket of a coarse grid over the bounds (a patch is put in every
        // bucket its box, widened by the tolerance, overlaps): near-linear for tiled walls.
        const BUCKETS: f64 = 32.0;
        let lo = self.bounds.lo;
        let inv = BUCKETS / self.bounds.scale();
        let top = BUCKETS as i64 - 1;
        let cell = |x: DVec3| {
            (((x - lo) * inv).floor())
                .as_i64vec3()
                .clamp(glam::I64Vec3::ZERO, glam::I64Vec3::splat(top))
        };
        let mut buckets: std::collections::HashMap<glam::I64Vec3, Vec<u32>> =
            std::collections::HashMap::new();
        // Each patch's lowest bucket: a pair is tested only in the larger of its two
        // (a bucket both lie in when any is), once however many buckets they share.
        let mut corner: Vec<glam::I64Vec3> = Vec::with_capacity(n);
        for (id, p) in self.patches.iter().enumerate() {
            let b_lo = p
                .vertices
                .iter()
                .copied()
                .reduce(DVec3::min)
                .unwrap_or_default();
            let b_hi = p
                .vertices
                .iter()
                .copied()
                .reduce(DVec3::max)
                .unwrap_or_default();
            let (c0, c1) = (cell(b_lo - tol), cell(b_hi + tol));
            corner.push(c0);
            for z in c0.z..=c1.z {
                for y in c0.y..=c1.y {
                    for x in c0.x..=c1.x {
                        buckets
                            .entry(glam::I64Vec3::new(x, y, z))
                            .or_default()
                            .push(id as u32);
                    }
                }
            }
        }
        let mut pairs: Vec<(u32, u32)> = Vec::new();
        for (&b, ids) in &buckets {
            for (i, j) in self.candidate_pairs(ids) {
                if corner[i as usize].max(corner[j as usize]) == b
                    && self.coplanar_overlap(i, j, tol)
                {
                    pairs.push((i, j));
                }
            }
        }
        let mut out = vec![Vec::new(); n];
        for (i, j) in pairs {
            out[i as usize].push(j);
            out[j as usize].push(i);
        }
        for t in &mut out {
            t.sort_unstable();
            t.dedup();
        }
        out
    }

    /// What a person loading the scene should know of its twins (`None` when it has none):
    /// the pairs with their names, the first eight listed.
    pub fn twins_warning(&self) -> Option<String> {
        let pairs = self.twin_pairs();
        if pairs.is_empty() {
            return None;
        }
        let name = |i: u32| {
            self.patches[i as usize]
                .label()
                .map_or(format!("{i}"), |l| {
                    format!("{i} ({})", crate::error::shown(l))
                })
        };
        let mut list: Vec<String> = pairs
            .iter()
            .take(8)
            .map(|&(i, j)| format!("{} and {}", name(i), name(j)))
            .collect();
        if pairs.len() > 8 {
            list.push(format!("{} more", pairs.len() - 8));
        }
        Some(format!(
            "{} pairs of coplanar overlapping patches (twins: a source's rays pass through its twins in every model): {}",
            pairs.len(),
            list.join(", ")
        ))
    }

    /// The coplanar twin pairs `(i, j)`, `i < j`, ascending (see [`Scene::twins`]).
    pub fn twin_pairs(&self) -> Vec<(u32, u32)> {
        self.twins()
            .iter()
            .enumerate()
            .flat_map(|(i, t)| {
                t.iter()
                    .filter(move |&&j| j > i as u32)
                    .map(move |&j| (i as u32, j))
            })
            .collect()
    }

    /// The pairs of `ids` (one bucket of [`Scene::twins`]) that may overlap: every pair of
    /// a small bucket; in a large one, the patches around the vertex most of them share (a
    /// face split into a fan of thousands of triangles) are paired only when their wedges
    /// at that vertex overlap — two convex polygons of one plane whose wedges at a common
    /// vertex are disjoint are separated by a line through it — by a sweep over the
    /// wedges' angles, so that a fan costs O(n log n), not O(n²). Other pairs are all
    /// listed.
    fn candidate_pairs(&self, ids: &[u32]) -> Vec<(u32, u32)> {
        let all = |v: &[u32], out: &mut Vec<(u32, u32)>| {
            for (k, &i) in v.iter().enumerate() {
                for &j in &v[k + 1..] {
                    out.push((i, j));
                }
            }
        };
        let mut out = Vec::new();
        if ids.len() <= 64 {
            all(ids, &mut out);
            return out;
        }
        let key = |v: DVec3| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
        let mut count: std::collections::HashMap<[u64; 3], usize> = Default::default();
        for &i in ids {
            for &v in &self.patches[i as usize].vertices {
                *count.entry(key(v)).or_default() += 1;
            }
        }
        let Some((&vk, _)) = count.iter().max_by_key(|(k, c)| (**c, **k)) else {
            all(ids, &mut out);
            return out;
        };
        // The wedge of each patch at the vertex: (axis dropped, start angle, width).
        let mut rest: Vec<u32> = Vec::new();
        let mut wedges: Vec<(usize, f64, f64, u32)> = Vec::new();
        for &i in ids {
            match self.wedge(i, vk) {
                Some((k, a, w)) => wedges.push((k, a, w, i)),
                None => rest.push(i),
            }
        }
        all(&rest, &mut out);
        for &r in &rest {
            for w in &wedges {
                out.push((r.min(w.3), r.max(w.3)));
            }
        }
        // Per projection, a sweep over the angle (a wedge past 2π also starts below 0).
        const MARGIN: f64 = 1e-9;
        let tau = std::f64::consts::TAU;
        for axis in 0..3 {
            let mut items: Vec<(f64, f64, u32)> = Vec::new();
            for &(k, a, w, i) in &wedges {
                if k == axis {
                    items.push((a, a + w, i));
                    if a + w > tau {
                        items.push((a - tau, a + w - tau, i));
                    }
                }
            }
            items.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.2.cmp(&y.2)));
            let mut active: Vec<(f64, u32)> = Vec::new();
            let mut found: Vec<(u32, u32)> = Vec::new();
            for &(a, e, i) in &items {
                active.retain(|&(end, _)| end >= a - MARGIN);
                for &(_, j) in &active {
                    if j != i {
                        found.push((i.min(j), i.max(j)));
                    }
                }
                active.push((e, i));
            }
            found.sort_unstable();
            found.dedup();
            out.extend(found);
        }
        out
    }

    /// Patch `i`'s wedge at its vertex `v` (bits of x, y, z), in the plane of its normal's
    /// largest axis dropped: (that axis, the start angle in [0, 2π), the width, in (0, π)).
    /// `None` when `v` is not a vertex of it or the wedge is degenerate.
    fn wedge(&self, i: u32, v: [u64; 3]) -> Option<(usize, f64, f64)> {
        let p = &self.patches[i as usize];
        let m = p.vertices.len();
        let at = p
            .vertices
            .iter()
            .position(|q| [q.x.to_bits(), q.y.to_bits(), q.z.to_bits()] == v)?;
        let a = p.normal().abs();
        if !a.is_finite() {
            return None;
        }
        let k = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let flat = |q: DVec3| {
            let r = q.to_array();
            (r[(k + 1) % 3], r[(k + 2) % 3])
        };
        let o = flat(p.vertices[at]);
        let angle = |q: DVec3| {
            let (x, y) = flat(q);
            (y - o.1).atan2(x - o.0).rem_euclid(std::f64::consts::TAU)
        };
        let a1 = angle(p.vertices[(at + 1) % m]);
        let a2 = angle(p.vertices[(at + m - 1) % m]);
        let d = (a2 - a1).rem_euclid(std::f64::consts::TAU);
        let (start, width) = if d < std::f64::consts::PI {
            (a1, d)
        } else {
            (a2, std::f64::consts::TAU - d)
        };
        let pi = std::f64::consts::PI;
        (width > 1e-12 && width < pi - 1e-12 && start.is_finite()).then_some((k, start, width))
    }

    /// Whether patch `j` lies in patch `i`'s plane within `tol` (and `i` in `j`'s) and
    /// overlaps it by more than `tol` in that plane.
    fn coplanar_overlap(&self, i: u32, j: u32, tol: f64) -> bool {
        self.lies_on(j, i, tol) && self.lies_on(i, j, tol)
    }

    /// Whether every vertex of patch `j` lies within `tol` of patch `i`'s plane and `j`
    /// overlaps `i` by more than `tol` there (compared in the plane's coordinates: the
    /// normal's largest axis dropped).
    fn lies_on(&self, j: u32, i: u32, tol: f64) -> bool {
        let (src, p) = (&self.patches[i as usize], &self.patches[j as usize]);
        let (n, c) = (src.normal(), src.vertices[0]);
        if !p.vertices.iter().all(|v| (*v - c).dot(n).abs() <= tol) {
            return false;
        }
        let a = n.abs();
        let k = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let flat = |v: &[DVec3]| -> Vec<[f64; 2]> {
            v.iter()
                .map(|p| {
                    let a = p.to_array();
                    [a[(k + 1) % 3], a[(k + 2) % 3]]
                })
                .collect()
        };
        polygons_overlap(&flat(&src.vertices), &flat(&p.vertices), tol)
    }

    /// The patches lying on patch `id`: in its plane (every vertex within 1e-9 of the
    /// scene's scale of it, whichever way they face) and overlapping it with positive area
    /// — a tile on the floor. Rays leaving `id` meet them at t ≈ 0, where the answer turns
    /// on rounding. Patches that only touch it along an edge or at a vertex are not listed.
    pub fn lying_on(&self, id: u32) -> Vec<u32> {
        if id as usize >= self.patches.len() {
            return Vec::new();
        }
        let eps = 1e-9 * self.bounds.scale();
        (0..self.patches.len() as u32)
            .filter(|&j| j != id && self.lies_on(j, id, eps))
            .collect()
    }
}

/// Distance from a patch's plane, as a fraction of the scene's scale, within which an
/// overlapping patch is its coplanar twin ([`Scene::twins`]): coplanar up to the float
/// rounding of the input (as [`Scene::lying_on`]). A patch a visible distance in front of
/// another (cornell's light, 1.8e-4 below the ceiling) is not a twin: the float reference
/// meets its back, as it should for reciprocity, and a datapath too narrow to separate the
/// two fails `check` saying so.
pub const TWIN_TOL: f64 = 1e-9;

/// Whether two convex polygons of one plane overlap by more than `eps` on every axis that
/// could separate them (their edges' normals): their interiors meet.
fn polygons_overlap(a: &[[f64; 2]], b: &[[f64; 2]], eps: f64) -> bool {
    let axes = |p: &[[f64; 2]]| -> Vec<[f64; 2]> {
        (0..p.len())
            .map(|i| {
                let (u, v) = (p[i], p[(i + 1) % p.len()]);
                let (x, y) = (v[1] - u[1], u[0] - v[0]);
                let l = x.hypot(y);
                [x / l, y / l]
            })
            .collect()
    };
    let span = |p: &[[f64; 2]], ax: [f64; 2]| {
        p.iter()
            .map(|q| q[0] * ax[0] + q[1] * ax[1])
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
                (lo.min(x), hi.max(x))
            })
    };
    axes(a).into_iter().chain(axes(b)).all(|ax| {
        let (a0, a1) = span(a, ax);
        let (b0, b1) = span(b, ax);
        a1.min(b1) - a0.max(b0) > eps
    })
}

/// The top level of a JSON scene file; patches are parsed one by one so that an error can
/// name the patch.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    name: String,
    bounds: [[f64; 3]; 2],
    patches: Vec<serde_json::Value>,
}

/// Serde glue: a list of `[x, y, z]` arrays as `Vec<DVec3>`.
mod vec3_list {
    use glam::DVec3;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    pub fn serialize<S: Serializer>(v: &[DVec3], s: S) -> Result<S::Ok, S::Error> {
        let arrays: Vec<[f64; 3]> = v.iter().map(|p| p.to_array()).collect();
        arrays.serialize(s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<DVec3>, D::Error> {
        let arrays: Vec<[f64; 3]> = Vec::deserialize(d)?;
        Ok(arrays.into_iter().map(DVec3::from_array).collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad(z: f64) -> Patch {
        Patch::new(
            vec![
                DVec3::new(0.0, 0.0, z),
                DVec3::new(1.0, 0.0, z),
                DVec3::new(1.0, 1.0, z),
                DVec3::new(0.0, 1.0, z),
            ],
            0.0,
            0.5,
        )
    }

    #[test]
    fn unit_square_geometry() {
        let p = quad(0.0);
        assert_eq!(p.area(), 1.0);
        assert_eq!(p.normal(), DVec3::Z);
        assert!(p.check().is_ok());
    }

    #[test]
    fn json_round_trip_is_exact() {
        let s = Scene {
            name: "t".into(),
            bounds: Aabb {
                lo: DVec3::ZERO,
                hi: DVec3::ONE,
            },
            patches: vec![quad(0.1), quad(0.7)],
        };
        let text = s.to_json_string();
        let back = Scene::from_json_str(&text, Path::new("t.json")).unwrap();
        assert_eq!(s, back);
    }

    #[test]
    fn bowtie_is_not_convex() {
        let mut p = quad(0.0);
        p.vertices.swap(2, 3);
        let e = p.check().unwrap_err();
        assert!(e.contains("convex") || e.contains("area"), "{e}");
    }
}

#[cfg(test)]
mod linear_twins {
    use super::{Aabb, Patch, Scene};
    use glam::DVec3;

    /// A regular polygon of `n` vertices split into a fan of n − 2 triangles sharing its
    /// first vertex, as the OBJ importer splits a large face.
    fn fan(n: usize) -> Scene {
        let v: Vec<DVec3> = (0..n)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / n as f64;
                DVec3::new(a.cos(), a.sin(), 0.0)
            })
            .collect();
        let patches = (1..n - 1)
            .map(|k| Patch::new(vec![v[0], v[k], v[k + 1]], 0.0, 0.5))
            .collect();
        Scene {
            name: "fan".into(),
            bounds: Aabb {
                lo: DVec3::new(-1.0, -1.0, -1.0),
                hi: DVec3::new(1.0, 1.0, 1.0),
            },
            patches,
        }
    }

    /// Seconds [`super::Scene::twins`] takes on a fan of `n` vertices; it has no twins.
    fn seconds(n: usize) -> f64 {
        let s = fan(n);
        assert_eq!(s.patches.len(), n - 2);
        let start = std::time::Instant::now();
        let t = s.twins();
        let secs = start.elapsed().as_secs_f64();
        assert!(t.iter().all(|v| v.is_empty()), "a fan has no twins");
        secs
    }

    #[test]
    fn twins_of_a_fan_are_found_in_near_linear_time() {
        // Before: every pair of the fan was tested (20k vertices: 2 × 10^8 pairs, most of
        // `scene info`'s 36 s). Four times the triangles must take less than 8 times as long
        // (quadratic: 16).
        let small = seconds(2_500);
        let large = seconds(10_000);
        assert!(
            large < 8.0 * small.max(0.01),
            "2.5k: {small:.3} s, 10k: {large:.3} s — not near linear"
        );
    }

    #[test]
    fn twins_in_a_large_bucket_are_still_found() {
        // The fan and, on top of it, a copy of one of its triangles and a square over the
        // middle: the sweep must still pair them.
        let mut s = fan(400);
        let copy = s.patches[100].clone();
        s.patches.push(copy);
        let mut sq = s.patches[0].clone();
        sq.vertices = vec![
            glam::DVec3::new(-0.1, -0.1, 0.0),
            glam::DVec3::new(0.1, -0.1, 0.0),
            glam::DVec3::new(0.1, 0.1, 0.0),
            glam::DVec3::new(-0.1, 0.1, 0.0),
        ];
        s.patches.push(sq);
        let t = s.twins();
        let n = s.patches.len();
        assert!(t[100].contains(&(n as u32 - 2)), "{:?}", t[100]);
        assert!(t[n - 2].contains(&100));
        // The square overlaps the triangles that cross the middle.
        assert!(t[n - 1].len() > 10, "{}", t[n - 1].len());
        // The brute force agrees, pair for pair.
        let tol = super::TWIN_TOL * s.bounds.scale();
        for i in 0..n as u32 {
            for j in i + 1..n as u32 {
                assert_eq!(
                    s.coplanar_overlap(i, j, tol),
                    t[i as usize].contains(&j),
                    "{i} {j}"
                );
            }
        }
    }
}
