//! `shellsim size`: the machine it writes loads with `--hw`, meets the target when run (0
//! mismatches against the untimed model), and costs fewer bits than paper.toml; targets no
//! machine can meet are refused with exit status 2 and a message saying what was tried.

use crate::common;

use shellsim::machine::run::run;
use shellsim::size::{size, Against, SizeSpec};
use std::path::Path;
use std::process::Command;

fn spec(source: u32, e: f64) -> SizeSpec {
    SizeSpec {
        source,
        target_error: e,
        against: Against::Float,
        ratio: 1,
        max_cycles: None,
        tolerance: 0.01,
        allow_larger: false,
    }
}

/// Sizes `file` for E = 1e-3, writes the TOML, loads it as `--hw` does and runs it.
fn sized_machine_meets_the_target(file: &str, source: u32) {
    let scene = common::load(file);
    let path = common::scene_path(file);
    let base = common::config("paper");
    let r = size(&scene, &path, &base, &spec(source, 1e-3)).unwrap();
    assert!(r.measured.ff_err_max <= 1e-3, "{file}: {:?}", r.measured);
    assert_eq!(r.measured.mismatches_vs_fixed, 0);
    assert!(
        r.measured.cost.total_bits < r.base.cost.total_bits,
        "{file}: sized {} bits, paper.toml {}",
        r.measured.cost.total_bits,
        r.base.cost.total_bits
    );
    // The base is the ceiling of what buys cycles: no buffer or shape grew.
    let (m, b) = (&r.machine, &base);
    assert!(m.machine.ray_buffer_capacity <= b.machine.ray_buffer_capacity);
    assert!(m.machine.patch_buffer_capacity <= b.machine.patch_buffer_capacity);
    assert!(m.machine.request_queue_capacity <= b.machine.request_queue_capacity);
    assert!(m.machine.clusters <= b.machine.clusters);
    // The bisection's evidence: the chosen width meets, one fewer does not.
    let at = |b: u32| r.bits.iter().find(|t| t.frac_bits == b).map(|t| t.meets);
    assert_eq!(at(r.frac_bits), Some(true));
    assert_eq!(at(r.frac_bits - 1), Some(false), "{:?}", r.bits);
    // The written configuration loads and, run, gives what the report says.
    let dir = tempfile::tempdir().unwrap();
    let toml = dir.path().join("machine.toml");
    std::fs::write(&toml, shellsim::size::toml(&r)).unwrap();
    let cfg = shellsim::config::machine(Some(&toml)).unwrap();
    let spec = shellsim::machine::run::RunSpec {
        source,
        ..common::spec()
    };
    let out = run(&scene, Path::new(file), &cfg, &spec, None).unwrap();
    assert_eq!(out.stats.mismatches_vs_fixed, 0);
    assert_eq!(out.stats.cycles, r.measured.cycles);
}

testcases! { sized_machine_meets_the_target;
    cornell => "cornell.json", 1;
    scene2 => "scene2.json", 0;
}

/// `shellsim size ARGS` on cornell exits 2 and says `want`.
fn refused(args: &str, want: &str) {
    let scene = common::scene_path("cornell.json");
    let out = Command::new(env!("CARGO_BIN_EXE_shellsim"))
        .args(["size", "--scene", scene.to_str().unwrap(), "--source", "1"])
        .args(args.split_whitespace())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{args}: {stderr}");
    assert!(stderr.contains(want), "{args}: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}

mod refused {
    use super::*;
    testcases! { refused;
        zero_target => "--target-error 0", "not a positive form-factor error";
        negative_target => "--target-error -1e-3", "not a positive form-factor error";
        below_the_estimators_own_error => "--target-error 1e-6 --against reference", "below the float estimator's own error";
        no_machine_fast_enough => "--target-error 1e-2 --max-cycles 10 --allow-larger", "no machine up to 64 clusters";
        no_machine_within_the_base => "--target-error 1e-2 --max-cycles 10", "no machine up to the base configuration's 4 clusters × 2 CTUs";
        rays_not_a_multiple => "--target-error 1e-2 --rays 1000", "not a positive multiple of 969";
    }
}
