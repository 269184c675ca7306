//! The fuzz suite: property tests that mutate valid inputs of every parser the CLI has —
//! scene JSON, OBJ, MTL (through an OBJ that uses it), machine TOML, explore specs, the
//! files `explore merge` reads (a shard's `spec.json` and point files) and Matrix Market
//! `.mtx` files (`radiosity --matrix`) — with structure-aware edits (byte flips,
//! deletions, insertions, truncations, duplicated and swapped tokens, numbers replaced by
//! extremes) and feed them to the parsers. Every case must end in one of two ways: an
//! `Error` of exit status 2 whose message names the file and says something, or success
//! with a value that passes validation again. A panic fails the case; so does a case
//! slower than [`CASE_LIMIT`] (a hang); an abort (an allocation the size of a declared
//! count) kills the binary.
//!
//! **Sample and long run.** `cargo test --release --test it fuzz::` runs a seeded sample
//! (`sample` counts below; the seed is `FUZZ_SEED`, 37 by default) in well under a minute.
//! The long run sets `FUZZ_CASES`, the cases per test (each parser has two tests, one per
//! base file, so 2 × FUZZ_CASES per parser):
//!
//! ```text
//! FUZZ_CASES=10000 cargo test --release --test it fuzz:: -- --nocapture --test-threads 2
//! ```
//!
//! Each test prints one row of the outcome table: parser, base, cases, panics, aborts,
//! timeouts, exit 0 (valid), exit 2 (refused; not-UTF-8 input counted apart, as the
//! loaders refuse it before parsing), and the slowest case.

use crate::common;

use proptest::prelude::*;
use shellsim::scene::{obj, Scene};
use std::path::Path;

/// The sample's cases per test (`FUZZ_CASES` overrides them all); each parser has two
/// tests (two base files). The tests print their outcomes (`-- --nocapture`).
const CASES_JSON: u32 = 5_000;
const CASES_OBJ: u32 = 5_000;
const CASES_TOML: u32 = 5_000;
const CASES_MTL: u32 = 2_000;
const CASES_MTX: u32 = 5_000;
/// An explore spec parse loads its scene and parses a configuration per point: fewer cases.
const CASES_SPEC: u32 = 500;
/// A merge writes the tables, fronts, charts and report: fewer cases.
const CASES_MERGE: u32 = 150;

/// A case slower than this is a hang.
const CASE_LIMIT: std::time::Duration = std::time::Duration::from_secs(10);

/// Cases per test: `FUZZ_CASES` when set (the long run), else `sample`.
fn cases(sample: u32) -> u32 {
    std::env::var("FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(sample)
}

/// Numbers a mutation puts in place of a number.
const EXTREMES: [&str; 18] = [
    "0",
    "-0",
    "1e308",
    "-1e308",
    "1e-308",
    "1e999",
    "NaN",
    "inf",
    "-inf",
    "4294967295",
    "4294967296",
    "18446744073709551616",
    "-9223372036854775809",
    "0.5",
    "-1",
    "1e300",
    "1000000000000",
    "99999999999999999999999999999999999999999999999999999999999999999999999999999999",
];

/// One edit of a file's bytes; positions are taken modulo the length.
#[derive(Clone, Debug)]
enum Mutation {
    FlipBit(usize, u8),
    Delete(usize, usize),
    Insert(usize, u8),
    DuplicateToken(usize),
    SwapTokens(usize, usize),
    Extreme(usize, usize),
    /// The file cut at a position (a partial write, a header alone).
    Truncate(usize),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<usize>(), 0u8..8).prop_map(|(p, b)| Mutation::FlipBit(p, b)),
        (any::<usize>(), 1usize..40).prop_map(|(p, n)| Mutation::Delete(p, n)),
        (any::<usize>(), any::<u8>()).prop_map(|(p, b)| Mutation::Insert(p, b)),
        any::<usize>().prop_map(Mutation::DuplicateToken),
        (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Mutation::SwapTokens(a, b)),
        (any::<usize>(), 0..EXTREMES.len()).prop_map(|(p, k)| Mutation::Extreme(p, k)),
        any::<usize>().prop_map(Mutation::Truncate),
    ]
}

/// Byte ranges of the tokens of `b`: runs of letters, digits and `.+-_`, or single
/// other non-space bytes.
fn tokens(b: &[u8]) -> Vec<(usize, usize)> {
    let word = |c: u8| c.is_ascii_alphanumeric() || b".+-_".contains(&c);
    let mut v = Vec::new();
    let mut i = 0;
    while i < b.len() {
        if b[i].is_ascii_whitespace() {
            i += 1;
        } else if word(b[i]) {
            let s = i;
            while i < b.len() && word(b[i]) {
                i += 1;
            }
            v.push((s, i));
        } else {
            v.push((i, i + 1));
            i += 1;
        }
    }
    v
}

fn is_number(t: &[u8]) -> bool {
    std::str::from_utf8(t).is_ok_and(|s| s.parse::<f64>().is_ok())
}

/// Applies `m` to `b`.
fn apply(b: &mut Vec<u8>, m: &Mutation) {
    if b.is_empty() {
        return;
    }
    match *m {
        Mutation::FlipBit(p, bit) => {
            let p = p % b.len();
            b[p] ^= 1 << bit;
        }
        Mutation::Delete(p, n) => {
            let p = p % b.len();
            let e = (p + n).min(b.len());
            b.drain(p..e);
        }
        Mutation::Insert(p, c) => {
            let p = p % (b.len() + 1);
            b.insert(p, c);
        }
        Mutation::DuplicateToken(k) => {
            let t = tokens(b);
            if let Some(&(s, e)) = t.get(k % t.len().max(1)) {
                let tok = b[s..e].to_vec();
                b.splice(e..e, tok);
            }
        }
        Mutation::SwapTokens(x, y) => {
            let t = tokens(b);
            if t.len() < 2 {
                return;
            }
            let (mut i, mut j) = (x % t.len(), y % t.len());
            if i == j {
                return;
            }
            if i > j {
                std::mem::swap(&mut i, &mut j);
            }
            let (a, c) = (t[i], t[j]);
            let mut out = b[..a.0].to_vec();
            out.extend_from_slice(&b[c.0..c.1]);
            out.extend_from_slice(&b[a.1..c.0]);
            out.extend_from_slice(&b[a.0..a.1]);
            out.extend_from_slice(&b[c.1..]);
            *b = out;
        }
        Mutation::Extreme(k, x) => {
            let nums: Vec<(usize, usize)> = tokens(b)
                .into_iter()
                .filter(|&(s, e)| is_number(&b[s..e]))
                .collect();
            if let Some(&(s, e)) = nums.get(k % nums.len().max(1)) {
                b.splice(s..e, EXTREMES[x].bytes());
            }
        }
        Mutation::Truncate(p) => {
            let p = p % b.len();
            b.truncate(p);
        }
    }
}

/// The base file mutated by `muts`.
fn mutated(base: &[u8], muts: &[Mutation]) -> Vec<u8> {
    let mut b = base.to_vec();
    for m in muts {
        apply(&mut b, m);
    }
    b
}

/// The contract for a failed parse: exit status 2, the file named, a message after it.
fn check_error(e: &shellsim::Error, file: &str, input: &[u8]) -> Result<(), TestCaseError> {
    check_error_any(e, &[file], input)
}

/// [`check_error`] where the error may name any of `files` (an MTL's fault may be told at
/// the OBJ face that uses it).
fn check_error_any(e: &shellsim::Error, files: &[&str], input: &[u8]) -> Result<(), TestCaseError> {
    let msg = e.to_string();
    let shown = || format!("{msg}\ninput: {:?}", String::from_utf8_lossy(input));
    prop_assert_eq!(e.exit_code(), 2, "{}", shown());
    let Some(file) = files.iter().find(|f| msg.contains(*f)) else {
        return Err(TestCaseError::fail(format!(
            "the message names none of {files:?}: {}",
            shown()
        )));
    };
    let rest = msg[msg.find(file).unwrap() + file.len()..]
        .trim_matches(|c: char| c == ':' || c.is_whitespace());
    prop_assert!(rest.len() > 3, "an empty message: {}", shown());
    prop_assert!(
        msg.len() < 2_000,
        "a message of {} bytes: {}",
        msg.len(),
        shown()
    );
    Ok(())
}

fn committed(name: &str) -> Vec<u8> {
    std::fs::read(common::scene_path(name)).unwrap()
}

/// How a case ended.
#[derive(Clone, Copy)]
enum Outcome {
    Valid = 0,
    Refused = 1,
    NotUtf8 = 2,
}

type CaseResult = Result<Outcome, TestCaseError>;

/// A JSON case: a valid scene, or an error by the contract.
fn json_case(base: &[u8], muts: &[Mutation]) -> CaseResult {
    let b = mutated(base, muts);
    let file = Path::new("fuzz.json");
    let text = match String::from_utf8(b.clone()) {
        Ok(t) => t,
        // Not UTF-8: the loader reports it as unreadable input (tested in bad_input.rs).
        Err(_) => return Ok(Outcome::NotUtf8),
    };
    match Scene::from_json_str(&text, file) {
        Ok(s) => prop_assert!(s.validate(file).is_ok()),
        Err(e) => {
            check_error(&e, "fuzz.json", &b)?;
            return Ok(Outcome::Refused);
        }
    }
    Ok(Outcome::Valid)
}

/// An OBJ case: a valid scene, or an error by the contract.
fn obj_case(base: &[u8], muts: &[Mutation]) -> CaseResult {
    let b = mutated(base, muts);
    // A directory of its own, so that a mutated `mtllib` finds nothing of the repository.
    let file = Path::new("/nonexistent-shellsim-fuzz/fuzz.obj");
    match obj::import_bytes(b.clone(), file, &obj::ImportOptions::default()) {
        Ok((s, _)) => prop_assert!(s.validate(file).is_ok()),
        Err(e) => {
            check_error(&e, "fuzz.obj", &b)?;
            return Ok(Outcome::Refused);
        }
    }
    Ok(Outcome::Valid)
}

/// A TOML case: a configuration that validates, or an error by the contract.
fn toml_case(base: &[u8], muts: &[Mutation]) -> CaseResult {
    let b = mutated(base, muts);
    let file = Path::new("fuzz.toml");
    let Ok(text) = String::from_utf8(b.clone()) else {
        return Ok(Outcome::NotUtf8);
    };
    match shellsim::config::parse(&text, file) {
        Ok(c) => prop_assert!(c.validate().is_ok()),
        Err(e) => {
            check_error(&e, "fuzz.toml", &b)?;
            return Ok(Outcome::Refused);
        }
    }
    Ok(Outcome::Valid)
}

/// An explore spec case: a spec whose every point validates, or an error by the contract.
fn spec_case(base: &[u8], muts: &[Mutation]) -> CaseResult {
    let b = mutated(base, muts);
    let file = common::scene_path("fuzz-spec.toml");
    let Ok(text) = String::from_utf8(b.clone()) else {
        return Ok(Outcome::NotUtf8);
    };
    match shellsim::explore::spec::parse(&text, &file) {
        Ok(s) => {
            for p in &s.points {
                prop_assert!(p.config.validate().is_ok());
            }
        }
        Err(e) => {
            check_error(&e, "fuzz-spec.toml", &b)?;
            return Ok(Outcome::Refused);
        }
    }
    Ok(Outcome::Valid)
}

/// An MTL case: `base` mutated as the material library `m.mtl` of [`MTL_OBJ`], both in
/// `dir`; a valid scene, or an error by the contract (naming the library, or the OBJ where
/// a face gets a bad material).
fn mtl_case(dir: &Path, base: &[u8], muts: &[Mutation]) -> CaseResult {
    let b = mutated(base, muts);
    std::fs::write(dir.join("m.mtl"), &b).unwrap();
    let file = dir.join("fuzz.obj");
    match obj::import_bytes(
        MTL_OBJ.as_bytes().to_vec(),
        &file,
        &obj::ImportOptions::default(),
    ) {
        Ok((s, _)) => prop_assert!(s.validate(&file).is_ok()),
        Err(e) => {
            check_error_any(&e, &["m.mtl", "fuzz.obj"], &b)?;
            return Ok(Outcome::Refused);
        }
    }
    Ok(Outcome::Valid)
}

/// A Matrix Market case on the Cornell box (18 patches): a matrix whose every check
/// passes, or an error by the contract.
fn mtx_case(scene: &Scene, base: &[u8], muts: &[Mutation]) -> CaseResult {
    let b = mutated(base, muts);
    let file = Path::new("fuzz.mtx");
    match shellsim::radiosity::matrix::from_bytes(&b, file, scene) {
        Ok(m) => {
            prop_assert_eq!(m.n, 18);
            for r in &m.rows {
                let sum: f64 = r.entries.iter().map(|e| e.1).sum();
                prop_assert!(sum <= 1.0 + 1e-9 && r.entries.iter().all(|e| e.1.is_finite()));
            }
        }
        Err(e) => {
            check_error(&e, "fuzz.mtx", &b)?;
            return Ok(Outcome::Refused);
        }
    }
    Ok(Outcome::Valid)
}

/// A merge case: the shard `shard` (an `explore run` output) copied with its file `rel`
/// replaced by `base` mutated, merged into a fresh directory; the merged tables, or an error
/// by the contract naming that file.
fn merge_case(shard: &Path, rel: &str, base: &[u8], muts: &[Mutation]) -> CaseResult {
    let b = mutated(base, muts);
    let tmp = tempfile::tempdir().unwrap();
    let copy = tmp.path().join("shard");
    std::fs::create_dir_all(copy.join("points")).unwrap();
    std::fs::copy(shard.join("spec.json"), copy.join("spec.json")).unwrap();
    for e in std::fs::read_dir(shard.join("points")).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), copy.join("points").join(e.file_name())).unwrap();
    }
    std::fs::write(copy.join(rel), &b).unwrap();
    let out = tmp.path().join("merged");
    match shellsim::explore::merge(&out, &[copy]) {
        Ok(n) => prop_assert!(n > 0 && out.join("points.csv").is_file()),
        Err(e) => {
            let name = Path::new(rel).file_name().unwrap().to_str().unwrap();
            check_error(&e, name, &b)?;
            return Ok(Outcome::Refused);
        }
    }
    Ok(Outcome::Valid)
}

fn muts() -> impl Strategy<Value = Vec<Mutation>> {
    prop::collection::vec(mutation(), 1..4)
}

/// A small OBJ: a box of quads, a pentagon (split into a fan), with texture and normal
/// indices, a group and a comment.
const BOX_OBJ: &str = "# a box\no box\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\nvt 0 0\nvn 0 0 1\ng walls\nf 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2/1 3/1 7/1 6/1\nf 3 4 8 7\nf 4//1 1//1 5//1 8//1\n";
const PENTAGON_OBJ: &str = "v 0 0 0\nv 2 0 0\nv 2.6 1.5 0\nv 1 2.5 0\nv -0.6 1.5 0\nv 0 0 1\nv 2 0 1\nv 1 1 -1\nf 1 2 3 4 5\nf 1 2 7 6\nf -1 -2 -3\n";

/// The seed of the sample (`FUZZ_SEED`, default 37): every run tests the same cases.
fn seed() -> u64 {
    std::env::var("FUZZ_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(37)
}

/// Runs `cases` mutations of `base` through `case`, seeded, failing on the first failure
/// (with its input, shrunk) or a case slower than [`CASE_LIMIT`], and prints the test's
/// row of the outcome table.
fn fuzz(name: &str, cases: u32, base: &[u8], case: &dyn Fn(&[u8], &[Mutation]) -> CaseResult) {
    use proptest::test_runner::{RngAlgorithm, TestRng, TestRunner};
    use std::cell::Cell;
    let counts = [Cell::new(0u64), Cell::new(0u64), Cell::new(0u64)];
    let slowest = Cell::new(std::time::Duration::ZERO);
    let config = ProptestConfig {
        cases,
        failure_persistence: None,
        ..ProptestConfig::default()
    };
    let mut key = [0u8; 32];
    key[..8].copy_from_slice(&seed().to_le_bytes());
    key[8..16].copy_from_slice(&(name.len() as u64).to_le_bytes());
    for (k, b) in key[16..].iter_mut().zip(name.bytes().cycle()) {
        *k = b;
    }
    let mut runner =
        TestRunner::new_with_rng(config, TestRng::from_seed(RngAlgorithm::ChaCha, &key));
    let result = runner.run(&muts(), |m| {
        let start = std::time::Instant::now();
        let o = case(base, &m)?;
        let t = start.elapsed();
        prop_assert!(t < CASE_LIMIT, "a case took {:?} (a hang): {:?}", t, m);
        slowest.set(slowest.get().max(t));
        counts[o as usize].set(counts[o as usize].get() + 1);
        Ok(())
    });
    if let Err(e) = result {
        panic!("{name}: {e}");
    }
    let [v, r, u] = counts.map(|c| c.get());
    // Panics, aborts and timeouts are 0 when this line is reached: any would have failed
    // the test or killed the binary.
    println!(
        "| {name} | {cases} | 0 | 0 | 0 | {v} | {r} + {u} not UTF-8 | {:.1} ms |",
        slowest.get().as_secs_f64() * 1e3
    );
    assert_eq!(v + r + u, cases as u64);
    // The suite is worth something only if it reaches both outcomes.
    assert!(v > 0 && r > 0, "{name}: {v} valid, {r} refused");
}

#[test]
fn json_cornell() {
    fuzz(
        "json cornell.json",
        cases(CASES_JSON),
        &committed("cornell.json"),
        &json_case,
    );
}

#[test]
fn json_scene1() {
    fuzz(
        "json scene1.json",
        cases(CASES_JSON),
        &committed("scene1.json"),
        &json_case,
    );
}

#[test]
fn obj_box() {
    fuzz("obj box", cases(CASES_OBJ), BOX_OBJ.as_bytes(), &obj_case);
}

#[test]
fn obj_pentagon() {
    fuzz(
        "obj pentagon",
        cases(CASES_OBJ),
        PENTAGON_OBJ.as_bytes(),
        &obj_case,
    );
}

#[test]
fn toml_paper() {
    fuzz(
        "toml paper.toml",
        cases(CASES_TOML),
        shellsim_hw::config::PAPER_TOML.as_bytes(),
        &toml_case,
    );
}

#[test]
fn spec_ci() {
    // Scene paths are relative to the spec, which "lives" in scenes/.
    let base = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/explore/ci.toml"),
    )
    .unwrap()
    .replace("../../scenes/scene2.json", "scene1.json");
    fuzz(
        "spec ci.toml",
        cases(CASES_SPEC),
        base.as_bytes(),
        &spec_case,
    );
}

#[test]
fn spec_blocks() {
    let base = "title = \"blocks\"\nscene = [\"scene1.json\", \"cornell.json\"]\nlevel = \"fixed\"\n[[sweep]]\nratio = { from = 1, to = 3 }\ncell = [0.05, \"auto\"]\n[[point]]\nlevel = \"machine\"\nmachine.clusters = 2\nbalance.enabled = false\n";
    fuzz(
        "spec blocks",
        cases(CASES_SPEC),
        base.as_bytes(),
        &spec_case,
    );
}

#[test]
fn toml_small() {
    let base = std::fs::read(common::config_path("small")).unwrap();
    fuzz("toml small.toml", cases(CASES_TOML), &base, &toml_case);
}

/// An OBJ using the material library `m.mtl`: three faces, two materials.
const MTL_OBJ: &str = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nusemtl wall\nf 1 2 3 4\nusemtl lamp\nf 1 2 5\nf 1 5 4\n";
/// Its library: a grey wall, a coloured lamp, comments, and keys the importer skips.
const MTL_GREY: &str = "# walls\nnewmtl wall\nKd 0.5\nKa 0 0 0\nNs 10\nd 1\nillum 2\n\nnewmtl lamp\nKd 0.2 0.4 0.6\nKe 1 0.9 0.8\n";
const MTL_RGB: &str =
    "newmtl lamp\nKe 4 4 4\nKd 0 0 0\nnewmtl wall\nKd 0.725 0.71 0.68\nKs 0 0 0\nmap_Kd none.png\n";

#[test]
fn mtl_grey() {
    let dir = tempfile::tempdir().unwrap();
    fuzz(
        "mtl grey",
        cases(CASES_MTL),
        MTL_GREY.as_bytes(),
        &|b, m| mtl_case(dir.path(), b, m),
    );
}

#[test]
fn mtl_rgb() {
    let dir = tempfile::tempdir().unwrap();
    fuzz("mtl rgb", cases(CASES_MTL), MTL_RGB.as_bytes(), &|b, m| {
        mtl_case(dir.path(), b, m)
    });
}

/// A valid matrix of the Cornell box as `shellsim matrix` writes it (a few rows).
const MTX_CORNELL: &str = "%%MatrixMarket matrix coordinate real general\n% written by shellsim\n18 18 7\n1 2 0.25\n1 3 0.125\n1 18 0.5\n2 1 0.0625\n9 9 0\n17 4 1\n18 1 3.0517578125e-5\n";

#[test]
fn mtx_cornell() {
    let scene = common::load("cornell.json");
    fuzz(
        "mtx cornell",
        cases(CASES_MTX),
        MTX_CORNELL.as_bytes(),
        &|b, m| mtx_case(&scene, b, m),
    );
}

#[test]
fn mtx_computed() {
    // A whole matrix the float model computes (every row), as written.
    let scene = common::load("cornell.json");
    let spec = shellsim::radiosity::matrix::MatrixSpec {
        model: shellsim::radiosity::matrix::Model::Float,
        rays: 64,
        directions: shellsim::reference::rays::Directions::Malley,
        seed: 1,
        sources: 0..18,
    };
    let file = common::scene_path("cornell.json");
    let cfg = common::config("paper");
    let m = shellsim::radiosity::matrix::compute(&scene, &file, &cfg, &spec, false).unwrap();
    let base = m.matrix_market();
    fuzz("mtx computed", cases(CASES_MTX), &base, &|b, m| {
        mtx_case(&scene, b, m)
    });
}

/// A finished `explore run` directory of a two-point spec (float, scene1), made once.
fn merge_shard() -> &'static Path {
    static DIR: std::sync::OnceLock<std::path::PathBuf> = std::sync::OnceLock::new();
    DIR.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap().keep();
        let text = "reference_rays = 2000\nscene = \"scene1.json\"\nlevel = \"float\"\nrays = 200\nseed = [1, 2]\n";
        let spec = shellsim::explore::spec::parse(text, &common::scene_path("merge.toml")).unwrap();
        shellsim::explore::run(&spec, &dir, None, false).unwrap();
        dir
    })
}

#[test]
fn merge_spec_json() {
    let shard = merge_shard();
    let base = std::fs::read(shard.join("spec.json")).unwrap();
    fuzz("merge spec.json", cases(CASES_MERGE), &base, &|b, m| {
        merge_case(shard, "spec.json", b, m)
    });
}

#[test]
fn merge_point_file() {
    let shard = merge_shard();
    let base = std::fs::read(shard.join("points/000001.json")).unwrap();
    fuzz("merge point file", cases(CASES_MERGE), &base, &|b, m| {
        merge_case(shard, "points/000001.json", b, m)
    });
}

#[test]
fn the_mutations_change_the_files() {
    // Tests that could be false: each kind of mutation edits the base.
    let base = b"{\"a\": [1, 2.5, -3]}".to_vec();
    for m in [
        Mutation::FlipBit(3, 0),
        Mutation::Delete(2, 3),
        Mutation::Insert(1, b'x'),
        Mutation::DuplicateToken(2),
        Mutation::SwapTokens(1, 4),
        Mutation::Extreme(1, 2),
        Mutation::Truncate(5),
    ] {
        assert_ne!(mutated(&base, std::slice::from_ref(&m)), base, "{m:?}");
    }
    assert_eq!(
        mutated(&base, &[Mutation::Extreme(0, 2)]),
        b"{\"a\": [1e308, 2.5, -3]}".to_vec()
    );
}
