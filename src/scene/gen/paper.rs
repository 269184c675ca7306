//! The paper's test scenes: scene 1 (six walls and 20 random patches) and scene 2 (a
//! furnished room of 808 quads).

use super::*;

/// The paper's test scene 1: the cube's walls as six single inward quads (floor first, the
/// ceiling emitting) and 20 random patches, quads and triangles alternately, of size about
/// 0.05–0.3 (bounding radius 0.035–0.21), at least 0.02 from the walls and from each other.
pub(super) fn scene1(rng: &mut Pcg64) -> Vec<Patch> {
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
pub(super) fn separated(a: &[DVec3], b: &[DVec3], gap: f64) -> bool {
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
pub(super) fn scene2() -> Vec<Patch> {
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
