//! The fuzz suite: property tests that mutate valid scene JSON, OBJ, machine TOML files and
//! explore specs
//! (byte flips, deletions, insertions, duplicated and swapped tokens, numbers replaced by
//! extremes) and feed them to the parsers the CLI uses. Every case must end in one of two
//! ways: an `Error` of exit status 2 whose message names the file and says something, or
//! success with a value that passes validation again. A panic fails the case. Case counts
//! (`CASES_*`) add up to more than 10⁵ per parser (2 × 10⁴ for the explore spec, whose parse
//! loads its scenes and parses a configuration per point); the binary runs in well under a
//! minute on 2 cores in release.

mod common;

use proptest::prelude::*;
use shellsim::scene::{obj, Scene};
use std::path::Path;

/// Cases per test; each parser has two tests (two base files), so 2 × this per parser.
/// The tests print their outcomes (`cargo test --release --test fuzz -- --nocapture`).
const CASES_JSON: u32 = 100_000;
const CASES_OBJ: u32 = 100_000;
const CASES_TOML: u32 = 100_000;
/// An explore spec parse loads its scene and parses a configuration per point: fewer cases.
const CASES_SPEC: u32 = 10_000;

/// Numbers a mutation puts in place of a number.
const EXTREMES: [&str; 16] = [
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
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<usize>(), 0u8..8).prop_map(|(p, b)| Mutation::FlipBit(p, b)),
        (any::<usize>(), 1usize..40).prop_map(|(p, n)| Mutation::Delete(p, n)),
        (any::<usize>(), any::<u8>()).prop_map(|(p, b)| Mutation::Insert(p, b)),
        any::<usize>().prop_map(Mutation::DuplicateToken),
        (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Mutation::SwapTokens(a, b)),
        (any::<usize>(), 0..EXTREMES.len()).prop_map(|(p, k)| Mutation::Extreme(p, k)),
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
    let msg = e.to_string();
    let shown = || format!("{msg}\ninput: {:?}", String::from_utf8_lossy(input));
    prop_assert_eq!(e.exit_code(), 2, "{}", shown());
    prop_assert!(
        msg.contains(file),
        "the message does not name {}: {}",
        file,
        shown()
    );
    let rest = msg
        .trim_start_matches(file)
        .trim_matches(|c: char| c == ':' || c.is_whitespace());
    prop_assert!(rest.len() > 3, "an empty message: {}", shown());
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

fn muts() -> impl Strategy<Value = Vec<Mutation>> {
    prop::collection::vec(mutation(), 1..4)
}

/// A small OBJ: a box of quads, a pentagon (split into a fan), with texture and normal
/// indices, a group and a comment.
const BOX_OBJ: &str = "# a box\no box\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\nvt 0 0\nvn 0 0 1\ng walls\nf 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2/1 3/1 7/1 6/1\nf 3 4 8 7\nf 4//1 1//1 5//1 8//1\n";
const PENTAGON_OBJ: &str = "v 0 0 0\nv 2 0 0\nv 2.6 1.5 0\nv 1 2.5 0\nv -0.6 1.5 0\nv 0 0 1\nv 2 0 1\nv 1 1 -1\nf 1 2 3 4 5\nf 1 2 7 6\nf -1 -2 -3\n";

/// Runs `cases` mutations of `base` through `case`, panicking on the first failure (with
/// its input, shrunk), and prints the outcomes.
fn fuzz(name: &str, cases: u32, base: &[u8], case: fn(&[u8], &[Mutation]) -> CaseResult) {
    use std::cell::Cell;
    let counts = [Cell::new(0u64), Cell::new(0u64), Cell::new(0u64)];
    let config = ProptestConfig {
        cases,
        failure_persistence: None,
        ..ProptestConfig::default()
    };
    let mut runner = proptest::test_runner::TestRunner::new(config);
    let result = runner.run(&muts(), |m| {
        let o = case(base, &m)?;
        counts[o as usize].set(counts[o as usize].get() + 1);
        Ok(())
    });
    if let Err(e) = result {
        panic!("{name}: {e}");
    }
    let [v, r, u] = counts.map(|c| c.get());
    println!("fuzz {name}: {cases} cases: {v} valid, {r} refused with exit status 2, {u} not UTF-8 (refused before parsing)");
    assert_eq!(v + r + u, cases as u64);
    // The suite is worth something only if it reaches both outcomes.
    assert!(v > 0 && r > 0, "{name}: {v} valid, {r} refused");
}

#[test]
fn json_cornell() {
    fuzz(
        "json cornell.json",
        CASES_JSON,
        &committed("cornell.json"),
        json_case,
    );
}

#[test]
fn json_scene1() {
    fuzz(
        "json scene1.json",
        CASES_JSON,
        &committed("scene1.json"),
        json_case,
    );
}

#[test]
fn obj_box() {
    fuzz("obj box", CASES_OBJ, BOX_OBJ.as_bytes(), obj_case);
}

#[test]
fn obj_pentagon() {
    fuzz("obj pentagon", CASES_OBJ, PENTAGON_OBJ.as_bytes(), obj_case);
}

#[test]
fn toml_paper() {
    fuzz(
        "toml paper.toml",
        CASES_TOML,
        shellsim_hw::config::PAPER_TOML.as_bytes(),
        toml_case,
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
    fuzz("spec ci.toml", CASES_SPEC, base.as_bytes(), spec_case);
}

#[test]
fn spec_blocks() {
    let base = "title = \"blocks\"\nscene = [\"scene1.json\", \"cornell.json\"]\nlevel = \"fixed\"\n[[sweep]]\nratio = { from = 1, to = 3 }\ncell = [0.05, \"auto\"]\n[[point]]\nlevel = \"machine\"\nmachine.clusters = 2\nbalance.enabled = false\n";
    fuzz("spec blocks", CASES_SPEC, base.as_bytes(), spec_case);
}

#[test]
fn toml_small() {
    let base = std::fs::read(common::config_path("small")).unwrap();
    fuzz("toml small.toml", CASES_TOML, &base, toml_case);
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
    ] {
        assert_ne!(mutated(&base, std::slice::from_ref(&m)), base, "{m:?}");
    }
    assert_eq!(
        mutated(&base, &[Mutation::Extreme(0, 2)]),
        b"{\"a\": [1e308, 2.5, -3]}".to_vec()
    );
}
