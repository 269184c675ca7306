//! `shellsim stability`: per case, at the default format, the float reference leaks nothing,
//! double-hits nothing and its DDA neither skips nor repeats a cell; the fixed-point model
//! has no unexplained difference and no leak; the machine equals the untimed model with the
//! configuration's buffers and with the smallest, and never deadlocks. A source lying on
//! another patch is warned about by name and every hit on that patch is classed. The
//! committed docs/stability.* regenerate byte for byte with the command they name.

use crate::common;

use shellsim::fixed::records::HostFixed;
use shellsim::stability::cases::generate_case;
use shellsim::stability::{self, report, CaseReport, Counts, Model, Options};
use shellsim_hw::Exceptions;
use std::path::Path;

/// Rays per case in these tests.
const RAYS: usize = 300;

fn options(case: &str) -> Options {
    Options {
        cases: vec![case.into()],
        rays: RAYS,
        seed: 1,
        bits: 12..=12,
        config: *shellsim::config::built_in(),
    }
}

/// The case at the default format only.
fn run(case: &str) -> CaseReport {
    let opts = options(case);
    let c = generate_case(case, RAYS, 1).unwrap();
    stability::run_case(&c, &opts, &[opts.config.datapath.frac_bits]).unwrap()
}

fn counts(r: &CaseReport, m: Model) -> &Counts {
    &report::find(r, m, shellsim::config::built_in().datapath.frac_bits)
        .unwrap_or_else(|| panic!("{}: no {m:?} row", r.name))
        .counts
}

/// The properties every case must have; the command reproduces a failure.
fn holds_on(case: &str) {
    let r = run(case);
    let repro = format!(
        "reproduce: shellsim stability --cases {case} --rays {RAYS} --frac-bits 12..=12 --out DIR"
    );
    let f = counts(&r, Model::Float);
    assert_eq!(f.rays, RAYS as u64, "{repro}");
    assert_eq!(
        (f.leaks, f.double_hits),
        (Some(0), Some(0)),
        "float leaks / double hits; {repro}"
    );
    assert_eq!(
        (f.dda_skipped, f.dda_repeated),
        (Some(0), Some(0)),
        "float DDA; {repro}"
    );
    // The float reference's differences from the exact answer are ties or grazing only.
    let c = f.classes;
    assert_eq!(c.grazing + c.tie, f.differ, "float classes {c:?}; {repro}");
    let x = counts(&r, Model::Fixed);
    assert_eq!(x.classes.unexplained, 0, "fixed unexplained; {repro}");
    assert_eq!(x.leaks, Some(0), "fixed leaks; {repro}");
    assert_eq!(
        (x.dda_skipped, x.dda_repeated),
        (Some(0), Some(0)),
        "fixed DDA; {repro}"
    );
    for m in [Model::Machine, Model::MachineMin] {
        let k = counts(&r, m);
        assert_eq!(
            (k.machine_mismatches, k.deadlocks),
            (Some(0), Some(0)),
            "{m:?}; {repro}"
        );
        // Equal hits, so equal differences (the machine runs the rays that have a record).
        if k.rays == x.rays {
            assert_eq!(k.differ, x.differ, "{m:?} differences; {repro}");
        } else {
            assert_eq!(x.rays - k.rays, x.classes.overflow, "{m:?}; {repro}");
        }
    }
    match case {
        // Exact by construction and watertight: no difference at all.
        "shared-edge" | "shared-vertex" | "cell-boundary" | "axis-directions" => {
            assert_eq!((f.differ, x.differ), (0, 0), "{repro}");
        }
        // Overflow is counted, never silent: every ray the format cannot hold is an
        // overflow and its difference is classed so.
        "format-limits" => {
            let ovf = x.overflow.unwrap();
            assert!(ovf > 0, "{repro}");
            assert_eq!(x.classes.overflow, ovf, "{repro}");
        }
        "coplanar-overlap" => assert!(f.classes.tie > 0, "{repro}"),
        "grazing" => assert!(x.classes.grazing > 0, "{repro}"),
        // Rays leaving their source start an LSB inside it and off its plane
        // (`HostFixed::ray_from`): neither the wall it meets nor the floor a tile lies on
        // is missed or met at t = 0 at the default width.
        "near-origin" | "coplanar-source" => assert_eq!(x.differ, 0, "{repro}"),
        _ => {}
    }
}

mod cases {
    use super::*;
    testcases! { holds_on;
        shared_edge => "shared-edge";
        shared_vertex => "shared-vertex";
        cell_boundary => "cell-boundary";
        axis_directions => "axis-directions";
        grazing => "grazing";
        near_origin => "near-origin";
        coplanar_overlap => "coplanar-overlap";
        coplanar_source => "coplanar-source";
        tiny_patches => "tiny-patches";
        whole_scene_patches => "whole-scene-patches";
        slivers => "slivers";
        cell_corner => "cell-corner";
        format_limits => "format-limits";
        stress_edges => "stress-edges";
        stress_grazing => "stress-grazing";
        stress_skewed => "stress-skewed";
        stress_dense => "stress-dense";
    }
}

/// Every case has a test above.
#[test]
fn every_case_is_tested() {
    assert_eq!(stability::all_cases().len(), 17);
}

/// A source tile lying on the floor: a warning names both patches; the fixed-point rays
/// start an LSB off the tile's plane, so none meets the floor at the default width (the
/// float test meets its plane at exactly t = 0: no hit), and the report's
/// `coplanar_source` count is exactly the rays that do.
#[test]
fn a_source_lying_on_the_floor_is_warned_about_and_classed() {
    let case = generate_case("coplanar-source", RAYS, 1).unwrap();
    assert_eq!(case.scene.lying_on(case.source), vec![0]);
    let w = stability::warnings(&case);
    assert_eq!(w.len(), 1);
    assert!(
        w[0].contains("patch 6 (the source)") && w[0].contains("lies on patch 0"),
        "{w:?}"
    );
    let cfg = shellsim::config::built_in().datapath;
    let host = HostFixed::new(&case.scene, Path::new("coplanar-source"), cfg, 0.05).unwrap();
    let on_floor = case
        .rays
        .iter()
        .enumerate()
        .filter(|(i, _)| {
            let rec = stability::record(&host, &case, *i).unwrap();
            let mut e = Exceptions::default();
            host.scene
                .nearest_grid(&rec, Some(6), &mut e)
                .0
                .map(|h| h.patch)
                == Some(0)
        })
        .count() as u64;
    // Started an LSB off its plane (`ray_from`), no ray of the tile meets the floor at the
    // default width, and the report classes exactly those that do.
    assert_eq!(on_floor, 0, "rays from the tile meet the floor");
    let r = run("coplanar-source");
    assert_eq!(counts(&r, Model::Fixed).classes.coplanar_source, on_floor);
    // Tiles that only share edges (scene2's floor) lie on nothing.
    let s2 = common::load("scene2.json");
    assert!(s2.lying_on(0).is_empty());
}

/// The committed docs/stability.{md,csv,svg} are what the command in the markdown writes.
#[test]
fn the_committed_report_regenerates_byte_identically() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let md = std::fs::read_to_string(root.join("docs/stability.md")).unwrap();
    let cmd = md
        .lines()
        .find_map(|l| {
            l.split('`')
                .nth(1)
                .filter(|c| c.starts_with("shellsim stability"))
        })
        .expect("the markdown names its command");
    let dir = tempfile::tempdir().unwrap();
    let args: Vec<String> = cmd
        .split_whitespace()
        .skip(1)
        .map(|a| {
            if a == "docs" {
                dir.path().display().to_string()
            } else {
                a.to_string()
            }
        })
        .collect();
    assert!(args.iter().any(|a| a == "--out"), "{cmd}");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_shellsim"))
        .args(&args)
        .current_dir(root)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{cmd}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    for f in report::FILES {
        let want = std::fs::read(root.join("docs").join(f)).unwrap();
        let mut got = std::fs::read(dir.path().join(f)).unwrap();
        if f == "stability.md" {
            // The markdown names the directory it was written to.
            got = String::from_utf8(got)
                .unwrap()
                .replace(&dir.path().display().to_string(), "docs")
                .into_bytes();
        }
        assert!(got == want, "docs/{f} differs from what `{cmd}` writes");
    }
}

/// `shellsim check` on a scene whose source lies on the floor warns, naming both patches,
/// and still accounts for every difference (exit 0).
#[test]
fn check_warns_about_a_source_lying_on_another_patch() {
    let case = generate_case("coplanar-source", 10, 1).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("tile.json");
    case.scene.save_json(&file).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_shellsim"))
        .args(["check", "--scene"])
        .arg(&file)
        .args(["--source", "6", "--rays", "2000"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("patch 6 (the source) lies on patch 0"),
        "no warning: {err}"
    );
}
