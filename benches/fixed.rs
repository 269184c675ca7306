//! Untimed fixed-point model throughput against the float reference, in ray/patch tests per
//! second (brute force: every patch of scene2 against the paper's 969 ring rays), one thread.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use shellsim::fixed::records::HostFixed;
use shellsim::paper::PAPER_RAYS;
use shellsim::reference::rays::{hemisphere_rays, Directions, Origins};
use shellsim::reference::tracer::{PreparedRay, Tracer};
use shellsim::Scene;
use shellsim_hw::datapath::intersect;
use shellsim_hw::Exceptions;
use std::hint::black_box;
use std::path::Path;

fn bench(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/scene2.json");
    let scene = Scene::load_json(&path).expect("scenes/scene2.json");
    let tracer = Tracer::new(&scene, 0.05).unwrap();
    let host = HostFixed::new(&scene, &path, shellsim_hw::config::paper().datapath, 0.05).unwrap();
    let set = hemisphere_rays(
        &scene.patches[0],
        PAPER_RAYS,
        Directions::Rings,
        Origins::Patch,
        1,
    );
    let records: Vec<_> = set
        .rays
        .iter()
        .enumerate()
        .map(|(i, r)| host.ray(i as u32, r).unwrap())
        .collect();
    let prepared: Vec<_> = set.rays.iter().map(PreparedRay::new).collect();
    let tests = (set.len() * scene.patches.len()) as u64;
    let mut g = c.benchmark_group("ray_patch_tests_scene2");
    g.throughput(Throughput::Elements(tests));
    g.sample_size(10);
    g.bench_function("float_reference", |b| {
        b.iter(|| {
            let mut n = 0u32;
            for r in &prepared {
                for (id, p) in tracer.patches.iter().enumerate() {
                    n += black_box(p.intersect(r, id as u32)).is_some() as u32;
                }
            }
            n
        })
    });
    g.bench_function("fixed_model", |b| {
        let f = *host.formats();
        b.iter(|| {
            let mut n = 0u32;
            let mut exc = Exceptions::default();
            for r in &records {
                for p in &host.scene.patches {
                    n += black_box(intersect(r, p, &f, &mut exc)).is_some() as u32;
                }
            }
            n
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
