//! Watertight: 10⁶ rays aimed at the shared edges and vertices of stress-edges each hit
//! exactly one of the patches that share that edge or vertex (no leak, no double hit), and
//! the traced nearest hit is never beyond the aimed-at point.

use crate::common;

use glam::DVec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use rayon::prelude::*;
use shellsim::reference::tracer::{PatchGeom, PreparedRay, Ray, Tracer};
use std::collections::HashMap;

type Key = [u64; 3];

fn key(v: DVec3) -> Key {
    [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()]
}

/// A target: a point and the patches that share the edge or vertex it lies on.
struct Target {
    a: DVec3,
    b: DVec3,
    patches: Vec<u32>,
}

/// Interior shared edges and vertices of the near-horizontal tessellated surfaces (either
/// facing): a near-vertical ray crosses them transversally, never along a silhouette.
fn targets(scene: &shellsim::Scene) -> (Vec<Target>, Vec<Target>) {
    let up: Vec<usize> = (0..scene.patches.len())
        .filter(|&i| scene.patches[i].normal().z.abs() > 0.5)
        .collect();
    let mut edges: HashMap<(Key, Key), Vec<u32>> = HashMap::new();
    let mut verts: HashMap<Key, Vec<u32>> = HashMap::new();
    for &i in &up {
        let v = &scene.patches[i].vertices;
        for k in 0..v.len() {
            let (a, b) = (key(v[k]), key(v[(k + 1) % v.len()]));
            edges
                .entry(if a < b { (a, b) } else { (b, a) })
                .or_default()
                .push(i as u32);
            verts.entry(a).or_default().push(i as u32);
        }
    }
    let from = |k: Key| {
        DVec3::new(
            f64::from_bits(k[0]),
            f64::from_bits(k[1]),
            f64::from_bits(k[2]),
        )
    };
    // A vertex is interior when every edge at it is shared by two patches.
    let mut edges_at: HashMap<Key, Vec<usize>> = HashMap::new();
    for ((a, b), ps) in &edges {
        edges_at.entry(*a).or_default().push(ps.len());
        edges_at.entry(*b).or_default().push(ps.len());
    }
    let mut e: Vec<Target> = edges
        .iter()
        .filter(|(_, ps)| ps.len() == 2)
        .map(|((a, b), ps)| Target {
            a: from(*a),
            b: from(*b),
            patches: ps.clone(),
        })
        .collect();
    let mut v: Vec<Target> = verts
        .iter()
        .filter(|(k, ps)| ps.len() >= 3 && edges_at[*k].iter().all(|&n| n == 2))
        .map(|(k, ps)| Target {
            a: from(*k),
            b: from(*k),
            patches: ps.clone(),
        })
        .collect();
    // HashMap order is random: sort for a reproducible test.
    e.sort_by(|x, y| key(x.a).cmp(&key(y.a)).then(key(x.b).cmp(&key(y.b))));
    v.sort_by_key(|x| key(x.a));
    (e, v)
}

#[test]
fn shared_edges_and_vertices_hit_exactly_once() {
    let scene = common::load("stress-edges.json");
    let tr = Tracer::new(&scene, 0.05).unwrap();
    let geo: Vec<PatchGeom> = scene.patches.iter().map(PatchGeom::new).collect();
    let (edges, verts) = targets(&scene);
    assert!(edges.len() >= 500, "only {} shared edges", edges.len());
    assert!(verts.len() >= 100, "only {} shared vertices", verts.len());
    const RAYS: usize = 1_000_000;
    let bad: Vec<String> = (0..RAYS)
        .into_par_iter()
        .filter_map(|i| {
            let mut rng = Pcg64::seed_from_u64(i as u64);
            // Even rays: at an edge (half of them at its exact midpoint); odd: at a vertex.
            let t = if i % 2 == 0 {
                &edges[rng.gen_range(0..edges.len())]
            } else {
                &verts[rng.gen_range(0..verts.len())]
            };
            let s = if i % 4 == 0 { 0.5 } else { rng.gen::<f64>() };
            let x = t.a + (t.b - t.a) * s;
            // Half the rays come straight down (the ray passes exactly through the edge or
            // vertex: the fill rule decides); half tilted up to 40° (rounding decides).
            // The ray must cross the surface there, not graze a fold of it (a silhouette
            // edge, where touching 0 or 2 patches is right): every patch at the target is
            // seen from the same side. Tilted directions are redrawn until that holds.
            let crosses = |d: DVec3| {
                let s: Vec<f64> = t
                    .patches
                    .iter()
                    .map(|&p| geo[p as usize].normal.dot(d))
                    .collect();
                s.iter().all(|&x| x > 1e-6) || s.iter().all(|&x| x < -1e-6)
            };
            let d = if i % 3 == 0 {
                DVec3::NEG_Z
            } else {
                loop {
                    let phi = rng.gen_range(0.0..std::f64::consts::TAU);
                    let th = rng.gen_range(0.0..0.7f64);
                    let d = DVec3::new(th.sin() * phi.cos(), th.sin() * phi.sin(), -th.cos());
                    if crosses(d) {
                        break d;
                    }
                }
            };
            if !crosses(d) {
                return Some(format!("ray {i}: the surface at {x:?} is vertical"));
            }
            let h = rng.gen_range(0.01..0.2);
            let ray = Ray { o: x - d * h, d };
            let pr = PreparedRay::new(&ray);
            let n_hit = t
                .patches
                .iter()
                .filter(|&&p| geo[p as usize].intersect(&pr, p).is_some())
                .count();
            let nearest = tr.trace(&ray, None);
            let leak = match nearest {
                None => true,
                Some(hit) => hit.t > h * (1.0 + 1e-9),
            };
            (n_hit != 1 || leak).then(|| {
                format!(
                    "ray {i} at {x:?} dir {d:?}: {n_hit} of {:?} hit, nearest {nearest:?}",
                    t.patches
                )
            })
        })
        .collect();
    assert!(
        bad.is_empty(),
        "{} of {RAYS} rays failed; first: {}",
        bad.len(),
        bad[0]
    );
}
