//! Enclosures: in scene1, scene2 and cornell, from every source tried no ray escapes and the
//! form factors sum to 1; on cornell, reciprocity A_i·F_ij = A_j·F_ji within sampling error.

use crate::common;

use rayon::prelude::*;
use shellsim::reference::cast::{form_factors, FormFactor};
use shellsim::reference::rays::{hemisphere_rays, Directions, Origins};
use shellsim::reference::tracer::Tracer;
use shellsim::Scene;

fn ff_from(
    scene: &Scene,
    tr: &Tracer,
    src: usize,
    n: usize,
    dirs: Directions,
) -> (Vec<FormFactor>, usize, f64) {
    let set = hemisphere_rays(&scene.patches[src], n, dirs, Origins::Patch, 1 + src as u64);
    let hits: Vec<_> = set
        .rays
        .iter()
        .map(|r| tr.trace(r, Some(src as u32)))
        .collect();
    form_factors(&hits, &set.weights, scene.patches.len())
}

fn enclosed(file: &str, sources: Vec<usize>) {
    let scene = common::load(file);
    let tr = Tracer::new(&scene, 0.05).unwrap();
    let (scene, tr) = (&scene, &tr);
    let failures: Vec<String> = sources
        .par_iter()
        .flat_map_iter(|&src| {
            [Directions::Rings, Directions::Malley]
                .into_iter()
                .filter_map(move |d| {
                    let (ff, escaped, _) = ff_from(scene, tr, src, 4000, d);
                    let sum: f64 = ff.iter().map(|f| f.value).sum();
                    let self_hit = ff.iter().any(|f| f.patch as usize == src);
                    (escaped > 0 || (sum - 1.0).abs() > 1e-9 || self_hit).then(|| {
                        format!("source {src} {d:?}: {escaped} escaped, ΣF = {sum}, self hit {self_hit}")
                    })
                })
                .collect::<Vec<_>>()
        })
        .collect();
    assert!(failures.is_empty(), "{file}: {failures:#?}");
}

#[test]
fn scene1_every_source() {
    enclosed("scene1.json", (0..26).collect());
}

#[test]
fn scene2_fifty_sources() {
    // Every 16th patch: floor, walls, ceiling, furniture alike.
    enclosed("scene2.json", (0..808).step_by(16).collect());
}

#[test]
fn cornell_every_source() {
    let n = common::load("cornell.json").patches.len();
    enclosed("cornell.json", (0..n).collect());
}

#[test]
fn cornell_reciprocity() {
    let scene = common::load("cornell.json");
    let tr = Tracer::new(&scene, 0.05).unwrap();
    let n = scene.patches.len();
    const RAYS: usize = 200_000;
    // Reciprocity holds between front sides: count a hit only when it lands on the front
    // of j (the floor runs under the blocks, the light hangs under the ceiling: rays
    // reach their backs, which emit and receive nothing).
    let f: Vec<Vec<f64>> = (0..n)
        .into_par_iter()
        .map(|i| {
            let mut row = vec![0.0; n];
            let set = hemisphere_rays(
                &scene.patches[i],
                RAYS,
                Directions::Malley,
                Origins::Patch,
                1 + i as u64,
            );
            for (r, w) in set.rays.iter().zip(&set.weights) {
                if let Some(h) = tr.trace(r, Some(i as u32)) {
                    if r.d.dot(tr.patches[h.patch as usize].normal) < 0.0 {
                        row[h.patch as usize] += w;
                    }
                }
            }
            row
        })
        .collect();
    let area: Vec<f64> = scene.patches.iter().map(|p| p.area()).collect();
    let sigma = |f: f64| (f * (1.0 - f) / RAYS as f64).sqrt();
    let mut checked = 0;
    for i in 0..n {
        for j in i + 1..n {
            if f[i][j] < 0.01 && f[j][i] < 0.01 {
                continue;
            }
            let lhs = area[i] * f[i][j];
            let rhs = area[j] * f[j][i];
            let tol = 3.0
                * ((area[i] * sigma(f[i][j])).powi(2) + (area[j] * sigma(f[j][i])).powi(2)).sqrt();
            assert!(
                (lhs - rhs).abs() <= tol,
                "patches {i},{j}: A_i F_ij = {lhs:.6} vs A_j F_ji = {rhs:.6} (3σ = {tol:.2e})"
            );
            checked += 1;
        }
    }
    assert!(checked >= 20, "only {checked} pairs had F above 0.01");
}
