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
//!
//! [`corpus`] holds closed scenes the model was not tuned for (subdivided boxes, the
//! Cornell room subdivided and in millimetres, a jittered hexahedron, convex hulls of
//! random points, a room on cell boundaries): conforming meshes facing inward, built by
//! their own functions rather than as [`Kind`]s.

mod cornell;
pub mod corpus;
mod paper;
mod stress;

use crate::scene::model::{Aabb, Patch, Scene, Spectrum};
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
        Kind::Scene1 => paper::scene1(&mut rng),
        Kind::Scene2 => paper::scene2(),
        Kind::Cornell => cornell::cornell(),
        Kind::StressEdges => stress::stress_edges(&mut rng),
        Kind::StressGrazing => stress::stress_grazing(&mut rng),
        Kind::StressSkewed => stress::stress_skewed(&mut rng),
        Kind::StressDense => stress::stress_dense(&mut rng),
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

#[cfg(test)]
mod tests {
    use super::cornell::{cornell_point, CB, CORNELL_GREEN, CORNELL_MM, CORNELL_RED};
    use super::paper::separated;
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
