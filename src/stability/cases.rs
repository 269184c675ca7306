//! The adversarial cases of `shellsim stability`, each a seeded generator: a scene in the
//! unit cube, a source patch (excluded, as the machine excludes it), rays, and per ray what
//! the analytic construction knows of the answer ([`Expect`]).
//!
//! Rays are built so that the construction's answer is exact: a ray aimed at a point of a
//! shared edge crosses the tiled surface there, so it must hit one of the patches around
//! that point (watertightness); a ray aimed well inside a patch with nothing in front hits
//! it; a ray in the plane `y = k/20` through an edge along x passes exactly through it in
//! f64 (the zero component is exact). Only `+ - * /` and `sqrt` are used (no `sin`/`cos`).

use crate::reference::rays::{hemisphere_rays, Directions, Origins};
use crate::reference::tracer::Ray;
use crate::scene::gen::{generate, unit_cube, Kind, DEFAULT_SEED};
use crate::scene::{Aabb, Patch, Scene};
use glam::DVec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

/// What the construction knows of one ray's nearest hit.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Expect {
    /// The exact answer (`Some(None)`: a miss), when the construction gives one.
    pub exact: Option<Option<u32>>,
    /// Without an exact answer: the patches around the point the ray meets first (sharing
    /// the edge or vertex it passes through), any one of which is right. Empty: the float
    /// reference is the answer.
    pub around: Vec<u32>,
    /// The patch ids of a watertight surface the ray crosses exactly once (a tiled plane, a
    /// closed room seen from inside): hitting none of them is a leak, two a double hit.
    pub surface: std::ops::Range<u32>,
}

impl Expect {
    fn exact(id: u32, surface: std::ops::Range<u32>) -> Expect {
        Expect {
            exact: Some(Some(id)),
            around: Vec::new(),
            surface,
        }
    }

    fn around(around: Vec<u32>, surface: std::ops::Range<u32>) -> Expect {
        Expect {
            exact: None,
            around,
            surface,
        }
    }
}

/// One case: its scene, source, rays and what is known of their answers.
#[derive(Clone, Debug)]
pub struct Case {
    pub name: &'static str,
    /// What the case does to the models, one sentence.
    pub about: &'static str,
    /// Why a model does or does not fail on it, one sentence (for docs/stability.md).
    pub why: &'static str,
    pub scene: Scene,
    pub source: u32,
    pub rays: Vec<Ray>,
    pub expect: Vec<Expect>,
}

/// A case generator: `n` rays from `seed`.
type Generator = fn(usize, u64) -> Case;

/// Every case, by name, in report order.
pub const CASES: &[(&str, Generator)] = &[
    ("shared-edge", shared_edge),
    ("shared-vertex", shared_vertex),
    ("cell-boundary", cell_boundary),
    ("axis-directions", axis_directions),
    ("grazing", grazing),
    ("near-origin", near_origin),
    ("coplanar-overlap", coplanar_overlap),
    ("coplanar-source", coplanar_source),
    ("tiny-patches", tiny_patches),
    ("whole-scene-patches", whole_scene_patches),
    ("slivers", slivers),
    ("cell-corner", cell_corner),
    ("format-limits", format_limits),
    ("stress-edges", |n, s| committed(Kind::StressEdges, n, s)),
    ("stress-grazing", |n, s| {
        committed(Kind::StressGrazing, n, s)
    }),
    ("stress-skewed", |n, s| committed(Kind::StressSkewed, n, s)),
    ("stress-dense", |n, s| committed(Kind::StressDense, n, s)),
];

/// The case `name` with `n` rays from `seed`; `None` for an unknown name.
pub fn generate_case(name: &str, n: usize, seed: u64) -> Option<Case> {
    let (i, (_, g)) = CASES.iter().enumerate().find(|(_, (c, _))| *c == name)?;
    // Each case its own stream: adding a case changes no other.
    Some(g(
        n,
        seed.wrapping_mul(0x9e37_79b9_7f4a_7c15)
            .wrapping_add(i as u64),
    ))
}

fn v3(x: f64, y: f64, z: f64) -> DVec3 {
    DVec3::new(x, y, z)
}

/// A small upward quad of half-width `h` in the middle of the room (a source out of the way).
fn centre_patch(h: f64) -> Patch {
    let (a, b) = (0.5 - h, 0.5 + h);
    Patch::new(
        vec![v3(a, a, 0.5), v3(b, a, 0.5), v3(b, b, 0.5), v3(a, b, 0.5)],
        0.0,
        0.5,
    )
}

fn scene(name: &str, patches: Vec<Patch>) -> Scene {
    Scene {
        name: name.into(),
        bounds: Aabb {
            lo: DVec3::ZERO,
            hi: DVec3::ONE,
        },
        patches,
    }
}

/// A point of the triangle `t` at barycentric weights at least `m` (well inside).
fn inside(rng: &mut Pcg64, t: &[DVec3], m: f64) -> DVec3 {
    let a = rng.gen_range(m..1.0 - 2.0 * m);
    let b = rng.gen_range(m..1.0 - a - m);
    t[0] * a + t[1] * b + t[2] * (1.0 - a - b)
}

/// A ray from a random point of the box `lo..hi` to `target`, with |d_z|/|d| ≥ 0.2.
fn aimed(rng: &mut Pcg64, lo: DVec3, hi: DVec3, target: DVec3) -> Ray {
    loop {
        let o = v3(
            rng.gen_range(lo.x..hi.x),
            rng.gen_range(lo.y..hi.y),
            rng.gen_range(lo.z..hi.z),
        );
        let d = target - o;
        if d.z.abs() >= 0.2 * d.length() {
            return Ray { o, d };
        }
    }
}

/// A tiled plane at z = `z` facing down: an m×m grid of quads over [0.1, 0.9]², each split
/// along alternating diagonals; interior vertices moved by up to `jitter` of a quad in x
/// and y. Returns the triangles, the interior edges with the two triangles on them, and the
/// interior vertices with the triangles around them.
struct Surface {
    tris: Vec<[DVec3; 3]>,
    /// The triangles' patch ids.
    ids: std::ops::Range<u32>,
    edges: Vec<(DVec3, DVec3, [u32; 2])>,
    verts: Vec<(DVec3, Vec<u32>)>,
}

fn surface(rng: &mut Pcg64, m: usize, z: f64, jitter: f64, first_id: u32, exact: bool) -> Surface {
    let h = 0.8 / m as f64;
    let idx = |i: usize, j: usize| i + (m + 1) * j;
    let mut pts = Vec::new();
    for j in 0..=m {
        for i in 0..=m {
            let (mut x, mut y) = if exact {
                // k/20 exactly (m = 16 gives 2/20..18/20): cell boundaries.
                ((i + 2) as f64 / 20.0, (j + 2) as f64 / 20.0)
            } else {
                (0.1 + h * i as f64, 0.1 + h * j as f64)
            };
            if i > 0 && i < m && j > 0 && j < m && jitter > 0.0 {
                x += rng.gen_range(-jitter..jitter) * h;
                y += rng.gen_range(-jitter..jitter) * h;
            }
            pts.push(v3(x, y, z));
        }
    }
    let mut tris = Vec::new();
    // (vertex a, vertex b) sorted → triangles on it; vertex → triangles.
    let mut edge_map: std::collections::BTreeMap<(usize, usize), Vec<u32>> = Default::default();
    let mut vert_map: Vec<Vec<u32>> = vec![Vec::new(); pts.len()];
    for j in 0..m {
        for i in 0..m {
            let (a, b, c, d) = (idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1));
            let pair = if (i + j) % 2 == 0 {
                [[a, b, c], [a, c, d]]
            } else {
                [[a, b, d], [b, c, d]]
            };
            for t in pair {
                let id = first_id + tris.len() as u32;
                for k in 0..3 {
                    let (u, v) = (t[k], t[(k + 1) % 3]);
                    edge_map.entry((u.min(v), u.max(v))).or_default().push(id);
                    vert_map[t[k]].push(id);
                }
                // Counter-clockwise from above, reversed to face down.
                tris.push([pts[t[0]], pts[t[2]], pts[t[1]]]);
            }
        }
    }
    let edges = edge_map
        .into_iter()
        .filter(|(_, t)| t.len() == 2)
        .map(|((u, v), t)| (pts[u], pts[v], [t[0], t[1]]))
        .collect();
    let verts = (0..pts.len())
        .filter(|&k| {
            let (i, j) = (k % (m + 1), k / (m + 1));
            i > 0 && i < m && j > 0 && j < m
        })
        .map(|k| (pts[k], vert_map[k].clone()))
        .collect();
    let ids = first_id..first_id + tris.len() as u32;
    Surface {
        tris,
        ids,
        edges,
        verts,
    }
}

fn tri_patches(s: &Surface) -> Vec<Patch> {
    s.tris
        .iter()
        .map(|t| Patch::new(t.to_vec(), 0.0, 0.5))
        .collect()
}

/// The unit cube (patches 0..6) and a jittered tiled plane at z = 0.5 from patch 6.
fn cube_and_surface(rng: &mut Pcg64, name: &str, exact: bool) -> (Scene, Surface) {
    let mut cube = unit_cube();
    let s = if exact {
        surface(rng, 16, 0.5, 0.0, 6, true)
    } else {
        surface(rng, 8, 0.5, 0.3, 6, false)
    };
    cube.patches.extend(tri_patches(&s));
    cube.name = name.into();
    (cube, s)
}

/// A point of the tiled plane at least 0.03 inside its outline [0.1, 0.9]².
fn interior(p: DVec3) -> bool {
    (0.13..=0.87).contains(&p.x) && (0.13..=0.87).contains(&p.y)
}

const BELOW_LO: DVec3 = DVec3::new(0.15, 0.15, 0.05);
const BELOW_HI: DVec3 = DVec3::new(0.85, 0.85, 0.4);

fn shared_edge(n: usize, seed: u64) -> Case {
    let mut rng = Pcg64::seed_from_u64(seed);
    let (scene, s) = cube_and_surface(&mut rng, "shared-edge", false);
    let (mut rays, mut expect) = (Vec::new(), Vec::new());
    while rays.len() < n {
        let (a, b, t) = s.edges[rng.gen_range(0..s.edges.len())];
        let target = a + (b - a) * rng.gen_range(0.05..0.95);
        // Away from the surface's outline, which a ray quantized at few bits may pass.
        if !interior(target) {
            continue;
        }
        rays.push(aimed(&mut rng, BELOW_LO, BELOW_HI, target));
        expect.push(Expect::around(t.to_vec(), s.ids.clone()));
    }
    Case {
        name: "shared-edge",
        about: "rays through points of the shared edges of a jittered triangulated plane",
        why: "both tests are watertight (an edge has one edge function in both patches, its exact zeros go to one side by the top-left rule), so nothing leaks at any width; at few bits a ray strays an LSB onto the next triangle near a vertex (classed near an edge)",
        scene,
        source: 0,
        rays,
        expect,
    }
}

fn shared_vertex(n: usize, seed: u64) -> Case {
    let mut rng = Pcg64::seed_from_u64(seed);
    let (scene, s) = cube_and_surface(&mut rng, "shared-vertex", false);
    let (mut rays, mut expect) = (Vec::new(), Vec::new());
    for _ in 0..n {
        let (p, t) = &s.verts[rng.gen_range(0..s.verts.len())];
        rays.push(aimed(&mut rng, BELOW_LO, BELOW_HI, *p));
        expect.push(Expect::around(t.clone(), s.ids.clone()));
    }
    Case {
        name: "shared-vertex",
        about: "rays through the shared vertices (valence 4 to 8) of a jittered triangulated plane",
        why: "watertight as for edges: every patch around a vertex evaluates the same edge functions there",
        scene,
        source: 0,
        rays,
        expect,
    }
}

fn cell_boundary(n: usize, seed: u64) -> Case {
    let mut rng = Pcg64::seed_from_u64(seed);
    let (scene, s) = cube_and_surface(&mut rng, "cell-boundary", true);
    let x_edges: Vec<_> = s.edges.iter().filter(|(a, b, _)| a.y == b.y).collect();
    let (mut rays, mut expect) = (Vec::new(), Vec::new());
    while rays.len() < n {
        let k = rays.len();
        let (ray, surface) = match k % 3 {
            // In the plane y = k/20 through an edge along x: exactly through it.
            0 => {
                let (a, b, t) = x_edges[rng.gen_range(0..x_edges.len())];
                let target = a + (b - a) * rng.gen_range(0.05..0.95);
                let o = v3(
                    rng.gen_range(0.15..0.85),
                    a.y,
                    rng.gen_range(BELOW_LO.z..BELOW_HI.z),
                );
                (Ray { o, d: target - o }, t.to_vec())
            }
            1 => {
                let (a, b, t) = s.edges[rng.gen_range(0..s.edges.len())];
                let target = a + (b - a) * rng.gen_range(0.05..0.95);
                (aimed(&mut rng, BELOW_LO, BELOW_HI, target), t.to_vec())
            }
            _ => {
                let (p, t) = &s.verts[rng.gen_range(0..s.verts.len())];
                (aimed(&mut rng, BELOW_LO, BELOW_HI, *p), t.clone())
            }
        };
        // Away from the surface's outline, which a ray quantized at few bits may pass.
        if !interior(ray.o + ray.d) {
            continue;
        }
        rays.push(ray);
        expect.push(Expect::around(surface, s.ids.clone()));
    }
    Case {
        name: "cell-boundary",
        about: "a union-jack triangulation on the cell-boundary plane z = 10/20 with every vertex at k/20: rays through its edges (a third exactly, in the plane y = k/20) and vertices, hits exactly on cell faces",
        why: "the DDAs' stopping rules (the next cell starts beyond the best hit plus a slack) never drop a hit that lies on a cell face, and nothing leaks; at few bits a ray strays onto the next triangle (classed near an edge)",
        scene,
        source: 0,
        rays,
        expect,
    }
}

/// The unit cube's walls as `t`×`t` inward tiles; the tile of wall `w` (0 floor, 1 ceiling,
/// 2 x = 0, 3 x = 1, 4 y = 0, 5 y = 1) at (i, j) is patch `(w·t + j)·t + i`.
fn tiled_cube(t: usize) -> Vec<Patch> {
    let cube = unit_cube();
    let mut out = Vec::new();
    for wall in &cube.patches {
        let v = &wall.vertices;
        let (o, u, w) = (v[0], v[1] - v[0], v[3] - v[0]);
        for j in 0..t {
            for i in 0..t {
                let at =
                    |a: usize, b: usize| o + u * (a as f64 / t as f64) + w * (b as f64 / t as f64);
                out.push(Patch::new(
                    vec![at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)],
                    0.0,
                    0.5,
                ));
            }
        }
    }
    out
}

/// Per wall of [`tiled_cube`], the axes of its tiles' i and j.
const WALL_AXES: [(usize, usize); 6] = [(0, 1), (1, 0), (1, 2), (2, 1), (2, 0), (0, 2)];

/// The tiles of [`tiled_cube`]`(t)` (ids from 1) whose closed squares hold the point `p`
/// of the cube's surface, in units of 1/`u` (`u` a multiple of `t`).
fn tiles_at(p: [i64; 3], t: i64, u: i64) -> Vec<u32> {
    let side = u / t;
    let span = |x: i64| -> Vec<i64> {
        let mut v = vec![x / side];
        if x % side == 0 {
            v.insert(0, x / side - 1);
        }
        v.retain(|&k| (0..t).contains(&k));
        v
    };
    let mut out = Vec::new();
    // (axis, at the high side) → wall.
    for (wall, (axis, high)) in [
        (2, false),
        (2, true),
        (0, false),
        (0, true),
        (1, false),
        (1, true),
    ]
    .into_iter()
    .enumerate()
    {
        if p[axis] != if high { u } else { 0 } {
            continue;
        }
        let (ua, wa) = WALL_AXES[wall];
        for j in span(p[wa]) {
            for i in span(p[ua]) {
                out.push(1 + ((wall as i64 * t + j) * t + i) as u32);
            }
        }
    }
    out
}

fn axis_directions(n: usize, seed: u64) -> Case {
    let mut rng = Pcg64::seed_from_u64(seed);
    // A small source patch in the room's middle, out of every ray's way.
    let mut patches = vec![centre_patch(0.01)];
    patches.extend(tiled_cube(4));
    let eps = [
        0.0,
        0.0,
        (-30f64).exp2(),
        (-24f64).exp2(),
        (-16f64).exp2(),
        (-12f64).exp2(),
        (-8f64).exp2(),
    ];
    let (mut rays, mut expect) = (Vec::new(), Vec::new());
    while rays.len() < n {
        let axis = rng.gen_range(0..3usize);
        let up = rng.gen_bool(0.5);
        let mut d = [0.0f64; 3];
        d[axis] = if up { 1.0 } else { -1.0 };
        let mut o = [0.0f64; 3];
        for a in 0..3 {
            if a == axis {
                o[a] = rng.gen_range(0.1..0.9);
                continue;
            }
            let e = eps[rng.gen_range(0..eps.len())];
            d[a] = if rng.gen_bool(0.5) { e } else { -e };
            // Off tile edges (k/4) by ≥ 0.05; exactly on a cell boundary k/20 when the
            // component is zero.
            let k = loop {
                let k = rng.gen_range(1..20usize);
                if k % 5 != 0 {
                    break k;
                }
            };
            o[a] = if e == 0.0 {
                k as f64 / 20.0
            } else {
                k as f64 / 20.0 + rng.gen_range(-0.02..0.02)
            };
        }
        let o = DVec3::from_array(o);
        let d = DVec3::from_array(d);
        let ray = Ray { o, d };
        // The wall it reaches and the tile, analytically (the drift ≤ 2^-8 stays in it).
        let wall = 2 * axis + usize::from(up);
        let wall = [2, 3, 4, 5, 0, 1][wall];
        let t = if up { 1.0 - o[axis] } else { o[axis] } / d[axis].abs();
        let p = o + d * t;
        if (p - DVec3::splat(0.5)).abs().max_element() > 0.5 {
            continue;
        }
        let (ua, wa) = WALL_AXES[wall];
        let cell = |x: f64| ((x * 4.0) as usize).min(3);
        let (i, j) = (cell(p[ua]), cell(p[wa]));
        let id = 1 + ((wall * 4 + j) * 4 + i) as u32;
        rays.push(ray);
        expect.push(Expect::exact(id, 1..97));
    }
    Case {
        name: "axis-directions",
        about: "direction components exactly 0 and ±2^-30, ±2^-24, ±2^-16, ±2^-12 (1 LSB at the default), ±2^-8 towards a tiled wall, origins on cell boundaries where a component is 0",
        why: "a zero component is the DDA's never-crossing axis (exact in both), and a tiny one only moves the hit within its tile",
        scene: scene("axis-directions", patches),
        source: 0,
        rays,
        expect,
    }
}

/// A downward-facing quad at z = `z` over `[a, b]²` (counter-clockwise seen from below).
fn quad_down(a: f64, b: f64, z: f64) -> Patch {
    Patch::new(
        vec![v3(a, a, z), v3(a, b, z), v3(b, b, z), v3(b, a, z)],
        0.0,
        0.5,
    )
}

/// A unit horizontal vector from a random point of the unit disk's ring.
fn horizontal(rng: &mut Pcg64) -> DVec3 {
    loop {
        let (x, y) = (rng.gen_range(-1.0..1.0f64), rng.gen_range(-1.0..1.0f64));
        let l = (x * x + y * y).sqrt();
        if (0.2..=1.0).contains(&l) {
            return v3(x / l, y / l, 0.0);
        }
    }
}

fn grazing(n: usize, seed: u64) -> Case {
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut s = unit_cube();
    s.name = "grazing".into();
    s.patches.push(quad_down(0.05, 0.95, 0.5));
    let cosines = [
        1e-1,
        3e-2,
        1e-2,
        3e-3,
        1e-3,
        (-12f64).exp2() * 2.0,
        (-12f64).exp2(),
    ];
    let (mut rays, mut expect) = (Vec::new(), Vec::new());
    for k in 0..n {
        let c = cosines[k % cosines.len()];
        let h = horizontal(&mut rng);
        let d = h * (1.0 - c * c).sqrt() + DVec3::Z * c;
        let target = v3(rng.gen_range(0.35..0.65), rng.gen_range(0.35..0.65), 0.5);
        let o = target - d * rng.gen_range(0.05..0.25);
        rays.push(Ray { o, d });
        expect.push(Expect::exact(6, 0..0));
    }
    Case {
        name: "grazing",
        about: "rays meeting a large quad at |n·d| = 1e-1, 3e-2, 1e-2, 3e-3, 1e-3, 2 LSB and 1 LSB (2^-12), from origins within |n·d| × 0.25 of its plane",
        why: "a grazing ray's origin lies within an LSB of the plane, so its quantized origin may lie beyond it (classed grazing or near the origin)",
        scene: s,
        source: 0,
        rays,
        expect,
    }
}

fn near_origin(n: usize, seed: u64) -> Case {
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut s = unit_cube();
    s.name = "near-origin".into();
    let deltas = [1e-2, 1e-3, 1e-4, (-12f64).exp2(), 1e-5, 1e-6, 1e-8];
    let (mut rays, mut expect) = (Vec::new(), Vec::new());
    for k in 0..n {
        // From the floor (the source), δ short of the wall x = 1 (patch 3), to a point of the
        // wall within 3δ: |n·d| ≥ 0.23, the hit δ to 4δ away.
        let delta = deltas[k % deltas.len()];
        let o = v3(1.0 - delta, rng.gen_range(0.1..0.9), 0.0);
        let d = v3(
            delta,
            delta * rng.gen_range(-3.0..3.0),
            delta * rng.gen_range(0.01..3.0),
        );
        rays.push(Ray { o, d });
        expect.push(Expect::exact(3, 0..0));
    }
    Case {
        name: "near-origin",
        about: "rays leaving the floor 1e-2 down to 1e-8 from where it meets a wall, hitting the wall 1 to 4 times as far away, at |n·d| ≥ 0.23",
        why: "an origin rounded onto the floor's edge would lie on the wall's plane (the wall missed, or met a fraction of an LSB above their shared edge); the host starts a ray leaving its source an LSB inside the source and off its plane (`HostFixed::ray_from`), so it meets the wall at least an LSB above the edge at every width; δ = 1e-8 is below every LSB",
        scene: s,
        source: 0,
        rays,
        expect,
    }
}

/// z of the tilted plane of `coplanar-overlap` over (x, y).
fn tilted(x: f64, y: f64) -> f64 {
    0.5 + 0.05 * (x - 0.5) + 0.1 * (y - 0.5)
}

/// A ray from below to `target`, within 0.15 of vertical (its origin 0.1–0.3 under it).
fn from_below(rng: &mut Pcg64, target: DVec3) -> Ray {
    let d = v3(rng.gen_range(-0.15..0.15), rng.gen_range(-0.15..0.15), 1.0);
    Ray {
        o: target - d * rng.gen_range(0.1..0.3),
        d,
    }
}

fn coplanar_overlap(n: usize, seed: u64) -> Case {
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut s = unit_cube();
    s.name = "coplanar-overlap".into();
    // Tiles first (smaller ids, so the tie rule picks them), then the large quads under them:
    // 6 tile and 7 large quad at z = 0.4 (axis-aligned, x ≤ 0.45); 8 tile and 9 large quad
    // on a tilted plane (x ≥ 0.55), each vertex's z computed from its own x and y.
    let quad_tilted = |a: f64, b: f64, c: f64, e: f64| {
        let q = |x: f64, y: f64| v3(x, y, tilted(x, y));
        Patch::new(vec![q(a, c), q(a, e), q(b, e), q(b, c)], 0.0, 0.5)
    };
    s.patches.push(quad_down(0.2, 0.35, 0.4));
    s.patches.push(quad_down(0.1, 0.45, 0.4));
    s.patches.push(quad_tilted(0.62, 0.82, 0.3, 0.7));
    s.patches.push(quad_tilted(0.55, 0.9, 0.2, 0.8));
    let (mut rays, mut expect) = (Vec::new(), Vec::new());
    for k in 0..n {
        let (target, id) = if k % 2 == 0 {
            let p = v3(rng.gen_range(0.12..0.43), rng.gen_range(0.12..0.43), 0.4);
            let on_tile = (0.2..=0.35).contains(&p.x) && (0.2..=0.35).contains(&p.y);
            (p, if on_tile { 6 } else { 7 })
        } else {
            let (x, y) = (rng.gen_range(0.57..0.88), rng.gen_range(0.22..0.78));
            let on_tile = (0.62..=0.82).contains(&x) && (0.3..=0.7).contains(&y);
            (v3(x, y, tilted(x, y)), if on_tile { 8 } else { 9 })
        };
        rays.push(from_below(&mut rng, target));
        expect.push(Expect::exact(id, 0..0));
    }
    Case {
        name: "coplanar-overlap",
        about: "tiles lying on larger coplanar quads (one pair axis-aligned, one on a tilted plane): equal t, the tie rule (smaller id) decides",
        why: "the two patches' t differ by rounding only (the float plane offsets, the fixed interpolation), so the tie rule sees unequal t (classed tie)",
        scene: s,
        source: 0,
        rays,
        expect,
    }
}

fn coplanar_source(n: usize, seed: u64) -> Case {
    let mut s = unit_cube();
    s.name = "coplanar-source".into();
    // The source: a tile lying on the floor (patch 0), facing up like it.
    s.patches.push(Patch::new(
        vec![
            v3(0.4, 0.4, 0.0),
            v3(0.6, 0.4, 0.0),
            v3(0.6, 0.6, 0.0),
            v3(0.4, 0.6, 0.0),
        ],
        0.0,
        0.5,
    ));
    let set = hemisphere_rays(&s.patches[6], n, Directions::Malley, Origins::Patch, seed);
    let expect = vec![Expect::default(); set.rays.len()];
    Case {
        name: "coplanar-source",
        about: "the source is a tile lying on the floor (coplanar and overlapping): every ray leaves the floor's plane at t = 0",
        why: "the float test meets the floor's plane at exactly t = 0 (no hit); the host starts the tile's rays an LSB off its plane (`HostFixed::ray_from`), so the floor lies behind them in fixed point too, except at so few bits that the floor's rounded plane rises above that LSB (classed coplanar with the source, warned about by name)",
        scene: s,
        source: 6,
        rays: set.rays,
        expect,
    }
}

fn tiny_patches(n: usize, seed: u64) -> Case {
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut s = unit_cube();
    s.name = "tiny-patches".into();
    // 64 squares of 1..=4 LSB of the default format (2^-12), on dyadic corners at z = 0.5,
    // each with its centre's id.
    let lsb = (-12f64).exp2();
    let mut centres = Vec::new();
    for j in 0..8 {
        for i in 0..8 {
            let size = ((i + j) % 4 + 1) as f64 * lsb;
            let (x, y) = (0.25 + i as f64 / 16.0, 0.25 + j as f64 / 16.0);
            centres.push((
                v3(x + size / 2.0, y + size / 2.0, 0.5),
                s.patches.len() as u32,
            ));
            s.patches.push(Patch::new(
                vec![
                    v3(x, y, 0.5),
                    v3(x, y + size, 0.5),
                    v3(x + size, y + size, 0.5),
                    v3(x + size, y, 0.5),
                ],
                0.0,
                0.5,
            ));
        }
    }
    let (mut rays, mut expect) = (Vec::new(), Vec::new());
    for _ in 0..n {
        let (c, id) = centres[rng.gen_range(0..centres.len())];
        rays.push(aimed(&mut rng, BELOW_LO, BELOW_HI, c));
        expect.push(Expect::exact(id, 0..0));
    }
    Case {
        name: "tiny-patches",
        about: "squares of 1 to 4 LSB (2^-12) on dyadic corners, rays at their centres",
        why: "a ray quantized to the LSB strays about an LSB per unit of t, enough to miss a 1-LSB patch (classed near an edge); at fewer bits the squares collapse",
        scene: s,
        source: 0,
        rays,
        expect,
    }
}

fn whole_scene_patches(n: usize, seed: u64) -> Case {
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut s = unit_cube();
    s.name = "whole-scene-patches".into();
    // A quad across the whole room at z = 0.5 facing up, and the diagonal plane x = y from
    // floor to ceiling, both spanning the scene wall to wall.
    s.patches.push(Patch::new(
        vec![
            v3(0.0, 0.0, 0.5),
            v3(1.0, 0.0, 0.5),
            v3(1.0, 1.0, 0.5),
            v3(0.0, 1.0, 0.5),
        ],
        0.0,
        0.5,
    ));
    s.patches.push(Patch::new(
        vec![
            v3(0.0, 0.0, 0.0),
            v3(1.0, 1.0, 0.0),
            v3(1.0, 1.0, 1.0),
            v3(0.0, 0.0, 1.0),
        ],
        0.0,
        0.5,
    ));
    let (mut rays, mut expect) = (Vec::new(), Vec::new());
    for _ in 0..n {
        let o = v3(
            rng.gen_range(0.02..0.98),
            rng.gen_range(0.02..0.98),
            rng.gen_range(0.02..0.98),
        );
        let d = loop {
            let d = v3(
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
            );
            if d.length() > 0.1 {
                break d;
            }
        };
        rays.push(Ray { o, d });
        expect.push(Expect::around(Vec::new(), 0..6));
    }
    Case {
        name: "whole-scene-patches",
        about: "two patches spanning the whole scene (a floor-to-ceiling diagonal and a wall-to-wall quad), listed in a third of the cells; random rays",
        why: "a patch listed in hundreds of cells is tested once per cell by the machine and once in all by the float tracer's mailbox, and both see the same nearest hit; at few bits a ray near where the two planes or a wall cross may take the other (classed near an edge or the origin)",
        scene: s,
        source: 0,
        rays,
        expect,
    }
}

fn slivers(n: usize, seed: u64) -> Case {
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut s = unit_cube();
    s.name = "slivers".into();
    // A strip of 16 rows, each two triangles 0.8 long and 8e-5 high (aspect 1e4), between two
    // quads it shares its long edges with: one watertight surface at z = 0.5, facing down.
    let h = 8e-5;
    let rows = 16;
    let y = |k: usize| 0.5 + h * k as f64;
    let first = s.patches.len() as u32;
    let mut tris = Vec::new();
    for k in 0..rows {
        let (a, b, c, d) = (
            v3(0.1, y(k), 0.5),
            v3(0.9, y(k), 0.5),
            v3(0.9, y(k + 1), 0.5),
            v3(0.1, y(k + 1), 0.5),
        );
        for t in [[a, b, c], [a, c, d]] {
            tris.push(t);
            s.patches.push(Patch::new(vec![t[0], t[2], t[1]], 0.0, 0.5));
        }
    }
    let quad = |y0: f64, y1: f64| {
        Patch::new(
            vec![
                v3(0.1, y0, 0.5),
                v3(0.1, y1, 0.5),
                v3(0.9, y1, 0.5),
                v3(0.9, y0, 0.5),
            ],
            0.0,
            0.5,
        )
    };
    s.patches.push(quad(0.1, y(0)));
    s.patches.push(quad(y(rows), 0.9));
    let surface = first..s.patches.len() as u32;
    let (mut rays, mut expect) = (Vec::new(), Vec::new());
    for _ in 0..n {
        let k = rng.gen_range(0..tris.len());
        let target = inside(&mut rng, &tris[k], 0.2);
        rays.push(aimed(&mut rng, BELOW_LO, BELOW_HI, target));
        expect.push(Expect::exact(first + k as u32, surface.clone()));
    }
    Case {
        name: "slivers",
        about: "32 sliver triangles of aspect 1e4 (0.8 by 8e-5, a third of an LSB at 12 bits) in a watertight strip, rays well inside each",
        why: "a sliver thinner than an LSB collapses when quantized, its rays go to a neighbour (classed near an edge), never through the strip",
        scene: s,
        source: 0,
        rays,
        expect,
    }
}

fn cell_corner(n: usize, seed: u64) -> Case {
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut patches = vec![centre_patch(0.03)];
    patches.extend(tiled_cube(5));
    let sign = |rng: &mut Pcg64| if rng.gen_bool(0.5) { 1 } else { -1 };
    let (mut rays, mut expect) = (Vec::new(), Vec::new());
    for k in 0..n {
        // In units of 1/20: the origin and the direction's components in {-1, 0, 1}.
        let oi = [0; 3].map(|_| rng.gen_range(1..20i64));
        let mut di = [0; 3].map(|_| sign(&mut rng));
        match k % 4 {
            0 => {
                let a = rng.gen_range(0..3);
                di = [0, 1, 2].map(|b| if b == a { di[b] } else { 0 });
            }
            1 => {}
            2 => di[rng.gen_range(0..3)] = 0,
            _ => {}
        }
        let o = DVec3::from_array(oi.map(|x| x as f64 / 20.0));
        let (d, around) = if k % 4 == 3 {
            let d = v3(
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
            );
            (d, Vec::new())
        } else {
            // Where it meets the walls, exactly: the first wall along any moving axis.
            let t = (0..3)
                .filter(|&a| di[a] != 0)
                .map(|a| if di[a] > 0 { 20 - oi[a] } else { oi[a] })
                .min()
                .expect("a nonzero direction");
            let p = [0, 1, 2].map(|a| oi[a] + t * di[a]);
            (DVec3::from_array(di.map(|x| x as f64)), tiles_at(p, 5, 20))
        };
        rays.push(Ray { o, d });
        expect.push(Expect::around(around, 1..151));
    }
    Case {
        name: "cell-corner",
        about: "rays starting exactly on cell corners (k/20), along axes, face and space diagonals (through a cell corner at every step) and at random, into walls tiled on cell boundaries",
        why: "both DDAs break exact ties by the lowest axis and start in the cell the origin's coordinates name, so a walk through corners visits each cell once; a diagonal ray meeting a wall at a tile corner may take any tile there, all of which are right",
        scene: scene("cell-corner", patches),
        source: 0,
        rays,
        expect,
    }
}

fn format_limits(n: usize, seed: u64) -> Case {
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut s = unit_cube();
    s.name = "format-limits".into();
    // The source: a small patch in the middle (not a wall, whose corners the rays aim at).
    s.patches.push(centre_patch(0.01));
    let (mut rays, mut expect) = (Vec::new(), Vec::new());
    let corner = |rng: &mut Pcg64| {
        v3(
            rng.gen_range(0..2) as f64,
            rng.gen_range(0..2) as f64,
            rng.gen_range(0..2) as f64,
        )
    };
    for k in 0..n {
        let inner = v3(
            rng.gen_range(0.2..0.8),
            rng.gen_range(0.2..0.8),
            rng.gen_range(0.2..0.8),
        );
        let (ray, exp) = match k % 4 {
            // Beyond the coordinate format ([-2, 2) scene scales from the grid origin).
            0 => {
                let far = [3.0, 8.0, 1e3][rng.gen_range(0..3)];
                let mut o = inner;
                let a = rng.gen_range(0..3);
                o[a] += if rng.gen_bool(0.5) { far } else { -far };
                (Ray { o, d: inner - o }, Expect::default())
            }
            // On a corner of the grid (its far corner is the format's 1.0), across the room.
            1 => {
                let o = corner(&mut rng);
                (Ray { o, d: inner - o }, Expect::default())
            }
            // Half an LSB (2^-13) inside a wall: rounds onto it.
            2 => {
                let mut o = inner;
                let a = rng.gen_range(0..3);
                o[a] = if rng.gen_bool(0.5) {
                    (-13f64).exp2()
                } else {
                    1.0 - (-13f64).exp2()
                };
                (
                    Ray {
                        o,
                        d: DVec3::splat(0.5) - o,
                    },
                    Expect::default(),
                )
            }
            // Directions of extreme magnitude (the host normalizes them) at a corner of the
            // room, where three walls meet: any of them is right.
            _ => {
                let m = [1e-150, 1e150][rng.gen_range(0..2)];
                let c = corner(&mut rng);
                // unit_cube's walls: floor, ceiling, x = 0, x = 1, y = 0, y = 1.
                let planes = [(2, 0.0), (2, 1.0), (0, 0.0), (0, 1.0), (1, 0.0), (1, 1.0)];
                let walls = (0..6u32)
                    .filter(|&w| {
                        let (axis, at) = planes[w as usize];
                        c[axis] == at
                    })
                    .collect();
                (
                    Ray {
                        o: inner,
                        d: (c - inner) * m,
                    },
                    Expect::around(walls, 0..6),
                )
            }
        };
        rays.push(ray);
        expect.push(exp);
    }
    Case {
        name: "format-limits",
        about: "origins beyond the coordinate format's range (3 to 1000 scene scales away along an axis), on the grid's corners, half an LSB inside a wall; directions to a corner of the room scaled by 1e-150 and 1e150",
        why: "an origin the format cannot hold has no ray record: the host counts it as an overflow (classed overflow), never wraps it; an origin half an LSB in front of a wall rounds onto its plane and meets it at t = 0, which the datapath takes as a hit (classed near the origin)",
        scene: s,
        source: 6,
        rays,
        expect,
    }
}

/// A committed stress scene from its default source, Malley rays.
fn committed(kind: Kind, n: usize, seed: u64) -> Case {
    let s = generate(kind, DEFAULT_SEED);
    let src = kind.default_source() as u32;
    let set = hemisphere_rays(
        &s.patches[src as usize],
        n,
        Directions::Malley,
        Origins::Patch,
        seed,
    );
    let (name, about, why) = match kind {
        Kind::StressEdges => (
            "stress-edges",
            "scenes/stress-edges.json: a heightfield and fans of valence 6–8 with every vertex on a cell boundary",
            "no exact answer: the fixed point differs from the float reference only near shared edges and vertices",
        ),
        Kind::StressGrazing => (
            "stress-grazing",
            "scenes/stress-grazing.json: slats and fins nearly parallel to the source's rays",
            "rays nearly parallel to the slats and fins meet them near their edges (classed near an edge, some grazing or near the origin)",
        ),
        Kind::StressSkewed => (
            "stress-skewed",
            "scenes/stress-skewed.json: 1728 small patches in one narrow cone",
            "many small patches: differences near their edges",
        ),
        _ => (
            "stress-dense",
            "scenes/stress-dense.json: 20,283 patches, one per cell of a 27³ lattice",
            "dense small patches: differences near their edges",
        ),
    };
    let expect = vec![Expect::default(); set.rays.len()];
    Case {
        name,
        about,
        why,
        scene: s,
        source: src,
        rays: set.rays,
        expect,
    }
}
