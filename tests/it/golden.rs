//! Regression goldens: the key statistics of the cycle-level machine (cycles, busy / idle /
//! stalled cycles per unit, patch loads, jobs, memory traffic) per committed scene ×
//! configuration, compared exactly with tests/golden/*.json. `UPDATE_GOLDEN=1 cargo test
//! --release --test it golden::` rewrites them on purpose (review the diff before committing).

use crate::common;

use serde_json::{json, Value};
use shellsim_hw::config::JobSource;
use std::path::{Path, PathBuf};

/// The figures a golden pins.
fn key_figures(s: &shellsim::machine::run::RunStats) -> Value {
    json!({
        "rays": s.rays,
        "cycles": s.cycles,
        "patch_loads": s.patch_loads,
        "jobs": s.jobs,
        "memory_wait_cycles": s.memory.wait_cycles,
        "memory_busy_cycles": s.memory.busy_cycles,
        "clusters": s.clusters.iter().map(|c| json!({
            "icu_busy_cycles": c.icu.busy_cycles,
            "icu_idle_cycles": c.icu.idle_cycles,
            "icu_stalled_cycles": c.icu.stalled_cycles,
            "icu_busy_stage_cycles": c.icu.busy_stage_cycles,
            "ctus": c.ctus.iter().map(|t| json!({
                "busy_cycles": t.busy_cycles,
                "idle_cycles": t.idle_cycles,
                "stalled_cycles": t.stalled_cycles,
                "dda_steps": t.dda_steps,
                "patch_requests": t.patch_requests,
                "jobs_issued": t.jobs_issued,
                "subshells": t.subshells,
            })).collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
    })
}

fn golden(scene_file: &str, config: &str) {
    golden_of(scene_file, config, None);
}

/// A golden of a machine variant (issue 14): `variant` is (job_source, overlap_joins), and
/// its name is part of the golden's file name.
fn golden_variant(scene_file: &str, config: &str, job_source: JobSource, overlap_joins: bool) {
    golden_of(scene_file, config, Some((job_source, overlap_joins)));
}

fn golden_of(scene_file: &str, config: &str, variant: Option<(JobSource, bool)>) {
    let mut cfg = common::config(config);
    let mut suffix = String::new();
    if let Some((source, overlap)) = variant {
        cfg.machine.job_source = source;
        cfg.machine.overlap_joins = overlap;
        suffix = format!(
            "__{}{}",
            source.name(),
            if overlap { "_overlap" } else { "" }
        );
    }
    let r = common::MachineRun::new(scene_file, cfg, common::spec());
    let _e = common::Evidence::for_test(&[&r]);
    let out = r.run();
    assert_eq!(out.stats.mismatches_vs_fixed, 0);
    let text = serde_json::to_string_pretty(&key_figures(&out.stats)).unwrap() + "\n";
    let name = format!(
        "{}__{}{suffix}.json",
        scene_file.trim_end_matches(".json"),
        config
    );
    let path: PathBuf = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/golden")
        .join(&name);
    if std::env::var_os("UPDATE_GOLDEN").is_some() {
        std::fs::write(&path, &text).unwrap();
        return;
    }
    let want = std::fs::read_to_string(&path).unwrap_or_else(|e| {
        panic!(
            "{}: {e}; create it with UPDATE_GOLDEN=1 cargo test --release --test it golden::",
            path.display()
        )
    });
    if want != text {
        let first = want
            .lines()
            .zip(text.lines())
            .position(|(a, b)| a != b)
            .unwrap_or(0);
        panic!(
            "{name} changed (first difference at line {}: golden {:?}, now {:?}).\n\
             If the change is intended: UPDATE_GOLDEN=1 cargo test --release --test it golden::, and review the diff.",
            first + 1,
            want.lines().nth(first),
            text.lines().nth(first)
        );
    }
}

testcases! { golden;
    scene1_paper => "scene1.json", "paper";
    scene1_small => "scene1.json", "small";
    scene2_paper => "scene2.json", "paper";
    scene2_small => "scene2.json", "small";
    cornell_paper => "cornell.json", "paper";
    cornell_small => "cornell.json", "small";
    stress_edges_paper => "stress-edges.json", "paper";
    stress_edges_small => "stress-edges.json", "small";
    stress_grazing_paper => "stress-grazing.json", "paper";
    stress_grazing_small => "stress-grazing.json", "small";
    stress_skewed_paper => "stress-skewed.json", "paper";
    stress_skewed_small => "stress-skewed.json", "small";
    stress_dense_paper => "stress-dense.json", "paper";
    stress_dense_small => "stress-dense.json", "small";
}

testcases! { golden_variant;
    scene2_paper_bundle => "scene2.json", "paper", JobSource::Bundle, false;
    scene2_small_bundle => "scene2.json", "small", JobSource::Bundle, false;
    stress_skewed_paper_bundle => "stress-skewed.json", "paper", JobSource::Bundle, false;
    cornell_paper_bundle => "cornell.json", "paper", JobSource::Bundle, false;
    scene2_paper_bundle_overlap => "scene2.json", "paper", JobSource::Bundle, true;
    scene2_paper_ctu_overlap => "scene2.json", "paper", JobSource::Ctu, true;
}
