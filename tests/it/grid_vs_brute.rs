//! Grid traversal equals brute force (every patch tested) on 10⁶ rays in every committed
//! scene but stress-dense, and on 10⁵ there (brute force over its 20,283 patches costs ~25×
//! scene2's per ray: 10⁶ rays took ~4.5 min on 2 cores, 10⁵ take ~30 s): identical patch ids
//! and identical bits of t. A quarter of the rays are adversarial
//! for the 3D-DDA: origins on cell boundaries, zero direction components, directions with
//! equal components (ties between axes, paths through cell edges and corners).
//!
//! The bundle path, `Tracer::trace_packet`, equals the one-ray `trace_counted` ray for ray —
//! the same patch, the same bits of t, the same cell and test counts — over every committed
//! scene and every stability case at the paper's ray count from several sources, and over
//! generated slanted and millimetre rooms.

use crate::common;

use glam::DVec3;
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use rayon::prelude::*;
use shellsim::paper::PAPER_RAYS;
use shellsim::reference::rays::{hemisphere_rays, Directions, Origins};
use shellsim::reference::tracer::{Hit, Ray, TraceCounts, Tracer};
use shellsim::scene::gen::corpus;
use shellsim::Scene;
use shellsim_hw::config::Length;

/// Rays per scene, and on stress-dense.
const RAYS: usize = 1_000_000;
const RAYS_DENSE: usize = 100_000;

/// Ray `i` of the test set for a scene (seeded by index, so a failure names its ray).
fn ray(i: usize, n_patches: usize, scene: &shellsim::Scene) -> (Ray, Option<u32>) {
    let mut rng = Pcg64::seed_from_u64(i as u64);
    let lo = scene.bounds.lo;
    let ext = scene.bounds.extent();
    let mut o = lo + DVec3::new(rng.gen(), rng.gen(), rng.gen()) * ext;
    let mut d = loop {
        let v = DVec3::new(
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
        );
        if v.length_squared() > 1e-6 && v.length_squared() <= 1.0 {
            break v;
        }
    };
    let mut exclude = None;
    match i % 8 {
        // Origin snapped to a cell boundary on one or more axes.
        0 | 1 => {
            for a in 0..3 {
                if rng.gen_bool(0.6) {
                    o[a] = lo[a] + (rng.gen_range(0..=20) as f64) / 20.0 * ext[a];
                }
            }
        }
        // One or two zero direction components.
        2 => {
            d[rng.gen_range(0..3)] = 0.0;
            if rng.gen_bool(0.3) {
                d[rng.gen_range(0..3)] = 0.0;
            }
            if d == DVec3::ZERO {
                d.z = 1.0;
            }
        }
        // Equal-magnitude components from a cell corner: the ray runs through cell edges
        // and corners, every step a tie between axes.
        3 => {
            let s = |r: &mut Pcg64| if r.gen_bool(0.5) { 1.0 } else { -1.0 };
            d = DVec3::new(s(&mut rng), s(&mut rng), s(&mut rng));
            if rng.gen_bool(0.3) {
                d[rng.gen_range(0..3)] = 0.0;
            }
            for a in 0..3 {
                o[a] = lo[a] + (rng.gen_range(0..=20) as f64) / 20.0 * ext[a];
            }
        }
        // From a point of a patch, the patch excluded (as the reference casts).
        4 => {
            let id = rng.gen_range(0..n_patches);
            let p = &scene.patches[id];
            let w: Vec<f64> = p.vertices.iter().map(|_| rng.gen::<f64>() + 1e-3).collect();
            let sw: f64 = w.iter().sum();
            o = p
                .vertices
                .iter()
                .zip(&w)
                .map(|(v, w)| *v * *w)
                .sum::<DVec3>()
                / sw;
            if d.dot(p.normal()) < 0.0 {
                d = -d;
            }
            exclude = Some(id as u32);
        }
        _ => {}
    }
    (Ray { o, d }, exclude)
}

fn grid_equals_brute(file: &str, rays: usize) {
    let scene = common::load(file);
    let tr = Tracer::new(&scene, 0.05).unwrap();
    let n = scene.patches.len();
    let bad: Vec<String> = (0..rays)
        .into_par_iter()
        .filter_map(|i| {
            let (r, ex) = ray(i, n, &scene);
            let g = tr.trace(&r, ex);
            let b = tr.trace_brute(&r, ex);
            let same = match (g, b) {
                (None, None) => true,
                (Some(g), Some(b)) => g.patch == b.patch && g.t.to_bits() == b.t.to_bits(),
                _ => false,
            };
            (!same).then(|| format!("ray {i} {r:?} exclude {ex:?}: grid {g:?} brute {b:?}"))
        })
        .collect();
    assert!(
        bad.is_empty(),
        "{file}: {} of {rays} rays differ; first: {}",
        bad.len(),
        bad[0]
    );
}

testcases! { grid_equals_brute;
    scene1 => "scene1.json", RAYS;
    scene2 => "scene2.json", RAYS;
    cornell => "cornell.json", RAYS;
    stress_edges => "stress-edges.json", RAYS;
    stress_grazing => "stress-grazing.json", RAYS;
    stress_skewed => "stress-skewed.json", RAYS;
    stress_dense => "stress-dense.json", RAYS_DENSE;
}

#[test]
fn every_committed_scene_is_covered() {
    // The macro above must name every committed scene.
    let mut files: Vec<String> = std::fs::read_dir(common::scene_path(""))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|f| f.ends_with(".json"))
        .collect();
    files.sort();
    let mut listed: Vec<String> = common::COMMITTED.iter().map(|s| s.to_string()).collect();
    listed.sort();
    assert_eq!(files, listed);
}

/// The first ray of `rays` on which `trace_packet` and `trace_counted` differ (patch, bits
/// of t or counts), described.
fn packet_difference(tr: &Tracer, rays: &[Ray], source: Option<u32>) -> Option<String> {
    let mut packet = vec![(None, TraceCounts::default()); rays.len()];
    tr.trace_packet(rays, source, &mut packet);
    let key = |(h, c): &(Option<Hit>, TraceCounts)| (h.map(|h| (h.patch, h.t.to_bits())), *c);
    rays.iter()
        .zip(&packet)
        .enumerate()
        .find_map(|(i, (r, p))| {
            let one = tr.trace_counted(r, source);
            (key(&one) != key(p)).then(|| format!("ray {i} {r:?}: one-ray {one:?}, packet {p:?}"))
        })
}

/// `trace_packet` equals `trace_counted` on `scene`'s hemisphere bundles from `sources`
/// spread over its patches (the paper's ray count, rings and Malley directions), on the
/// sized grid and the paper's (scale / 20); `extra` more rays from `extra_source`.
fn packet_equals_one_ray(
    name: &str,
    scene: &Scene,
    sources: usize,
    extra: &[Ray],
    extra_source: u32,
) {
    let n = scene.patches.len();
    for cell in [
        shellsim::config::cell_size(Length::Auto, scene.size()),
        scene.bounds.scale() / 20.0,
    ] {
        let tr = Tracer::new(scene, cell).unwrap();
        let bad: Vec<String> = (0..sources.min(n))
            .into_par_iter()
            .flat_map_iter(|k| {
                let src = k * n / sources.min(n);
                [Directions::Rings, Directions::Malley].map(|dirs| {
                    let set = hemisphere_rays(
                        &scene.patches[src],
                        PAPER_RAYS,
                        dirs,
                        Origins::Patch,
                        k as u64,
                    );
                    packet_difference(&tr, &set.rays, Some(src as u32))
                        .map(|d| format!("source {src} {dirs:?}: {d}"))
                })
            })
            .flatten()
            .chain(packet_difference(&tr, extra, Some(extra_source)))
            .collect();
        assert!(
            bad.is_empty(),
            "{name}, cell {cell}: {} bundles differ; first: {}",
            bad.len(),
            bad[0]
        );
    }
}

#[test]
fn packet_equals_one_ray_on_every_committed_scene() {
    let mut files: Vec<&str> = common::COMMITTED.to_vec();
    files.push("cornell-public.obj");
    for file in files {
        let scene = Scene::load(&common::scene_path(file)).unwrap_or_else(|e| panic!("{e}"));
        packet_equals_one_ray(file, &scene, 8, &[], 0);
    }
}

#[test]
fn packet_equals_one_ray_on_every_stability_case() {
    for (name, _) in shellsim::stability::cases::CASES {
        let case = shellsim::stability::cases::generate_case(name, 2000, 1).unwrap();
        packet_equals_one_ray(name, &case.scene, 4, &case.rays, case.source);
    }
}

#[test]
fn packet_equals_one_ray_in_millimetres() {
    packet_equals_one_ray(
        "millimetre cornell",
        &corpus::millimetre_cornell(),
        12,
        &[],
        0,
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// Slanted rooms (every wall oblique to the grid), subdivided, scaled to millimetres or
    /// not: bundles from random sources, directions random.
    #[test]
    fn packet_equals_one_ray_in_slanted_rooms(seed in 0u64..1_000_000, n in 1usize..7, mm in any::<bool>(), src in any::<prop::sample::Index>()) {
        let mut scene = corpus::slanted_room_subdivided(seed, n);
        if mm {
            let k = 559.2;
            scene.bounds.lo *= k;
            scene.bounds.hi *= k;
            for p in &mut scene.patches {
                for v in &mut p.vertices {
                    *v *= k;
                }
            }
        }
        let tr = Tracer::new(&scene, shellsim::config::cell_size(Length::Auto, scene.size())).unwrap();
        let s = src.index(scene.patches.len());
        let set = hemisphere_rays(&scene.patches[s], PAPER_RAYS, Directions::Random, Origins::Patch, seed);
        let d = packet_difference(&tr, &set.rays, Some(s as u32));
        prop_assert!(d.is_none(), "{}", d.unwrap());
    }
}
