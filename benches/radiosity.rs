//! The whole form-factor matrix per model (a bench binary, not criterion: one machine
//! matrix of scene2 takes tens of seconds). `cargo bench --bench radiosity [-- SCENE...]`
//! prints, per scene and model, the wall time of `matrix::compute` at 969 rays per source
//! on the machine's threads, and for the machine its cycles and time at 50 MHz.

use shellsim::radiosity::matrix::{self, MatrixSpec, Model, Summary};
use shellsim::reference::rays::Directions;
use shellsim::Scene;
use std::path::Path;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        .collect();
    let scenes = if args.is_empty() {
        vec!["cornell".to_string(), "scene2".to_string()]
    } else {
        args
    };
    let cfg = shellsim::config::built_in();
    println!(
        "{} threads, 969 rays per source, paper.toml",
        rayon::current_num_threads()
    );
    println!("scene    model    rows  wall_s  machine_cycles  machine_s_at_50MHz");
    for name in &scenes {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("scenes/{name}.json"));
        let scene = Scene::load_json(&path).expect("a committed scene");
        for model in [Model::Float, Model::Fixed, Model::Machine] {
            let spec = MatrixSpec {
                model,
                rays: 969,
                directions: Directions::Rings,
                seed: 1,
                sources: 0..scene.patches.len() as u32,
            };
            let t = Instant::now();
            let m = matrix::compute(&scene, &path, cfg, &spec, false).expect("computes");
            let wall = t.elapsed().as_secs_f64();
            let s = Summary::new(&m, &spec, cfg, 50.0);
            s.verdict().expect("0 mismatches");
            let (c, ts) = s
                .machine
                .as_ref()
                .map_or(("-".to_string(), "-".to_string()), |t| {
                    (t.cycles.to_string(), format!("{:.4}", t.time_s))
                });
            println!(
                "{name:<8} {:<8} {:>4} {wall:>7.2} {c:>15} {ts:>19}",
                model.name(),
                m.rows.len()
            );
        }
    }
}
