//! Malformed scenes, JSON and OBJ, one test per kind: `shellsim scene info FILE` must exit
//! with status 2 and say which file and which patch (or face, line) is wrong, without
//! panicking; a valid scene must exit 0, so that these tests can fail both ways.

use std::path::Path;
use std::process::Command;

/// Runs `shellsim scene info FILE`; returns the exit status, stdout and stderr.
fn scene_info(file: &Path) -> (Option<i32>, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_shellsim"))
        .args(["scene", "info"])
        .arg(file)
        .output()
        .expect("the shellsim binary runs");
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Writes `files` (name, contents) into a fresh directory, runs `scene info` on `run` in
/// it and checks the exit status and, for a failure, that stderr names `run` and holds
/// every string of `want`; for success, that stdout holds them.
fn check_files(files: &[(&str, &[u8])], run: &str, status: i32, want: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    for (name, bytes) in files {
        std::fs::write(dir.path().join(name), bytes).unwrap();
    }
    let (code, stdout, stderr) = scene_info(&dir.path().join(run));
    let shown = format!("status {code:?}\n--- stdout\n{stdout}--- stderr\n{stderr}");
    assert_eq!(code, Some(status), "{shown}");
    assert!(!stderr.contains("panicked"), "{shown}");
    if status == 0 {
        assert!(stderr.is_empty(), "{shown}");
        for w in want {
            assert!(stdout.contains(w), "stdout lacks {w:?}\n{shown}");
        }
    } else {
        assert!(stdout.is_empty(), "{shown}");
        assert!(stderr.starts_with("error: "), "{shown}");
        assert!(stderr.contains(run), "stderr does not name {run}\n{shown}");
        for w in want {
            assert!(stderr.contains(w), "stderr lacks {w:?}\n{shown}");
        }
    }
}

/// [`check_files`] with one file.
fn check(name: &str, text: impl AsRef<[u8]>, status: i32, want: &[&str]) {
    check_files(&[(name, text.as_ref())], name, status, want);
}

/// A JSON scene with the given bounds: three good patches (0-2), then `extra` as patch 3
/// on line 8 of the file, one patch a line.
fn json_scene(bounds: &str, extra: Option<&str>) -> String {
    let mut patches = vec![
        r#"{"vertices": [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], "emission": 1}"#,
        r#"{"vertices": [[0, 0, 1], [0, 1, 1], [1, 1, 1], [1, 0, 1]], "reflectance": [0.2, 0.4, 0.6]}"#,
        r#"{"vertices": [[0, 0, 0], [0, 0, 1], [1, 0, 1]]}"#,
    ];
    patches.extend(extra);
    format!(
        "{{\n  \"name\": \"t\",\n  \"bounds\": {bounds},\n  \"patches\": [\n    {}\n  ]\n}}\n",
        patches.join(",\n    ")
    )
}

const BOUNDS: &str = "[[-1, -1, -1], [2, 2, 2]]";

/// [`json_scene`] with [`BOUNDS`] and `patch` as patch 3.
fn json_with(patch: &str) -> String {
    json_scene(BOUNDS, Some(patch))
}

/// A patch with the given vertices (JSON text of the list).
fn json_patch(vertices: &str) -> String {
    format!(r#"{{"vertices": {vertices}}}"#)
}

/// An OBJ scene: the 8 corners of the unit cube, three good faces (1-3, patches 0-2),
/// then `extra` (more vertices from index 9, and face 4 = patch 3).
fn obj_with(extra: &str) -> String {
    let mut s = String::new();
    for (x, y, z) in [
        (0, 0, 0),
        (1, 0, 0),
        (1, 1, 0),
        (0, 1, 0),
        (0, 0, 1),
        (1, 0, 1),
        (1, 1, 1),
        (0, 1, 1),
    ] {
        s.push_str(&format!("v {x} {y} {z}\n"));
    }
    s.push_str("f 1 2 3 4\nf 5 8 7 6\nf 1 5 6 2\n");
    s.push_str(extra);
    s
}

/// One `#[test]` per case: `name: file, contents => exit status, [strings stderr holds]`.
macro_rules! cases {
    ($($name:ident: $file:expr, $text:expr => $status:expr, [$($want:expr),* $(,)?];)*) => {
        $(
            #[test]
            fn $name() {
                check($file, $text, $status, &[$($want),*]);
            }
        )*
    };
}

cases! {
    // --- valid scenes: the tests must be able to fail the other way too.
    json_valid_scene: "valid.json", json_scene(BOUNDS, None) => 0, ["patches      3 ("];
    obj_valid_scene: "valid.obj",
        obj_with("v 0 1.3 0.5\nv 0 -0.3 0.5\nf 1 4 9 8 5 10\nl 1 7\n") => 0, ["patches      7 ("];

    // --- JSON: patch geometry.
    json_non_planar_quad: "nonplanar.json",
        json_with(&json_patch("[[0, 0, 0], [1, 0, 0], [1, 1, 0.5], [0, 1, 0]]"))
        => 2, ["patch 3", "not planar"];
    json_non_convex_quad: "nonconvex.json",
        json_with(&json_patch("[[0, 0, 0], [1, 0, 0], [0.3, 0.3, 0], [0, 1, 0]]"))
        => 2, ["patch 3", "not convex"];
    json_bowtie_quad: "bowtie.json",
        json_with(&json_patch("[[0, 0, 0], [1, 1, 0], [1, 0, 0], [0, 1, 0]]"))
        => 2, ["patch 3"];
    json_two_vertices: "two_vertices.json",
        json_with(&json_patch("[[0, 0, 0], [1, 0, 0]]"))
        => 2, ["patch 3", "has 2 vertices"];
    json_no_vertices: "no_vertices.json",
        json_with(&json_patch("[]")) => 2, ["patch 3", "has 0 vertices"];
    json_five_vertices: "five_vertices.json",
        json_with(&json_patch("[[0, 0, 0], [1, 0, 0], [1.5, 0.5, 0], [1, 1, 0], [0, 1, 0]]"))
        => 2, ["patch 3", "has 5 vertices"];
    json_zero_area_collinear: "collinear.json",
        json_with(&json_patch("[[0, 0, 0], [0.5, 0, 0], [1, 0, 0]]"))
        => 2, ["patch 3", "zero area"];
    json_coincident_vertices: "coincident.json",
        json_with(&json_patch("[[0, 0, 0], [1, 0, 0], [1, 0, 0], [0, 1, 0]]"))
        => 2, ["patch 3", "coincide"];
    json_vertex_outside_bounds: "outside.json",
        json_with(&json_patch("[[0, 0, 0], [3, 0, 0], [0, 1, 0]]"))
        => 2, ["patch 3", "vertex 1", "outside the bounds"];
    json_vertex_not_a_point: "not_a_point.json",
        json_with(&json_patch("[[0, 0], [1, 0, 0], [0, 1, 0]]")) => 2, ["patch 3"];

    // --- JSON: numbers (JSON has no NaN or infinity; an out-of-range number is a parse error).
    json_number_overflows: "overflow.json",
        json_with(&json_patch("[[0, 0, 0], [1e999, 0, 0], [0, 1, 0]]"))
        => 2, ["line 8 column", "out of range"];
    json_nan_literal: "nan.json",
        json_with(&json_patch("[[0, 0, 0], [NaN, 0, 0], [0, 1, 0]]"))
        => 2, ["line 8 column"];
    json_huge_number: "huge.json",
        json_with(&json_patch("[[0, 0, 0], [1e300, 0, 0], [0, 1, 0]]"))
        => 2, ["patch 3", "out of range"];
    json_infinite_bounds: "infinite_bounds.json",
        json_scene("[[-1, -1, -1], [2, 1e999, 2]]", None) => 2, ["line 3 column"];

    // --- JSON: materials.
    json_negative_reflectance: "negative_reflectance.json",
        json_with(r#"{"vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "reflectance": -0.1}"#)
        => 2, ["patch 3", "reflectance"];
    json_reflectance_above_one: "bright_reflectance.json",
        json_with(r#"{"vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "reflectance": [0.5, 1.5, 0.5]}"#)
        => 2, ["patch 3", "reflectance", "at most 1"];
    json_negative_emission: "negative_emission.json",
        json_with(r#"{"vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "emission": [1, -1, 1]}"#)
        => 2, ["patch 3", "emission"];

    // --- JSON: bounds.
    json_bounds_lo_not_below_hi: "flat_bounds.json",
        json_scene("[[-1, 0, -1], [2, 0, 2]]", None) => 2, ["bounds", "lo < hi"];
    json_bounds_reversed: "reversed_bounds.json",
        json_scene("[[2, 2, 2], [-1, -1, -1]]", None) => 2, ["bounds", "lo < hi"];

    // --- JSON: schema.
    json_unknown_patch_field: "colour.json",
        json_with(r#"{"vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "colour": 0.5}"#)
        => 2, ["patch 3", "unknown field `colour`"];
    json_unknown_top_level_field: "top_colour.json",
        json_scene(BOUNDS, None).replacen("{\n", "{\n  \"colour\": 1,\n", 1)
        => 2, ["top level", "unknown field `colour`"];
    json_missing_patch_field: "missing_vertices.json",
        json_with(r#"{"reflectance": 0.5}"#) => 2, ["patch 3", "missing field `vertices`"];
    json_missing_top_level_field: "missing_bounds.json",
        json_scene(BOUNDS, None).replacen(&format!("  \"bounds\": {BOUNDS},\n"), "", 1)
        => 2, ["top level", "missing field `bounds`"];
    json_wrong_type: "wrong_type.json",
        json_with(r#"{"vertices": "a triangle"}"#) => 2, ["patch 3", "invalid type"];
    json_not_json: "not_json.json",
        "this is not a scene\n" => 2, ["line 1 column", "not valid JSON"];
    json_truncated: "truncated.json",
        &json_scene(BOUNDS, None)[..60] => 2, ["not valid JSON"];
    json_empty_file: "empty.json", "" => 2, ["not valid JSON"];
    json_empty_patch_list: "no_patches.json",
        "{\"name\": \"t\", \"bounds\": [[0, 0, 0], [1, 1, 1]], \"patches\": []}" => 2, ["no patches"];

    // --- OBJ: face geometry. Face 4 is patch 3, on line 12, or 13 after one extra vertex.
    // Faces that are not planar and convex but not broken are split, said once.
    obj_non_planar_quad: "nonplanar.obj",
        obj_with("f 1 2 7 4\n") => 0, ["patches      5 (", "warning      1 face is not planar and convex: split into 2 triangles"];
    obj_non_convex_quad: "nonconvex.obj",
        obj_with("v 0.3 0.3 0\nf 1 2 9 4\n") => 0, ["patches      5 (", "1 face is not planar and convex"];
    obj_non_convex_pentagon: "nonconvex5.obj",
        obj_with("v 0.3 0.3 0\nf 1 2 9 3 4\n") => 0, ["patches      6 (", "1 face is not planar and convex: split into 3 triangles"];
    obj_bow_tie_quad: "bowtie.obj",
        obj_with("v 2 0 0\nf 1 9 4 3\n") => 2, ["face 4 (line 13, patch 3)", "no fan of triangles"];
    obj_star_pentagon: "star.obj",
        obj_with("v 0.5 1.5 0\nv 1.2 -0.6 0\nv -0.2 0.6 0\nv 1.2 0.6 0\nv -0.2 -0.6 0\nf 9 10 11 12 13\n")
        => 2, ["face 4 (line 17, patches 3 to 5)", "no fan of triangles"];
    obj_zero_area_triangle: "collinear.obj",
        obj_with("v 0.5 0 0\nf 1 9 2\n") => 2, ["face 4 (line 13, patch 3)", "zero area"];
    obj_coincident_vertices: "coincident.obj",
        obj_with("f 1 2 2 3\n") => 2, ["face 4 (line 12, patch 3)", "coincide"];
    obj_nan_vertex: "nan.obj",
        obj_with("v nan 0 0\nf 9 2 3\n") => 2, ["face 4 (line 13, patch 3)", "not a finite point"];
    obj_infinite_vertex: "infinite.obj",
        obj_with("v 1e999 0 0\nf 9 2 3\n") => 2, ["face 4 (line 13, patch 3)", "not a finite point"];

    // --- OBJ: what tobj rejects or what is not a face.
    obj_two_vertex_face: "two_vertices.obj",
        obj_with("f 1 2\n") => 2, ["face 4 (line 12, patch 3)", "has 2 vertices"];
    obj_one_vertex_face: "one_vertex.obj",
        obj_with("f 1\n") => 2, ["face 4 (line 12, patch 3)", "has 1 vertex"];
    obj_index_out_of_range: "index_range.obj",
        obj_with("f 1 2 99\n") => 2, ["face vertex index out of bounds"];
    obj_index_zero: "index_zero.obj",
        obj_with("f 0 1 2\n") => 2, ["face vertex index out of bounds"];
    obj_bad_index: "bad_index.obj",
        obj_with("f 1 2 three\n") => 2, ["face parse error"];
    obj_short_vertex: "short_vertex.obj",
        obj_with("v 1 2\n") => 2, ["position parse error"];
    obj_garbage_text: "garbage.obj",
        "this is not an OBJ file\n{\"patches\": []}\n" => 2, ["no faces"];
    obj_only_lines: "lines.obj",
        "v 0 0 0\nv 1 0 0\nl 1 2\n" => 2, ["no faces"];
    obj_not_utf8: "binary.obj",
        b"v 0 0 0\n\xff\xfe\x00\x01\n" => 2, ["not UTF-8"];
}

// --- A file that does not exist or cannot be read: bad input (status 2).

#[test]
fn json_missing_file() {
    check_files(&[], "missing.json", 2, &["cannot read", "No such file"]);
}

#[test]
fn obj_missing_file() {
    check_files(&[], "missing.obj", 2, &["cannot read", "No such file"]);
}

// --- OBJ materials.

const MTL_SCENE: &str = "mtllib m.mtl\nusemtl a\n";

#[test]
fn obj_valid_materials() {
    let obj = format!("{MTL_SCENE}{}", obj_with(""));
    let mtl = b"newmtl a\nKd 0.5\nKe 1 1 1\n";
    check_files(
        &[("lit.obj", obj.as_bytes()), ("m.mtl", mtl)],
        "lit.obj",
        0,
        &["patches      3 ("],
    );
}

#[test]
fn obj_reflectance_above_one() {
    let obj = format!("{MTL_SCENE}{}", obj_with(""));
    let mtl = b"newmtl a\nKd 0.5 1.5 0.5\n";
    check_files(
        &[("bright.obj", obj.as_bytes()), ("m.mtl", mtl)],
        "bright.obj",
        2,
        &["face 1 (line 11, patch 0)", "reflectance"],
    );
}

#[test]
fn obj_malformed_mtl() {
    // tobj 4.0.5 panics on a colour of 2 numbers; the import must report it instead.
    let obj = format!("{MTL_SCENE}{}", obj_with(""));
    let mtl = b"newmtl a\nKd 0.5 0.5\n";
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("m.mtl"), mtl).unwrap();
    std::fs::write(dir.path().join("badmtl.obj"), obj).unwrap();
    let (code, stdout, stderr) = scene_info(&dir.path().join("badmtl.obj"));
    assert_eq!(code, Some(2), "{stdout}{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(
        stderr.contains("m.mtl") && stderr.contains("line 2"),
        "{stderr}"
    );
}

// --- OBJ vertices outside given bounds: the CLI has no bounds option, so through the library.

#[test]
fn obj_vertex_outside_given_bounds() {
    use shellsim::scene::obj::{import, ImportOptions};
    use shellsim::Aabb;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("outside.obj");
    std::fs::write(&path, obj_with("v 3 3 0\nf 1 2 9\n")).unwrap();
    let opts = ImportOptions {
        bounds: Some(Aabb {
            lo: glam::DVec3::splat(-1.0),
            hi: glam::DVec3::splat(2.0),
        }),
        ..Default::default()
    };
    let e = import(&path, &opts).unwrap_err();
    let msg = e.to_string();
    assert_eq!(e.exit_code(), 2, "{msg}");
    assert!(msg.contains("outside.obj"), "{msg}");
    assert!(
        msg.contains("face 4 (line 13, patch 3)") && msg.contains("outside the bounds"),
        "{msg}"
    );
    // The same file without given bounds is fine: they are its bounding box.
    let (scene, report) = import(&path, &ImportOptions::default()).unwrap();
    assert_eq!((scene.patches.len(), report.faces), (4, 4));
    assert_eq!(scene.bounds.hi, glam::DVec3::new(3.0, 3.0, 1.0));
}

// --- Hostile inputs through the whole CLI, each with a time limit (a hang is a failure).

/// How a run of the binary ended: its exit status (`None` when killed after the time
/// limit), standard output and standard error.
struct Ran {
    code: Option<i32>,
    stdout: String,
    stderr: String,
}

impl Ran {
    fn shown(&self) -> String {
        format!(
            "status {:?}\n--- stdout\n{}--- stderr\n{}",
            self.code, self.stdout, self.stderr
        )
    }

    /// Exit status 2, an `error:` line holding every string of `want`, no panic.
    fn refused(&self, want: &[&str]) {
        assert_eq!(self.code, Some(2), "{}", self.shown());
        assert!(self.stderr.starts_with("error: "), "{}", self.shown());
        assert!(!self.stderr.contains("panicked"), "{}", self.shown());
        for w in want {
            assert!(
                self.stderr.contains(w),
                "stderr lacks {w:?}\n{}",
                self.shown()
            );
        }
    }
}

/// Runs `shellsim ARGS` in `dir` (one thread), killed after `secs` seconds.
fn run_in(dir: &Path, args: &[&str], secs: u64) -> Ran {
    let out = dir.join(".stdout");
    let err = dir.join(".stderr");
    let mut child = Command::new(env!("CARGO_BIN_EXE_shellsim"))
        .args(args)
        .current_dir(dir)
        .env("RAYON_NUM_THREADS", "1")
        .stdin(std::process::Stdio::null())
        .stdout(std::fs::File::create(&out).unwrap())
        .stderr(std::fs::File::create(&err).unwrap())
        .spawn()
        .expect("the shellsim binary runs");
    let start = std::time::Instant::now();
    let code = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s.code();
        }
        if start.elapsed().as_secs() >= secs {
            child.kill().unwrap();
            child.wait().unwrap();
            break None;
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    };
    let read = |p: &Path| String::from_utf8_lossy(&std::fs::read(p).unwrap()).into_owned();
    Ran {
        code,
        stdout: read(&out),
        stderr: read(&err),
    }
}

/// A committed scene's absolute path.
fn scene_file(name: &str) -> String {
    format!("{}/scenes/{name}", env!("CARGO_MANIFEST_DIR"))
}

/// `radiosity --matrix FILE` on cornell.json (18 patches) with `text` as FILE.
fn radiosity_matrix(text: &str) -> (tempfile::TempDir, Ran) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("m.mtx"), text).unwrap();
    let r = run_in(
        dir.path(),
        &[
            "radiosity",
            "--scene",
            &scene_file("cornell.json"),
            "--matrix",
            "m.mtx",
            "--size",
            "8x8",
            "--out",
            "out",
        ],
        30,
    );
    (dir, r)
}

const MTX_HEAD: &str = "%%MatrixMarket matrix coordinate real general\n";

#[test]
fn mtx_index_beyond_the_size() {
    // Before: exit 101, sprs panicked on the index.
    let (d, r) = radiosity_matrix(&format!("{MTX_HEAD}18 18 2\n1 2 0.1\n19 1 0.5\n"));
    r.refused(&["m.mtx", "line 4", "row 19 is out of range (1..=18)"]);
    assert!(!d.path().join("out").exists(), "{}", r.shown());
    let (_, r) = radiosity_matrix(&format!("{MTX_HEAD}18 18 1\n1 0 0.5\n"));
    r.refused(&["m.mtx", "line 3", "column 0 is out of range"]);
}

#[test]
fn mtx_header_only_ends() {
    // Before: a loop at 100 % CPU, never ending.
    let (_, r) = radiosity_matrix(MTX_HEAD);
    r.refused(&["m.mtx", "line 1", "size line"]);
    let (_, r) = radiosity_matrix("");
    r.refused(&["m.mtx", "line 1", "empty"]);
    let (_, r) = radiosity_matrix(&format!("{MTX_HEAD}% a comment\n"));
    r.refused(&["m.mtx", "line 2", "size line"]);
}

#[test]
fn mtx_huge_declared_sizes_are_refused_without_allocating() {
    // Before: 10^12 entries aborted allocating 8 TB.
    let (_, r) = radiosity_matrix(&format!("{MTX_HEAD}18 18 1000000000000\n1 1 0.5\n"));
    r.refused(&["m.mtx", "line 2", "1000000000000 entries", "(324)"]);
    let (_, r) = radiosity_matrix(&format!("{MTX_HEAD}4000000000 4000000000 1\n1 1 0.5\n"));
    r.refused(&["m.mtx", "line 2", "4000000000×4000000000", "18 patches"]);
    let big = "9".repeat(300);
    let (_, r) = radiosity_matrix(&format!("{MTX_HEAD}18 18 {big}\n"));
    r.refused(&["m.mtx", "line 2", "not a count of entries", "…"]);
    assert!(
        r.stderr.len() < 200,
        "a 300-digit number printed whole: {}",
        r.shown()
    );
}

#[test]
fn mtx_entry_count_checked_both_ways() {
    // Before: a header declaring fewer entries than the file holds dropped the rest, exit 0.
    let (_, r) = radiosity_matrix(&format!("{MTX_HEAD}18 18 1\n1 2 0.1\n1 3 0.1\n"));
    r.refused(&["m.mtx", "line 4", "past the 1"]);
    let (_, r) = radiosity_matrix(&format!("{MTX_HEAD}18 18 3\n1 2 0.1\n1 3 0.1\n"));
    r.refused(&["m.mtx", "line 4", "declares 3 entries", "after 2"]);
}

#[test]
fn mtx_malformed_lines_and_headers() {
    for (text, want) in [
        (
            "%%MatrixMarket matrix array real general\n18 18\n",
            "line 1",
        ),
        ("hello\n", "not a Matrix Market header"),
        (&format!("{MTX_HEAD}18 18\n") as &str, "three counts"),
        (&format!("{MTX_HEAD}18 18 1\n1 2\n"), "row column value"),
        (
            &format!("{MTX_HEAD}18 18 1\n1 2 x\n"),
            "\"x\" is not a number",
        ),
        (
            &format!("{MTX_HEAD}18 18 1\n1 2 1.5\n"),
            "not a form factor",
        ),
        (&format!("{MTX_HEAD}18 18 1\n-1 2 0.5\n"), "not an index"),
    ] {
        let (_, r) = radiosity_matrix(text);
        r.refused(&["m.mtx", want]);
    }
    // The same file, valid: exit 0 (the test can fail both ways).
    let (_, r) = radiosity_matrix(&format!("{MTX_HEAD}18 18 1\n1 2 0.25\n"));
    assert_eq!(r.code, Some(0), "a valid matrix: {}", r.shown());
}

// --- Outputs checked before any work: an input named as an output, bad paths, modes.

/// `scene import a.obj --out OUT` in a fresh directory holding `a.obj` (a valid box), with
/// `setup` run on the directory first; returns it, the run, and a.obj's bytes before.
fn import_to(out: &str, setup: impl FnOnce(&Path)) -> (tempfile::TempDir, Ran) {
    let dir = tempfile::tempdir().unwrap();
    let obj = format!("mtllib m.mtl\nusemtl a\n{}", obj_with(""));
    std::fs::write(dir.path().join("a.obj"), obj).unwrap();
    std::fs::write(dir.path().join("m.mtl"), "newmtl a\nKd 0.5\n").unwrap();
    setup(dir.path());
    let r = run_in(dir.path(), &["scene", "import", "a.obj", "--out", out], 30);
    (dir, r)
}

#[test]
fn an_input_named_as_the_output_is_refused() {
    // Before: the OBJ was replaced by the JSON scene, exit 0.
    let (d, r) = import_to("a.obj", |_| {});
    r.refused(&["--out a.obj", "is the input a.obj", "name another output"]);
    assert!(std::fs::read_to_string(d.path().join("a.obj"))
        .unwrap()
        .starts_with("mtllib"));
    // Through a symlink, a hard link and `./`.
    let (d, r) = import_to("link.json", |d| {
        std::os::unix::fs::symlink("a.obj", d.join("link.json")).unwrap()
    });
    r.refused(&["--out link.json", "is the input a.obj"]);
    assert!(std::fs::read_to_string(d.path().join("a.obj"))
        .unwrap()
        .starts_with("mtllib"));
    let (_, r) = import_to("hard.json", |d| {
        std::fs::hard_link(d.join("a.obj"), d.join("hard.json")).unwrap()
    });
    r.refused(&["is the input a.obj"]);
    // The material library.
    let (d, r) = import_to("./m.mtl", |_| {});
    r.refused(&["--out ./m.mtl", "is the input", "m.mtl"]);
    assert_eq!(
        std::fs::read_to_string(d.path().join("m.mtl")).unwrap(),
        "newmtl a\nKd 0.5\n"
    );
    // Another output path is fine (the test can fail both ways).
    let (d, r) = import_to("b.json", |_| {});
    assert_eq!(r.code, Some(0), "{}", r.shown());
    assert!(d.path().join("b.json").is_file());
}

#[test]
fn a_scene_or_machine_configuration_named_as_the_output_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::copy(scene_file("cornell.json"), d.join("s.json")).unwrap();
    let before = std::fs::read(d.join("s.json")).unwrap();
    let r = run_in(
        d,
        &[
            "reference",
            "--scene",
            "s.json",
            "--source",
            "0",
            "--rays",
            "100",
            "--json",
            "s.json",
        ],
        30,
    );
    r.refused(&["--json s.json", "is the input s.json"]);
    // `matrix --out m.mtx` writes its summary to m.json: the scene there is refused.
    std::fs::copy(d.join("s.json"), d.join("m.json")).unwrap();
    let r = run_in(
        d,
        &[
            "matrix", "--scene", "m.json", "--model", "float", "--out", "m.mtx",
        ],
        30,
    );
    r.refused(&["m.json", "is the input m.json"]);
    assert!(!d.join("m.mtx").exists(), "{}", r.shown());
    let toml = shellsim_hw::config::PAPER_TOML;
    std::fs::write(d.join("c.toml"), toml).unwrap();
    let r = run_in(
        d,
        &[
            "check", "--scene", "s.json", "--source", "0", "--rays", "100", "--hw", "c.toml",
            "--json", "c.toml",
        ],
        30,
    );
    r.refused(&["--json c.toml", "is the input c.toml"]);
    assert_eq!(std::fs::read_to_string(d.join("c.toml")).unwrap(), toml);
    assert_eq!(std::fs::read(d.join("s.json")).unwrap(), before);
}

/// `scene gen cornell --out OUT` in a fresh directory after `setup`.
fn gen_to(out: &str, setup: impl FnOnce(&Path)) -> (tempfile::TempDir, Ran) {
    let dir = tempfile::tempdir().unwrap();
    setup(dir.path());
    let r = run_in(dir.path(), &["scene", "gen", "cornell", "--out", out], 30);
    (dir, r)
}

#[test]
fn bad_output_paths_are_refused_before_the_work() {
    // Before: a 300-byte name failed after the work, exit 1.
    let long = format!("{}.json", "a".repeat(300));
    let (_, r) = gen_to(&long, |_| {});
    r.refused(&["--out", "305 bytes long", "255"]);
    // A trailing slash on a file output.
    let (d, r) = gen_to("x.json/", |d| {
        std::fs::write(d.join("x.json"), "old").unwrap()
    });
    r.refused(&["--out x.json/", "ends in `/`"]);
    assert_eq!(
        std::fs::read_to_string(d.path().join("x.json")).unwrap(),
        "old"
    );
    let (_, r) = gen_to("new.json/", |_| {});
    r.refused(&["ends in `/`"]);
    // A symlink loop (before: replaced by a file, exit 0), directly and in the path.
    let (d, r) = gen_to("loop", |d| {
        std::os::unix::fs::symlink("loop2", d.join("loop")).unwrap();
        std::os::unix::fs::symlink("loop", d.join("loop2")).unwrap();
    });
    r.refused(&["--out loop", "loop of symbolic links"]);
    assert!(std::fs::symlink_metadata(d.path().join("loop"))
        .unwrap()
        .file_type()
        .is_symlink());
    let (_, r) = gen_to("self/x.json", |d| {
        std::os::unix::fs::symlink("self", d.join("self")).unwrap()
    });
    assert_eq!(r.code, Some(2), "{}", r.shown());
    // A directory, and a parent that is a file.
    let (_, r) = gen_to("d", |d| std::fs::create_dir(d.join("d")).unwrap());
    r.refused(&["--out d", "is a directory"]);
    let (_, r) = gen_to("f/x.json", |d| std::fs::write(d.join("f"), "").unwrap());
    r.refused(&["--out f/x.json", "not a directory"]);
    let (d, r) = gen_to("ok.json", |_| {});
    assert_eq!(r.code, Some(0), "{}", r.shown());
    assert!(d.path().join("ok.json").is_file());
}

#[test]
fn a_replaced_file_keeps_its_mode() {
    use std::os::unix::fs::PermissionsExt;
    // Before: 0600 became 0644.
    for mode in [0o600, 0o640, 0o755] {
        let (d, r) = gen_to("out.json", |d| {
            let p = d.join("out.json");
            std::fs::write(&p, "old").unwrap();
            std::fs::set_permissions(&p, std::fs::Permissions::from_mode(mode)).unwrap();
        });
        assert_eq!(r.code, Some(0), "{}", r.shown());
        let m = std::fs::metadata(d.path().join("out.json")).unwrap();
        assert_eq!(m.permissions().mode() & 0o777, mode);
        assert!(m.len() > 100, "replaced");
    }
}

#[test]
fn a_fifo_as_material_library_is_refused() {
    // Before: read without the cap, a FIFO with no writer blocked forever.
    let (_, r) = import_to("b.json", |d| {
        std::fs::remove_file(d.join("m.mtl")).unwrap();
        let ok = Command::new("mkfifo")
            .arg(d.join("m.mtl"))
            .status()
            .unwrap();
        assert!(ok.success());
    });
    r.refused(&["m.mtl", "FIFO, device or socket, not a regular file"]);
}

#[test]
fn radiosity_with_light_never_absorbed_is_bad_input() {
    // Before: a closed box of reflectance 1 everywhere (which the validator accepts) ran
    // 10^4 sweeps and exited 1, "check failed: float did not converge".
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let r = run_in(
        d,
        &[
            "scene",
            "gen",
            "corpus-subdivided-box",
            "--n",
            "2",
            "--out",
            "box.json",
        ],
        30,
    );
    assert_eq!(r.code, Some(0), "{}", r.shown());
    let text = std::fs::read_to_string(d.join("box.json")).unwrap();
    for (rho, status) in [(1.0, 2), (0.99, 0)] {
        let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
        for p in v["patches"].as_array_mut().unwrap() {
            p["reflectance"] = serde_json::json!(rho);
        }
        v["patches"][0]["emission"] = serde_json::json!(1.0);
        std::fs::write(d.join("white.json"), v.to_string()).unwrap();
        let r = run_in(
            d,
            &[
                "radiosity",
                "--scene",
                "white.json",
                "--size",
                "8x8",
                "--out",
                "out",
            ],
            60,
        );
        if status == 2 {
            r.refused(&["white.json", "reflectance", "never absorbed"]);
        } else {
            assert_eq!(r.code, Some(0), "{}", r.shown());
        }
    }
}
