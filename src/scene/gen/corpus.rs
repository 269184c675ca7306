//! A corpus of closed scenes nobody tuned the model for: subdivided boxes (even and uneven
//! tiles), the Cornell room subdivided (its slanted red wall included), a jittered
//! hexahedron, convex hulls of random points, a room whose vertices all lie on grid-cell
//! boundaries, and the Cornell room in millimetres.
//!
//! Every scene is a closed, conforming mesh: each edge is shared by exactly two patches,
//! run in opposite directions, with bit-identical end points (no T-junctions), and every
//! patch faces into the room. Shared points are computed once from one formula: a box's
//! coordinates come from one tick list per axis, and a point on an edge between two corners
//! from `edge_point`, which orders the two corners canonically so that both patches (or
//! walls) along the edge get the same bits. Deterministic for a seed (one `Pcg64`, as the
//! other generators).
//!
//! Not included: the Cornell box's two blocks. They stand on the floor with open bottoms,
//! so their bottom edges lie inside floor tiles (T-junctions) unless the floor is cut
//! around them; the corpus keeps the room alone. The published light is likewise not a
//! separate patch: the ceiling tiles under it emit instead.

use super::cornell::{CB, CORNELL_GREEN, CORNELL_MM, CORNELL_RED, CORNELL_WHITE};
use super::*;
use std::path::Path;

/// How many scenes [`corpus`] lists: `Small` stays under 5,000 patches in all (for tests);
/// `Large` adds scenes up to about 100,000 patches.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CorpusSize {
    Small,
    Large,
}

/// A representative set of corpus scenes, from about 100 patches (`Small`) to about
/// 100,000 (`Large` only).
pub fn corpus(size: CorpusSize) -> Vec<Scene> {
    let mut v = vec![
        subdivided_box(4, DVec3::ONE, false),
        subdivided_box(8, DVec3::new(1.0, 2.0, 0.5), true),
        subdivided_cornell(6),
        slanted_room(1),
        slanted_room_subdivided(2, 4),
        convex_hull_room(200, 1),
        cell_boundary_room(0.05),
        millimetre_cornell(),
    ];
    if size == CorpusSize::Large {
        v.extend([
            subdivided_box(50, DVec3::new(3.0, 2.0, 1.0), true),
            subdivided_cornell(40),
            slanted_room_subdivided(3, 30),
            convex_hull_room(2000, 2),
            subdivided_box(129, DVec3::ONE, false),
        ]);
    }
    v
}

/// A corpus family as `shellsim scene gen` knows it; `--n` sets its size parameter
/// ([`CorpusKind::n_meaning`]), `--seed` its random parts.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CorpusKind {
    /// The unit cube, each wall n×n quads (`subdivided_box`).
    #[value(name = "corpus-subdivided-box")]
    SubdividedBox,
    /// The unit cube, each wall n×n quads of growing size (`subdivided_box` by area).
    #[value(name = "corpus-subdivided-box-by-area")]
    SubdividedBoxByArea,
    /// The Cornell room, each wall n×n (`subdivided_cornell`).
    #[value(name = "corpus-subdivided-cornell")]
    SubdividedCornell,
    /// A jittered hexahedron, each triangle split n² (`slanted_room_subdivided`).
    #[value(name = "corpus-slanted-room")]
    SlantedRoom,
    /// The convex hull of n random points on a sphere (`convex_hull_room`).
    #[value(name = "corpus-convex-hull")]
    ConvexHull,
    /// A room on the boundaries of n grid cells per unit (`cell_boundary_room`).
    #[value(name = "corpus-cell-boundary-room")]
    CellBoundaryRoom,
    /// The Cornell room in millimetres; no --n (`millimetre_cornell`).
    #[value(name = "corpus-millimetre-cornell")]
    MillimetreCornell,
}

impl CorpusKind {
    /// Every corpus kind.
    pub const ALL: [CorpusKind; 7] = [
        CorpusKind::SubdividedBox,
        CorpusKind::SubdividedBoxByArea,
        CorpusKind::SubdividedCornell,
        CorpusKind::SlantedRoom,
        CorpusKind::ConvexHull,
        CorpusKind::CellBoundaryRoom,
        CorpusKind::MillimetreCornell,
    ];

    /// What `--n` means for the kind, its default and its range; `None` when the kind
    /// takes no size.
    pub fn n_meaning(self) -> Option<(&'static str, usize, std::ops::RangeInclusive<usize>)> {
        match self {
            CorpusKind::SubdividedBox | CorpusKind::SubdividedBoxByArea => {
                Some(("tiles per wall side", 8, 1..=1000))
            }
            CorpusKind::SubdividedCornell => Some(("tiles per wall side", 6, 1..=1000)),
            CorpusKind::SlantedRoom => Some(("splits per triangle side", 1, 1..=1000)),
            CorpusKind::ConvexHull => Some(("points", 200, 4..=20_000)),
            CorpusKind::CellBoundaryRoom => Some(("grid cells per unit", 20, 1..=1000)),
            CorpusKind::MillimetreCornell => None,
        }
    }

    /// Builds the kind at size `n` (its default when `None`) and `seed` (used by the
    /// slanted room and the convex hull). An `n` out of range, or given to a kind without
    /// a size, is an error on `--n`.
    pub fn generate(self, n: Option<usize>, seed: u64) -> crate::error::Result<Scene> {
        let n = match (self.n_meaning(), n) {
            (None, None) => 0,
            (None, Some(n)) => {
                return Err(crate::error::Error::param(
                    "n",
                    format!("{n}: this corpus kind has no size; leave --n out"),
                ))
            }
            (Some((what, default, range)), n) => {
                let n = n.unwrap_or(default);
                if !range.contains(&n) {
                    return Err(crate::error::Error::param(
                        "n",
                        format!(
                            "{n} is out of range ({}..={} {what})",
                            range.start(),
                            range.end()
                        ),
                    ));
                }
                n
            }
        };
        Ok(match self {
            CorpusKind::SubdividedBox => subdivided_box(n, DVec3::ONE, false),
            CorpusKind::SubdividedBoxByArea => subdivided_box(n, DVec3::ONE, true),
            CorpusKind::SubdividedCornell => subdivided_cornell(n),
            CorpusKind::SlantedRoom => slanted_room_subdivided(seed, n),
            CorpusKind::ConvexHull => convex_hull_room(n, seed),
            CorpusKind::CellBoundaryRoom => cell_boundary_room(grid(1, n)),
            CorpusKind::MillimetreCornell => millimetre_cornell(),
        })
    }
}

// ---------------------------------------------------------------------------------------
// Shared building blocks
// ---------------------------------------------------------------------------------------

/// The scene, validated; a generator that builds an invalid scene is a bug, so this panics.
fn finish(name: String, bounds: Aabb, patches: Vec<Patch>) -> Scene {
    let s = Scene {
        name,
        bounds,
        patches,
    };
    if let Err(e) = s.validate(Path::new(&s.name)) {
        panic!("corpus scene {} does not validate: {e}", s.name);
    }
    s
}

/// A point's coordinates as bits: a total order and an exact key.
fn bits(v: DVec3) -> [u64; 3] {
    v.to_array().map(f64::to_bits)
}

/// Point `k` of `n + 1` evenly spaced on the segment between corners `a` and `b` (`k = 0`
/// is `a`, `k = n` is `b`, both exactly). The corners are put in a canonical order first,
/// so the segment gives the same bits whichever way it is walked: two patches or walls
/// sharing an edge share its points.
fn edge_point(a: DVec3, b: DVec3, k: usize, n: usize) -> DVec3 {
    if bits(a) > bits(b) {
        return edge_point(b, a, n - k, n);
    }
    match k {
        0 => a,
        _ if k == n => b,
        _ => a + (b - a) * grid(k, n),
    }
}

/// A patch of the given colours.
fn coloured(vertices: Vec<DVec3>, emission: Spectrum, reflectance: Spectrum) -> Patch {
    Patch {
        vertices,
        emission,
        reflectance,
        name: None,
        material: None,
    }
}

/// The quad `c` (corners at parameters (0,0), (1,0), (1,1), (0,1), facing its winding)
/// as an `n`×`n` grid of cells: the points of its four sides by [`edge_point`], the inner
/// points by bilinear interpolation. A cell that is not planar (a quad failing
/// [`Patch::check`]) is split into two triangles along its (0, 2) diagonal. `style` gives a
/// cell's (emission, reflectance) from its vertices.
fn grid_wall(
    c: [DVec3; 4],
    n: usize,
    style: impl Fn(&[DVec3]) -> (Spectrum, Spectrum),
) -> Vec<Patch> {
    let at = |i: usize, j: usize| -> DVec3 {
        let bottom = edge_point(c[0], c[1], i, n);
        let top = edge_point(c[3], c[2], i, n);
        if j == 0 {
            bottom
        } else if j == n {
            top
        } else if i == 0 {
            edge_point(c[0], c[3], j, n)
        } else if i == n {
            edge_point(c[1], c[2], j, n)
        } else {
            bottom + (top - bottom) * grid(j, n)
        }
    };
    let pts: Vec<Vec<DVec3>> = (0..=n)
        .map(|j| (0..=n).map(|i| at(i, j)).collect())
        .collect();
    let mut out = Vec::with_capacity(n * n);
    for j in 0..n {
        for i in 0..n {
            let v = vec![pts[j][i], pts[j][i + 1], pts[j + 1][i + 1], pts[j + 1][i]];
            let (e, r) = style(&v);
            let quad = coloured(v, e, r);
            if quad.check().is_ok() {
                out.push(quad);
            } else {
                let v = &quad.vertices;
                out.push(coloured(vec![v[0], v[1], v[2]], e, r));
                out.push(coloured(vec![v[0], v[2], v[3]], e, r));
            }
        }
    }
    out
}

/// The triangle `(a, b, c)` as `n²` triangles facing its way: lattice points `(i, j)`,
/// `i + j <= n`, at `a + (b − a) i/n + (c − a) j/n`, those on its sides by [`edge_point`].
fn subdivide_triangle(a: DVec3, b: DVec3, c: DVec3, n: usize) -> Vec<[DVec3; 3]> {
    let at = |i: usize, j: usize| -> DVec3 {
        if j == 0 {
            edge_point(a, b, i, n)
        } else if i == 0 {
            edge_point(a, c, j, n)
        } else if i + j == n {
            edge_point(b, c, j, n)
        } else {
            a + (b - a) * grid(i, n) + (c - a) * grid(j, n)
        }
    };
    let mut out = Vec::with_capacity(n * n);
    for j in 0..n {
        for i in 0..n - j {
            out.push([at(i, j), at(i + 1, j), at(i, j + 1)]);
            if i + j + 1 < n {
                out.push([at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)]);
            }
        }
    }
    out
}

/// The walls of the axis-aligned box whose coordinates along each axis are `t[axis]` (the
/// first and last ticks are the box's faces), each wall a grid of inward quads over the
/// other two axes' ticks. Each coordinate is read from the one tick list, so walls share
/// their boundary points exactly. Order: x = lo, x = hi, y = lo, y = hi, z = lo, z = hi.
fn box_walls(t: &[Vec<f64>; 3]) -> Vec<[DVec3; 4]> {
    let mut out = Vec::new();
    for axis in 0..3 {
        let (ta, tb) = (&t[(axis + 1) % 3], &t[(axis + 2) % 3]);
        for (c, inward_positive) in [(t[axis][0], true), (t[axis][t[axis].len() - 1], false)] {
            for j in 0..tb.len() - 1 {
                for i in 0..ta.len() - 1 {
                    let v = rect(
                        axis,
                        c,
                        inward_positive,
                        (ta[i], ta[i + 1]),
                        (tb[j], tb[j + 1]),
                    );
                    out.push([v[0], v[1], v[2], v[3]]);
                }
            }
        }
    }
    out
}

/// `n + 1` ticks from `lo` to `hi` whose steps grow geometrically by `ratio` (ends exact).
fn geometric_ticks(lo: f64, hi: f64, n: usize, ratio: f64) -> Vec<f64> {
    let mut cum = vec![0.0];
    let mut w = 1.0;
    for _ in 0..n {
        cum.push(cum[cum.len() - 1] + w);
        w *= ratio;
    }
    let total = cum[n];
    (0..=n)
        .map(|k| match k {
            0 => lo,
            _ if k == n => hi,
            _ => lo + (hi - lo) * (cum[k] / total),
        })
        .collect()
}

// ---------------------------------------------------------------------------------------
// The families
// ---------------------------------------------------------------------------------------

/// The box `[0, extent]` with each of its 6 walls an `n`×`n` grid of inward quads: `6 n²`
/// patches. Evenly spaced, or with `by_area` steps growing geometrically (ratio 1.25 along
/// each axis, so the largest tile is up to `1.25^(2(n−1))` times the smallest). The first
/// tile of the ceiling (z = extent.z) emits 1.
pub fn subdivided_box(n: usize, extent: DVec3, by_area: bool) -> Scene {
    assert!(n >= 1, "subdivided_box: n must be at least 1");
    let e = extent.to_array();
    let t: [Vec<f64>; 3] = std::array::from_fn(|k| {
        if by_area {
            geometric_ticks(0.0, e[k], n, 1.25)
        } else {
            ticks(0.0, e[k], n)
        }
    });
    let walls = box_walls(&t);
    let ceiling_first = 5 * n * n;
    let patches = walls
        .into_iter()
        .enumerate()
        .map(|(k, v)| {
            let emission = if k == ceiling_first { 1.0 } else { 0.0 };
            Patch::new(v.to_vec(), emission, 0.5)
        })
        .collect();
    let name = format!(
        "corpus-subdivided-box-{n}{}",
        if by_area { "-by-area" } else { "" }
    );
    finish(
        name,
        Aabb {
            lo: DVec3::ZERO,
            hi: extent,
        },
        patches,
    )
}

/// The Cornell room's six walls (floor, ceiling, back, green right wall x = 0, red left
/// wall — not planar — and the added front wall) from the published corners mapped by
/// `point`, each oriented into the room, with their colours.
fn cornell_walls(point: impl Fn([f64; 3]) -> DVec3) -> Vec<([DVec3; 4], Spectrum)> {
    let faces: [([usize; 4], Spectrum); 6] = [
        ([0, 1, 2, 3], CORNELL_WHITE), // floor
        ([4, 5, 6, 7], CORNELL_WHITE), // ceiling
        ([3, 2, 6, 5], CORNELL_WHITE), // back wall
        ([2, 1, 7, 6], CORNELL_GREEN), // right wall (x = 0)
        ([0, 3, 5, 4], CORNELL_RED),   // left wall (not planar)
        ([0, 1, 7, 4], CORNELL_WHITE), // front wall
    ];
    let corners: Vec<DVec3> = CB.iter().map(|&c| point(c)).collect();
    let inside = corners.iter().copied().sum::<DVec3>() / 8.0;
    faces
        .iter()
        .map(|&(k, colour)| {
            let mut c = k.map(|i| corners[i]);
            let centre = c.iter().copied().sum::<DVec3>() / 4.0;
            if crate::scene::polygon::area_vector(&c).dot(inside - centre) < 0.0 {
                c.reverse();
            }
            (c, colour)
        })
        .collect()
}

/// The Cornell room with every wall an `n`×`n` grid, corners from `point` (published mm →
/// scene). Ceiling cells whose centre lies over the published light (x 213–343 mm, z
/// 227–332 mm) emit its [17, 12, 4].
fn cornell_room(name: String, n: usize, point: impl Fn([f64; 3]) -> DVec3, bounds: Aabb) -> Scene {
    assert!(n >= 1, "the Cornell room needs n >= 1");
    let walls = cornell_walls(&point);
    let (l0, l1) = (point([213.0, 0.0, 332.0]), point([343.0, 0.0, 227.0]));
    let (lo, hi) = (l0.min(l1), l0.max(l1));
    let mut patches = Vec::new();
    for (w, (c, colour)) in walls.into_iter().enumerate() {
        patches.extend(grid_wall(c, n, |v| {
            let m = v.iter().copied().sum::<DVec3>() / v.len() as f64;
            let lit = w == 1 && m.x > lo.x && m.x < hi.x && m.y > lo.y && m.y < hi.y;
            let e = if lit {
                Spectrum::Rgb([17.0, 12.0, 4.0])
            } else {
                Spectrum::Grey(0.0)
            };
            (e, colour)
        }));
    }
    finish(name, bounds, patches)
}

/// The Cornell room of `cornell` (scaled by 1/559.2, z up, closed at the front) with each
/// of its 6 walls an `n`×`n` grid, the red wall's non-planar cells split in two triangles:
/// between `6 n²` and `7 n²` patches. The blocks are left out (see the module docs).
pub fn subdivided_cornell(n: usize) -> Scene {
    cornell_room(
        format!("corpus-subdivided-cornell-{n}"),
        n,
        super::cornell::cornell_point,
        Aabb {
            lo: DVec3::ZERO,
            hi: DVec3::ONE,
        },
    )
}

/// The Cornell room in millimetres (the published coordinates turned z up,
/// `(x, y, z) → (x, 559.2 − z, y)`, unscaled), each wall a 6×6 grid; bounds
/// `[0, 559.2]³`. Large units for code that assumes a unit scene.
pub fn millimetre_cornell() -> Scene {
    cornell_room(
        "corpus-millimetre-cornell".into(),
        6,
        |[x, y, z]| v3(x, CORNELL_MM - z, y),
        Aabb {
            lo: DVec3::ZERO,
            hi: DVec3::splat(CORNELL_MM),
        },
    )
}

/// [`slanted_room_subdivided`] with undivided triangles: 12 patches.
pub fn slanted_room(seed: u64) -> Scene {
    slanted_room_subdivided(seed, 1)
}

/// A closed hexahedron: the unit cube's 8 corners each moved by up to ±0.15 per axis
/// (seeded), each of the 6 faces split into two triangles along the diagonal that keeps
/// the fold convex, each triangle split into `n²`: `12 n²` patches, bounds
/// `[−0.15, 1.15]³`. The first ceiling tile region (the first triangles of face 1) emits.
pub fn slanted_room_subdivided(seed: u64, n: usize) -> Scene {
    assert!(n >= 1, "slanted_room: n must be at least 1");
    let mut rng = Pcg64::seed_from_u64(seed);
    // Corner (i, j, k) ∈ {0, 1}³ at index i + 2j + 4k.
    let corners: Vec<DVec3> = (0..8)
        .map(|c| {
            let base = v3((c & 1) as f64, ((c >> 1) & 1) as f64, ((c >> 2) & 1) as f64);
            base + v3(
                rng.gen_range(-0.15..0.15),
                rng.gen_range(-0.15..0.15),
                rng.gen_range(-0.15..0.15),
            )
        })
        .collect();
    let index = |v: DVec3| (v.x as usize) + 2 * (v.y as usize) + 4 * (v.z as usize);
    let mut patches = Vec::new();
    for (f, face) in unit_cube().patches.iter().enumerate() {
        let [a, b, c, d] = [0, 1, 2, 3].map(|k| corners[index(face.vertices[k])]);
        // Split along a–c when d lies in front of (a, b, c) (a convex fold seen from
        // inside), else along b–d.
        let n_abc = (b - a).cross(c - a);
        let tris = if n_abc.dot(d - a) >= 0.0 {
            [[a, b, c], [a, c, d]]
        } else {
            [[a, b, d], [b, c, d]]
        };
        for (h, [p, q, r]) in tris.into_iter().enumerate() {
            for (k, t) in subdivide_triangle(p, q, r, n).into_iter().enumerate() {
                let emission = if f == 1 && h == 0 && k == 0 { 1.0 } else { 0.0 };
                patches.push(Patch::new(t.to_vec(), emission, 0.5));
            }
        }
    }
    finish(
        format!("corpus-slanted-room-{seed}-{n}"),
        Aabb {
            lo: DVec3::splat(-0.15),
            hi: DVec3::splat(1.15),
        },
        patches,
    )
}

/// The grid the convex hull's points are snapped to: 2^20 steps per unit, so coordinates
/// are exact doubles and the orientation test is exact in `i128`.
const HULL_STEPS: i64 = 1 << 20;

/// Exact orientation: positive when `p` lies on the side of the plane `(a, b, c)` that
/// its counter-clockwise winding faces.
fn orient(a: [i64; 3], b: [i64; 3], c: [i64; 3], p: [i64; 3]) -> i128 {
    let d = |u: [i64; 3], v: [i64; 3]| [0, 1, 2].map(|k| (u[k] - v[k]) as i128);
    let (u, v, w) = (d(b, a), d(c, a), d(p, a));
    let n = [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ];
    n[0] * w[0] + n[1] * w[1] + n[2] * w[2]
}

/// The convex hull of integer points as outward-wound triangles (indices into `pts`), by
/// incremental insertion with the exact [`orient`]: a point joins the hull only when it is
/// strictly in front of some face, so coplanar, collinear and repeated points are simply
/// left out. `None` when all points are coplanar. O(n · faces).
fn convex_hull(pts: &[[i64; 3]]) -> Option<Vec<[usize; 3]>> {
    let i0 = 0;
    let i1 = (1..pts.len()).find(|&i| pts[i] != pts[i0])?;
    let collinear = |i: usize| {
        let d = |u: [i64; 3], v: [i64; 3]| [0, 1, 2].map(|k| (u[k] - v[k]) as i128);
        let (u, v) = (d(pts[i1], pts[i0]), d(pts[i], pts[i0]));
        u[1] * v[2] == u[2] * v[1] && u[2] * v[0] == u[0] * v[2] && u[0] * v[1] == u[1] * v[0]
    };
    let i2 = (1..pts.len()).find(|&i| !collinear(i))?;
    let i3 = (1..pts.len()).find(|&i| orient(pts[i0], pts[i1], pts[i2], pts[i]) != 0)?;
    let tet = [i0, i1, i2, i3];
    let mut faces: Vec<[usize; 3]> = Vec::new();
    for skip in 0..4 {
        let f: Vec<usize> = (0..4).filter(|&k| k != skip).map(|k| tet[k]).collect();
        let mut f = [f[0], f[1], f[2]];
        if orient(pts[f[0]], pts[f[1]], pts[f[2]], pts[tet[skip]]) > 0 {
            f.swap(1, 2);
        }
        faces.push(f);
    }
    for (p, &q) in pts.iter().enumerate() {
        if tet.contains(&p) {
            continue;
        }
        let visible: Vec<usize> = (0..faces.len())
            .filter(|&i| {
                let f = faces[i];
                orient(pts[f[0]], pts[f[1]], pts[f[2]], q) > 0
            })
            .collect();
        if visible.is_empty() {
            continue;
        }
        let mut is_visible = vec![false; faces.len()];
        let mut edges = std::collections::HashSet::new();
        for &i in &visible {
            is_visible[i] = true;
            let f = faces[i];
            for k in 0..3 {
                edges.insert((f[k], f[(k + 1) % 3]));
            }
        }
        let mut next: Vec<[usize; 3]> = (0..faces.len())
            .filter(|&i| !is_visible[i])
            .map(|i| faces[i])
            .collect();
        // Horizon edges in the order of the visible faces (deterministic).
        for &i in &visible {
            let f = faces[i];
            for k in 0..3 {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                if !edges.contains(&(b, a)) {
                    next.push([a, b, p]);
                }
            }
        }
        faces = next;
    }
    Some(faces)
}

/// The convex hull of `n_points` random points on the sphere of radius 0.5 about the unit
/// cube's centre (snapped to a grid of 2^−20), as inward-facing triangles: about
/// `2 n_points − 4` patches (points that the snapping leaves inside, or coplanar, drop
/// out). Exact orientation tests make the hull consistent; should every point be coplanar
/// (only for tiny `n_points`), the points are drawn again from the same generator.
pub fn convex_hull_room(n_points: usize, seed: u64) -> Scene {
    assert!(n_points >= 4, "convex_hull_room: needs at least 4 points");
    let mut rng = Pcg64::seed_from_u64(seed);
    let (pts, faces) = loop {
        let pts: Vec<[i64; 3]> = (0..n_points)
            .map(|_| {
                let u = unit_vector(&mut rng) * 0.5 + DVec3::splat(0.5);
                u.to_array()
                    .map(|c| ((c * HULL_STEPS as f64).round() as i64).clamp(0, HULL_STEPS))
            })
            .collect();
        if let Some(f) = convex_hull(&pts) {
            break (pts, f);
        }
    };
    let point = |p: [i64; 3]| DVec3::from_array(p.map(|c| c as f64 / HULL_STEPS as f64));
    let patches = faces
        .iter()
        .enumerate()
        .map(|(k, f)| {
            // Outward (a, b, c) → inward (a, c, b).
            let v = vec![point(pts[f[0]]), point(pts[f[2]]), point(pts[f[1]])];
            Patch::new(v, if k == 0 { 1.0 } else { 0.0 }, 0.5)
        })
        .collect();
    finish(
        format!("corpus-convex-hull-{n_points}-{seed}"),
        Aabb {
            lo: DVec3::ZERO,
            hi: DVec3::ONE,
        },
        patches,
    )
}

/// The unit cube with every vertex on a boundary of the grid of cell size `cell` (`1/cell`
/// must be a whole number m, e.g. 20 for 0.05): ticks `k/m` along each axis at steps of 1,
/// 2, 3, 1, 2, 3, … cells, each wall a grid of inward quads over those ticks, every third
/// quad (by `(i + j) % 3 == 0`) split into two triangles along its diagonal. Tile edges
/// run along cell faces; the ceiling's first tile emits.
pub fn cell_boundary_room(cell: f64) -> Scene {
    let m = (1.0 / cell).round() as usize;
    assert!(
        m >= 1 && (grid(1, m) - cell).abs() <= 1e-12,
        "cell_boundary_room: 1/cell must be a whole number (cell {cell})"
    );
    let mut steps = Vec::new();
    let (mut k, mut s) = (0, 1);
    while k < m {
        k = (k + s).min(m);
        steps.push(k);
        s = s % 3 + 1;
    }
    let t: Vec<f64> = std::iter::once(0.0)
        .chain(steps.iter().map(|&k| grid(k, m)))
        .collect();
    let per_axis = t.len() - 1;
    let walls = box_walls(&[t.clone(), t.clone(), t]);
    let mut patches = Vec::new();
    for (k, v) in walls.into_iter().enumerate() {
        let (i, j) = (k % per_axis, (k / per_axis) % per_axis);
        let emission = if k == 5 * per_axis * per_axis {
            1.0
        } else {
            0.0
        };
        if (i + j) % 3 == 0 {
            patches.push(Patch::new(vec![v[0], v[1], v[2]], emission, 0.5));
            patches.push(Patch::new(vec![v[0], v[2], v[3]], emission, 0.5));
        } else {
            patches.push(Patch::new(v.to_vec(), emission, 0.5));
        }
    }
    finish(
        format!("corpus-cell-boundary-room-{m}"),
        Aabb {
            lo: DVec3::ZERO,
            hi: DVec3::ONE,
        },
        patches,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    /// Every undirected edge (keyed by its end points' bits) is used by exactly two
    /// patches, in opposite directions.
    fn assert_closed(s: &Scene) {
        let mut edges: HashMap<([u64; 3], [u64; 3]), Vec<bool>> = HashMap::new();
        for p in &s.patches {
            let v = &p.vertices;
            for i in 0..v.len() {
                let (a, b) = (bits(v[i]), bits(v[(i + 1) % v.len()]));
                let (key, forward) = if a < b {
                    ((a, b), true)
                } else {
                    ((b, a), false)
                };
                edges.entry(key).or_default().push(forward);
            }
        }
        for ((a, b), uses) in &edges {
            let pa = DVec3::from_array(a.map(f64::from_bits));
            let pb = DVec3::from_array(b.map(f64::from_bits));
            assert_eq!(
                uses.len(),
                2,
                "{}: edge {pa} – {pb} used {} times",
                s.name,
                uses.len()
            );
            assert_ne!(
                uses[0], uses[1],
                "{}: edge {pa} – {pb} run the same way twice",
                s.name
            );
        }
    }

    /// The mean of the vertices (inside a convex room) is in front of every patch.
    fn assert_faces_inward(s: &Scene) {
        let all: Vec<DVec3> = s
            .patches
            .iter()
            .flat_map(|p| p.vertices.iter().copied())
            .collect();
        let c = all.iter().copied().sum::<DVec3>() / all.len() as f64;
        for (id, p) in s.patches.iter().enumerate() {
            let d = (c - p.centroid()).dot(p.normal());
            assert!(d > 0.0, "{}: patch {id} faces out ({d})", s.name);
        }
        // Closed and facing in: the signed volume (divergence theorem) is negative.
        let vol: f64 = s
            .patches
            .iter()
            .map(|p| (p.vertices[0] - c).dot(p.area_vector()) / 6.0)
            .sum();
        assert!(vol < 0.0, "{}: volume {vol}", s.name);
    }

    #[test]
    fn corpus_small_is_valid_closed_inward_and_watertight() {
        let scenes = corpus(CorpusSize::Small);
        let total: usize = scenes.iter().map(|s| s.patches.len()).sum();
        assert!(total < 5000, "{total}");
        for s in &scenes {
            s.validate(Path::new(&s.name)).unwrap();
            assert_closed(s);
            assert_faces_inward(s);

            assert!(
                s.patches.iter().any(|p| p.emission.is_nonzero()),
                "{}",
                s.name
            );
        }
        let names: std::collections::HashSet<&str> =
            scenes.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(names.len(), scenes.len());
    }

    #[test]
    fn corpus_patch_counts() {
        assert_eq!(subdivided_box(4, DVec3::ONE, false).patches.len(), 96);
        assert_eq!(subdivided_box(7, DVec3::ONE, true).patches.len(), 294);
        assert_eq!(slanted_room(5).patches.len(), 12);
        assert_eq!(slanted_room_subdivided(5, 3).patches.len(), 108);
        let c = subdivided_cornell(5).patches.len();
        assert!((150..=175).contains(&c), "{c}");
        let h = convex_hull_room(100, 3).patches.len();
        assert!((150..=196).contains(&h), "{h}");
    }

    #[test]
    fn corpus_by_area_tiles_differ_in_area() {
        let s = subdivided_box(8, DVec3::ONE, true);
        let (lo, hi) = s
            .patches
            .iter()
            .map(Patch::area)
            .fold((f64::INFINITY, 0.0f64), |(lo, hi), a| {
                (lo.min(a), hi.max(a))
            });
        assert!(hi / lo > 10.0, "{lo} {hi}");
        let total: f64 = s.total_area();
        assert!((total - 6.0).abs() < 1e-12, "{total}");
    }

    #[test]
    fn corpus_cornell_red_wall_is_split_and_lit() {
        let s = subdivided_cornell(6);
        let red: Vec<&Patch> = s
            .patches
            .iter()
            .filter(|p| p.reflectance == CORNELL_RED)
            .collect();
        assert!(red.iter().any(|p| p.vertices.len() == 3));
        let lit = s.patches.iter().filter(|p| p.emission.is_nonzero()).count();
        assert_eq!(lit, 4);
        let mm = millimetre_cornell();
        assert_eq!(mm.bounds.hi, DVec3::splat(559.2));
        assert!(mm
            .patches
            .iter()
            .any(|p| p.vertices.iter().any(|v| v.x > 550.0)));
    }

    #[test]
    fn corpus_cell_boundary_vertices_are_on_cell_faces() {
        for cell in [0.05, 0.1, 0.25] {
            let s = cell_boundary_room(cell);
            let m = (1.0 / cell).round() as usize;
            for p in &s.patches {
                for v in &p.vertices {
                    for c in v.to_array() {
                        let k = (c * m as f64).round() as usize;
                        assert_eq!(c, grid(k, m), "{}: {v}", s.name);
                    }
                }
            }
            assert_closed(&s);
            assert_faces_inward(&s);
        }
    }

    #[test]
    fn corpus_kinds_generate_with_defaults_and_check_n() {
        use clap::ValueEnum;
        assert_eq!(CorpusKind::value_variants(), &CorpusKind::ALL);
        for k in CorpusKind::ALL {
            let s = k.generate(None, 1).unwrap();
            assert_closed(&s);
            match k.n_meaning() {
                Some((_, _, range)) => {
                    assert!(k.generate(Some(range.end() + 1), 1).is_err());
                    assert!(k.generate(Some(range.start() - 1), 1).is_err());
                }
                None => assert!(k.generate(Some(3), 1).is_err()),
            }
        }
        let s = CorpusKind::CellBoundaryRoom.generate(Some(10), 1).unwrap();
        assert_eq!(s.name, "corpus-cell-boundary-room-10");
    }

    #[test]
    fn corpus_is_deterministic_and_seeded() {
        assert_eq!(slanted_room(4), slanted_room(4));
        assert_ne!(slanted_room(4), slanted_room(5));
        assert_eq!(convex_hull_room(50, 4), convex_hull_room(50, 4));
        assert_ne!(convex_hull_room(50, 4), convex_hull_room(50, 5));
    }

    #[test]
    fn corpus_hull_handles_degenerate_points() {
        // Coplanar, collinear and repeated points: the cube's corners, edge midpoints, face
        // centres and centre, twice over, give a closed hull of the cube's volume.
        let mut pts = Vec::new();
        for _ in 0..2 {
            for x in 0..3 {
                for y in 0..3 {
                    for z in 0..3 {
                        pts.push([x, y, z]);
                    }
                }
            }
        }
        let f = convex_hull(&pts).unwrap();
        let vol: i128 = f
            .iter()
            .map(|t| orient([1, 1, 1], pts[t[0]], pts[t[1]], pts[t[2]]))
            .sum();
        assert_eq!(vol, 6 * 8, "{f:?}");
        assert!(convex_hull(&[[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]).is_none());
    }

    /// The large corpus (about 130,000 patches): valid, closed and facing in.
    /// `cargo test --release --lib corpus_large -- --ignored`.
    #[test]
    fn a_large_member_is_closed() {
        // The large corpus's slanted room of 10,800 patches (the whole large corpus is
        // checked the same way by the corpus study).
        let s = slanted_room_subdivided(3, 30);
        assert_closed(&s);
        assert_faces_inward(&s);
    }
}
