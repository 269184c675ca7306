//! `shellsim explore` through the binary: the results are byte-identical across runs, thread
//! counts, resumption and sharding (merged shards for N = 1, 3, 7 equal the unsharded run);
//! bad specs and mismatched shards are refused with exit status 2 naming the file and the
//! problem; the Slurm scripts hold the array, the shard commands and the dependency.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

/// The files that must be byte-identical between two runs of one spec.
const COMPARED: [&str; 7] = [
    "spec.json",
    "points.csv",
    "points.json",
    "front.csv",
    "report.md",
    "front-cycles-scene1-0.svg",
    "front-cost-scene1-0.svg",
];

/// A tiny study (7 points: float once — it reads neither knob — fixed per width, the
/// machine per width and cluster count; scene1 at ratio 1, a small reference).
fn tiny_spec(extra: &str) -> String {
    format!(
        "reference_rays = 20000\nscene = {:?}\nlevel = [\"float\", \"fixed\", \"machine\"]\nfrac_bits = [9, 12]\nmachine.clusters = [1, 2]\n{extra}",
        common::scene_path("scene1.json").display().to_string()
    )
}

fn shellsim(args: &[&str], threads: Option<usize>) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_shellsim"));
    c.args(args)
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env_remove("SLURM_ARRAY_TASK_COUNT");
    if let Some(t) = threads {
        c.env("RAYON_NUM_THREADS", t.to_string());
    }
    c.output().expect("shellsim runs")
}

fn ok(o: &Output, what: &str) {
    assert!(
        o.status.success(),
        "{what} failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// A temporary directory that lives as long as the test binary.
fn keep() -> PathBuf {
    tempfile::tempdir().unwrap().keep()
}

/// Writes `text` as a spec in a new directory.
fn spec_file(text: &str) -> PathBuf {
    let p = keep().join("spec.toml");
    std::fs::write(&p, text).unwrap();
    p
}

/// `explore run` of `spec` into `out`.
fn run(spec: &Path, out: &Path, shard: Option<&str>, threads: Option<usize>) -> Output {
    let mut a = vec![
        "explore",
        "run",
        "--space",
        spec.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    if let Some(s) = shard {
        a.extend(["--shard", s]);
    }
    shellsim(&a, threads)
}

/// The tiny spec run once, unsharded: (spec, output directory).
fn whole() -> &'static (PathBuf, PathBuf) {
    static W: OnceLock<(PathBuf, PathBuf)> = OnceLock::new();
    W.get_or_init(|| {
        let spec = spec_file(&tiny_spec(""));
        let out = keep().join("whole");
        ok(&run(&spec, &out, None, Some(2)), "the unsharded run");
        (spec, out)
    })
}

fn same_results(a: &Path, b: &Path, how: &str) {
    for f in COMPARED {
        let x = std::fs::read(a.join(f)).unwrap_or_else(|e| panic!("{}: {e}", a.join(f).display()));
        let y = std::fs::read(b.join(f)).unwrap_or_else(|e| panic!("{}: {e}", b.join(f).display()));
        assert!(
            x == y,
            "{f} differs between {} and {} ({how}); reproduce: cargo test --release --test explore",
            a.display(),
            b.display()
        );
    }
}

#[test]
fn two_runs_are_identical() {
    let (spec, out) = whole();
    let again = keep().join("again");
    ok(&run(spec, &again, None, Some(2)), "the second run");
    same_results(out, &again, "two runs");
    let rows = std::fs::read_to_string(out.join("points.csv")).unwrap();
    assert_eq!(rows.lines().count(), 8, "a header and 7 points:\n{rows}");
    // The float point carries neither knob; the fixed points the width only.
    let levels: Vec<&str> = rows
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(3).unwrap_or(""))
        .collect();
    assert_eq!(
        levels.iter().filter(|l| **l == "float").count(),
        1,
        "{rows}"
    );
    assert_eq!(
        levels.iter().filter(|l| **l == "fixed").count(),
        2,
        "{rows}"
    );
}

#[test]
fn one_and_two_threads_agree() {
    let (spec, out) = whole();
    let one = keep().join("one");
    ok(&run(spec, &one, None, Some(1)), "the one-thread run");
    same_results(out, &one, "RAYON_NUM_THREADS=1 against 2");
}

/// Runs the tiny spec as `n` shards, merges them, compares with the unsharded run.
fn merged_equals_whole(n: usize) {
    let (spec, out) = whole();
    let dir = keep();
    let mut shards = Vec::new();
    for k in 0..n {
        let d = dir.join(format!("shard-{k}"));
        ok(
            &run(spec, &d, Some(&format!("{k}/{n}")), Some(1)),
            &format!("shard {k}/{n}"),
        );
        shards.push(d.to_str().unwrap().to_string());
    }
    let merged = dir.join("merged");
    let mut a = vec!["explore", "merge", "--out", merged.to_str().unwrap()];
    a.extend(shards.iter().map(|s| s.as_str()));
    ok(&shellsim(&a, None), "the merge");
    same_results(out, &merged, &format!("merged {n} shards"));
}

testcases! { merged_equals_whole;
    merged_shards_1 => 1;
    merged_shards_3 => 3;
    merged_shards_7 => 7;
}

#[test]
fn a_shard_is_taken_from_slurm_when_not_given() {
    let (spec, _) = whole();
    let out = keep().join("slurm-shard");
    let o = Command::new(env!("CARGO_BIN_EXE_shellsim"))
        .args(["explore", "run", "--space", spec.to_str().unwrap(), "--out"])
        .arg(&out)
        .env("SLURM_ARRAY_TASK_ID", "1")
        .env("SLURM_ARRAY_TASK_COUNT", "5")
        .output()
        .unwrap();
    ok(&o, "the array task");
    let rows = std::fs::read_to_string(out.join("points.csv")).unwrap();
    let ids: Vec<&str> = rows
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().unwrap())
        .collect();
    assert_eq!(ids, ["1", "6"], "shard 1/5 of 7 points");
    assert!(!out.join("report.md").exists(), "a shard writes no report");
}

#[test]
fn an_interrupted_run_resumes_without_recomputing() {
    let (spec, out) = whole();
    let dir = keep().join("resumed");
    ok(&run(spec, &dir, None, Some(2)), "the first run");
    // As if killed after ten points: two point files and the tables are gone.
    for f in [
        "points/000003.json",
        "points/000006.json",
        "points.csv",
        "report.md",
    ] {
        std::fs::remove_file(dir.join(f)).unwrap();
    }
    let o = run(spec, &dir, None, Some(2));
    ok(&o, "the resumed run");
    let said = String::from_utf8_lossy(&o.stdout);
    assert!(said.contains("2 measured, 5 already there"), "{said}");
    same_results(out, &dir, "resumed");
}

/// Runs `explore run` on a spec `text` and checks exit status 2 and every `want` in the
/// message.
fn refused(text: &str, want: &[&str]) {
    let spec = spec_file(text);
    let out = keep().join("out");
    let o = run(&spec, &out, None, None);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains(spec.to_str().unwrap()),
        "names the file: {err}"
    );
    for w in want {
        assert!(err.contains(w), "{w:?} not in: {err}");
    }
    assert!(!out.join("points.csv").exists(), "nothing written");
}

fn malformed() {
    refused(&tiny_spec("machine.clusters = = 3\n"), &["line 6"]);
}

fn unknown_key() {
    refused(
        &tiny_spec("machine.clusterz = [1]\n"),
        &["line 6", "machine.clusterz", "unknown key"],
    );
}

fn unknown_top_key() {
    refused(&tiny_spec("rayz = 3\n"), &["line 6", "rayz", "unknown key"]);
}

fn empty_range() {
    refused(
        &tiny_spec("ratio = { from = 3, to = 1 }\n"),
        &["line 6", "ratio", "empty range"],
    );
}

fn empty_list() {
    refused(&tiny_spec("seed = []\n"), &["line 6", "seed", "empty list"]);
}

fn impossible_value() {
    refused(
        &tiny_spec("[[sweep]]\nmachine.ctus_per_cluster = [2, 0]\n"),
        &["line 7", "machine.ctus_per_cluster", "0"],
    );
}

fn wrong_type() {
    refused(
        &tiny_spec("balance.enabled = [1]\n"),
        &["line 6", "balance.enabled", "true or false"],
    );
}

fn bad_level() {
    refused(
        &tiny_spec("[[point]]\nlevel = \"rtl\"\n"),
        &["line 7", "level", "rtl"],
    );
}

fn missing_scene() {
    refused("level = \"fixed\"\n", &["scene", "missing"]);
}

fn missing_source() {
    refused(
        &tiny_spec("source = 999\n"),
        &["line 6", "source patch 999"],
    );
}

testcases! { refused_case;
    a_malformed_spec => malformed;
    an_unknown_configuration_key => unknown_key;
    an_unknown_spec_key => unknown_top_key;
    an_empty_range => empty_range;
    an_empty_list => empty_list;
    an_impossible_value => impossible_value;
    a_value_of_the_wrong_type => wrong_type;
    an_unknown_level => bad_level;
    no_scene => missing_scene;
    a_source_that_does_not_exist => missing_source;
}

fn refused_case(f: fn()) {
    f();
}

#[test]
fn shards_of_different_specs_are_not_merged() {
    let (_, out) = whole();
    let other = spec_file(&tiny_spec("seed = 7\n"));
    let d = keep().join("other");
    ok(
        &run(&other, &d, Some("1/3"), Some(1)),
        "the other spec's shard",
    );
    let merged = keep().join("merged");
    let o = shellsim(
        &[
            "explore",
            "merge",
            "--out",
            merged.to_str().unwrap(),
            out.to_str().unwrap(),
            d.to_str().unwrap(),
        ],
        None,
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains(&format!("{}", d.join("spec.json").display())),
        "{err}"
    );
    assert!(err.contains("another spec"), "{err}");
    assert!(!merged.join("points.csv").exists());
}

#[test]
fn a_missing_shard_is_named() {
    let (spec, _) = whole();
    let d = keep().join("only");
    ok(&run(spec, &d, Some("0/2"), Some(1)), "shard 0/2");
    let merged = keep().join("merged");
    let o = shellsim(
        &[
            "explore",
            "merge",
            "--out",
            merged.to_str().unwrap(),
            d.to_str().unwrap(),
        ],
        None,
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("3 of 7 points are in no shard"), "{err}");
}

#[test]
fn the_slurm_scripts_run_the_shards_then_the_merge() {
    let (spec, _) = whole();
    let dir = keep().join("slurm");
    let o = shellsim(
        &[
            "explore",
            "slurm",
            "--space",
            spec.to_str().unwrap(),
            "--tasks",
            "4",
            "--out",
            dir.to_str().unwrap(),
        ],
        None,
    );
    ok(&o, "explore slurm");
    let array = std::fs::read_to_string(dir.join("explore.sbatch")).unwrap();
    assert!(array.contains("#SBATCH --array=0-3\n"), "{array}");
    let bin = std::fs::canonicalize(env!("CARGO_BIN_EXE_shellsim")).unwrap();
    assert!(
        array.contains(&format!(
            "'{}' explore run --space '{}'",
            bin.display(),
            spec.display()
        )),
        "{array}"
    );
    assert!(array.contains("/shard-\"$SLURM_ARRAY_TASK_ID\""), "{array}");
    let merge = std::fs::read_to_string(dir.join("merge.sbatch")).unwrap();
    let d = std::fs::canonicalize(&dir).unwrap();
    assert!(merge.contains(&format!("explore merge --out '{}/merged' '{0}/shard-0' '{0}/shard-1' '{0}/shard-2' '{0}/shard-3'\n", d.display())), "{merge}");
    let submit = std::fs::read_to_string(dir.join("submit.sh")).unwrap();
    assert!(submit.contains("sbatch --parsable"), "{submit}");
    assert!(
        submit.contains("--dependency=afterok:\"$array\""),
        "{submit}"
    );
}

/// `source` takes a name as every command does: the public box's `light` is patch 6; a
/// name that names nothing is refused at its line.
#[test]
fn a_source_by_name() {
    let obj = common::scene_path("cornell-public.obj");
    let spec = spec_file(&format!(
        "reference_rays = 2000\nscene = {:?}\nsource = \"light\"\nlevel = \"float\"\n",
        obj.display().to_string()
    ));
    let out = keep().join("named");
    ok(&run(&spec, &out, None, Some(1)), "a source by name");
    let rows = std::fs::read_to_string(out.join("points.csv")).unwrap();
    let row = rows.lines().nth(1).unwrap();
    assert_eq!(row.split(',').nth(2), Some("6"), "{rows}");
    refused(
        &format!(
            "scene = {:?}\nsource = \"lamp\"\n",
            obj.display().to_string()
        ),
        &["line 2", "source", "lamp"],
    );
}
