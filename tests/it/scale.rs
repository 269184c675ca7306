//! Scale invariance: a committed scene scaled by 278, 0.01 or 1000 and moved away from the
//! origin, run with no configuration written by hand (the built-in paper.toml, whose cell
//! size and shell radius are `auto`), gives the same rays the same hits — patch ids in the
//! float reference and in the fixed-point model — and the machine the same cycles and
//! statistics as the original. The hardware works in units of the scene's largest extent,
//! so it sees the same numbers.

use crate::common;

use glam::DVec3;
use shellsim::machine::run::run;
use shellsim::reference::rays::{hemisphere_rays, Directions, Origins};
use shellsim::reference::tracer::Tracer;
use shellsim::scene::Scene;
use std::path::Path;

/// `scene` with every point p mapped to k·p + t (bounds included).
fn transformed(scene: &Scene, k: f64, t: DVec3) -> Scene {
    let mut s = scene.clone();
    s.name = format!("{}-x{k}", scene.name);
    s.bounds.lo = s.bounds.lo * k + t;
    s.bounds.hi = s.bounds.hi * k + t;
    for p in &mut s.patches {
        for v in &mut p.vertices {
            *v = *v * k + t;
        }
    }
    s.validate(Path::new("<transformed>"))
        .unwrap_or_else(|e| panic!("the transformed scene is valid: {e}"));
    s
}

/// The natural source of each committed scene used here.
fn source(file: &str) -> u32 {
    if file == "cornell.json" {
        1
    } else {
        0
    }
}

/// Float reference: the same 2,000 Malley rays (drawn on each scene's own source patch)
/// hit the same patches.
fn float_hits(scene: &Scene, src: u32) -> Vec<Option<u32>> {
    let cell =
        shellsim::config::cell_size(shellsim::config::built_in().machine.cell_size, scene.size());
    let tracer = Tracer::new(scene, cell).unwrap();
    let set = hemisphere_rays(
        &scene.patches[src as usize],
        2000,
        Directions::Malley,
        Origins::Patch,
        7,
    );
    set.rays
        .iter()
        .map(|r| tracer.trace(r, Some(src)).map(|h| h.patch))
        .collect()
}

fn same_after_scaling(file: &str, k: f64) {
    let original = common::load(file);
    let moved = transformed(&original, k, DVec3::new(17.0, -3.5, 250.0) * k);
    let src = source(file);
    let what = format!("{file} scaled by {k}");
    // Float reference.
    assert_eq!(
        float_hits(&original, src),
        float_hits(&moved, src),
        "{what}: float hits"
    );
    // Fixed-point model and machine, on the built-in configuration (lengths `auto`).
    let cfg = *shellsim::config::built_in();
    let a = run(&original, Path::new(file), &cfg, &common::spec(), None).unwrap();
    let b = run(&moved, Path::new(file), &cfg, &common::spec(), None)
        .unwrap_or_else(|e| panic!("{what}: {e}"));
    let ids = |h: &[Option<shellsim_hw::FixedHit>]| -> Vec<Option<u32>> {
        h.iter().map(|x| x.map(|x| x.patch)).collect()
    };
    assert_eq!(
        ids(&a.reference),
        ids(&b.reference),
        "{what}: fixed-point hits"
    );
    assert_eq!(b.stats.mismatches_vs_fixed, 0, "{what}");
    assert_eq!(ids(&a.hits), ids(&b.hits), "{what}: machine hits");
    let (mut sa, mut sb) = (a.stats.clone(), b.stats.clone());
    sa.scene.clear();
    sb.scene.clear();
    assert_eq!(
        serde_json::to_string(&sa).unwrap(),
        serde_json::to_string(&sb).unwrap(),
        "{what}: machine statistics (cycles {} vs {})",
        a.stats.cycles,
        b.stats.cycles
    );
}

testcases! { same_after_scaling;
    scene1_x278 => "scene1.json", 278.0;
    scene1_x0_01 => "scene1.json", 0.01;
    scene1_x1000 => "scene1.json", 1000.0;
    cornell_x278 => "cornell.json", 278.0;
    cornell_x0_01 => "cornell.json", 0.01;
    cornell_x1000 => "cornell.json", 1000.0;
    scene2_x278 => "scene2.json", 278.0;
    scene2_x0_01 => "scene2.json", 0.01;
    scene2_x1000 => "scene2.json", 1000.0;
}

#[test]
fn the_resolved_lengths_scale_with_the_scene() {
    use shellsim::config::SceneSize;
    let cfg = shellsim::config::built_in();
    let r = shellsim::config::resolve(cfg, SceneSize::of_scale(555.0)).unwrap();
    assert_eq!(r.machine.cell_size.value(), 555.0 / 20.0);
    assert_eq!(r.machine.shell_radius.value(), 0.289 * 555.0);
    // On the unit cube the rules give Table 12.1 exactly.
    let u = shellsim::config::resolve(cfg, SceneSize::of_scale(1.0)).unwrap();
    assert_eq!(u.machine.cell_size.value(), 0.05);
    assert_eq!(u.machine.shell_radius.value(), 0.289);
    // Sized to the scene: about 1.6·∛N cells along the largest extent, 20 at least.
    let big = SceneSize {
        scale: 555.0,
        patches: 100_800,
    };
    let r = shellsim::config::resolve(cfg, big).unwrap();
    assert_eq!(r.machine.cell_size.value(), 555.0 / 75.0);
    let small = SceneSize {
        scale: 555.0,
        patches: 1_953,
    };
    let r = shellsim::config::resolve(cfg, small).unwrap();
    assert_eq!(r.machine.cell_size.value(), 555.0 / 20.0);
    // An explicit value wins.
    let mut c = *cfg;
    c.machine.cell_size = shellsim_hw::config::Length::Value(10.0);
    assert_eq!(
        shellsim::config::resolve(&c, SceneSize::of_scale(555.0))
            .unwrap()
            .machine
            .cell_size
            .value(),
        10.0
    );
}

/// The float reference's form factors from source 0 (969 rings rays, default seed) and its
/// escaped-ray count, on `scene` as given.
fn reference_form_factors(scene: &Scene) -> (Vec<f64>, usize) {
    use shellsim::reference::cast::run_scene;
    use shellsim::reference::rays::RaySpec;
    let spec = RaySpec {
        source: 0,
        rays: 969,
        directions: Directions::Rings,
        seed: 1,
    };
    let cell =
        shellsim::config::cell_size(shellsim::config::built_in().machine.cell_size, scene.size());
    let r = run_scene(scene, Path::new("<placed>"), &spec, cell).unwrap();
    let mut ff = vec![0.0; scene.patches.len()];
    for f in &r.form_factors {
        ff[f.patch as usize] = f.value;
    }
    (ff, r.escaped)
}

/// The untimed fixed-point model's hits from source 0 (969 rings rays, seed 1, origins
/// placed as every command places them), as (patch, raw t), and how many rays it lost.
fn fixed_hits(scene: &Scene) -> (Vec<Option<(u32, i64)>>, usize) {
    use shellsim::fixed::records::HostFixed;
    use shellsim_hw::Exceptions;
    let cell =
        shellsim::config::cell_size(shellsim::config::built_in().machine.cell_size, scene.size());
    let host = HostFixed::new(
        scene,
        Path::new("<placed>"),
        shellsim_hw::config::paper().datapath,
        cell,
    )
    .unwrap();
    let set = hemisphere_rays(&scene.patches[0], 969, Directions::Rings, Origins::Patch, 1);
    let hits: Vec<Option<(u32, i64)>> = set
        .rays
        .iter()
        .enumerate()
        .map(|(i, r)| {
            let rec = host.ray_from(i as u32, r, 0).expect("the ray fits");
            let mut e = Exceptions::default();
            host.scene
                .nearest_grid(&rec, Some(0), &mut e)
                .0
                .map(|h| (h.patch, h.t))
        })
        .collect();
    let lost = hits.iter().filter(|h| h.is_none()).count();
    (hits, lost)
}

/// Far from the origin and at any size the validator accepts, the float reference loses no
/// ray and finds the form factors it finds at the origin, and the fixed-point model gives
/// every ray the same patch and the same t bits (issue 30's offset × extent table): it traces in the scene's own frame
/// (bounds' low corner at the origin), so only the input's own rounding differs. Offsets
/// reach 4·10⁶ extents, just inside the validator's 2^22 (in world coordinates 10⁶ extents
/// already lost hundreds of rays). A placement 10⁸ extents out is refused as an input error.
#[test]
fn far_and_small_placements_trace_as_at_the_origin() {
    let scenes = [
        ("unit-cube", common::unit_cube()),
        ("cornell", common::load("cornell.json")),
        ("scene2", common::load("scene2.json")),
    ];
    for (name, scene) in &scenes {
        let (at_origin, escaped) = reference_form_factors(scene);
        assert_eq!(escaped, 0, "{name} at the origin");
        let (fixed_at_origin, lost) = fixed_hits(scene);
        assert_eq!(lost, 0, "{name} at the origin: fixed-point rays lost");
        for ext in [1e-6, 1e-3, 1.0, 1e3] {
            for off in [0.0, 1e2, 1e4, 1e6, 4e6] {
                let placed = transformed(scene, ext, DVec3::splat(off * ext));
                let (ff, escaped) = reference_form_factors(&placed);
                let what = format!("{name} × {ext:e} moved {off:e} extents");
                assert_eq!(escaped, 0, "{what}: escaped rays");
                for (j, (a, b)) in at_origin.iter().zip(&ff).enumerate() {
                    assert!((a - b).abs() <= 1e-9, "{what}: F to patch {j}: {a} vs {b}");
                }
                let (fixed, _) = fixed_hits(&placed);
                let differ = fixed_at_origin
                    .iter()
                    .zip(&fixed)
                    .filter(|(a, b)| a != b)
                    .count();
                assert_eq!(
                    differ, 0,
                    "{what}: fixed-point hits that differ from the origin's"
                );
            }
        }
        // Too far out for f64 to hold the scene to 2^-30 of its extent: refused.
        for (ext, off) in [(1.0, 1e8), (1e-3, 1e7), (1e-6, 1e11)] {
            let mut s = scene.clone();
            let t = DVec3::splat(off * ext);
            s.bounds.lo = s.bounds.lo * ext + t;
            s.bounds.hi = s.bounds.hi * ext + t;
            for p in &mut s.patches {
                for v in &mut p.vertices {
                    *v = *v * ext + t;
                }
            }
            let e = s
                .validate(Path::new("<far>"))
                .expect_err("a scene 10^8 extents out is refused");
            assert_eq!(e.exit_code(), 2, "{name}: an input error: {e}");
            assert!(
                matches!(e, shellsim::error::Error::Input { ref place, .. } if place == "bounds")
                    && e.to_string().contains("2^22"),
                "{name}: names the bounds and the bound: {e}"
            );
        }
    }
}
