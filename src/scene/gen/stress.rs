//! The stress scenes: shared edges and vertices on cell boundaries (`stress-edges`),
//! grazing rays (`stress-grazing`), and lattices of small random patches (`stress-skewed`,
//! `stress-dense`).

use super::*;

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
pub(super) fn stress_edges(rng: &mut Pcg64) -> Vec<Patch> {
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
pub(super) fn stress_grazing(rng: &mut Pcg64) -> Vec<Patch> {
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
pub(super) fn stress_skewed(rng: &mut Pcg64) -> Vec<Patch> {
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
pub(super) fn stress_dense(rng: &mut Pcg64) -> Vec<Patch> {
    let mut p = enclosure(10, (4, 4), |face, _, _| match face {
        Face::Ceiling => (1.0, 0.5),
        _ => (0.0, 0.5),
    });
    p.extend(lattice(rng, 0.04, 0.96, 27, None, 0.5));
    p
}
