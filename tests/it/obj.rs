//! Real OBJ files: scenes/cornell-public.obj, a Cornell box written the way such files are
//! found (y up, about 2 units on a side, the measured non-planar left wall, relative vertex
//! indices, named groups, a material library that is not there), runs through `reference`,
//! `check`, `run` and `size` with no configuration written by hand — 0 unexplained
//! mismatches, 0 machine mismatches — with the light named as the source and marked as the
//! emitter (`--source light`, `--emitter light`); the names reach `scene info` and the
//! radiosity CSV; `--flip` turns faces that face outward; bad input exits 2 naming the
//! file, the line and the face, or the unknown name.

use crate::common;

use shellsim::machine::run::run;
use shellsim::reference::orient::outward_faces;
use shellsim::reference::tracer::Tracer;
use shellsim::scene::{load_with, obj, Edits, Flip, PatchRef, Scene};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const FILE: &str = "cornell-public.obj";

fn path() -> PathBuf {
    common::scene_path(FILE)
}

/// The public box as every command loads it, with `edits`.
fn load(edits: Edits) -> Scene {
    load_with(&path(), &edits)
        .unwrap_or_else(|e| panic!("{e}"))
        .scene
}

/// The patch `name` names (exactly one).
fn id(scene: &Scene, name: &str) -> u32 {
    PatchRef::Name(name.into())
        .resolve(scene, &path())
        .unwrap_or_else(|e| panic!("{e}"))
}

/// `shellsim ARGS` from the repository root, with `{}` in an argument replaced by the public
/// box's path.
fn shellsim(args: &[&str]) -> Output {
    let file = path();
    let file = file.to_str().unwrap();
    Command::new(env!("CARGO_BIN_EXE_shellsim"))
        .args(args.iter().map(|a| a.replace("{}", file)))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap()
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

fn cell(scene: &Scene) -> f64 {
    shellsim::config::cell_size(shellsim::config::built_in().machine.cell_size, scene.size())
}

/// The paper's 969 ring rays from `source`, seed 1 (the commands' default).
fn rings(source: u32) -> shellsim::reference::rays::RaySpec {
    shellsim::reference::rays::RaySpec {
        source,
        rays: 969,
        directions: shellsim::reference::rays::Directions::Rings,
        seed: 1,
    }
}

#[test]
fn import_reads_the_file_as_written() {
    let (s, r) = obj::import(&path(), &obj::ImportOptions::default()).unwrap();
    // 16 quads, the left wall not planar: split into 2 triangles, said once.
    assert_eq!((r.faces, r.mended_faces, r.mended_quads), (16, 1, 1));
    assert_eq!(s.patches.len(), 17);
    assert_eq!(r.warnings.len(), 2, "{:?}", r.warnings);
    assert!(r.warnings[0].contains("cornell-public.mtl not found"));
    assert!(
        r.warnings[0].contains("reflectance 0.5"),
        "{}",
        r.warnings[0]
    );
    assert!(r.warnings[1].starts_with("1 face is not planar and convex: split into 2 triangles"));
    // Not the unit cube: about 2 units on a side, centred on the y axis.
    assert!(
        s.bounds.lo.x < -0.9 && s.bounds.hi.y > 1.9,
        "{:?}",
        s.bounds
    );
    assert!((s.bounds.scale() - 2.02).abs() < 1e-9);
    // Relative indices resolved per face: every patch lies on its own group's geometry.
    let light = &s.patches[id(&s, "light") as usize];
    assert!(light.vertices.iter().all(|v| v.y == 1.96));
    assert!(light.normal().y < -0.999, "the light faces down");
    let floor = &s.patches[id(&s, "floor") as usize];
    assert!(floor.vertices.iter().all(|v| v.y == 0.0));
    // Every patch is named by its group and material; no emitter without `Ke`.
    assert!(s
        .patches
        .iter()
        .all(|p| p.name.is_some() && p.material.is_some()));
    assert!(s.patches.iter().all(|p| !p.emission.is_nonzero()));
    let names: Vec<&str> = s.names().iter().map(|(n, _)| *n).collect();
    assert_eq!(
        names,
        [
            "floor",
            "ceiling",
            "backWall",
            "rightWall",
            "leftWall",
            "light",
            "shortBox",
            "tallBox"
        ]
    );
}

#[test]
fn scene_info_shows_names_warnings_and_the_emitter() {
    let out = shellsim(&["scene", "info", "{}", "--emitter", "light"]);
    let stdout = text(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{stdout}{}", text(&out.stderr));
    assert!(out.stderr.is_empty(), "{}", text(&out.stderr));
    for want in [
        "patches      17 (2 triangles, 15 quads, 1 emitting)",
        "groups       floor 0; ceiling 1; backWall 2; rightWall 3; leftWall 4-5; light 6; shortBox 7-11; tallBox 12-16",
        "materials    floor 0; ceiling 1; backWall 2; rightWall 3; leftWall 4-5; light 6; shortBox 7-11; tallBox 12-16",
        "warning      material library",
        "warning      1 face is not planar and convex",
    ] {
        assert!(stdout.contains(want), "lacks {want:?}:\n{stdout}");
    }
    // Every face of the file faces into the room (or out of its block).
    assert!(!stdout.contains("out of the enclosure"), "{stdout}");
    // Without --emitter the file has no emitter.
    let out = shellsim(&["scene", "info", "{}"]);
    assert!(text(&out.stdout).contains("0 emitting"));
}

#[test]
fn reference_from_the_light() {
    let scene = load(Edits::default());
    let src = id(&scene, "light");
    let spec = rings(src);
    let r = shellsim::reference::cast::run_scene(&scene, &path(), &spec, cell(&scene)).unwrap();
    let f = |name: &str| -> f64 {
        let ids = scene.named(name);
        r.form_factors
            .iter()
            .filter(|f| ids.contains(&f.patch))
            .map(|f| f.value)
            .sum()
    };
    // The box is open at the front: some rays escape; the rest is the form factors.
    let hit: f64 = r.form_factors.iter().map(|f| f.value).sum();
    assert!(
        r.escaped > 0 && r.escaped < r.rays / 2,
        "{} escaped",
        r.escaped
    );
    assert!((r.weight_sum - 1.0).abs() < 1e-9);
    assert!(hit > 0.5 && hit < 1.0, "{hit}");
    // The light faces down: it sees the floor and the blocks, never the ceiling behind it.
    assert_eq!(f("ceiling"), 0.0);
    assert!(
        f("floor") > 0.05 && f("tallBox") > 0.01,
        "{:?}",
        r.form_factors
    );
}

/// `check` from patch `source`, on the built-in datapath: no unexplained mismatch.
fn check_explains_every_mismatch(source: &str) {
    let scene = load(Edits::default());
    let src = source.parse::<PatchRef>().unwrap();
    let src = src.resolve(&scene, &path()).unwrap();
    let spec = rings(src);
    let dp = shellsim::config::built_in().datapath;
    let r = shellsim::fixed::check::check_scene(&scene, &path(), dp, &spec, cell(&scene))
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(r.rays, 969);
    assert_eq!(
        r.unexplained_mismatches, 0,
        "{source}: {:?} — shellsim check --scene scenes/{FILE} --source {source}",
        r.unexplained
    );
}

mod check {
    use super::*;
    testcases! { check_explains_every_mismatch;
        light => "light";
        floor => "floor";
        left_wall_triangle => "4";
        tall_box_top => "12";
    }
}

#[test]
fn run_matches_the_untimed_model() {
    let scene = load(Edits::default());
    let spec = shellsim::machine::run::RunSpec {
        source: id(&scene, "light"),
        ..common::spec()
    };
    let cfg = *shellsim::config::built_in();
    let out = run(&scene, &path(), &cfg, &spec, None).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(out.stats.rays, 969);
    assert!(out.stats.cycles > 0);
    assert_eq!(
        out.stats.mismatches_vs_fixed, 0,
        "shellsim run --scene scenes/{FILE} --source light --ratio 1"
    );
}

#[test]
fn size_meets_the_target() {
    let scene = load(Edits::default());
    let spec = shellsim::size::SizeSpec {
        source: id(&scene, "light"),
        target_error: 1e-3,
        against: shellsim::size::Against::Float,
        ratio: 1,
        max_cycles: None,
        tolerance: 0.01,
        allow_larger: false,
    };
    let base = *shellsim::config::built_in();
    let r = shellsim::size::size(&scene, &path(), &base, &spec).unwrap_or_else(|e| panic!("{e}"));
    assert!(r.measured.ff_err_max <= 1e-3, "{:?}", r.measured);
    assert_eq!(r.measured.mismatches_vs_fixed, 0);
    // The written configuration loads as `--hw` loads it.
    let dir = tempfile::tempdir().unwrap();
    let toml = dir.path().join("machine.toml");
    std::fs::write(&toml, shellsim::size::toml(&r)).unwrap();
    let cfg = shellsim::config::machine(Some(&toml)).unwrap();
    assert_eq!(cfg.datapath, r.machine.datapath);
}

/// `shellsim COMMAND --scene cornell-public.obj --source light --emitter light ARGS` exits 0
/// and prints `want`: the names work on the command line of every command that runs it.
fn command_takes_names(args: &str, want: &str) {
    let mut a = vec!["--scene", "{}", "--source", "light", "--emitter", "light"];
    let mut all: Vec<&str> = args.split_whitespace().collect();
    all.splice(1..1, a.drain(..));
    let out = shellsim(&all);
    let (stdout, stderr) = (text(&out.stdout), text(&out.stderr));
    assert_eq!(out.status.code(), Some(0), "{args}: {stdout}{stderr}");
    assert!(stdout.contains(want), "{args}: lacks {want:?}\n{stdout}");
    // The file's warnings once each on standard error.
    assert_eq!(
        stderr.matches("not planar and convex").count(),
        1,
        "{stderr}"
    );
}

mod command {
    use super::*;
    testcases! { command_takes_names;
        reference => "reference", "from patch 6: 969 rays (rings)";
        check => "check", "unexplained: 0";
        run => "run --ratio 1", "0 mismatches vs fixed";
        size => "size --target-error 1e-2", "# Sizing cornell-public from patch 6";
    }
}

#[test]
fn flip_turns_the_faces_that_face_outward() {
    let outward = |s: &Scene| outward_faces(s, &Tracer::new(s, cell(s)).unwrap());
    let named = |n: &str| Edits {
        flip: Some(Flip::Named(n.into())),
        ..Edits::default()
    };
    assert_eq!(outward(&load(Edits::default())), Vec::<u32>::new());
    // A wall turned out of the room (rule 1), found by name and turned back.
    let mut s = load(named("leftWall"));
    assert_eq!(outward(&s), vec![4, 5]);
    named("leftWall").apply(&mut s, &path()).unwrap();
    assert_eq!(outward(&s), Vec::<u32>::new());
    // A file wound the other way: every wall faces out (the blocks are then closed
    // enclosures of their own, and the light faces the ceiling: neither is found).
    let all = Edits {
        flip: Some(Flip::All),
        ..Edits::default()
    };
    assert_eq!(outward(&load(all)), vec![0, 1, 2, 3, 4, 5]);
    // One face of a block turned into the block (rule 2).
    let mut s = load(Edits::default());
    s.patches[12].flip();
    assert_eq!(outward(&s), vec![12]);
}

#[test]
fn the_radiosity_csv_names_patches() {
    let scene = load(Edits::default());
    let b = vec![[0.0; 3]; scene.patches.len()];
    let csv = shellsim::radiosity::solve::csv(&scene, &b);
    let names: Vec<&str> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap())
        .collect();
    assert_eq!(
        &names[..7],
        [
            "floor",
            "ceiling",
            "backWall",
            "rightWall",
            "leftWall",
            "leftWall",
            "light"
        ]
    );
    // Unnamed patches keep `patch<id>`; a name with a comma or a quote is quoted.
    let mut plain = common::load("cornell.json");
    let csv = shellsim::radiosity::solve::csv(&plain, &vec![[0.0; 3]; plain.patches.len()]);
    assert!(csv.lines().nth(2).unwrap().starts_with("1,patch1,"));
    plain.patches[1].name = Some("a \"b\", c".into());
    let csv = shellsim::radiosity::solve::csv(&plain, &vec![[0.0; 3]; plain.patches.len()]);
    assert!(
        csv.lines()
            .nth(2)
            .unwrap()
            .starts_with("1,\"a \"\"b\"\", c\","),
        "{csv}"
    );
}

/// The public box with `extra` appended (face 17 on the line after the file's last).
fn broken(extra: &str, want: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let text_in = std::fs::read_to_string(path()).unwrap();
    let line = text_in.lines().count() + extra.lines().count();
    let bad = dir.path().join("bad.obj");
    std::fs::write(&bad, format!("{text_in}{extra}")).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_shellsim"))
        .args([
            "check",
            "--scene",
            bad.to_str().unwrap(),
            "--source",
            "light",
        ])
        .output()
        .unwrap();
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(out.stdout.is_empty());
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(stderr.contains("bad.obj: "), "{stderr}");
    assert!(
        stderr.contains(&format!("line {line}")),
        "line {line}: {stderr}"
    );
    for w in want {
        assert!(stderr.contains(w), "lacks {w:?}: {stderr}");
    }
}

mod broken_face {
    use super::*;
    testcases! { broken;
        bow_tie => "v 0 0 0\nv 0.5 0 0\nv 0 0.5 0\nv 0.25 0.5 0\nf -4 -3 -2 -1\n", &["face 17 (", "patch 17)", "no fan of triangles"];
        collinear => "v 0 0.5 0\nv 0.5 0.5 0\nv 0.9 0.5 0\nf -3 -2 -1\n", &["face 17 (", "zero area"];
        nan => "v nan 0 0\nv 0.5 0 0\nv 0 0.5 0\nf -3 -2 -1\n", &["face 17 (", "not a finite point"];
        index_beyond => "f 1 2 999\n", &["face 17", "vertex index 999 is beyond"];
        relative_index_beyond => "f -1 -2 -999\n", &["face 17", "vertex index -999 is beyond"];
    }
}

/// `shellsim ARGS` on the public box exits 2 and says `want`.
fn refused(args: &str, want: &[&str]) {
    let all: Vec<&str> = args.split_whitespace().collect();
    let out = shellsim(&all);
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{args}: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    for w in want {
        assert!(stderr.contains(w), "{args}: lacks {w:?}: {stderr}");
    }
}

mod refused {
    use super::*;
    testcases! { refused;
        unknown_emitter => "scene info {} --emitter lamp", &["cornell-public.obj: --emitter: no group, object or material is named \"lamp\"", "its names: floor, ceiling"];
        unknown_flip => "reference --scene {} --source 0 --flip lamp", &["--flip: no group, object or material is named \"lamp\""];
        unknown_source => "check --scene {} --source lamp", &["--source: no group, object or material is named \"lamp\""];
        source_names_several => "run --scene {} --source shortBox", &["--source: \"shortBox\" names 5 patches (7, 8, 9, 10, 11)"];
        name_in_a_json_scene => "reference --scene scenes/cornell.json --source light", &["cornell.json: --source", "the scene has no names"];
    }
}

#[test]
fn a_json_scene_without_names_is_written_as_before() {
    // The committed scenes have no names: their JSON form is unchanged, byte for byte.
    let p = common::scene_path("cornell.json");
    let text_in = std::fs::read_to_string(&p).unwrap();
    let s = Scene::load_json(Path::new(&p)).unwrap();
    assert_eq!(s.to_json_string(), text_in);
    // The imported public box keeps its names through JSON.
    let named = load(Edits::default());
    let back = Scene::from_json_str(&named.to_json_string(), Path::new("x.json")).unwrap();
    assert_eq!(back, named);
}

/// The default picture of a y-up OBJ looks horizontally into the room: with no `.mtl` and
/// no `--emitter` the up axis is the file's convention (y); with the light named as the
/// emitter it is the light's (facing down y). Either way the floor fills the lower half of
/// the image and the ceiling the upper.
#[test]
fn the_default_camera_looks_into_a_y_up_room() {
    use shellsim::radiosity::render::{cast, up_axis, Camera};
    for emitter in [None, Some("light")] {
        let scene = load(Edits {
            emitter: emitter.map(String::from),
            ..Edits::default()
        });
        let (up, why) = up_axis(&scene, &path());
        assert_eq!(up, 1, "{emitter:?}: {why}");
        let cam = Camera::default_for(&scene, up);
        let tracer = Tracer::new(&scene, cell(&scene)).unwrap();
        let h = 64;
        let hits = cast(&tracer, &cam, 64, h);
        let rows_of = |name: &str| -> Vec<u32> {
            let ids: Vec<u32> = scene
                .patches
                .iter()
                .enumerate()
                .filter(|(_, p)| p.name.as_deref() == Some(name))
                .map(|(i, _)| i as u32)
                .collect();
            (0..hits.hits.len())
                .filter(|&k| hits.hits[k].is_some_and(|(p, _)| ids.contains(&p)))
                .map(|k| k as u32 / hits.width)
                .collect()
        };
        let (floor, ceiling) = (rows_of("floor"), rows_of("ceiling"));
        assert!(!floor.is_empty() && !ceiling.is_empty(), "{emitter:?}");
        assert!(
            floor.iter().all(|&r| r >= h / 2),
            "{emitter:?}: floor pixels above the middle"
        );
        assert!(
            ceiling.iter().all(|&r| r < h / 2),
            "{emitter:?}: ceiling pixels below the middle"
        );
    }
}

/// A file where nothing emits is refused by `radiosity` (exit 2) with `--emitter` and the
/// file's names, instead of a black picture.
#[test]
fn radiosity_without_an_emitter_names_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r");
    let o = shellsim(&["radiosity", "--scene", "{}", "--out", out.to_str().unwrap()]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("no patch emits light"), "{err}");
    assert!(err.contains("--emitter NAME"), "{err}");
    assert!(err.contains("ceiling, floor, leftWall, light"), "{err}");
    assert!(!out.exists(), "nothing written");
}

/// A file written the way some exporters write it — `g NAME` after its faces, a group
/// whose faces change material — is warned about with the lines, and `scene info` lists
/// groups and materials apart.
#[test]
fn names_that_follow_their_faces_are_warned_about() {
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("boxes.obj");
    std::fs::write(
        &f,
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\n\
         usemtl white\nf 1 2 3 4\ng shortBox\n\
         usemtl white\nf 1 2 6 5\nusemtl red\nf 4 3 2 1\ng tallBox\n",
    )
    .unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_shellsim"))
        .args(["scene", "info"])
        .arg(&f)
        .output()
        .unwrap();
    let out = text(&o.stdout);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    assert!(
        out.contains("1 group or object statement with no face after it (line 14 `tallBox`)"),
        "{out}"
    );
    assert!(
        out.contains("group `shortBox` spans 2 materials (white, red, from lines 11, 13)"),
        "{out}"
    );
    assert!(out.contains("groups       shortBox 1-2"), "{out}");
    assert!(out.contains("materials    white 0-1; red 2"), "{out}");
}

/// A planar convex face of many vertices (a 20,000-gon) is split into well-shaped
/// triangles, not a fan whose slivers all meet at one vertex and crowd its grid cells: no
/// vertex is shared by more than about 2·log₂ n triangles, and the triangles tile the face.
#[test]
fn a_face_of_many_vertices_is_split_without_a_fan() {
    let n = 20_000;
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("disc.obj");
    let mut text = String::new();
    for i in 0..n {
        let a = std::f64::consts::TAU * i as f64 / n as f64;
        text.push_str(&format!("v {:.12} {:.12} 0\n", a.cos(), a.sin()));
    }
    text.push('f');
    for i in 1..=n {
        text.push_str(&format!(" {i}"));
    }
    text.push('\n');
    std::fs::write(&f, text).unwrap();
    let (s, r) = obj::import(&f, &obj::ImportOptions::default()).unwrap();
    assert_eq!((r.split_faces, s.patches.len()), (1, n - 2));
    let mut degree = std::collections::HashMap::<[u64; 3], usize>::new();
    for p in &s.patches {
        for v in &p.vertices {
            *degree.entry(v.to_array().map(f64::to_bits)).or_default() += 1;
        }
    }
    let most = degree.values().copied().max().unwrap();
    assert!(most <= 2 * 15 + 2, "a vertex shared by {most} triangles");
    let area: f64 = s.patches.iter().map(|p| p.area()).sum();
    let want = 0.5 * n as f64 * (std::f64::consts::TAU / n as f64).sin();
    assert!((area - want).abs() < 1e-6, "{area} vs {want}");
}
