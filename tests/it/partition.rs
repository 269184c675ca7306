//! The shelling partitioner on the committed scenes: the schedule finds the float tracer's
//! nearest hit for every ray; sectors tile the hemisphere and own every ray exactly once;
//! a ray's hit patch is active no later than the subshell it retires after; shelling loads
//! fewer patches than ray-by-ray casting; stress-skewed is badly balanced; the CLI's
//! outputs, errors and determinism.

use crate::common;

use proptest::prelude::*;
use shellsim::partition::angles::{AngleBox, Angles};
use shellsim::partition::schedule::Schedule;
use shellsim::partition::{partition, Config, Granularity, Partition};
use shellsim::reference::rays::Frame;
use shellsim::reference::tracer::Tracer;
use shellsim::scene::Scene;
use std::collections::HashSet;
use std::process::Command;

fn run(scene: &Scene, cfg: &Config) -> Partition {
    cfg.validate(scene, std::path::Path::new("<test>"))
        .expect("a valid configuration");
    let tracer = Tracer::new(scene, cfg.cell_size).unwrap();
    partition(scene, &tracer, cfg)
}

/// Checks every ray's shelling hit against the float tracer, one by one.
fn assert_hits_equal_tracer(scene: &Scene, p: &Partition, what: &str) {
    let tracer = Tracer::new(scene, p.config.cell_size).unwrap();
    let mut checked = 0;
    for s in &p.sectors {
        for (j, &r) in s.rays.iter().enumerate() {
            let ray = &p.high_rays.rays[r as usize];
            let want = tracer.trace(ray, Some(p.config.source));
            assert_eq!(s.run.hits[j], want, "{what}: ray {r} ({ray:?})");
            checked += 1;
        }
    }
    assert_eq!(checked, p.high_rays.len(), "{what}: every ray checked once");
    assert_eq!(p.nearest_hit_mismatches, 0, "{what}");
}

/// The structural invariants of a partition (see the module docs of `partition`).
fn assert_invariants(p: &Partition, what: &str) {
    // Sections tile the hemisphere, and each section's sectors tile the section.
    let sections: Vec<AngleBox> = p.plan.sections.iter().map(|s| s.bounds).collect();
    assert_tiling(&sections, &AngleBox::HEMISPHERE, what);
    for s in &p.plan.sections {
        assert_tiling(&s.sectors, &s.bounds, what);
    }
    let boxes = p.plan.sector_boxes();
    assert_tiling(&boxes, &AngleBox::HEMISPHERE, what);
    assert_eq!(boxes.len(), p.config.sections * p.config.ctus, "{what}");
    // Every high-resolution ray lies in exactly one sector box, and that sector owns it.
    let src = &common_scene_patch(p);
    let frame = Frame::of_patch(src);
    let mut owner = vec![usize::MAX; p.high_rays.len()];
    for (k, s) in p.sectors.iter().enumerate() {
        for &r in &s.rays {
            assert_eq!(
                owner[r as usize],
                usize::MAX,
                "{what}: ray {r} in two sectors"
            );
            owner[r as usize] = k;
        }
        assert!(s.rays.windows(2).all(|w| w[0] < w[1]));
    }
    for (r, ray) in p.high_rays.rays.iter().enumerate() {
        let a = Angles::of(&frame, ray.d);
        let holding: Vec<usize> = (0..boxes.len()).filter(|&k| boxes[k].contains(a)).collect();
        assert_eq!(holding, vec![owner[r]], "{what}: ray {r} at {a:?}");
        assert_eq!(p.sector_of[r] as usize, owner[r]);
    }
    // The patch the float reference hits is active in the ray's sector no later than the
    // subshell after which the ray retires; each patch loads once per sector.
    for s in &p.sectors {
        let mut seen = HashSet::new();
        for sub in &s.run.subshells {
            for &q in &sub.patches {
                assert!(seen.insert(q), "{what}: patch {q} loaded twice in a sector");
            }
        }
        let loaded = s.run.loaded_in();
        for (j, &r) in s.rays.iter().enumerate() {
            if let Some(h) = p.reference_hit(r as usize) {
                let at = loaded.get(&h.patch).unwrap_or_else(|| {
                    panic!(
                        "{what}: ray {r} hits patch {} that its sector never loads",
                        h.patch
                    )
                });
                let retired = s.run.retired_after[j].expect("a ray that hits took work");
                assert!(
                    *at <= retired,
                    "{what}: ray {r}: patch active in subshell {at}, retired after {retired}"
                );
            }
        }
    }
}

fn assert_tiling(boxes: &[AngleBox], whole: &AngleBox, what: &str) {
    let m: u128 = boxes.iter().map(|b| b.measure()).sum();
    assert_eq!(m, whole.measure(), "{what}: measures do not add up");
    for (i, a) in boxes.iter().enumerate() {
        assert!(
            a.theta[0] >= whole.theta[0]
                && a.theta[1] <= whole.theta[1]
                && a.phi[0] >= whole.phi[0]
                && a.phi[1] <= whole.phi[1],
            "{what}: {a:?} outside {whole:?}"
        );
        for b in &boxes[i + 1..] {
            assert!(!a.overlaps(b), "{what}: {a:?} overlaps {b:?}");
        }
    }
}

/// The source patch of a run, from the committed scene it was made on.
fn common_scene_patch(p: &Partition) -> shellsim::Patch {
    common::load(&format!("{}.json", p.scene)).patches[p.config.source as usize].clone()
}

fn cfg(source: usize, sections: usize, ctus: usize, ratio: usize, g: Granularity) -> Config {
    let mut c = Config::paper(source as u32, sections, ctus, ratio);
    c.granularity = g;
    c
}

/// Every ray of a scene at ratio 30 (29,070 rays), 4 sections × 4 CTUs: the schedule's
/// nearest hit equals the float tracer's; a small subshell threshold must cut some shell.
fn schedule_finds_the_tracers_nearest_hit(name: &str, g: Granularity, max: usize) {
    let scene = common::load(name);
    let mut c = cfg(0, 4, 4, 30, g);
    c.subshell_max = max;
    let p = run(&scene, &c);
    if max == 4 {
        let split = p
            .sectors
            .iter()
            .any(|s| s.run.subshells.iter().any(|x| x.part > 0));
        assert!(
            split,
            "{name}: a small threshold cuts some shell into subshells"
        );
    }
    assert_hits_equal_tracer(&scene, &p, &format!("{name} {g:?} subshell max {max}"));
    assert_invariants(&p, name);
}

mod schedule_nearest_hit {
    use super::*;
    testcases! { schedule_finds_the_tracers_nearest_hit;
        scene1_subregion_64 => "scene1.json", Granularity::Subregion, 64;
        scene1_ray_4 => "scene1.json", Granularity::Ray, 4;
        scene2_subregion_64 => "scene2.json", Granularity::Subregion, 64;
        scene2_ray_4 => "scene2.json", Granularity::Ray, 4;
    }
}

#[test]
fn every_source_of_scene1() {
    let scene = common::load("scene1.json");
    for source in 0..scene.patches.len() {
        let p = run(&scene, &cfg(source, 3, 2, 1, Granularity::Ray));
        assert_hits_equal_tracer(&scene, &p, &format!("scene1 source {source}"));
        assert_invariants(&p, &format!("scene1 source {source}"));
    }
}

/// Shelling loads under a quarter of the ray-by-ray baseline's patches on scene2.
fn shelling_loads_fewer_patches_than_ray_by_ray_on_scene2(ratio: usize) {
    let scene = common::load("scene2.json");
    let p = run(&scene, &cfg(0, 4, 4, ratio, Granularity::Subregion));
    let (shell, base) = (p.patch_loads(), p.patch_loads_baseline);
    eprintln!(
        "scene2 ratio {ratio}: {shell} loads with shelling, {base} ray by ray ({:.4})",
        shell as f64 / base as f64
    );
    assert!(shell * 4 < base, "ratio {ratio}: {shell} vs {base}");
}

mod shelling_loads {
    use super::*;
    testcases! { shelling_loads_fewer_patches_than_ray_by_ray_on_scene2;
        ratio_1 => 1;
        ratio_10 => 10;
        ratio_30 => 30;
    }
}

#[test]
fn stress_skewed_is_badly_balanced() {
    let skewed = common::load("stress-skewed.json");
    let scene2 = common::load("scene2.json");
    let p = run(&skewed, &cfg(0, 8, 4, 10, Granularity::Subregion));
    let q = run(&scene2, &cfg(0, 8, 4, 10, Granularity::Subregion));
    eprintln!(
        "imbalance P=8: stress-skewed {:.3}, scene2 {:.3}",
        p.imbalance(),
        q.imbalance()
    );
    assert!(p.imbalance() > 2.0, "{}", p.imbalance());
    assert!(p.imbalance() > 1.5 * q.imbalance());
}

#[test]
fn predicted_equals_actual_shape_and_sums() {
    // Section predictions are the sums of their sectors'; intersections equal the jobs of
    // the schedule; each section's work is the sum of its sectors'.
    let scene = common::load("scene2.json");
    let p = run(&scene, &cfg(0, 3, 3, 10, Granularity::Ray));
    let work = p.section_work();
    for (i, w) in work.iter().enumerate() {
        let of: Vec<_> = p.sectors.iter().filter(|s| s.section == i).collect();
        assert_eq!(of.len(), 3);
        assert_eq!(
            w.intersections,
            of.iter().map(|s| s.actual().intersections).sum::<u64>()
        );
        assert_eq!(
            p.predicted_sections[i].intersections,
            of.iter().map(|s| s.predicted.intersections).sum::<u64>()
        );
    }
    let total_low: u64 = p.low.work.iter().map(|w| w.intersections).sum();
    let total_pred: u64 = p.predicted_sections.iter().map(|w| w.intersections).sum();
    assert_eq!(total_pred, 10 * total_low);
    let sched = Schedule::new(&p);
    assert_eq!(
        sched.jobs(),
        work.iter().map(|w| w.intersections).sum::<u64>()
    );
    assert_eq!(sched.sections.len(), 3);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, .. ProptestConfig::default() })]

    /// Random configurations on scene1, cornell and scene2: every ray in exactly one sector,
    /// sectors tile the hemisphere, hit patches active no later than retirement, and the
    /// tracer's nearest hits.
    #[test]
    fn partitions_are_sound(
        which in 0usize..3,
        source_pick in 0usize..1000,
        sections in 1usize..9,
        ctus in 1usize..5,
        ratio in 1usize..4,
        rays_low in 40usize..400,
        sub_t in 1usize..8,
        sub_p in 1usize..9,
        ray_gran in any::<bool>(),
        radius in 0.08f64..0.7,
        subshell_max in 1usize..200,
        seed in 0u64..1000,
    ) {
        let name = ["scene1.json", "cornell.json", "scene2.json"][which];
        let scene = common::load(name);
        // Cornell's floor runs under its blocks: use its natural source there.
        let source = if which == 1 { 1 } else { source_pick % scene.patches.len() };
        let c = Config {
            source: source as u32,
            sections,
            ctus,
            ratio,
            rays_low,
            subregions: (sub_t, sub_p),
            granularity: if ray_gran { Granularity::Ray } else { Granularity::Subregion },
            shell_radius: radius,
            subshell_max,
            seed,
            cell_size: 0.05,
        };
        let p = run(&scene, &c);
        let what = format!("{name} {c:?}");
        assert_invariants(&p, &what);
        assert_hits_equal_tracer(&scene, &p, &what);
    }
}

// --- the command line ---------------------------------------------------------------

fn shellsim(args: &[&str]) -> (Option<i32>, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_shellsim"))
        .args(args)
        .output()
        .expect("the shellsim binary runs");
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn cli_writes_deterministic_json_svg_and_schedule() {
    let dir = tempfile::tempdir().unwrap();
    let scene = common::scene_path("scene2.json");
    let scene = scene.to_str().unwrap();
    let out = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    let (a, b, svg, sched) = (out("a.json"), out("b.json"), out("w.svg"), out("s.json"));
    for json in [&a, &b] {
        let (code, stdout, stderr) = shellsim(&[
            "partition",
            "--scene",
            scene,
            "--source",
            "0",
            "--sections",
            "3",
            "--ctus",
            "2",
            "--ratio",
            "10",
            "--granularity",
            "ray",
            "--json",
            json,
            "--svg",
            &svg,
            "--schedule",
            &sched,
        ]);
        assert_eq!(code, Some(0), "{stdout}{stderr}");
        assert!(stdout.contains("imbalance"), "{stdout}");
    }
    let ja = std::fs::read(&a).unwrap();
    assert_eq!(
        ja,
        std::fs::read(&b).unwrap(),
        "two runs give byte-identical JSON"
    );
    let v: serde_json::Value = serde_json::from_slice(&ja).unwrap();
    let sections = v["sections"].as_array().unwrap();
    assert_eq!(sections.len(), 3);
    for s in sections {
        for k in [
            "intersections",
            "traversals",
            "predicted_intersections",
            "predicted_traversals",
        ] {
            assert!(s[k].is_u64(), "section lacks {k}: {s}");
        }
        assert_eq!(s["sectors"].as_array().unwrap().len(), 2);
    }
    for k in ["imbalance", "patch_loads", "patch_loads_baseline"] {
        assert!(v[k].is_number(), "report lacks {k}");
    }
    assert_eq!(v["nearest_hit_mismatches"], 0);
    let imbalance = v["imbalance"].as_f64().unwrap();
    let isect: Vec<f64> = sections
        .iter()
        .map(|s| s["intersections"].as_f64().unwrap())
        .collect();
    let mean = isect.iter().sum::<f64>() / 3.0;
    let max = isect.iter().cloned().fold(0.0, f64::max);
    assert!((imbalance - max / mean).abs() < 1e-12);
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.starts_with("<svg") && text.contains("ICU"));
    let sched: Schedule = serde_json::from_slice(&std::fs::read(&sched).unwrap()).unwrap();
    assert_eq!(sched.rays, 9690);
    assert_eq!(sched.jobs(), v["intersections"].as_u64().unwrap());
}

/// `shellsim partition --scene scenes/scene1.json ARGS` exits 2 and its message holds `want`.
fn cli_bad_input_exits_2(args: &str, want: &str) {
    let scene = common::scene_path("scene1.json");
    let mut argv = vec!["partition", "--scene", scene.to_str().unwrap()];
    argv.extend(args.split_whitespace());
    let (code, stdout, stderr) = shellsim(&argv);
    assert_eq!(code, Some(2), "{argv:?}\n{stdout}{stderr}");
    assert!(
        stderr.contains(want),
        "{argv:?}: stderr lacks {want:?}\n{stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
}

mod cli_bad_input {
    use super::*;
    const OK: &str = "--source 0 --sections 2 --ctus 2";
    testcases! { cli_bad_input_exits_2;
        source_out_of_range => "--source 26 --sections 2 --ctus 2 --ratio 1", "source patch 26 does not exist";
        zero_sections => "--source 0 --sections 0 --ctus 2 --ratio 1", "--sections 0";
        zero_ctus => "--source 0 --sections 2 --ctus 0 --ratio 1", "--ctus 0";
        zero_ratio => &format!("{OK} --ratio 0"), "--ratio 0";
        absurd_ratio => &format!("{OK} --ratio 100000"), "--ratio 100000";
        zero_shell_radius => &format!("{OK} --ratio 1 --shell-radius 0"), "--shell-radius";
        zero_subshell_max => &format!("{OK} --ratio 1 --subshell-max 0"), "--subshell-max";
        empty_subregions => &format!("{OK} --ratio 1 --subregions 0x5"), "subregions";
        missing_ratio => OK, "--ratio";
    }

    #[test]
    fn missing_scene_file() {
        let (code, _, stderr) = shellsim(&[
            "partition",
            "--scene",
            "/nonexistent.json",
            "--source",
            "0",
            "--sections",
            "2",
            "--ctus",
            "2",
            "--ratio",
            "1",
        ]);
        assert_eq!(code, Some(2), "{stderr}");
        assert!(stderr.contains("nonexistent.json"), "{stderr}");
    }
}
