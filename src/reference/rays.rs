//! Ray sets over a source patch's hemisphere: stratified origins on the patch, and direction
//! sets — the paper's equal-angle `rings`, Malley's stratified cosine-weighted set, and
//! plain random cosine-weighted rays — with the weights that make their sums form factors.

use crate::error::{Error, Result};
use crate::reference::tracer::Ray;
use crate::scene::{Patch, Scene};
use glam::DVec3;
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use std::f64::consts::{FRAC_PI_2, PI};
use std::path::Path;

/// How ray directions are chosen over the hemisphere.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Directions {
    /// The paper's equal-angle rings (Δθ = 90°/20 gives 969 rays), each ray weighted by the
    /// projected solid angle of its cell. Deterministic directions.
    Rings,
    /// Malley's method: a jittered grid on the unit disk lifted to the hemisphere; weight 1/N.
    Malley,
    /// Independent cosine-weighted directions; weight 1/N (binomial error).
    Random,
}

impl Directions {
    /// The set's name as the command line spells it (`rings`, `malley`, `random`).
    pub fn name(self) -> &'static str {
        match self {
            Directions::Rings => "rings",
            Directions::Malley => "malley",
            Directions::Random => "random",
        }
    }
}

/// Relative pull of origins towards the patch centroid, keeping them clear of the patch's
/// edges (so no origin lies on an edge shared with a neighbour).
pub const ORIGIN_CLEARANCE: f64 = 1e-6;

/// Rays with weights: `form factor to j = Σ weight over rays whose nearest hit is j`.
#[derive(Clone, Debug, PartialEq)]
pub struct RaySet {
    pub rays: Vec<Ray>,
    pub weights: Vec<f64>,
}

impl RaySet {
    pub fn len(&self) -> usize {
        self.rays.len()
    }
    pub fn is_empty(&self) -> bool {
        self.rays.is_empty()
    }
}

/// An orthonormal frame with `n` as its z axis.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    pub t: DVec3,
    pub b: DVec3,
    pub n: DVec3,
}

impl Frame {
    /// The frame of a patch: z along its front normal, x along its first edge.
    pub fn of_patch(p: &Patch) -> Frame {
        let n = p.normal();
        let e = p.vertices[1] - p.vertices[0];
        let t = (e - n * n.dot(e)).normalize();
        Frame {
            t,
            b: n.cross(t),
            n,
        }
    }
    /// A local direction (x, y, z) in world space.
    #[inline]
    pub fn to_world(&self, l: DVec3) -> DVec3 {
        self.t * l.x + self.b * l.y + self.n * l.z
    }
}

/// The rings layout for `n` rays: number of rings and azimuths per ring (index 0 = zenith).
/// `R = round(sqrt(n / 2.4225))` rings of Δθ = 90°/R with ⌊2π·sin θ_k / Δθ⌋ azimuths each
/// (969 rays for R = 20, the paper's set); other `n` are met exactly by adding azimuths to
/// the rings whose floor dropped the most, or removing them from those that dropped the least.
pub fn rings_layout(n: usize) -> (usize, Vec<usize>) {
    assert!(n >= 1, "at least one ray");
    let r = ((n as f64 / 2.4225).sqrt().round() as usize).max(1);
    let dtheta = FRAC_PI_2 / r as f64;
    let mut counts = vec![1usize];
    let mut frac = vec![0.0f64];
    for k in 1..r {
        let exact = 2.0 * PI * (k as f64 * dtheta).sin() / dtheta;
        counts.push(exact.floor() as usize);
        frac.push(exact - exact.floor());
    }
    let total: usize = counts.iter().sum();
    if total < n {
        // Rings in order of the largest fraction dropped; cycle until n.
        let mut order: Vec<usize> = (1..r).collect();
        order.sort_by(|&a, &b| frac[b].total_cmp(&frac[a]).then(a.cmp(&b)));
        if order.is_empty() {
            order.push(0);
        }
        for i in 0..n - total {
            counts[order[i % order.len()]] += 1;
        }
    } else if total > n {
        let mut order: Vec<usize> = (1..r).collect();
        order.sort_by(|&a, &b| frac[a].total_cmp(&frac[b]).then(b.cmp(&a)));
        let mut excess = total - n;
        let mut i = 0;
        while excess > 0 {
            let k = order[i % order.len()];
            if counts[k] > 1 {
                counts[k] -= 1;
                excess -= 1;
            }
            i += 1;
        }
    }
    (r, counts)
}

/// Local directions and weights of the rings set for `n` rays. Ring `k` sits at θ_k = kΔθ
/// and covers [θ_k − Δθ/2, θ_k + Δθ/2] (the zenith the cap [0, Δθ/2]; the last ring, at
/// 90° − Δθ, reaches the horizon);
/// each ray's weight is its cell's projected solid angle over π, so the weights sum to 1.
pub fn rings_local(n: usize) -> Vec<(DVec3, f64)> {
    let (r, counts) = rings_layout(n);
    let dtheta = FRAC_PI_2 / r as f64;
    let mut out = Vec::with_capacity(n);
    // Projected solid angle of the band [a, b] over π: sin²b − sin²a.
    let band = |a: f64, b: f64| b.sin().powi(2) - a.sin().powi(2);
    for (k, &m) in counts.iter().enumerate() {
        let theta = k as f64 * dtheta;
        let lo = (theta - 0.5 * dtheta).max(0.0);
        // The outermost ring also covers the last half step up to the horizon.
        let hi = if k + 1 == counts.len() {
            FRAC_PI_2
        } else {
            theta + 0.5 * dtheta
        };
        let w = band(lo, hi) / m as f64;
        for j in 0..m {
            let phi = 2.0 * PI * j as f64 / m as f64;
            let (st, ct) = theta.sin_cos();
            out.push((DVec3::new(st * phi.cos(), st * phi.sin(), ct), w));
        }
    }
    out
}

/// `n` points stratified over the unit square: ⌊√n⌉ rows, the columns spread so rows differ
/// by at most one, every cell of area exactly 1/n, one jittered point per cell.
pub fn stratified_square(n: usize, rng: &mut Pcg64) -> Vec<(f64, f64)> {
    let rows = ((n as f64).sqrt().round() as usize).clamp(1, n.max(1));
    let mut out = Vec::with_capacity(n);
    let mut y0 = 0.0;
    for row in 0..rows {
        let cols = n / rows + usize::from(row < n % rows);
        let h = cols as f64 / n as f64;
        for col in 0..cols {
            let u = (col as f64 + rng.gen::<f64>()) / cols as f64;
            let v = y0 + h * rng.gen::<f64>();
            out.push((u, v.min(1.0)));
        }
        y0 += h;
    }
    out
}

/// Shirley–Chiu concentric map of the unit square onto the unit disk (keeps strata compact).
#[inline]
pub fn concentric_disk(u: f64, v: f64) -> (f64, f64) {
    let a = 2.0 * u - 1.0;
    let b = 2.0 * v - 1.0;
    if a == 0.0 && b == 0.0 {
        return (0.0, 0.0);
    }
    let (r, phi) = if a.abs() > b.abs() {
        (a, std::f64::consts::FRAC_PI_4 * (b / a))
    } else {
        (b, FRAC_PI_2 - std::f64::consts::FRAC_PI_4 * (a / b))
    };
    (r * phi.cos(), r * phi.sin())
}

/// Lifts a disk point to the hemisphere (Malley): cosine-weighted.
#[inline]
fn lift(x: f64, y: f64) -> DVec3 {
    DVec3::new(x, y, (1.0 - x * x - y * y).max(0.0).sqrt())
}

/// `n` origins stratified over a convex patch (area-preserving map of a stratified square:
/// the first coordinate picks a fan triangle by area, the pair is then warped uniformly onto
/// it), each pulled towards the centroid by [`ORIGIN_CLEARANCE`].
pub fn stratified_origins(p: &Patch, n: usize, rng: &mut Pcg64) -> Vec<DVec3> {
    let v = &p.vertices;
    let tris: Vec<[DVec3; 3]> = (1..v.len() - 1).map(|i| [v[0], v[i], v[i + 1]]).collect();
    let areas: Vec<f64> = tris
        .iter()
        .map(|t| 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length())
        .collect();
    let total: f64 = areas.iter().sum();
    let c = p.centroid();
    stratified_square(n, rng)
        .into_iter()
        .map(|(u, w)| {
            let mut acc = 0.0;
            let mut k = tris.len() - 1;
            let mut uu = 1.0;
            for (i, a) in areas.iter().enumerate() {
                let f = a / total;
                if u < acc + f || i == tris.len() - 1 {
                    k = i;
                    uu = ((u - acc) / f).clamp(0.0, 1.0);
                    break;
                }
                acc += f;
            }
            let t = &tris[k];
            let s = uu.sqrt();
            let x = t[0] * (1.0 - s) + t[1] * (s * (1.0 - w)) + t[2] * (s * w);
            c + (x - c) * (1.0 - ORIGIN_CLEARANCE)
        })
        .collect()
}

/// Where the rays start.
#[derive(Clone, Copy, Debug)]
pub enum Origins {
    /// Stratified over the source patch (area-to-patch form factors).
    Patch,
    /// All at one point (differential-area form factors; used by tests).
    Point(DVec3),
}

/// `n` weighted rays over the hemisphere of `source`. Directions from `dirs`; origins from
/// `origins`, stratified ones randomly paired with directions (seeded). Deterministic:
/// the same arguments give the same rays, bit for bit.
pub fn hemisphere_rays(
    source: &Patch,
    n: usize,
    dirs: Directions,
    origins: Origins,
    seed: u64,
) -> RaySet {
    let mut rng = Pcg64::seed_from_u64(seed);
    let frame = Frame::of_patch(source);
    let local: Vec<(DVec3, f64)> = match dirs {
        Directions::Rings => rings_local(n),
        Directions::Malley => stratified_square(n, &mut rng)
            .into_iter()
            .map(|(u, v)| {
                let (x, y) = concentric_disk(u, v);
                (lift(x, y), 1.0 / n as f64)
            })
            .collect(),
        Directions::Random => (0..n)
            .map(|_| {
                let (x, y) = concentric_disk(rng.gen(), rng.gen());
                (lift(x, y), 1.0 / n as f64)
            })
            .collect(),
    };
    let starts: Vec<DVec3> = match origins {
        Origins::Point(p) => vec![p; n],
        Origins::Patch => {
            let mut o = stratified_origins(source, n, &mut rng);
            o.shuffle(&mut rng);
            o
        }
    };
    let (rays, weights) = local
        .into_iter()
        .zip(starts)
        .map(|((l, w), o)| {
            (
                Ray {
                    o,
                    d: frame.to_world(l),
                },
                w,
            )
        })
        .unzip();
    RaySet { rays, weights }
}

/// Most rays one run may cast.
pub const MAX_RAYS: usize = 100_000_000;

/// Bytes the float reference holds per ray at its peak: the ray, its weight, its prepared
/// form and its result (an estimate for [`crate::limits::check_memory`]).
pub fn ray_bytes() -> u64 {
    use crate::reference::tracer::{PreparedRay, Ray};
    (std::mem::size_of::<Ray>()
        + std::mem::size_of::<f64>()
        + std::mem::size_of::<PreparedRay>()
        + 32) as u64
}

/// Checks a source id and a ray count against the scene read from `file`: a source that
/// does not exist is `Error::Input` at place `source`; a ray count outside 1..=[`MAX_RAYS`]
/// is `Error::Param` `rays`.
pub fn check_source_and_rays(scene: &Scene, file: &Path, source: u32, rays: usize) -> Result<()> {
    if source as usize >= scene.patches.len() {
        return Err(Error::input(
            file,
            "source",
            format!(
                "source patch {source} does not exist (the scene has patches 0..{})",
                scene.patches.len() - 1
            ),
        ));
    }
    if rays == 0 || rays > MAX_RAYS {
        return Err(Error::param(
            "rays",
            format!("{rays} is out of range (1..={MAX_RAYS})"),
        ));
    }
    Ok(())
}

/// Which rays a job casts: `rays` of `directions` from patch `source`, origins stratified
/// over the patch, seeded by `seed`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RaySpec {
    pub source: u32,
    pub rays: usize,
    pub directions: Directions,
    pub seed: u64,
}

impl RaySpec {
    /// Checks the source and the ray count against `scene` (read from `file`), see
    /// [`check_source_and_rays`].
    pub fn validate(&self, scene: &Scene, file: &Path) -> Result<()> {
        check_source_and_rays(scene, file, self.source, self.rays)
    }

    /// The ray set over the source patch of `scene` (validated).
    pub fn rays(&self, scene: &Scene) -> RaySet {
        hemisphere_rays(
            &scene.patches[self.source as usize],
            self.rays,
            self.directions,
            Origins::Patch,
            self.seed,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::paper::PAPER_RAYS;

    #[test]
    fn paper_rings_are_969_with_unit_weight() {
        let (r, counts) = rings_layout(PAPER_RAYS);
        assert_eq!(r, 20);
        assert_eq!(counts.iter().sum::<usize>(), 969);
        assert_eq!(counts[0], 1);
        // ⌊80 sin 4.5°⌋ = 6 on the first ring, ⌊80 sin 85.5°⌋ = 79 on the last.
        assert_eq!(counts[1], 6);
        assert_eq!(counts[19], 79);
        let l = rings_local(PAPER_RAYS);
        let s: f64 = l.iter().map(|x| x.1).sum();
        assert!((s - 1.0).abs() < 1e-12, "{s}");
        assert!(l
            .iter()
            .all(|(d, _)| (d.length() - 1.0).abs() < 1e-12 && d.z > 0.0));
    }

    #[test]
    fn rings_meet_any_count_exactly() {
        for n in [1, 2, 7, 100, 500, 968, 970, 1000, 9690, 29070] {
            let l = rings_local(n);
            assert_eq!(l.len(), n, "n = {n}");
            let s: f64 = l.iter().map(|x| x.1).sum();
            assert!((s - 1.0).abs() < 1e-12, "n = {n}: {s}");
        }
    }

    #[test]
    fn stratified_square_has_one_point_per_cell() {
        let mut rng = Pcg64::seed_from_u64(3);
        for n in [1, 5, 17, 100, 101] {
            let p = stratified_square(n, &mut rng);
            assert_eq!(p.len(), n);
            assert!(p
                .iter()
                .all(|&(u, v)| (0.0..=1.0).contains(&u) && (0.0..=1.0).contains(&v)));
        }
    }

    #[test]
    fn origins_lie_inside_the_patch_clear_of_edges() {
        let p = Patch::new(
            vec![
                DVec3::new(0.0, 0.0, 0.0),
                DVec3::new(1.0, 0.0, 0.0),
                DVec3::new(0.8, 1.0, 0.0),
                DVec3::new(0.1, 0.7, 0.0),
            ],
            0.0,
            0.5,
        );
        let mut rng = Pcg64::seed_from_u64(1);
        let o = stratified_origins(&p, 100_000, &mut rng);
        let v = &p.vertices;
        for x in &o {
            assert_eq!(x.z, 0.0);
            for i in 0..4 {
                let a = v[i];
                let b = v[(i + 1) % 4];
                assert!(
                    (b - a).cross(*x - a).z > 0.0,
                    "{x:?} on or outside edge {i}"
                );
            }
        }
        // Area-uniform: the mean is the area centroid, not the vertex average.
        let mean = o.iter().copied().sum::<DVec3>() / o.len() as f64;
        let tri_c =
            |a: DVec3, b: DVec3, c: DVec3| ((a + b + c) / 3.0, 0.5 * (b - a).cross(c - a).z);
        let (c1, a1) = tri_c(v[0], v[1], v[2]);
        let (c2, a2) = tri_c(v[0], v[2], v[3]);
        let ac = (c1 * a1 + c2 * a2) / (a1 + a2);
        assert!(mean.distance(ac) < 5e-4, "{mean:?} vs {ac:?}");
    }

    #[test]
    fn same_seed_same_rays() {
        let p = Patch::new(
            vec![DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y],
            0.0,
            0.5,
        );
        for d in [Directions::Rings, Directions::Malley, Directions::Random] {
            let a = hemisphere_rays(&p, 500, d, Origins::Patch, 7);
            let b = hemisphere_rays(&p, 500, d, Origins::Patch, 7);
            let c = hemisphere_rays(&p, 500, d, Origins::Patch, 8);
            assert_eq!(a, b);
            assert_ne!(a, c);
            assert!(a.rays.iter().all(|r| r.d.z > 0.0));
        }
    }
}
