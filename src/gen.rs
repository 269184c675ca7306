//! Deterministic scene generators: the paper's two test scenes, a Cornell box and four
//! stress scenes, each a closed enclosure whose patch 0 lies on the floor facing up.
//!
//! Every scene lives in the unit cube `[0, 1]^3` (the paper's Table 12.1 scene bounds, with
//! grid cells of 0.05) and is built from one seeded `Pcg64`, so a kind and a seed always give
//! a bit-identical scene; `scenes/<kind>.json` holds each kind at [`DEFAULT_SEED`]. Only
//! `+ - * /`, `sqrt` and `round` are used on coordinates (no `sin`/`cos`, whose last bit may
//! differ between C libraries), and shared vertices are computed once from integer grid
//! indices (`k as f64 / n as f64`, the nearest double to the rational), so where patches
//! meet their coordinates are bit-identical. Every coordinate is finally rounded to 15
//! decimal places so that the JSON files read back exactly (see `decimal`).
//!
//! | kind | what | why |
//! | --- | --- | --- |
//! | `scene1` | the paper's test scene 1: the 6 walls as single inward quads and 20 random quads and triangles (size 0.05–0.3) floating inside, not touching the walls or each other; the ceiling emits | the paper's small scene; the empty cube's form factors are known analytically |
//! | `scene2` | the paper's test scene 2: a furnished room of exactly 808 quads — walls, floor and ceiling as 10×10 tiles, a table, two chairs, a bed, a wardrobe, a sofa and small pieces; four ceiling tiles emit | the paper's practical scene, with the workload concentrated where the furniture is |
//! | `cornell` | the Cornell box from the published measurements (mm, scaled by 1/559.2), turned z-up, closed at the front | a standard scene with a known look; non-planar published quads are split |
//! | `stress-edges` | a union-jack triangulated heightfield, a plane of cell-face quads at z = 0.75 and triangle fans of valence 6, 7 and 8, all with vertices on grid-cell boundaries | rays through shared edges and vertices and hits exactly on cell boundaries: a test that is not watertight leaks or double-counts |
//! | `stress-grazing` | thin horizontal slats at heights 0.01–0.1 and vertical fins in (or tilted 1e-3–1e-2 rad from) vertical planes through the source's centre | rays nearly parallel to patches (n·d near zero) |
//! | `stress-skewed` | 1728 small patches in a 0.16-wide cube near a top corner, seen from the source within a cone of about 7.5° half-angle | a static equal-angle partition of the hemisphere is badly unbalanced |
//! | `stress-dense` | 20283 patches: 600 wall tiles and one small random patch in each cell of a 27³ lattice filling the room | memory, grid and brute-force load at the paper's scale |
//!
//! Enclosure walls face inward (normals into the room); furniture and blocks face outward
//! (into the room). Boxes resting on the floor have no bottom face; random patches never
//! intersect each other (`scene1`'s are kept 0.02 apart, the lattices' each lie in their
//! own cell) nor touch the walls.

use crate::scene::{Aabb, Patch, Scene, Spectrum};
use glam::DVec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

/// A scene the generators can build; the clap value name is [`Kind::name`].
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Kind {
    /// The paper's test scene 1: 6 walls and 20 random patches.
    #[value(name = "scene1")]
    Scene1,
    /// The paper's test scene 2: a furnished room of 808 patches.
    #[value(name = "scene2")]
    Scene2,
    /// The Cornell box (published measurements), closed at the front.
    #[value(name = "cornell")]
    Cornell,
    /// Shared edges and vertices on grid-cell boundaries.
    #[value(name = "stress-edges")]
    StressEdges,
    /// Patches nearly parallel to many rays from the source.
    #[value(name = "stress-grazing")]
    StressGrazing,
    /// Most patches in one narrow cone from the source.
    #[value(name = "stress-skewed")]
    StressSkewed,
    /// More than 20,000 small patches.
    #[value(name = "stress-dense")]
    StressDense,
}

impl Kind {
    /// Every kind, in the order of the module documentation.
    pub const ALL: [Kind; 7] = [
        Kind::Scene1,
        Kind::Scene2,
        Kind::Cornell,
        Kind::StressEdges,
        Kind::StressGrazing,
        Kind::StressSkewed,
        Kind::StressDense,
    ];

    /// The kind's name: the clap value name, the scene's `name` and the file stem.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Scene1 => "scene1",
            Kind::Scene2 => "scene2",
            Kind::Cornell => "cornell",
            Kind::StressEdges => "stress-edges",
            Kind::StressGrazing => "stress-grazing",
            Kind::StressSkewed => "stress-skewed",
            Kind::StressDense => "stress-dense",
        }
    }

    /// The file the kind is committed as under `scenes/`, e.g. `scene1.json`.
    pub fn file_name(self) -> String {
        format!("{}.json", self.name())
    }

    /// A sensible source patch for form factors in this scene.
    ///
    /// Patch 0, on the floor facing up, everywhere except the Cornell box:
    /// - `scene1`: the whole floor; its hemisphere covers the whole room, and without the
    ///   random patches its form factors to the ceiling and walls are known analytically
    ///   (0.1998 and 0.2000), so the random patches' occlusion is measured against them.
    /// - `scene2`: the open floor tile [0.4, 0.5]² near the centre of the room, under no
    ///   furniture, which sees every wall, the light and every piece of furniture.
    /// - the stress scenes are built around patch 0: the edges, fans and window of
    ///   `stress-edges`, the slats and fins of `stress-grazing`, the cone of
    ///   `stress-skewed` are all placed as seen from it.
    /// - `cornell`: patch 1, the light. It is the emitter, so the first shooting step of a
    ///   radiosity solution starts there; its downward hemisphere sees the whole box. The
    ///   floor quad of the published data runs under the blocks, whose bottoms are open,
    ///   so rays from some of its points would start inside a block.
    pub fn default_source(self) -> usize {
        match self {
            Kind::Cornell => 1,
            _ => 0,
        }
    }
}

/// The seed the committed `scenes/*.json` files were generated with.
pub const DEFAULT_SEED: u64 = 1;

/// The unit cube's six walls as single inward-facing quads: 0 floor (z = 0), 1 ceiling,
/// 2 x = 0, 3 x = 1, 4 y = 0, 5 y = 1. The geometry of the analytic checks (floor centre →
/// ceiling, Howell C-11 and C-14).
pub fn unit_cube() -> Scene {
    let q =
        |v: [[f64; 3]; 4]| Patch::new(v.iter().map(|a| DVec3::from_array(*a)).collect(), 0.0, 0.5);
    Scene {
        name: "unit-cube".into(),
        bounds: Aabb {
            lo: DVec3::ZERO,
            hi: DVec3::ONE,
        },
        patches: vec![
            q([[0., 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]]),
            q([[0., 0., 1.], [0., 1., 1.], [1., 1., 1.], [1., 0., 1.]]),
            q([[0., 0., 0.], [0., 1., 0.], [0., 1., 1.], [0., 0., 1.]]),
            q([[1., 0., 0.], [1., 0., 1.], [1., 1., 1.], [1., 1., 0.]]),
            q([[0., 0., 0.], [0., 0., 1.], [1., 0., 1.], [1., 0., 0.]]),
            q([[0., 1., 0.], [1., 1., 0.], [1., 1., 1.], [0., 1., 1.]]),
        ],
    }
}

/// Builds scene `kind` from `seed`; the same kind and seed always give the same scene, bit
/// for bit. Scenes without random parts (`scene2`, `cornell`) ignore the seed.
pub fn generate(kind: Kind, seed: u64) -> Scene {
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut patches = match kind {
        Kind::Scene1 => scene1(&mut rng),
        Kind::Scene2 => scene2(),
        Kind::Cornell => cornell(),
        Kind::StressEdges => stress_edges(&mut rng),
        Kind::StressGrazing => stress_grazing(&mut rng),
        Kind::StressSkewed => stress_skewed(&mut rng),
        Kind::StressDense => stress_dense(&mut rng),
    };
    for p in &mut patches {
        for v in &mut p.vertices {
            *v = DVec3::from_array(v.to_array().map(decimal));
        }
    }
    Scene {
        name: kind.name().to_string(),
        bounds: Aabb {
            lo: DVec3::ZERO,
            hi: DVec3::ONE,
        },
        patches,
    }
}

// ---------------------------------------------------------------------------------------
// Building blocks
// ---------------------------------------------------------------------------------------

/// `x` rounded to 15 decimal places, the last step of every generator.
///
/// A double's shortest decimal form (what `serde_json` writes) can take 17 significant
/// digits, and `serde_json` without its `float_roundtrip` feature parses such a number as
/// `significand as f64 / 10^k`, rounding twice and missing by an ulp. At 15 decimal places
/// (coordinates lie in [0, 1]) the significand is below 2^53, the parse is one correctly
/// rounded division, and a saved scene loads back bit-identical. The change (at most 5e-16)
/// is below the planarity tolerance, keeps `k / n` values with short decimals (like
/// `k / 20`) as they are, and, being a function of the value, keeps shared vertices shared.
fn decimal(x: f64) -> f64 {
    (x * 1e15).round() / 1e15
}

/// Grid coordinate `k / n`, the nearest double to the rational (so `2/20` and `1/10` agree).
fn grid(k: usize, n: usize) -> f64 {
    k as f64 / n as f64
}

/// `n + 1` ticks from `lo` to `hi`; both ends exact, so boxes sharing a range share ticks.
fn ticks(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    (0..=n)
        .map(|k| match k {
            0 => lo,
            _ if k == n => hi,
            _ => lo + (hi - lo) * grid(k, n),
        })
        .collect()
}

/// The point with coordinate `c` on `axis` and `a`, `b` on the next two axes in cyclic
/// order (x→(y, z), y→(z, x), z→(x, y)), so that `e_a × e_b = e_axis`.
fn point(axis: usize, c: f64, a: f64, b: f64) -> DVec3 {
    let mut p = [0.0; 3];
    p[axis] = c;
    p[(axis + 1) % 3] = a;
    p[(axis + 2) % 3] = b;
    DVec3::from_array(p)
}

/// An axis-aligned rectangle in the plane `coord[axis] = c`, spanning `a` and `b` on the
/// next two axes; its front faces `+e_axis` when `positive`, else `-e_axis`.
fn rect(axis: usize, c: f64, positive: bool, a: (f64, f64), b: (f64, f64)) -> Vec<DVec3> {
    let (a0, a1) = a;
    let (b0, b1) = b;
    if positive {
        vec![
            point(axis, c, a0, b0),
            point(axis, c, a1, b0),
            point(axis, c, a1, b1),
            point(axis, c, a0, b1),
        ]
    } else {
        vec![
            point(axis, c, a0, b0),
            point(axis, c, a0, b1),
            point(axis, c, a1, b1),
            point(axis, c, a1, b0),
        ]
    }
}

/// The polygon with its front side turned over (vertex order reversed).
fn flipped(mut v: Vec<DVec3>) -> Vec<DVec3> {
    v.reverse();
    v
}

/// A unit vector uniform on the sphere (rejection from the cube: no trigonometry).
fn unit_vector(rng: &mut Pcg64) -> DVec3 {
    loop {
        let v = DVec3::new(
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
        );
        let l2 = v.length_squared();
        if l2 > 1e-4 && l2 <= 1.0 {
            return v / l2.sqrt();
        }
    }
}

/// A random convex patch around `c` in a random plane with a random front side: a
/// rectangle (aspect up to about 1:3) or a jittered equilateral triangle, every vertex
/// within `radius` of `c`.
fn random_patch(rng: &mut Pcg64, c: DVec3, radius: f64, triangle: bool) -> Vec<DVec3> {
    // Random plane (normal n) and a random direction u in it: (u, v, n) right-handed, so
    // vertices counter-clockwise in (u, v) face n.
    let n = unit_vector(rng);
    let u = loop {
        let w = unit_vector(rng);
        let t = w - n * w.dot(n);
        let l = t.length();
        if l > 0.1 {
            break t / l;
        }
    };
    let v = n.cross(u);
    if triangle {
        // Directions 120° apart, radii 0.5–0.7 and a jitter of at most 0.2 per axis: every
        // vertex stays within 0.99 radius and the three stay counter-clockwise.
        let h = 3f64.sqrt() / 2.0;
        [(1.0, 0.0), (-0.5, h), (-0.5, -h)]
            .iter()
            .map(|&(a, b)| {
                let r = radius * rng.gen_range(0.5..0.7);
                let ja = radius * rng.gen_range(-0.2..0.2);
                let jb = radius * rng.gen_range(-0.2..0.2);
                c + u * (r * a + ja) + v * (r * b + jb)
            })
            .collect()
    } else {
        // Half-diagonal r, half-sides a = r t and b = r sqrt(1 - t²).
        let r = radius * rng.gen_range(0.8..1.0);
        let t: f64 = rng.gen_range(0.35..0.94);
        let a = r * t;
        let b = r * (1.0 - t * t).sqrt();
        vec![
            c - u * a - v * b,
            c + u * a - v * b,
            c + u * a + v * b,
            c - u * a + v * b,
        ]
    }
}

/// A face of the unit cube as the enclosure sees it: the plane `coord[axis] = c` and the
/// inward direction of its normal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Face {
    Floor,
    Ceiling,
    X0,
    X1,
    Y0,
    Y1,
}

impl Face {
    const ALL: [Face; 6] = [
        Face::Floor,
        Face::Ceiling,
        Face::X0,
        Face::X1,
        Face::Y0,
        Face::Y1,
    ];

    /// (axis, plane coordinate, inward normal is +e_axis).
    fn plane(self) -> (usize, f64, bool) {
        match self {
            Face::Floor => (2, 0.0, true),
            Face::Ceiling => (2, 1.0, false),
            Face::X0 => (0, 0.0, true),
            Face::X1 => (0, 1.0, false),
            Face::Y0 => (1, 0.0, true),
            Face::Y1 => (1, 1.0, false),
        }
    }
}

/// The unit cube's six faces, each an `n`×`n` grid of inward-facing quads at `k / n`, so
/// the faces tile the cube exactly and tiles meet edge to edge across the cube's edges.
/// Floor tile `source` (index along x, then y) comes first and is patch 0; then the rest of
/// the floor, the ceiling, x = 0, x = 1, y = 0, y = 1, each in (a, b) grid order.
/// `style(face, i, j)` gives a tile's (emission, reflectance).
fn enclosure(
    n: usize,
    source: (usize, usize),
    style: impl Fn(Face, usize, usize) -> (f64, f64),
) -> Vec<Patch> {
    let tile = |face: Face, i: usize, j: usize| {
        let (axis, c, positive) = face.plane();
        let v = rect(
            axis,
            c,
            positive,
            (grid(i, n), grid(i + 1, n)),
            (grid(j, n), grid(j + 1, n)),
        );
        let (e, r) = style(face, i, j);
        Patch::new(v, e, r)
    };
    let mut patches = vec![tile(Face::Floor, source.0, source.1)];
    for face in Face::ALL {
        for j in 0..n {
            for i in 0..n {
                if face == Face::Floor && (i, j) == source {
                    continue;
                }
                patches.push(tile(face, i, j));
            }
        }
    }
    patches
}

/// Which faces of an axis-aligned box to build.
#[derive(Clone, Copy)]
enum Faces {
    /// All six (a floating box).
    All,
    /// All but the bottom (a box resting on something).
    NoBottom,
    /// The four sides only (a leg between the floor and a table top).
    Sides,
}

/// The axis-aligned box `[lo, hi]` as outward-facing quads; the face normal to axis `k` is
/// a grid of `n[(k+1)%3]` × `n[(k+2)%3]` quads.
fn cuboid(lo: DVec3, hi: DVec3, n: [usize; 3], faces: Faces, reflectance: f64) -> Vec<Patch> {
    let lo = lo.to_array();
    let hi = hi.to_array();
    let t: Vec<Vec<f64>> = (0..3).map(|k| ticks(lo[k], hi[k], n[k])).collect();
    let mut patches = Vec::new();
    for axis in 0..3 {
        for positive in [false, true] {
            let skip = axis == 2
                && match faces {
                    Faces::All => false,
                    Faces::NoBottom => !positive,
                    Faces::Sides => true,
                };
            if skip {
                continue;
            }
            let c = if positive { hi[axis] } else { lo[axis] };
            let (ta, tb) = (&t[(axis + 1) % 3], &t[(axis + 2) % 3]);
            for j in 0..tb.len() - 1 {
                for i in 0..ta.len() - 1 {
                    let v = rect(axis, c, positive, (ta[i], ta[i + 1]), (tb[j], tb[j + 1]));
                    patches.push(Patch::new(v, 0.0, reflectance));
                }
            }
        }
    }
    patches
}

fn v3(x: f64, y: f64, z: f64) -> DVec3 {
    DVec3::new(x, y, z)
}

// ---------------------------------------------------------------------------------------
// scene1: 6 walls + 20 random patches
// ---------------------------------------------------------------------------------------

/// The paper's test scene 1: the cube's walls as six single inward quads (floor first, the
/// ceiling emitting) and 20 random patches, quads and triangles alternately, of size about
/// 0.05–0.3 (bounding radius 0.035–0.21), at least 0.02 from the walls and from each other.
fn scene1(rng: &mut Pcg64) -> Vec<Patch> {
    let mut patches = enclosure(1, (0, 0), |face, _, _| match face {
        Face::Ceiling => (1.0, 0.5),
        _ => (0.0, 0.5),
    });
    let mut placed: Vec<Vec<DVec3>> = Vec::new();
    for k in 0..20 {
        let mut radius = rng.gen_range(0.035..0.21);
        let mut v = Vec::new();
        // Rejection until the patch is 0.02 clear of the others; every 1000 tries the
        // radius shrinks by a fifth (down to 0.035), and after 10,000 (which no seed tried
        // needs) the last candidate is taken as it is.
        for attempt in 1..=10_000 {
            let lo = radius + 0.02;
            let hi = 1.0 - lo;
            let centre = v3(
                rng.gen_range(lo..hi),
                rng.gen_range(lo..hi),
                rng.gen_range(lo..hi),
            );
            v = random_patch(rng, centre, radius, k % 2 == 1);
            if placed.iter().all(|q| separated(&v, q, 0.02)) {
                break;
            }
            if attempt % 1000 == 0 {
                radius = (radius * 0.8).max(0.035);
            }
        }
        placed.push(v.clone());
        patches.push(Patch::new(v, 0.0, 0.5));
    }
    patches
}

/// True when some axis separates convex polygons `a` and `b` by at least `gap` (then no two
/// of their points are closer than `gap`). The axes tried are those of the separating axis
/// test (both normals and the cross products of their edges) and the line through the
/// centroids; a `false` may be conservative.
fn separated(a: &[DVec3], b: &[DVec3], gap: f64) -> bool {
    let centroid = |v: &[DVec3]| v.iter().copied().sum::<DVec3>() / v.len() as f64;
    let normal = |v: &[DVec3]| (v[1] - v[0]).cross(v[2] - v[0]);
    let edge = |v: &[DVec3], i: usize| v[(i + 1) % v.len()] - v[i];
    let mut axes = vec![normal(a), normal(b), centroid(b) - centroid(a)];
    for i in 0..a.len() {
        for j in 0..b.len() {
            axes.push(edge(a, i).cross(edge(b, j)));
        }
    }
    let interval = |v: &[DVec3], u: DVec3| {
        v.iter()
            .map(|p| p.dot(u))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
                (lo.min(x), hi.max(x))
            })
    };
    axes.into_iter().any(|axis| {
        let l = axis.length();
        if l < 1e-12 {
            return false;
        }
        let u = axis / l;
        let (a0, a1) = interval(a, u);
        let (b0, b1) = interval(b, u);
        b0 - a1 >= gap || a0 - b1 >= gap
    })
}

// ---------------------------------------------------------------------------------------
// scene2: a furnished room of 808 patches
// ---------------------------------------------------------------------------------------

/// The paper's test scene 2, a room of exactly 808 quads: 600 tiles (10×10 per face, the
/// four central ceiling tiles emitting) and 208 of furniture, every piece at least 0.02
/// from the walls so no furniture face lies in a wall plane:
///
/// | piece | patches |
/// | --- | --- |
/// | table: top slab (3×3×1) on four legs | 30 + 16 |
/// | two chairs: seat, four legs, backrest | 2 × 27 |
/// | bed (4×2×1) and headboard (1×2×2) | 20 + 14 |
/// | wardrobe (2×2×4) | 36 |
/// | sofa: base and back (1×3×1 each) | 11 + 11 |
/// | nightstand, wall shelf, chest | 5 + 6 + 5 |
///
/// Patch 0 is floor tile [0.4, 0.5]², which no furniture covers.
fn scene2() -> Vec<Patch> {
    const FLOOR: f64 = 0.4;
    const WALL: f64 = 0.6;
    const CEILING: f64 = 0.8;
    const WOOD: f64 = 0.45;
    const FABRIC: f64 = 0.35;
    const LINEN: f64 = 0.7;
    let mut p = enclosure(10, (4, 4), |face, i, j| match face {
        Face::Floor => (0.0, FLOOR),
        Face::Ceiling if (4..6).contains(&i) && (4..6).contains(&j) => (1.0, CEILING),
        Face::Ceiling => (0.0, CEILING),
        _ => (0.0, WALL),
    });
    // A table or chair: a slab on four square legs of side `leg`, inset by `inset`.
    let legs = |p: &mut Vec<Patch>, lo: DVec3, hi: DVec3, leg: f64, inset: f64| {
        for (x0, y0) in [
            (lo.x + inset, lo.y + inset),
            (hi.x - inset - leg, lo.y + inset),
            (lo.x + inset, hi.y - inset - leg),
            (hi.x - inset - leg, hi.y - inset - leg),
        ] {
            p.extend(cuboid(
                v3(x0, y0, 0.0),
                v3(x0 + leg, y0 + leg, lo.z),
                [1, 1, 1],
                Faces::Sides,
                WOOD,
            ));
        }
    };
    // Table in the (x, y) < 0.4 quadrant: 30 + 16.
    let (tlo, thi) = (v3(0.10, 0.10, 0.40), v3(0.40, 0.35, 0.44));
    p.extend(cuboid(tlo, thi, [3, 3, 1], Faces::All, WOOD));
    legs(&mut p, tlo, thi, 0.03, 0.01);
    // Chair A north of the table, back to +y: seat 6, legs 16, backrest 5.
    let (slo, shi) = (v3(0.19, 0.38, 0.24), v3(0.31, 0.50, 0.27));
    p.extend(cuboid(slo, shi, [1, 1, 1], Faces::All, WOOD));
    legs(&mut p, slo, shi, 0.02, 0.005);
    p.extend(cuboid(
        v3(0.19, 0.48, 0.27),
        v3(0.31, 0.50, 0.55),
        [1, 1, 1],
        Faces::NoBottom,
        WOOD,
    ));
    // Chair B east of the table, back to +x.
    let (slo, shi) = (v3(0.43, 0.165, 0.24), v3(0.55, 0.285, 0.27));
    p.extend(cuboid(slo, shi, [1, 1, 1], Faces::All, WOOD));
    legs(&mut p, slo, shi, 0.02, 0.005);
    p.extend(cuboid(
        v3(0.53, 0.165, 0.27),
        v3(0.55, 0.285, 0.55),
        [1, 1, 1],
        Faces::NoBottom,
        WOOD,
    ));
    // Bed along the y = 1 wall with a headboard at its x = 0 end: 20 + 14.
    p.extend(cuboid(
        v3(0.05, 0.72, 0.0),
        v3(0.45, 0.97, 0.20),
        [4, 2, 1],
        Faces::NoBottom,
        LINEN,
    ));
    p.extend(cuboid(
        v3(0.02, 0.72, 0.0),
        v3(0.04, 0.97, 0.35),
        [1, 2, 2],
        Faces::NoBottom,
        WOOD,
    ));
    // Wardrobe in the (1, 1) corner: 36.
    p.extend(cuboid(
        v3(0.70, 0.74, 0.0),
        v3(0.96, 0.98, 0.60),
        [2, 2, 4],
        Faces::NoBottom,
        WOOD,
    ));
    // Sofa along the x = 1 wall: base and back, 11 + 11.
    p.extend(cuboid(
        v3(0.74, 0.08, 0.0),
        v3(0.96, 0.55, 0.15),
        [1, 3, 1],
        Faces::NoBottom,
        FABRIC,
    ));
    p.extend(cuboid(
        v3(0.90, 0.08, 0.15),
        v3(0.96, 0.55, 0.40),
        [1, 3, 1],
        Faces::NoBottom,
        FABRIC,
    ));
    // Nightstand 5, wall shelf (floating) 6, chest 5.
    p.extend(cuboid(
        v3(0.05, 0.58, 0.0),
        v3(0.15, 0.68, 0.15),
        [1, 1, 1],
        Faces::NoBottom,
        WOOD,
    ));
    p.extend(cuboid(
        v3(0.48, 0.93, 0.55),
        v3(0.66, 0.98, 0.58),
        [1, 1, 1],
        Faces::All,
        WOOD,
    ));
    p.extend(cuboid(
        v3(0.55, 0.05, 0.0),
        v3(0.65, 0.15, 0.10),
        [1, 1, 1],
        Faces::NoBottom,
        WOOD,
    ));
    p
}

// ---------------------------------------------------------------------------------------
// cornell: the Cornell box
// ---------------------------------------------------------------------------------------

/// The Cornell box's size in millimetres along its depth: the scale factor to the unit cube.
const CORNELL_MM: f64 = 559.2;

/// The published light's height is the ceiling's (548.8 mm); it is put 0.1 mm lower so it
/// is not coplanar with the ceiling.
const CORNELL_LIGHT_Y: f64 = 548.7;

/// A published point (mm, y up, open front at z = 0) in scene coordinates: scaled by
/// 1/559.2 and turned z-up by a proper rotation (x, y, z) → (x, 559.2 − z, y), so the red
/// wall stays on the left seen from the front. The back wall lands on y = 0, the added front
/// wall on y = 1, the floor on z = 0.
fn cornell_point([x, y, z]: [f64; 3]) -> DVec3 {
    v3(
        x / CORNELL_MM,
        (CORNELL_MM - z) / CORNELL_MM,
        y / CORNELL_MM,
    )
}

/// The Cornell box's 8 corners (mm), from which every shell face is built.
const CB: [[f64; 3]; 8] = [
    [552.8, 0.0, 0.0],     // 0: floor, front, x high
    [0.0, 0.0, 0.0],       // 1: floor, front, x = 0
    [0.0, 0.0, 559.2],     // 2: floor, back, x = 0
    [549.6, 0.0, 559.2],   // 3: floor, back, x high
    [556.0, 548.8, 0.0],   // 4: ceiling, front, x high
    [556.0, 548.8, 559.2], // 5: ceiling, back, x high
    [0.0, 548.8, 559.2],   // 6: ceiling, back, x = 0
    [0.0, 548.8, 0.0],     // 7: ceiling, front, x = 0
];

const CORNELL_WHITE: Spectrum = Spectrum::Grey(0.75);
const CORNELL_RED: Spectrum = Spectrum::Rgb([0.63, 0.065, 0.05]);
const CORNELL_GREEN: Spectrum = Spectrum::Rgb([0.14, 0.45, 0.091]);

/// The Cornell box's shell (floor, ceiling, back, right, left and the added front wall) as
/// published (corner indices into [`CB`]) with their colours; each face is oriented into
/// the box and split into two triangles if it is not planar.
fn cornell_shell() -> Vec<Patch> {
    let faces: [([usize; 4], Spectrum); 6] = [
        ([0, 1, 2, 3], CORNELL_WHITE), // floor
        ([4, 5, 6, 7], CORNELL_WHITE), // ceiling
        ([3, 2, 6, 5], CORNELL_WHITE), // back wall
        ([2, 1, 7, 6], CORNELL_GREEN), // right wall (x = 0)
        ([0, 3, 5, 4], CORNELL_RED),   // left wall (x ≈ 550–556; not planar)
        ([0, 1, 7, 4], CORNELL_WHITE), // front wall: not in the data, closes the box
    ];
    let inside = CB.iter().map(|&c| cornell_point(c)).sum::<DVec3>() / 8.0;
    let mut patches = Vec::new();
    for (corners, colour) in faces {
        let v: Vec<DVec3> = corners.iter().map(|&k| cornell_point(CB[k])).collect();
        let p = Patch {
            vertices: v,
            emission: Spectrum::Grey(0.0),
            reflectance: colour,
        };
        // Face into the box.
        let p = if p.area_vector().dot(inside - p.centroid()) < 0.0 {
            Patch {
                vertices: flipped(p.vertices),
                ..p
            }
        } else {
            p
        };
        patches.extend(split_if_bad(p));
    }
    patches
}

/// A quad that fails [`Patch::check`] (the published left wall bends by about 3 mm) as two
/// triangles split along its 0–2 diagonal; any other patch as it is.
fn split_if_bad(p: Patch) -> Vec<Patch> {
    if p.vertices.len() == 4 && p.check().is_err() {
        let v = &p.vertices;
        vec![
            Patch {
                vertices: vec![v[0], v[1], v[2]],
                ..p.clone()
            },
            Patch {
                vertices: vec![v[0], v[2], v[3]],
                ..p.clone()
            },
        ]
    } else {
        vec![p]
    }
}

/// The Cornell box (Cornell University Program of Computer Graphics, "Cornell Box Data"):
/// floor (patch 0), light (patch 1, emitting [17, 12, 4]), then the rest of the shell and
/// the two blocks. Walls face into the box, the blocks' faces outward (into the room); the
/// blocks have no bottom. The published box is open at the front (z = 0 mm); a white front
/// wall through the four front corners closes it so that every ray from inside hits a patch.
fn cornell() -> Vec<Patch> {
    let mut shell = cornell_shell();
    let floor = shell.remove(0);

    // The light, 0.1 mm below the ceiling, facing down.
    let light: Vec<DVec3> = [
        [343.0, CORNELL_LIGHT_Y, 227.0],
        [343.0, CORNELL_LIGHT_Y, 332.0],
        [213.0, CORNELL_LIGHT_Y, 332.0],
        [213.0, CORNELL_LIGHT_Y, 227.0],
    ]
    .iter()
    .map(|&c| cornell_point(c))
    .collect();
    let mut light = Patch {
        vertices: light,
        emission: Spectrum::Rgb([17.0, 12.0, 4.0]),
        reflectance: Spectrum::Grey(0.78),
    };
    if light.area_vector().z > 0.0 {
        light.vertices = flipped(light.vertices);
    }

    let mut patches = vec![floor, light];
    patches.extend(shell);

    // The blocks: the top's 4 corners (x, z in mm) and the height; 5 faces each.
    let short: [[f64; 2]; 4] = [[130.0, 65.0], [82.0, 225.0], [240.0, 272.0], [290.0, 114.0]];
    let tall: [[f64; 2]; 4] = [
        [423.0, 247.0],
        [265.0, 296.0],
        [314.0, 456.0],
        [472.0, 406.0],
    ];
    for (top, h) in [(short, 165.0), (tall, 330.0)] {
        let up = |k: usize| cornell_point([top[k][0], h, top[k][1]]);
        let down = |k: usize| cornell_point([top[k][0], 0.0, top[k][1]]);
        let mut centre = (0..4).map(up).sum::<DVec3>() / 4.0;
        centre.z /= 2.0;
        let mut faces = vec![(0..4).map(up).collect::<Vec<_>>()];
        for k in 0..4 {
            let l = (k + 1) % 4;
            faces.push(vec![down(k), up(k), up(l), down(l)]);
        }
        for v in faces {
            let p = Patch {
                vertices: v,
                emission: Spectrum::Grey(0.0),
                reflectance: CORNELL_WHITE,
            };
            // Face out of the block.
            let p = if p.area_vector().dot(p.centroid() - centre) < 0.0 {
                Patch {
                    vertices: flipped(p.vertices),
                    ..p
                }
            } else {
                p
            };
            patches.extend(split_if_bad(p));
        }
    }
    patches
}

// ---------------------------------------------------------------------------------------
// stress-edges: shared edges and vertices on cell boundaries
// ---------------------------------------------------------------------------------------

/// The default grid's cells per unit (cell size 0.05).
const CELLS: usize = 20;

/// Chebyshev polynomial `T_m(s)`, `|T_m(s)| <= 1` on `[-1, 1]`.
fn chebyshev(m: usize, s: f64) -> f64 {
    match m {
        0 => 1.0,
        1 => s,
        2 => 2.0 * s * s - 1.0,
        _ => 4.0 * s * s * s - 3.0 * s,
    }
}

/// Shared edges and vertices on grid-cell boundaries (cell 0.05), every one computed from
/// integer indices as `k / 20` so that shared coordinates are bit-identical:
/// - the enclosure as 5×5 tiles per face (ticks k/5 = 4k/20), the ceiling emitting; patch 0
///   is the central floor tile [0.4, 0.6]²;
/// - a heightfield over [0.1, 0.9]² with vertices (i/20, j/20, h(i, j)), h a smooth seeded
///   polynomial in [0.3, 0.6], each cell split along alternating diagonals (a union jack:
///   vertex valence 4 and 8), facing down to the source, with a window of 4×4 cells over
///   the source;
/// - above it, the plane z = 15/20 over [0.1, 0.9]² as one quad per cell face, facing down;
///   four 2×2-cell blocks of it are triangle fans instead, around the cell corners
///   (0.5, 0.5) and (0.6, 0.6) (valence 8), (0.4, 0.5) (valence 6) and (0.5, 0.4) (valence
///   7). The source's zenith ray through its centre hits the vertex (0.5, 0.5, 0.75).
fn stress_edges(rng: &mut Pcg64) -> Vec<Patch> {
    let mut p = enclosure(5, (2, 2), |face, _, _| match face {
        Face::Ceiling => (1.0, 0.5),
        _ => (0.0, 0.5),
    });

    // Heightfield h(i, j) = 0.45 + 0.15 f / sum|w|, f = sum w T_m(s) T_n(t), with s, t the
    // grid indices mapped exactly to [-1, 1].
    let terms = [(1, 1), (2, 1), (1, 2), (2, 2), (3, 1), (1, 3)];
    let w: Vec<f64> = terms.iter().map(|_| rng.gen_range(-1.0..1.0)).collect();
    let wsum: f64 = w.iter().map(|x: &f64| x.abs()).sum();
    let h = |i: usize, j: usize| {
        let s = (i as f64 - 10.0) / 8.0;
        let t = (j as f64 - 10.0) / 8.0;
        let f: f64 = terms
            .iter()
            .zip(&w)
            .map(|(&(m, n), &wk)| wk * chebyshev(m, s) * chebyshev(n, t))
            .sum();
        0.45 + 0.15 * (f / wsum)
    };
    let vert = |i: usize, j: usize| v3(grid(i, CELLS), grid(j, CELLS), h(i, j));
    let window = 8..12;
    for j in 2..18 {
        for i in 2..18 {
            if window.contains(&i) && window.contains(&j) {
                continue;
            }
            let (a, b, c, d) = (
                vert(i, j),
                vert(i + 1, j),
                vert(i + 1, j + 1),
                vert(i, j + 1),
            );
            // Counter-clockwise from above, then flipped to face down.
            let tris = if (i + j) % 2 == 0 {
                [[a, b, c], [a, c, d]]
            } else {
                [[a, b, d], [b, c, d]]
            };
            for t in tris {
                p.push(Patch::new(flipped(t.to_vec()), 0.0, 0.5));
            }
        }
    }

    // The plane z = 15/20, one quad per cell, except the fan blocks.
    let z = grid(15, CELLS);
    let at = |i: usize, j: usize| v3(grid(i, CELLS), grid(j, CELLS), z);
    // Fan centres (cell-corner indices) and rims (counter-clockwise offsets from above);
    // the triangles after the fan fill the block's remaining corners.
    type Fan = (
        usize,
        usize,
        &'static [(i32, i32)],
        &'static [[(i32, i32); 3]],
    );
    const RIM8: [(i32, i32); 8] = [
        (1, 0),
        (1, 1),
        (0, 1),
        (-1, 1),
        (-1, 0),
        (-1, -1),
        (0, -1),
        (1, -1),
    ];
    const RIM7: [(i32, i32); 7] = [(1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1)];
    const RIM6: [(i32, i32); 6] = [(1, 0), (1, 1), (0, 1), (-1, 0), (-1, -1), (0, -1)];
    const FILL7: [[(i32, i32); 3]; 1] = [[(0, -1), (1, -1), (1, 0)]];
    const FILL6: [[(i32, i32); 3]; 2] = [[(0, -1), (1, -1), (1, 0)], [(0, 1), (-1, 1), (-1, 0)]];
    let fans: [Fan; 4] = [
        (10, 10, &RIM8, &[]),
        (8, 10, &RIM6, &FILL6),
        (10, 8, &RIM7, &FILL7),
        (12, 12, &RIM8, &[]),
    ];
    let in_fan = |i: usize, j: usize| {
        fans.iter()
            .any(|&(ci, cj, _, _)| (ci - 1..ci + 1).contains(&i) && (cj - 1..cj + 1).contains(&j))
    };
    for j in 2..18 {
        for i in 2..18 {
            if !in_fan(i, j) {
                let v = rect(
                    2,
                    z,
                    false,
                    (grid(i, CELLS), grid(i + 1, CELLS)),
                    (grid(j, CELLS), grid(j + 1, CELLS)),
                );
                p.push(Patch::new(v, 0.0, 0.5));
            }
        }
    }
    let off = |ci: usize, cj: usize, (di, dj): (i32, i32)| {
        at((ci as i32 + di) as usize, (cj as i32 + dj) as usize)
    };
    for (ci, cj, rim, fill) in fans {
        let c = at(ci, cj);
        for k in 0..rim.len() {
            let t = vec![
                c,
                off(ci, cj, rim[k]),
                off(ci, cj, rim[(k + 1) % rim.len()]),
            ];
            p.push(Patch::new(flipped(t), 0.0, 0.5));
        }
        for tri in fill {
            let t = tri.iter().map(|&d| off(ci, cj, d)).collect();
            p.push(Patch::new(flipped(t), 0.0, 0.5));
        }
    }
    p
}

// ---------------------------------------------------------------------------------------
// stress-grazing: patches nearly parallel to rays from the source
// ---------------------------------------------------------------------------------------

/// Patches nearly parallel to many rays from the source (the central floor tile
/// [0.4, 0.6]², centre S = (0.5, 0.5, 0)), in the 5×5-tile enclosure:
/// - 37 thin horizontal slats (0.15–0.35 by 0.02–0.05) at distinct heights k/400 for
///   k = 4..=40 (0.01–0.1), seeded positions clear of the source, facing down: the source's
///   low rays reach them at a few degrees;
/// - 32 vertical fins (0.12–0.14 long, z 0.15–0.85) in two rings around S (radius
///   0.14–0.26 and 0.30–0.44) along 16 directions,
///   each in a vertical plane through S turned by δ ∈ {0, 1e-3, 2e-3, 5e-3, 1e-2} rad:
///   about a vertical axis through its middle (even fins) or about its radial centre line
///   (odd fins). δ = 0 puts the fin exactly in a plane through S (and, along x or y, on the
///   cell boundary y = 0.5 or x = 0.5).
fn stress_grazing(rng: &mut Pcg64) -> Vec<Patch> {
    let mut p = enclosure(5, (2, 2), |face, _, _| match face {
        Face::Ceiling => (1.0, 0.5),
        _ => (0.0, 0.5),
    });
    let s = v3(0.5, 0.5, 0.0);

    // Slats, each at its own height so no two can meet.
    for k in 4..=40 {
        let z = grid(k, 400);
        loop {
            let d = loop {
                let (a, b): (f64, f64) = (rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0));
                let l2 = a * a + b * b;
                if l2 > 1e-4 && l2 <= 1.0 {
                    let l = l2.sqrt();
                    break v3(a / l, b / l, 0.0);
                }
            };
            let q = v3(-d.y, d.x, 0.0);
            let half_len: f64 = rng.gen_range(0.15..0.35) / 2.0;
            let half_wid = rng.gen_range(0.02..0.05) / 2.0;
            let r = (half_len * half_len + half_wid * half_wid).sqrt();
            let c = v3(
                rng.gen_range(r + 0.02..1.0 - r - 0.02),
                rng.gen_range(r + 0.02..1.0 - r - 0.02),
                z,
            );
            // Clear of the source tile (half-diagonal 0.1414).
            if (c - s).truncate().length() < r + 0.15 {
                continue;
            }
            let (a, b) = (d * half_len, q * half_wid);
            let v = vec![c - a - b, c + a - b, c + a + b, c - a + b];
            p.push(Patch::new(flipped(v), 0.0, 0.5));
            break;
        }
    }

    // Fins along 16 directions with small integer components (no trigonometry).
    let dirs: [(f64, f64); 16] = [
        (1.0, 0.0),
        (2.0, 1.0),
        (1.0, 1.0),
        (1.0, 2.0),
        (0.0, 1.0),
        (-1.0, 2.0),
        (-1.0, 1.0),
        (-2.0, 1.0),
        (-1.0, 0.0),
        (-2.0, -1.0),
        (-1.0, -1.0),
        (-1.0, -2.0),
        (0.0, -1.0),
        (1.0, -2.0),
        (1.0, -1.0),
        (2.0, -1.0),
    ];
    let tilts = [0.0, 1e-3, 2e-3, 5e-3, 1e-2];
    let (z_mid, half_h) = (0.5, 0.35);
    for (ring, (r0, r1)) in [(0.14, 0.26), (0.30, 0.44)].into_iter().enumerate() {
        for (k, &(a, b)) in dirs.iter().enumerate() {
            let idx = ring * dirs.len() + k;
            let delta = tilts[idx % tilts.len()];
            let d = v3(a, b, 0.0) / (a * a + b * b).sqrt();
            let perp = v3(-d.y, d.x, 0.0);
            let half_l = (r1 - r0) / 2.0;
            let m = s + d * ((r0 + r1) / 2.0) + DVec3::Z * z_mid;
            // The fin's horizontal and upward edge directions.
            let (e, up) = if idx & 1 == 0 {
                // Yaw: turned about the vertical axis through its middle.
                let e = d + perp * delta;
                (e / e.length(), DVec3::Z)
            } else {
                // Lean: turned about its radial centre line.
                let up = DVec3::Z + perp * delta;
                (d, up / up.length())
            };
            let (e, up) = (e * half_l, up * half_h);
            let v = vec![m - e - up, m + e - up, m + e + up, m - e + up];
            p.push(Patch::new(v, 0.0, 0.5));
        }
    }
    p
}

// ---------------------------------------------------------------------------------------
// stress-skewed and stress-dense: lattices of small random patches
// ---------------------------------------------------------------------------------------

/// One small random patch (quad or triangle, random orientation) in each cell of an
/// `m`×`m`×`m` lattice over the cube `[lo, hi]^3`: centre jittered by up to 4% of a cell,
/// radius up to 42% of a cell, so each stays inside its cell's inscribed sphere and no two
/// meet. `facing` turns each patch's front toward that point.
fn lattice(
    rng: &mut Pcg64,
    lo: f64,
    hi: f64,
    m: usize,
    facing: Option<DVec3>,
    reflectance: f64,
) -> Vec<Patch> {
    let cell = (hi - lo) / m as f64;
    let at = |k: usize| lo + (hi - lo) * grid(2 * k + 1, 2 * m);
    let mut patches = Vec::with_capacity(m * m * m);
    for k in 0..m {
        for j in 0..m {
            for i in 0..m {
                let jitter = 0.04 * cell;
                let c = v3(
                    at(i) + rng.gen_range(-jitter..jitter),
                    at(j) + rng.gen_range(-jitter..jitter),
                    at(k) + rng.gen_range(-jitter..jitter),
                );
                let radius = 0.42 * cell * rng.gen_range(0.7..1.0);
                let triangle = rng.gen_bool(0.5);
                let mut v = random_patch(rng, c, radius, triangle);
                if let Some(f) = facing {
                    let pv = Patch::new(v.clone(), 0.0, 0.0);
                    if pv.area_vector().dot(f - pv.centroid()) < 0.0 {
                        v = flipped(v);
                    }
                }
                patches.push(Patch::new(v, 0.0, reflectance));
            }
        }
    }
    patches
}

/// Most of the work in one narrow cone: the 5×5-tile enclosure (patch 0 the central floor
/// tile, centre S = (0.5, 0.5, 0)) and 12³ = 1728 small patches (diameter ≤ 0.0112) in the
/// cube [0.80, 0.96]³ near the top corner (1, 1, 1), all facing S. From S the cluster lies
/// within about 7.5° of the direction (0.38, 0.38, 0.88) (θ ≈ 32° from the zenith,
/// φ = 45°), so a static partition of the hemisphere by equal angles (5×5 subregions of 18°
/// by 72°) puts nearly all intersection work into one or two subregions.
fn stress_skewed(rng: &mut Pcg64) -> Vec<Patch> {
    let mut p = enclosure(5, (2, 2), |face, _, _| match face {
        Face::Ceiling => (1.0, 0.5),
        _ => (0.0, 0.5),
    });
    p.extend(lattice(rng, 0.80, 0.96, 12, Some(v3(0.5, 0.5, 0.0)), 0.5));
    p
}

/// At least 20,000 small patches: the enclosure as 10×10 tiles per face (600; patch 0 the
/// floor tile [0.4, 0.5]²) and 27³ = 19683 random patches (diameter ≤ 0.029, random
/// orientation), one per cell of a lattice over [0.04, 0.96]³: 20283 in all.
fn stress_dense(rng: &mut Pcg64) -> Vec<Patch> {
    let mut p = enclosure(10, (4, 4), |face, _, _| match face {
        Face::Ceiling => (1.0, 0.5),
        _ => (0.0, 0.5),
    });
    p.extend(lattice(rng, 0.04, 0.96, 27, None, 0.5));
    p
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;
    use std::path::Path;

    /// Patches per kind at any seed.
    fn expected_count(kind: Kind) -> usize {
        match kind {
            Kind::Scene1 => 26,
            Kind::Scene2 => 808,
            Kind::Cornell => 18,
            Kind::StressEdges => 150 + 480 + 272,
            Kind::StressGrazing => 150 + 37 + 32,
            Kind::StressSkewed => 150 + 1728,
            Kind::StressDense => 600 + 19683,
        }
    }

    fn scenes() -> Vec<(Kind, Scene)> {
        Kind::ALL
            .iter()
            .map(|&k| (k, generate(k, DEFAULT_SEED)))
            .collect()
    }

    #[test]
    fn gen_every_kind_validates_with_expected_counts() {
        for (kind, s) in scenes() {
            s.validate(Path::new(&kind.file_name()))
                .unwrap_or_else(|e| panic!("{}: {e}", kind.name()));
            assert_eq!(s.name, kind.name());
            assert_eq!(s.bounds.lo, DVec3::ZERO);
            assert_eq!(s.bounds.hi, DVec3::ONE);
            assert_eq!(s.patches.len(), expected_count(kind), "{}", kind.name());
            assert!(kind.default_source() < s.patches.len());
            assert!(s
                .patches
                .iter()
                .all(|p| (3..=4).contains(&p.vertices.len())));
        }
        let dense = generate(Kind::StressDense, DEFAULT_SEED).patches.len();
        assert!((20_000..=21_000).contains(&dense), "{dense}");
    }

    #[test]
    fn gen_patch_zero_is_on_the_floor_facing_up() {
        for (kind, s) in scenes() {
            let p = &s.patches[0];
            assert!(p.vertices.iter().all(|v| v.z == 0.0), "{}", kind.name());
            assert!(p.normal().abs_diff_eq(DVec3::Z, 1e-15), "{}", kind.name());
        }
    }

    #[test]
    fn gen_same_seed_same_scene_and_seed_matters() {
        for kind in Kind::ALL {
            assert_eq!(generate(kind, 7), generate(kind, 7), "{}", kind.name());
        }
        assert_ne!(generate(Kind::Scene1, 1), generate(Kind::Scene1, 2));
        for kind in [
            Kind::StressEdges,
            Kind::StressGrazing,
            Kind::StressSkewed,
            Kind::StressDense,
        ] {
            assert_ne!(generate(kind, 1), generate(kind, 2), "{}", kind.name());
        }
    }

    #[test]
    fn gen_names_match_clap() {
        use clap::ValueEnum;
        for kind in Kind::ALL {
            let pv = kind.to_possible_value().unwrap();
            assert_eq!(pv.get_name(), kind.name());
            assert_eq!(<Kind as ValueEnum>::from_str(kind.name(), false), Ok(kind));
            assert_eq!(kind.file_name(), format!("{}.json", kind.name()));
        }
        assert_eq!(Kind::value_variants(), &Kind::ALL);
    }

    /// Patches lying in a cube face's plane, by exact coordinate.
    fn in_face(s: &Scene, face: Face) -> Vec<&Patch> {
        let (axis, c, _) = face.plane();
        s.patches
            .iter()
            .filter(|p| p.vertices.iter().all(|v| v[axis] == c))
            .collect()
    }

    /// Every directed edge of `patches` is matched by the reverse edge of another: the
    /// patches form a closed, consistently oriented surface without T-junctions.
    fn assert_closed(patches: &[&Patch], what: &str) {
        let key = |v: DVec3| v.to_array().map(f64::to_bits);
        let mut edges: HashMap<([u64; 3], [u64; 3]), i32> = HashMap::new();
        for p in patches {
            let v = &p.vertices;
            for i in 0..v.len() {
                let (a, b) = (key(v[i]), key(v[(i + 1) % v.len()]));
                *edges.entry((a, b)).or_default() += 1;
            }
        }
        for (&(a, b), &n) in &edges {
            assert_eq!(n, 1, "{what}: edge used {n} times");
            assert_eq!(
                edges.get(&(b, a)),
                Some(&1),
                "{what}: edge {a:?}→{b:?} has no reverse"
            );
        }
    }

    #[test]
    fn gen_walls_tile_the_cube_faces_facing_in() {
        for (kind, s) in scenes() {
            if kind == Kind::Cornell {
                continue;
            }
            let mut shell = Vec::new();
            for face in Face::ALL {
                let (axis, _, positive) = face.plane();
                let ps = in_face(&s, face);
                let area: f64 = ps.iter().map(|p| p.area()).sum();
                assert!(
                    (area - 1.0).abs() < 1e-12,
                    "{} {face:?}: area {area}",
                    kind.name()
                );
                let mut inward = DVec3::ZERO;
                inward[axis] = if positive { 1.0 } else { -1.0 };
                for p in &ps {
                    assert!(
                        p.normal().abs_diff_eq(inward, 1e-12),
                        "{} {face:?}",
                        kind.name()
                    );
                }
                shell.extend(ps);
            }
            assert_closed(&shell, kind.name());
        }
    }

    #[test]
    fn gen_cornell_is_closed_and_faces_the_room() {
        let s = generate(Kind::Cornell, DEFAULT_SEED);
        let corners: Vec<DVec3> = CB
            .iter()
            .map(|&c| DVec3::from_array(cornell_point(c).to_array().map(decimal)))
            .collect();
        let shell: Vec<&Patch> = s
            .patches
            .iter()
            .filter(|p| p.vertices.iter().all(|v| corners.contains(v)))
            .collect();
        // 6 faces, the left wall split in two.
        assert_eq!(shell.len(), 7);
        assert_closed(&shell, "cornell shell");
        let sum: DVec3 = shell.iter().map(|p| p.area_vector()).sum();
        assert!(sum.length() < 1e-12, "{sum}");
        // Facing in: the floor up (so, closed and consistent, the whole shell faces in).
        assert!(s.patches[0].normal().abs_diff_eq(DVec3::Z, 1e-12));
        // Patch 1 is the light: emitting, facing down, below the ceiling.
        let light = &s.patches[1];
        assert!(light.emission.is_nonzero());
        assert!(light.normal().abs_diff_eq(-DVec3::Z, 1e-12));
        let ceiling_z = 548.8 / CORNELL_MM;
        assert!(light.vertices.iter().all(|v| v.z < ceiling_z));
        assert_eq!(Kind::Cornell.default_source(), 1);
        // The blocks (the last 10 patches) face out of their blocks: away from the vertical
        // axis through their top's centre, or up.
        for block in s.patches[s.patches.len() - 10..].chunks(5) {
            let top = &block[0];
            assert!(top.normal().abs_diff_eq(DVec3::Z, 1e-12));
            let axis = top.centroid();
            for side in &block[1..] {
                let out = (side.centroid() - axis).truncate().extend(0.0);
                assert!(side.area_vector().dot(out) > 0.0);
            }
        }
        // Scaled by 1/559.2: the box's depth is exactly 1.
        let ys: Vec<f64> = corners.iter().map(|v| v.y).collect();
        assert!(ys.contains(&0.0) && ys.contains(&1.0));
        // The red and green walls are coloured.
        assert!(s
            .patches
            .iter()
            .any(|p| p.reflectance == CORNELL_RED && p.vertices.len() == 3));
        assert!(s.patches.iter().any(|p| p.reflectance == CORNELL_GREEN));
    }

    /// No two distinct vertices of the scene are closer than 1e-9: where patches share a
    /// vertex, its coordinates are bit-identical.
    fn assert_no_near_duplicates(s: &Scene) {
        let mut vs: Vec<DVec3> = s
            .patches
            .iter()
            .flat_map(|p| p.vertices.iter().copied())
            .collect();
        vs.sort_by(|a, b| a.x.total_cmp(&b.x));
        vs.dedup();
        for i in 0..vs.len() {
            for j in i + 1..vs.len() {
                if vs[j].x - vs[i].x > 1e-9 {
                    break;
                }
                if vs[i] != vs[j] {
                    assert!(
                        vs[i].distance(vs[j]) > 1e-9,
                        "{}: {} and {} nearly coincide",
                        s.name,
                        vs[i],
                        vs[j]
                    );
                }
            }
        }
    }

    #[test]
    fn gen_shared_vertices_are_bit_identical() {
        for (_, s) in scenes() {
            assert_no_near_duplicates(&s);
        }
    }

    #[test]
    fn gen_scene1_random_patches() {
        let s = generate(Kind::Scene1, DEFAULT_SEED);
        let random = &s.patches[6..];
        assert_eq!(random.len(), 20);
        let tris = random.iter().filter(|p| p.vertices.len() == 3).count();
        assert_eq!(tris, 10);
        for p in random {
            assert!(p
                .vertices
                .iter()
                .all(|v| v.cmpge(DVec3::splat(0.02)).all() && v.cmple(DVec3::splat(0.98)).all()));
            let d = p.diameter();
            assert!((0.02..0.45).contains(&d), "{d}");
        }
        assert_eq!(s.patches[1].emission, Spectrum::Grey(1.0));
        for seed in [DEFAULT_SEED, 2, 3] {
            let s = generate(Kind::Scene1, seed);
            let r = &s.patches[6..];
            for i in 0..r.len() {
                for j in i + 1..r.len() {
                    assert!(separated(&r[i].vertices, &r[j].vertices, 0.0199));
                }
            }
        }
    }

    #[test]
    fn gen_scene2_source_is_clear_and_lit() {
        let s = generate(Kind::Scene2, DEFAULT_SEED);
        assert_eq!(s.patches.len(), 808);
        let src = &s.patches[0];
        let (lo, hi) = (DVec3::new(0.4, 0.4, 0.0), DVec3::new(0.5, 0.5, 0.0));
        assert!(src
            .vertices
            .iter()
            .all(|v| v.cmpge(lo).all() && v.cmple(hi).all()));
        // Nothing above the source tile but the ceiling.
        for p in &s.patches[1..] {
            let c = p.centroid();
            let b_lo = p.vertices.iter().fold(DVec3::ONE, |m, v| m.min(*v));
            let b_hi = p.vertices.iter().fold(DVec3::ZERO, |m, v| m.max(*v));
            let overlaps = b_lo.x < 0.5 && b_hi.x > 0.4 && b_lo.y < 0.5 && b_hi.y > 0.4;
            assert!(!overlaps || b_lo.z == 1.0 || b_hi.z == 0.0, "{c}");
        }
        let lights = s.patches.iter().filter(|p| p.emission.is_nonzero()).count();
        assert_eq!(lights, 4);
    }

    #[test]
    fn gen_stress_edges_fans_and_cell_boundaries() {
        let s = generate(Kind::StressEdges, DEFAULT_SEED);
        // Neighbours of each vertex (distinct edge ends).
        let key = |v: DVec3| v.to_array().map(f64::to_bits);
        let mut nb: HashMap<[u64; 3], std::collections::HashSet<[u64; 3]>> = HashMap::new();
        for p in &s.patches {
            let v = &p.vertices;
            for i in 0..v.len() {
                let (a, b) = (key(v[i]), key(v[(i + 1) % v.len()]));
                nb.entry(a).or_default().insert(b);
                nb.entry(b).or_default().insert(a);
            }
        }
        let valence =
            |x: usize, y: usize| nb[&key(DVec3::new(grid(x, 20), grid(y, 20), 0.75))].len();
        assert_eq!(valence(10, 10), 8);
        assert_eq!(valence(12, 12), 8);
        assert_eq!(valence(8, 10), 6);
        assert_eq!(valence(10, 8), 7);
        // Every vertex above the floor and below the ceiling (heightfield, plane) lies on a
        // vertical cell edge: x and y are k/20.
        let on_grid = |c: f64| (c * 20.0).round() / 20.0 == c;
        for p in &s.patches {
            for v in &p.vertices {
                assert!(on_grid(v.x) && on_grid(v.y), "{v}");
            }
        }
        // The heightfield (the triangles below the plane) spans [0.3, 0.6] and the plane is
        // exactly 15/20.
        let hf: Vec<f64> = s
            .patches
            .iter()
            .filter(|p| p.vertices.len() == 3 && p.vertices[0].z < 0.7)
            .flat_map(|p| p.vertices.iter().map(|v| v.z))
            .collect();
        assert_eq!(hf.len(), 3 * 480);
        assert!(hf.iter().all(|&z| (0.3..=0.6).contains(&z)));
        assert!(s
            .patches
            .iter()
            .any(|p| p.vertices.iter().all(|v| v.z == 15.0 / 20.0)));
    }

    #[test]
    fn gen_stress_grazing_has_grazing_patches() {
        let s = generate(Kind::StressGrazing, DEFAULT_SEED);
        let src = s.patches[0].centroid();
        // Fins: vertical-ish patches whose plane passes within 1e-2 rad of S, as seen from
        // their centre.
        let grazing = s.patches[1..]
            .iter()
            .filter(|p| {
                let d = (p.centroid() - src).normalize();
                p.normal().dot(d).abs() < 1.1e-2
            })
            .count();
        assert!(grazing >= 32, "{grazing}");
        let slats = s
            .patches
            .iter()
            .filter(|p| p.vertices.iter().all(|v| v.z >= 0.01 && v.z <= 0.1))
            .count();
        assert_eq!(slats, 37);
    }

    #[test]
    fn gen_stress_skewed_is_in_a_narrow_cone() {
        let s = generate(Kind::StressSkewed, DEFAULT_SEED);
        let src = s.patches[0].centroid();
        let axis = (DVec3::splat(0.88) - src).normalize();
        let cos10 = 10f64.to_radians().cos();
        let inside = s
            .patches
            .iter()
            .filter(|p| (p.centroid() - src).normalize().dot(axis) > cos10)
            .count();
        assert!(inside * 10 >= s.patches.len() * 9, "{inside}");
    }

    /// The committed `scenes/<kind>.json` is `generate(kind, DEFAULT_SEED)`. To rewrite them
    /// on purpose: `UPDATE_SCENES=1 cargo test --release --lib gen_committed`.
    #[test]
    fn gen_committed_scene_files_match() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
        let update = std::env::var_os("UPDATE_SCENES").is_some();
        for (kind, s) in scenes() {
            let path = dir.join(kind.file_name());
            if update {
                std::fs::create_dir_all(&dir).unwrap();
                s.save_json(&path).unwrap();
            }
            let loaded = Scene::load_json(&path).unwrap_or_else(|e| {
                panic!(
                    "{e}\nrewrite with: UPDATE_SCENES=1 cargo test --release --lib gen_committed"
                )
            });
            assert!(
                loaded == s,
                "{} differs from generate({}, {DEFAULT_SEED}); rewrite with: \
                 UPDATE_SCENES=1 cargo test --release --lib gen_committed",
                path.display(),
                kind.name()
            );
        }
    }
}
