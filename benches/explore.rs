//! Design points per hour of `shellsim explore` on scene2 at ratio 1 (969 rays from patch 0,
//! paper.toml): one point measured by `explore::evaluate` on the fixed and machine levels —
//! the level's rays, the float model on the same rays, the errors, the cost, and for the
//! machine the cycle-level run checked against the untimed model (`machine`) or the queueing
//! network's estimate (`machine-queue`, `timing = "queue"`). Points per hour per core
//! = 3600 s / the time per point (BENCHMARKS.md).

use criterion::{criterion_group, criterion_main, Criterion};
use shellsim::explore::spec::Timing;
use shellsim::explore::{evaluate, spec};
use shellsim::radiosity::matrix::Model;
use std::hint::black_box;
use std::path::Path;

fn bench(c: &mut Criterion) {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/scene2.json");
    let text = format!(
        "scene = {:?}\nlevel = [\"fixed\", \"machine\"]\nratio = 1\n",
        scene.display().to_string()
    );
    let s = spec::parse(&text, Path::new("bench.toml")).expect("a valid spec");
    // The reference only sets the error's value, not the work: zeros will do.
    let reference = vec![0.0; s.scenes[0].scene.patches.len()];
    let mut g = c.benchmark_group("explore_point_scene2_ratio1");
    g.sample_size(10);
    for p in &s.points {
        let mut timings = vec![(p.level.name().to_string(), Timing::Cycle)];
        if p.level == Model::Machine {
            timings.push(("machine-queue".into(), Timing::Queue));
        }
        for (name, t) in timings {
            g.bench_function(name, |b| {
                b.iter(|| black_box(evaluate(&s, p, &reference, t).expect("measures")))
            });
        }
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
