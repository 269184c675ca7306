//! Measures the RMS error of the form-factor estimators against analytic values over many
//! seeds (the figures behind the bounds in tests/it/convergence.rs):
//! `cargo run --release --example estimator_error`.

use glam::DVec3;
use shellsim::reference::analytic;
use shellsim::reference::cast::form_factors;
use shellsim::reference::rays::{hemisphere_rays, Directions, Origins};
use shellsim::reference::tracer::Tracer;

fn main() {
    let scene = shellsim::scene::gen::unit_cube();
    let tr = Tracer::new(&scene, 0.05).unwrap();
    let centre = DVec3::new(0.5, 0.5, 0.0);
    let cases = [
        (
            "point->ceiling",
            Origins::Point(centre),
            1u32,
            analytic::point_to_polygon(centre, DVec3::Z, &scene.patches[1].vertices),
        ),
        (
            "point->wall",
            Origins::Point(centre),
            2,
            analytic::point_to_polygon(centre, DVec3::Z, &scene.patches[2].vertices),
        ),
        (
            "area->ceiling",
            Origins::Patch,
            1,
            analytic::parallel_rectangles(1.0, 1.0, 1.0),
        ),
        (
            "area->wall",
            Origins::Patch,
            2,
            analytic::perpendicular_rectangles(1.0, 1.0, 1.0),
        ),
    ];
    println!("case,directions,rays,seeds,rms,max_abs,binomial,rms_over_binomial,rms_times_n075");
    for (label, origins, target, truth) in cases {
        for dirs in [Directions::Random, Directions::Malley, Directions::Rings] {
            for n in [1_000usize, 10_000, 100_000, 1_000_000] {
                let seeds = if n >= 1_000_000 { 8 } else { 40 };
                let (mut se, mut max) = (0.0f64, 0.0f64);
                for s in 0..seeds {
                    let set = hemisphere_rays(&scene.patches[0], n, dirs, origins, s);
                    let hits: Vec<_> = set.rays.iter().map(|r| tr.trace(r, Some(0))).collect();
                    let (ff, _, _) = form_factors(&hits, &set.weights, scene.patches.len());
                    let f = ff
                        .iter()
                        .find(|f| f.patch == target)
                        .map_or(0.0, |f| f.value);
                    se += (f - truth).powi(2);
                    max = max.max((f - truth).abs());
                }
                let rms = (se / seeds as f64).sqrt();
                let binom = (truth * (1.0 - truth) / n as f64).sqrt();
                println!(
                    "{label},{dirs:?},{n},{seeds},{rms:.3e},{max:.3e},{binom:.3e},{:.3},{:.3}",
                    rms / binom,
                    rms * (n as f64).powf(0.75)
                );
            }
        }
    }
}
