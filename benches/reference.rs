//! Reference tracer throughput (rays/s, one thread) on scene2: the paper's 969 ring rays from
//! each of 50 source patches; the same rays as 50 bundles through `trace_packet` (which
//! counts the work, as `cast` asks); brute force on the same rays for the ratio.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use shellsim::paper::PAPER_RAYS;
use shellsim::reference::rays::{hemisphere_rays, Directions, Origins};
use shellsim::reference::tracer::{Ray, TraceCounts, Tracer};
use shellsim::Scene;
use std::hint::black_box;
use std::path::Path;

fn rays_from_50_sources(scene: &Scene) -> Vec<(Ray, u32)> {
    (0..scene.patches.len())
        .step_by(scene.patches.len() / 50)
        .take(50)
        .flat_map(|src| {
            hemisphere_rays(
                &scene.patches[src],
                PAPER_RAYS,
                Directions::Rings,
                Origins::Patch,
                1,
            )
            .rays
            .into_iter()
            .map(move |r| (r, src as u32))
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/scene2.json");
    let scene = Scene::load_json(&path).expect("scenes/scene2.json");
    let tracer = Tracer::new(&scene, 0.05).unwrap();
    let rays = rays_from_50_sources(&scene);
    let mut g = c.benchmark_group("reference_scene2");
    g.throughput(Throughput::Elements(rays.len() as u64));
    g.sample_size(20);
    g.bench_function("grid_dda", |b| {
        b.iter(|| {
            let mut n = 0u32;
            for (r, s) in &rays {
                n += black_box(tracer.trace(r, Some(*s))).map_or(0, |h| h.patch & 1);
            }
            n
        })
    });
    // The same rays as bundles, one per source, through the bulk entry point.
    let bundles: Vec<(u32, Vec<Ray>)> = rays
        .chunk_by(|a, b| a.1 == b.1)
        .map(|c| (c[0].1, c.iter().map(|(r, _)| *r).collect()))
        .collect();
    let mut out = vec![(None, TraceCounts::default()); PAPER_RAYS];
    g.bench_function("grid_dda_packet", |b| {
        b.iter(|| {
            let mut n = 0u32;
            for (s, rs) in &bundles {
                let out = &mut out[..rs.len()];
                tracer.trace_packet(rs, Some(*s), out);
                n += black_box(&*out)
                    .iter()
                    .map(|(h, _)| h.map_or(0, |h| h.patch & 1))
                    .sum::<u32>();
            }
            n
        })
    });
    g.sample_size(10);
    g.bench_function("brute_force", |b| {
        b.iter(|| {
            let mut n = 0u32;
            for (r, s) in &rays {
                n += black_box(tracer.trace_brute(r, Some(*s))).map_or(0, |h| h.patch & 1);
            }
            n
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
