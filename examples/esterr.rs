use glam::DVec3;
use shellsim::rays::*;
use shellsim::reference::form_factors;
use shellsim::scene::Scene;
use shellsim::trace::Tracer;
fn main() {
    let scene = Scene::load_json(std::path::Path::new("/tmp/cube.json")).unwrap();
    let tr = Tracer::new(&scene, 0.05).unwrap();
    for (label, origins, target, truth) in [
        ("point->ceil", Origins::Point(DVec3::new(0.5, 0.5, 0.0)), 1u32, 0.2394564705),
        ("point->wall", Origins::Point(DVec3::new(0.5, 0.5, 0.0)), 2u32, 0.1901358824),
        ("area->ceil", Origins::Patch, 1u32, 0.1998248957),
        ("area->wall", Origins::Patch, 2u32, 0.2000437761),
    ] {
        for dirs in [Directions::Random, Directions::Malley, Directions::Rings] {
            for n in [1000usize, 10_000, 100_000, 1_000_000] {
                let seeds = if n >= 1_000_000 { 8 } else { 40 };
                let mut se = 0.0;
                let mut maxe: f64 = 0.0;
                for s in 0..seeds {
                    let set = hemisphere_rays(&scene.patches[0], n, dirs, origins, s);
                    let hits: Vec<_> = set.rays.iter().map(|r| tr.trace(r, Some(0))).collect();
                    let (ff, _, _) = form_factors(&hits, &set.weights, 6);
                    let f = ff.iter().find(|f| f.patch == target).map(|f| f.value).unwrap_or(0.0);
                    se += (f - truth).powi(2);
                    maxe = maxe.max((f - truth).abs());
                }
                let rms = (se / seeds as f64).sqrt();
                let binom = (truth * (1.0 - truth) / n as f64).sqrt();
                println!("{label:12} {dirs:?} n={n:8} rms={rms:.3e} max={maxe:.3e} binom={binom:.3e} ratio={:.3} rms*n^.75={:.3}", rms / binom, rms * (n as f64).powf(0.75));
            }
        }
    }
}
