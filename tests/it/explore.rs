//! `shellsim explore` through the binary: the results are byte-identical across runs, thread
//! counts, resumption and sharding (merged shards for N = 1, 3, 7 equal the unsharded run);
//! bad specs and mismatched shards are refused with exit status 2 naming the file and the
//! problem; the Slurm scripts hold the array, the shard commands and the dependency.

use crate::common;

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
    match shard {
        Some(s) => run_with(spec, out, &["--shard", s], threads),
        None => run_with(spec, out, &[], threads),
    }
}

/// `explore run` of `spec` into `out` with `extra` arguments.
fn run_with(spec: &Path, out: &Path, extra: &[&str], threads: Option<usize>) -> Output {
    let mut a = vec![
        "explore",
        "run",
        "--space",
        spec.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    a.extend(extra);
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
            "{f} differs between {} and {} ({how}); reproduce: cargo test --release --test it explore::",
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

fn bad_timing() {
    refused(
        &tiny_spec("timing = \"fast\"\n"),
        &["line 6", "timing", "fast", "cycle, queue or auto"],
    );
}

fn a_margin_without_auto() {
    refused(
        &tiny_spec("auto_margin = 0.2\n"),
        &["line 6", "auto_margin", "only with timing = \"auto\""],
    );
}

fn margin_out_of_range() {
    refused(
        &tiny_spec("timing = \"auto\"\nauto_margin = 1.5\n"),
        &["line 7", "auto_margin", "not in (0, 1)"],
    );
}

testcases! { refused_case;
    an_unknown_timing_level => bad_timing;
    a_margin_without_auto_timing => a_margin_without_auto;
    a_margin_out_of_range => margin_out_of_range;
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

/// Scene-dependent point values are checked before the first point runs: nothing is left
/// in the output directory, and `explore slurm` refuses the same spec.
#[test]
fn scene_dependent_values_are_checked_before_any_point() {
    // Before: run wrote spec.json and the reference, then failed at the point; slurm
    // wrote its scripts.
    for (extra, want) in [
        ("[[point]]\ncell = 0.00001\n", "cell size"),
        (
            "[[point]]\ndatapath.coord_int_bits = 1\n",
            "does not fit the coordinate format",
        ),
    ] {
        let text = tiny_spec(extra);
        let spec = spec_file(&text);
        let out = keep().join("out");
        let o = run(&spec, &out, None, None);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(err.contains(spec.to_str().unwrap()), "{err}");
        assert!(err.contains(": point ") && err.contains(want), "{err}");
        assert!(!out.exists(), "{} was created: {err}", out.display());
        let dir = keep().join("slurm");
        let o = shellsim(
            &[
                "explore",
                "slurm",
                "--space",
                spec.to_str().unwrap(),
                "--tasks",
                "2",
                "--out",
                dir.to_str().unwrap(),
            ],
            None,
        );
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(err.contains(": point ") && err.contains(want), "{err}");
        assert!(!dir.join("explore.sbatch").exists());
    }
}

/// `explore slurm --space spec --tasks 2 --out out`.
fn slurm_into(spec: &Path, out: &Path) -> Output {
    shellsim(
        &[
            "explore",
            "slurm",
            "--space",
            spec.to_str().unwrap(),
            "--tasks",
            "2",
            "--out",
            out.to_str().unwrap(),
        ],
        None,
    )
}

#[test]
fn slurm_out_naming_a_file_is_refused_up_front() {
    // Before: exit 1 after loading the spec, from create_dir_all.
    let (spec, _) = whole();
    let file = keep().join("a-file");
    std::fs::write(&file, "keep me").unwrap();
    let o = slurm_into(spec, &file);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("--out") && err.contains("is not a directory"),
        "{err}"
    );
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "keep me");
}

/// `points.json` of a run directory as JSON values.
fn points_json(dir: &Path) -> Vec<serde_json::Value> {
    let text = std::fs::read_to_string(dir.join("points.json")).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v["points"].as_array().unwrap().clone()
}

#[test]
fn references_are_cached_by_content_not_by_name() {
    // Two different scenes that share a name (as every seed of a `scene gen` kind does).
    // Before: they shared one cache file; with one thread the second was measured against
    // the first one's reference, with two the run exited 1.
    let d = keep();
    let a = d.join("a.json");
    let b = d.join("b.json");
    std::fs::copy(common::scene_path("scene1.json"), &a).unwrap();
    let cornell = std::fs::read_to_string(common::scene_path("cornell.json")).unwrap();
    let v: serde_json::Value = serde_json::from_str(&cornell).unwrap();
    let name = serde_json::from_str::<serde_json::Value>(&std::fs::read_to_string(&a).unwrap())
        .unwrap()["name"]
        .clone();
    let mut v = v;
    v["name"] = name.clone();
    std::fs::write(&b, serde_json::to_string(&v).unwrap()).unwrap();
    let text = |scenes: &str| {
        format!("reference_rays = 20000\nscene = {scenes}\nlevel = \"float\"\nrays = 2000\n")
    };
    let both = spec_file(&text(&format!(
        "[{:?}, {:?}]",
        a.display().to_string(),
        b.display().to_string()
    )));
    let alone = spec_file(&text(&format!("{:?}", b.display().to_string())));
    let solo = keep().join("solo");
    ok(&run(&alone, &solo, None, Some(1)), "b alone");
    let want = points_json(&solo)[0]["ff_err_max"].clone();
    for threads in [1, 2] {
        let out = keep().join("both");
        ok(&run(&both, &out, None, Some(threads)), "both scenes");
        let p = points_json(&out);
        assert_eq!(p.len(), 2);
        assert_eq!(p[0]["scene"], name);
        assert_eq!(p[1]["scene"], name);
        assert_eq!(
            p[1]["ff_err_max"], want,
            "{threads} threads: the second scene measured against another reference"
        );
        let refs = std::fs::read_dir(out.join("reference")).unwrap().count();
        assert_eq!(refs, 2, "one cached reference per scene");
    }
}

/// A copy of the tiny spec's whole run directory.
fn copy_of_whole() -> PathBuf {
    let (_, out) = whole();
    let d = keep().join("copy");
    std::fs::create_dir_all(d.join("points")).unwrap();
    std::fs::copy(out.join("spec.json"), d.join("spec.json")).unwrap();
    for e in std::fs::read_dir(out.join("points")).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), d.join("points").join(e.file_name())).unwrap();
    }
    d
}

/// `explore merge` of `shards`, killed after 60 s (a hang fails the test).
fn merge_within(shards: &[&Path]) -> (Option<i32>, String, PathBuf) {
    let merged = keep().join("merged");
    let mut c = Command::new(env!("CARGO_BIN_EXE_shellsim"));
    c.args(["explore", "merge", "--out", merged.to_str().unwrap()])
        .args(shards)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped());
    let mut child = c.spawn().unwrap();
    let start = std::time::Instant::now();
    let code = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s.code();
        }
        if start.elapsed().as_secs() > 60 {
            child.kill().unwrap();
            child.wait().unwrap();
            break None;
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    };
    let mut err = String::new();
    use std::io::Read;
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    (code, err, merged)
}

#[test]
fn merge_is_bounded_by_the_files_present() {
    // Before: a spec.json claiming a huge number of points hung merge.
    let d = copy_of_whole();
    let sf = std::fs::read_to_string(d.join("spec.json")).unwrap();
    for (points, want) in [
        ("1000000000000000", "a spec expands to 1..=1000000"),
        ("0", "a spec expands to 1..=1000000"),
        ("999999", "999992 of 999999 points are in no shard"),
    ] {
        let huge = sf.replace("\"points\": 7,", &format!("\"points\": {points},"));
        assert_ne!(huge, sf);
        std::fs::write(d.join("spec.json"), huge).unwrap();
        let (code, err, merged) = merge_within(&[&d]);
        assert_eq!(code, Some(2), "{err}");
        assert!(
            err.contains("spec.json") || err.contains(d.to_str().unwrap()),
            "{err}"
        );
        assert!(err.contains(want), "{err}");
        assert!(!merged.join("points.csv").exists());
    }
    // The copy unchanged merges (the test can fail both ways).
    std::fs::write(d.join("spec.json"), &sf).unwrap();
    let (code, err, merged) = merge_within(&[&d]);
    assert_eq!(code, Some(0), "{err}");
    assert!(merged.join("points.csv").exists());
}

#[test]
fn merge_refuses_a_fifo_point_file() {
    // Before: merge blocked forever reading a FIFO with no writer.
    let d = copy_of_whole();
    let p = d.join("points/000003.json");
    std::fs::remove_file(&p).unwrap();
    assert!(Command::new("mkfifo").arg(&p).status().unwrap().success());
    let (code, err, _) = merge_within(&[&d]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("000003.json") && err.contains("FIFO"), "{err}");
}

#[test]
fn two_runs_started_at_once_on_one_directory_claim_it_once() {
    // Two different shards into one directory: exactly one may claim it. Before: both
    // could pass the exists-then-write check and write into it.
    let (spec, _) = whole();
    for _ in 0..5 {
        let out = keep().join("race");
        let start = |k: &str| {
            Command::new(env!("CARGO_BIN_EXE_shellsim"))
                .args(["explore", "run", "--space", spec.to_str().unwrap()])
                .args(["--out", out.to_str().unwrap(), "--shard", k])
                .env("RAYON_NUM_THREADS", "1")
                .stdout(std::process::Stdio::null())
                .stderr(std::process::Stdio::piped())
                .spawn()
                .unwrap()
        };
        let (a, b) = (start("0/2"), start("1/2"));
        let (a, b) = (a.wait_with_output().unwrap(), b.wait_with_output().unwrap());
        let codes = [a.status.code(), b.status.code()];
        assert!(
            codes.contains(&Some(0)) && codes.contains(&Some(2)),
            "{codes:?}: {}{}",
            String::from_utf8_lossy(&a.stderr),
            String::from_utf8_lossy(&b.stderr)
        );
        let loser = if codes[0] == Some(2) { &a } else { &b };
        assert!(String::from_utf8_lossy(&loser.stderr).contains("another spec or shard"));
    }
}

/// Seconds `spec::parse` takes on a spec whose `seed` lists `n` values.
fn parse_seconds(n: usize) -> f64 {
    let seeds: Vec<String> = (0..n).map(|i| i.to_string()).collect();
    let text = format!(
        "scene = \"scene1.json\"\nlevel = \"float\"\nseed = [{}]\n",
        seeds.join(", ")
    );
    let file = common::scene_path("linear.toml");
    let start = std::time::Instant::now();
    let s = shellsim::explore::spec::parse(&text, &file).unwrap();
    assert_eq!(s.points.len(), n);
    assert_eq!(
        s.axes
            .iter()
            .find(|a| a.key == "seed")
            .unwrap()
            .values
            .len(),
        n
    );
    start.elapsed().as_secs_f64()
}

#[test]
fn a_long_value_list_expands_in_linear_time() {
    // Before: the axes were built by searching each value's list, quadratic — 100k values
    // took 24 s, and 80k about 9 times as long as 20k here (linear: 4 times). Four times
    // the values must take less than 6 times as long.
    let small = parse_seconds(20_000);
    let large = parse_seconds(80_000);
    assert!(
        large < 6.0 * small.max(0.05),
        "20k values: {small:.2} s, 80k: {large:.2} s — not linear"
    );
}

#[test]
fn huge_numbers_are_shown_short() {
    // Before: `source = 1e300` was echoed as 301 digits.
    let spec = spec_file(&tiny_spec("source = 1e300\n"));
    let o = run(&spec, &keep().join("out"), None, None);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("line 6") && err.contains("1e300"), "{err}");
    assert!(!err.contains("0000000000"), "a number printed whole: {err}");
}

#[test]
fn a_spec_named_as_an_output_is_refused() {
    // The spec written where `explore slurm --out DIR` puts explore.sbatch. Before: the
    // spec was replaced by the script, exit 0.
    let dir = keep().join("slurm");
    std::fs::create_dir_all(&dir).unwrap();
    let spec = dir.join("explore.sbatch");
    let text = tiny_spec("");
    std::fs::write(&spec, &text).unwrap();
    let o = slurm_into(&spec, &dir);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("--out") && err.contains("is the input"),
        "{err}"
    );
    assert_eq!(std::fs::read_to_string(&spec).unwrap(), text);
    assert!(!dir.join("submit.sh").exists());
}

/// A reference whose rays cannot fit the memory limit is refused (exit 2, naming the
/// spec and `reference_rays`) before a ray is cast, not aborted by a failed allocation.
#[test]
fn a_reference_too_big_for_the_memory_limit_is_refused() {
    let spec = spec_file(&format!(
        "reference_rays = 100000000\nscene = {:?}\nlevel = \"float\"\n",
        common::scene_path("scene1.json").display().to_string()
    ));
    let out = keep().join("big");
    let o = Command::new(env!("CARGO_BIN_EXE_shellsim"))
        .args(["explore", "run", "--space", spec.to_str().unwrap(), "--out"])
        .arg(&out)
        .env("SHELLSIM_MAX_MEMORY", "2G")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("reference_rays: 100000000"), "{err}");
    assert!(err.contains("more than the limit of 2.1 GB"), "{err}");
}

/// The machine points of a study run with `--timing T` into a new directory: points.csv's
/// rows by index, and front.csv's cycles rows (without the timing column).
fn timed_study(spec: &Path, timing: &str) -> (PathBuf, Vec<Vec<String>>, Vec<String>) {
    let out = keep().join(timing);
    let o = run_with(spec, &out, &["--timing", timing], Some(2));
    ok(&o, &format!("explore run --timing {timing}"));
    let csv = std::fs::read_to_string(out.join("points.csv")).unwrap();
    let rows: Vec<Vec<String>> = csv
        .lines()
        .map(|l| l.split(',').map(String::from).collect())
        .collect();
    let front = std::fs::read_to_string(out.join("front.csv")).unwrap();
    let cycles: Vec<String> = front
        .lines()
        .filter(|l| l.starts_with("cycles,"))
        .map(|l| l.rsplit_once(',').unwrap().0.to_string())
        .collect();
    (out, rows, cycles)
}

/// `timing = "auto"` on a sweep of machine shapes and buffers over two scenes: the front of
/// error against cycles is the all-cycle run's, row for row; fewer points ran at the cycle
/// level; those that did have the cycle run's cycles exactly, the others the queueing
/// network's estimate; the report says which level decided. A sharded auto run is refused.
#[test]
fn auto_timing_finds_the_all_cycle_front_with_fewer_cycle_runs() {
    let spec = spec_file(&format!(
        "reference_rays = 20000\nscene = [{:?}, {:?}]\nlevel = \"machine\"\nratio = [1, 2]\nfrac_bits = [9, 12]\nmachine.clusters = [1, 2, 4]\nmachine.ctus_per_cluster = [1, 2]\nmachine.patch_buffer_capacity = [2, 8]\n",
        common::scene_path("scene1.json").display().to_string(),
        common::scene_path("cornell.json").display().to_string()
    ));
    let (_, cyc, cyc_front) = timed_study(&spec, "cycle");
    let (out, auto, auto_front) = timed_study(&spec, "auto");
    assert_eq!(cyc_front, auto_front, "the fronts of error against cycles");
    assert!(!cyc_front.is_empty());
    let col = |name: &str| cyc[0].iter().position(|h| h == name).unwrap();
    let (cycles, timing, queue) = (col("cycles"), col("timing"), col("queue_cycles"));
    assert_eq!(cyc.len(), 97, "a header and 96 points");
    let mut at_cycle = 0;
    for (c, a) in cyc.iter().zip(&auto).skip(1) {
        assert_eq!(c[timing], "cycle");
        assert_eq!(c[queue], "");
        match a[timing].as_str() {
            "cycle" => {
                at_cycle += 1;
                assert_eq!(a[cycles], c[cycles], "point {}", a[0]);
            }
            "queue" => assert_eq!(a[cycles], a[queue], "point {}", a[0]),
            t => panic!("point {}: timing {t:?}", a[0]),
        }
        assert!(!a[queue].is_empty(), "point {}: no queue estimate", a[0]);
    }
    assert!(
        at_cycle < 96 / 2,
        "{at_cycle} of 96 points ran at the cycle level"
    );
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(
        report.contains(&format!("| 96 | {at_cycle} | {} |", 96 - at_cycle)),
        "{report}"
    );
    // Interrupted after some cycle-level runs: the same points run at the same levels.
    let before: Vec<Vec<u8>> = ["points.csv", "report.md", "front.csv"]
        .iter()
        .map(|f| std::fs::read(out.join(f)).unwrap())
        .collect();
    let gone: Vec<&Vec<String>> = auto
        .iter()
        .skip(1)
        .filter(|r| r[timing] == "cycle")
        .take(3)
        .chain(auto.iter().skip(1).filter(|r| r[timing] == "queue").take(2))
        .collect();
    for r in &gone {
        let i: usize = r[0].parse().unwrap();
        std::fs::remove_file(out.join("points").join(format!("{i:06}.json"))).unwrap();
    }
    let o = run_with(&spec, &out, &["--timing", "auto"], Some(1));
    ok(&o, "the resumed auto run");
    assert!(String::from_utf8_lossy(&o.stdout).contains("5 measured, 91 already there"));
    for (f, b) in ["points.csv", "report.md", "front.csv"].iter().zip(&before) {
        assert!(
            &std::fs::read(out.join(f)).unwrap() == b,
            "{f} differs after resuming"
        );
    }
    let shard = keep().join("shard");
    let o = run_with(&spec, &shard, &["--timing", "auto", "--shard", "0/2"], None);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("unsharded"));
}
