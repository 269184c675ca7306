//! The robustness round (issue 15), one test per defect kind, through the binary: outputs
//! that never destroy what they replace (devices, FIFOs, symlinks, directories, same-path
//! outputs, names from data, a closed standard output), one error contract for every input
//! (exit status 2 with the file, the place and what is wrong), bounded resources and
//! interrupts. Device nodes, FIFOs and symlinks are made in a temporary directory, never
//! the real /dev.

use crate::common;

use std::os::unix::fs::FileTypeExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

/// What a run of the binary gave.
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

    /// Exit status 2, no panic, stderr one `error:` naming every string of `want`, and
    /// nothing on stdout (the check came before any work).
    fn refused(&self, want: &[&str]) {
        let s = self.shown();
        assert_eq!(self.code, Some(2), "{s}");
        assert!(!self.stderr.contains("panicked"), "{s}");
        assert!(self.stderr.starts_with("error: "), "{s}");
        for w in want {
            assert!(self.stderr.contains(w), "stderr lacks {w:?}\n{s}");
        }
    }
}

fn ran(out: Output) -> Ran {
    Ran {
        code: out.status.code(),
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    }
}

fn cmd(dir: &Path, args: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_shellsim"));
    c.current_dir(dir).args(args).stdin(Stdio::null());
    c
}

/// Runs the binary in `dir`.
fn shellsim(dir: &Path, args: &[&str]) -> Ran {
    ran(cmd(dir, args).output().expect("the binary runs"))
}

fn cornell() -> String {
    common::scene_path("cornell.json").display().to_string()
}

/// `shellsim reference` on the committed Cornell box (fast) with `extra` arguments.
fn reference(dir: &Path, extra: &[&str]) -> Ran {
    let scene = cornell();
    let mut args = vec!["reference", "--scene", &scene, "--source", "1"];
    args.extend_from_slice(extra);
    shellsim(dir, &args)
}

/// The names in `dir`, sorted.
fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

fn is_json_report(text: &str) -> bool {
    serde_json::from_str::<serde_json::Value>(text)
        .map(|v| v.get("form_factors").is_some())
        .unwrap_or(false)
}

#[test]
fn a_fifo_as_output_is_written_to_not_replaced() {
    let d = tempfile::tempdir().unwrap();
    let fifo = d.path().join("out.json");
    assert!(Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap()
        .success());
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::read_to_string(fifo).unwrap())
    };
    let r = reference(d.path(), &["--json", "out.json"]);
    assert_eq!(r.code, Some(0), "{}", r.shown());
    let got = reader.join().unwrap();
    assert!(is_json_report(&got), "{got}");
    let ft = std::fs::symlink_metadata(&fifo).unwrap().file_type();
    assert!(ft.is_fifo(), "the FIFO was replaced: {ft:?}");
    assert_eq!(names(d.path()), ["out.json"]);
}

#[test]
fn a_character_device_as_output_is_written_to_not_replaced() {
    let d = tempfile::tempdir().unwrap();
    let dev = d.path().join("null");
    // mknod needs root; as another user this one case is skipped (never the real /dev).
    let made = Command::new("mknod")
        .arg(&dev)
        .args(["c", "1", "3"])
        .stderr(Stdio::null())
        .status()
        .map(|s| s.success())
        .unwrap_or(false);
    if !made {
        eprintln!("skipped: mknod needs root to make a character device in a temporary directory");
        return;
    }
    for args in [
        &["--json", "null"][..],
        &["--json", "null", "--rays", "2000"][..],
    ] {
        let r = reference(d.path(), args);
        assert_eq!(r.code, Some(0), "{}", r.shown());
        let ft = std::fs::symlink_metadata(&dev).unwrap().file_type();
        assert!(ft.is_char_device(), "the device node was replaced: {ft:?}");
    }
    // A VCD streamed to the device: no .gtkw beside it, and the node stays a device.
    let scene = cornell();
    let r = shellsim(
        d.path(),
        &[
            "run", "--scene", &scene, "--source", "1", "--ratio", "1", "--vcd", "null", "--json",
            "run.json",
        ],
    );
    assert_eq!(r.code, Some(0), "{}", r.shown());
    assert!(std::fs::symlink_metadata(&dev)
        .unwrap()
        .file_type()
        .is_char_device());
    assert_eq!(names(d.path()), ["null", "run.json"]);
}

#[test]
fn a_symlink_as_output_keeps_the_link_and_replaces_its_target() {
    let d = tempfile::tempdir().unwrap();
    std::fs::write(d.path().join("target.json"), "old").unwrap();
    std::os::unix::fs::symlink("target.json", d.path().join("link.json")).unwrap();
    let r = reference(d.path(), &["--json", "link.json"]);
    assert_eq!(r.code, Some(0), "{}", r.shown());
    let link = d.path().join("link.json");
    assert!(std::fs::symlink_metadata(&link)
        .unwrap()
        .file_type()
        .is_symlink());
    assert_eq!(std::fs::read_link(&link).unwrap(), Path::new("target.json"));
    let text = std::fs::read_to_string(d.path().join("target.json")).unwrap();
    assert!(is_json_report(&text), "{text}");
    assert_eq!(names(d.path()), ["link.json", "target.json"]);
}

#[test]
fn a_directory_as_a_file_output_is_refused_before_any_work() {
    let d = tempfile::tempdir().unwrap();
    std::fs::create_dir(d.path().join("sub")).unwrap();
    let r = reference(d.path(), &["--json", "sub"]);
    r.refused(&["--json", "sub", "directory"]);
    assert!(
        r.stdout.is_empty(),
        "work ran before the check\n{}",
        r.shown()
    );
    // A parent that is a file, not a directory.
    std::fs::write(d.path().join("f"), "x").unwrap();
    let r = reference(d.path(), &["--json", "f/x.json"]);
    r.refused(&["--json", "not a directory"]);
    assert!(r.stdout.is_empty(), "{}", r.shown());
    assert_eq!(names(d.path()), ["f", "sub"]);
}

#[test]
fn a_file_as_an_output_directory_is_exit_2() {
    let d = tempfile::tempdir().unwrap();
    std::fs::write(d.path().join("afile"), "x").unwrap();
    let scene = cornell();
    for args in [
        vec![
            "sweep", "bits", "--scene", &scene, "--source", "1", "--out", "afile",
        ],
        vec![
            "experiment",
            "efficiency",
            "--scene",
            &scene,
            "--out",
            "afile",
        ],
        vec!["paper", "--out", "afile"],
    ] {
        let r = shellsim(d.path(), &args);
        r.refused(&["--out", "afile", "not a directory"]);
        assert!(r.stdout.is_empty(), "{}", r.shown());
    }
    assert_eq!(
        std::fs::read_to_string(d.path().join("afile")).unwrap(),
        "x"
    );
}

#[test]
fn a_read_only_directory_is_refused_before_any_work() {
    use std::os::unix::fs::PermissionsExt;
    let d = tempfile::tempdir().unwrap();
    let ro = d.path().join("ro");
    std::fs::create_dir(&ro).unwrap();
    std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o555)).unwrap();
    // Root writes in a 0555 directory: nothing to refuse then.
    let probe = ro.join("probe");
    if std::fs::write(&probe, "x").is_ok() {
        let _ = std::fs::remove_file(&probe);
        eprintln!("skipped: running as root, a 0555 directory is writable");
        return;
    }
    let r = reference(d.path(), &["--json", "ro/x.json"]);
    r.refused(&["--json", "cannot write in"]);
    assert!(r.stdout.is_empty(), "{}", r.shown());
}

#[test]
fn a_scene_name_with_dotdot_stays_inside_out() {
    let d = tempfile::tempdir().unwrap();
    let mut scene: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(common::scene_path("cornell.json")).unwrap())
            .unwrap();
    scene["name"] = "../../escaped".into();
    std::fs::write(d.path().join("s.json"), scene.to_string()).unwrap();
    std::fs::create_dir(d.path().join("a")).unwrap();
    let r = shellsim(
        &d.path().join("a"),
        &[
            "sweep",
            "bits",
            "--scene",
            "../s.json",
            "--source",
            "1",
            "--rays",
            "200",
            "--from",
            "10",
            "--to",
            "11",
            "--out",
            "out",
        ],
    );
    assert_eq!(r.code, Some(0), "{}", r.shown());
    assert_eq!(
        names(&d.path().join("a/out")),
        ["bits-______escaped.csv", "bits-______escaped.svg"]
    );
    assert_eq!(names(d.path()), ["a", "s.json"]);
    assert_eq!(names(&d.path().join("a")), ["out"]);
}

#[test]
fn a_closed_stdout_still_writes_the_files_and_says_so() {
    let d = tempfile::tempdir().unwrap();
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader); // every write to stdout fails with EPIPE
    let out = cmd(d.path(), &[])
        .args([
            "reference",
            "--scene",
            &cornell(),
            "--source",
            "1",
            "--json",
            "x.json",
        ])
        .stdout(writer)
        .output()
        .unwrap();
    let r = ran(out);
    assert_eq!(r.code, Some(1), "{}", r.shown());
    assert!(!r.stderr.contains("panicked"), "{}", r.shown());
    assert!(r.stderr.contains("standard output"), "{}", r.shown());
    let text = std::fs::read_to_string(d.path().join("x.json")).unwrap();
    assert!(is_json_report(&text));
}

/// Runs `args` (with `{scene}` replaced) in a fresh directory; it must be refused before
/// any work as two outputs naming one file, and leave the directory empty.
fn same_path(args: &[&str]) {
    let d = tempfile::tempdir().unwrap();
    let scene = cornell();
    let args: Vec<&str> = args
        .iter()
        .map(|a| if *a == "{scene}" { scene.as_str() } else { a })
        .collect();
    let r = shellsim(d.path(), &args);
    r.refused(&["name the same file"]);
    assert!(r.stdout.is_empty(), "{}", r.shown());
    assert!(names(d.path()).is_empty(), "{:?}", names(d.path()));
}

mod same_path_outputs {
    use super::same_path;
    const RUN: [&str; 7] = ["run", "--scene", "{scene}", "--source", "1", "--ratio", "1"];
    fn run(extra: &[&str]) {
        same_path(&[&RUN[..], extra].concat());
    }
    fn partition(extra: &[&str]) {
        let base = [
            "partition",
            "--scene",
            "{scene}",
            "--source",
            "1",
            "--sections",
            "2",
            "--ctus",
            "2",
            "--ratio",
            "1",
        ];
        same_path(&[&base[..], extra].concat());
    }
    crate::testcases! {
        run;
        json_is_vcd => &["--json", "w.vcd", "--vcd", "w.vcd"];
        json_is_gtkw => &["--json", "w.gtkw", "--vcd", "w.vcd"];
        vcd_is_its_own_gtkw => &["--vcd", "w.gtkw"];
        two_spellings => &["--json", "./x/../w.json", "--vcd", "w.json"];
    }
    crate::testcases! {
        partition;
        svg_is_json => &["--json", "p.json", "--svg", "p.json"];
        schedule_is_stdout_twice => &["--json", "-", "--schedule", "-"];
    }
}

#[test]
fn dash_is_standard_output_and_the_summary_moves_to_stderr() {
    let d = tempfile::tempdir().unwrap();
    let r = reference(d.path(), &["--json", "-"]);
    assert_eq!(r.code, Some(0), "{}", r.shown());
    assert!(is_json_report(&r.stdout), "{}", r.shown());
    assert!(r.stderr.contains("cornell from patch 1"), "{}", r.shown());
    assert!(names(d.path()).is_empty());
    let r = shellsim(d.path(), &["scene", "gen", "scene1", "-o", "-"]);
    assert_eq!(r.code, Some(0), "{}", r.shown());
    let v: serde_json::Value = serde_json::from_str(&r.stdout).unwrap();
    assert_eq!(v["name"], "scene1");
}

/// paper.toml with `edit` applied to its text.
fn bad_config(dir: &Path, edit: &dyn Fn(&str) -> String) -> PathBuf {
    let text = std::fs::read_to_string(common::config_path("paper")).unwrap();
    let p = dir.join("bad.toml");
    std::fs::write(&p, edit(&text)).unwrap();
    p
}

/// Every subcommand that takes `--hw` must refuse the same bad file the same way: exit
/// status 2, the file named, and `want` (the key, or the line and column).
fn every_hw_refuses(edit: &dyn Fn(&str) -> String, want: &[&str]) {
    let d = tempfile::tempdir().unwrap();
    bad_config(d.path(), edit);
    let scene = cornell();
    let base = [
        "--scene",
        scene.as_str(),
        "--source",
        "1",
        "--hw",
        "bad.toml",
    ];
    for cmdline in [
        vec!["check"],
        vec!["run", "--ratio", "1"],
        vec![
            "sweep", "bits", "--rays", "100", "--from", "10", "--to", "10",
        ],
        vec!["experiment", "speedup"],
    ] {
        let args = [&cmdline[..], &base[..]].concat();
        let r = shellsim(d.path(), &args);
        r.refused(&[&["bad.toml"][..], want].concat());
        let msg = r.stderr.trim_start_matches("error: ").trim();
        assert!(
            !msg.ends_with(':') && msg.len() > "bad.toml: line 1, column 1:".len() + 5,
            "an empty message\n{}",
            r.shown()
        );
        assert!(!r.stderr.contains("--shell-radius"), "{}", r.shown());
    }
}

mod hw_files {
    use super::every_hw_refuses;
    fn unknown_key() {
        every_hw_refuses(
            &|t| t.replacen("[machine]", "[machine]\nbogus = 1", 1),
            &["unknown field `bogus`", "line "],
        );
    }
    fn extra_table() {
        every_hw_refuses(&|t| format!("{t}\n[extra]\nx = 1\n"), &["extra", "line "]);
    }
    fn zero_clusters() {
        every_hw_refuses(
            &|t| t.replacen("clusters = 4", "clusters = 0", 1),
            &["machine.clusters", "0 is outside"],
        );
    }
    fn key_without_value_at_the_end() {
        every_hw_refuses(&|t| format!("{t}key ="), &["line ", "column", "missing"]);
    }
    fn huge_number_printed_short() {
        every_hw_refuses(
            &|t| t.replacen("cell_size = \"auto\"", "cell_size = -1e300", 1),
            &["machine.cell_size", "-1e300"],
        );
    }
    crate::testcases! {
        super::run_case;
        unknown_key_in_a_table => unknown_key;
        unknown_table => extra_table;
        clusters_zero => zero_clusters;
        key_equals_nothing_at_the_end => key_without_value_at_the_end;
        a_huge_number => huge_number_printed_short;
    }
}

fn run_case(f: fn()) {
    f()
}

#[test]
fn a_configuration_value_is_blamed_on_its_key_not_on_a_flag() {
    // A shell radius the t format holds but that cuts the unit cube into more than
    // 100,000 shells: the partition refuses it, naming the configuration's key.
    let d = tempfile::tempdir().unwrap();
    bad_config(d.path(), &|t| {
        t.replacen("shell_radius = \"auto\"", "shell_radius = 0.00001", 1)
            .replacen("t_frac_bits = 12", "t_frac_bits = 24", 1)
            .replacen("frac_bits = 12", "frac_bits = 14", 1)
    });
    let scene = cornell();
    let r = shellsim(
        d.path(),
        &[
            "run", "--scene", &scene, "--source", "1", "--ratio", "1", "--hw", "bad.toml",
        ],
    );
    r.refused(&["machine.shell_radius", "cornell.json"]);
    assert!(!r.stderr.contains("--shell-radius"), "{}", r.shown());
}

#[test]
fn a_sweep_beyond_the_format_names_the_flag_given() {
    let d = tempfile::tempdir().unwrap();
    let scene = cornell();
    let r = shellsim(
        d.path(),
        &[
            "sweep", "bits", "--scene", &scene, "--source", "1", "--to", "64", "--out", "o",
        ],
    );
    r.refused(&["--to 64"]);
    assert!(!r.stderr.contains("--bits"), "{}", r.shown());
    assert!(names(d.path()).is_empty());
}

#[test]
fn a_grid_error_names_the_scene_and_prints_numbers_short() {
    let d = tempfile::tempdir().unwrap();
    let r = reference(d.path(), &["--cell", "1e-300"]);
    r.refused(&["cornell.json", "1e-300"]);
    assert!(!r.stderr.contains("<grid>"), "{}", r.shown());
    assert!(r.stderr.len() < 200, "a long number\n{}", r.shown());
}

/// Writes `files` into a fresh directory and runs `scene info` on the first.
fn scene_info(files: &[(&str, &str)]) -> Ran {
    let d = tempfile::tempdir().unwrap();
    for (n, t) in files {
        std::fs::write(d.path().join(n), t).unwrap();
    }
    shellsim(d.path(), &["scene", "info", files[0].0])
}

#[test]
fn an_obj_error_names_the_line_and_the_face() {
    let r = scene_info(&[("a.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\nf 1 2 9\n")]);
    r.refused(&["a.obj", "line 5, face 2", "index 9"]);
    let r = scene_info(&[("a.obj", "v 0 0 0\nv 1 0 x\nv 1 1 0\nf 1 2 3\n")]);
    r.refused(&["a.obj", "line 2", "\"x\" is not a number"]);
}

#[test]
fn a_material_library_that_is_a_directory_is_exit_2() {
    let d = tempfile::tempdir().unwrap();
    std::fs::create_dir(d.path().join("m.mtl")).unwrap();
    std::fs::write(
        d.path().join("a.obj"),
        "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n",
    )
    .unwrap();
    let r = shellsim(d.path(), &["scene", "info", "a.obj"]);
    r.refused(&["m.mtl", "is a directory"]);
}

#[test]
fn control_characters_in_names_are_escaped() {
    let scene = r#"{"name": "a\u001b[2Jb", "bounds": [[0,0,0],[1,1,1]], "patches": [{"vertices": [[0,0,0],[1,0,0],[1,1,0]]}]}"#;
    let r = scene_info(&[("s.json", scene)]);
    assert_eq!(r.code, Some(0), "{}", r.shown());
    assert!(!r.stdout.contains('\u{1b}'), "{}", r.shown());
    assert!(r.stdout.contains("a\\u{1b}[2Jb"), "{}", r.shown());
}

/// Starts a long `run` with a VCD, waits until its temporary VCD exists (the run is then
/// under way), sends `signal` and checks the exit status and that no file is left: no
/// temporary file, and nothing under a final name.
fn interrupted(signal: &str, status: i32) {
    let d = tempfile::tempdir().unwrap();
    let scene = common::scene_path("scene2.json").display().to_string();
    let mut child = cmd(
        d.path(),
        &[
            "run",
            "--scene",
            &scene,
            "--ratio",
            "100",
            "--vcd",
            "w/run.vcd",
            "--json",
            "w/run.json",
        ],
    )
    .stdout(Stdio::null())
    .stderr(Stdio::piped())
    .spawn()
    .unwrap();
    let w = d.path().join("w");
    // Poll for the temporary file (not a timing assertion: the run takes minutes).
    loop {
        if w.is_dir() && names(&w).iter().any(|n| n.ends_with(".tmp")) {
            break;
        }
        if let Some(s) = child.try_wait().unwrap() {
            panic!("the run ended ({s}) before it could be interrupted");
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    let pid = child.id().to_string();
    assert!(Command::new("kill")
        .args([signal, &pid])
        .status()
        .unwrap()
        .success());
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(status), "{stderr}");
    assert!(stderr.contains("interrupted"), "{stderr}");
    assert!(names(&w).is_empty(), "left behind: {:?}", names(&w));
}

#[test]
fn sigint_mid_vcd_leaves_nothing_and_exits_130() {
    interrupted("-INT", 130);
}

#[test]
fn sigterm_mid_vcd_leaves_nothing_and_exits_143() {
    interrupted("-TERM", 143);
}

#[test]
fn absurd_rays_are_refused_with_an_estimate_before_allocating() {
    let d = tempfile::tempdir().unwrap();
    // 10^8 rays: the float and fixed-point rays need tens of GB, past the default limit
    // (at most 16 GiB) on any machine.
    let scene = cornell();
    let r = shellsim(
        d.path(),
        &[
            "check",
            "--scene",
            &scene,
            "--source",
            "1",
            "--rays",
            "100000000",
        ],
    );
    r.refused(&[
        "--rays 100000000",
        "would need about",
        "GB",
        "SHELLSIM_MAX_MEMORY",
    ]);
    // A stated, lower limit refuses a smaller request the same way.
    let out = cmd(
        d.path(),
        &[
            "reference",
            "--scene",
            &scene,
            "--source",
            "1",
            "--rays",
            "1000000",
        ],
    )
    .env("SHELLSIM_MAX_MEMORY", "1M")
    .output()
    .unwrap();
    ran(out).refused(&["--rays 1000000", "1.0 MB"]);
}

#[test]
fn a_machine_that_cannot_fit_is_refused_with_an_estimate() {
    let d = tempfile::tempdir().unwrap();
    bad_config(d.path(), &|t| {
        t.replacen("clusters = 4", "clusters = 256", 1)
            .replacen("ctus_per_cluster = 2", "ctus_per_cluster = 64", 1)
            .replacen(
                "ray_buffer_capacity = ",
                "ray_buffer_capacity = 1048576 #",
                1,
            )
            .replacen(
                "request_queue_capacity = ",
                "request_queue_capacity = 65536 #",
                1,
            )
            .replacen(
                "patch_buffer_capacity = ",
                "patch_buffer_capacity = 65536 #",
                1,
            )
    });
    let scene = cornell();
    let out = cmd(
        d.path(),
        &[
            "run", "--scene", &scene, "--source", "1", "--ratio", "1", "--hw", "bad.toml",
        ],
    )
    .env("SHELLSIM_MAX_MEMORY", "1G")
    .output()
    .unwrap();
    ran(out).refused(&[
        "machine configuration",
        "would need about",
        "limit of 1.1 GB",
    ]);
}

#[test]
fn dev_zero_as_input_under_a_memory_limit_is_refused() {
    let d = tempfile::tempdir().unwrap();
    // Address space capped at 512 MiB: reading /dev/zero to its end would be killed; the
    // input limit (16 MiB here) ends it with a message first.
    let bin = env!("CARGO_BIN_EXE_shellsim");
    let out = Command::new("sh")
        .current_dir(d.path())
        .arg("-c")
        .arg(format!(
            "ulimit -v 524288 && exec {bin} scene info /dev/zero"
        ))
        .env("SHELLSIM_MAX_INPUT", "16M")
        .output()
        .unwrap();
    ran(out).refused(&[
        "/dev/zero",
        "input limit of 16777216 bytes",
        "SHELLSIM_MAX_INPUT",
    ]);
    let out = cmd(
        d.path(),
        &["reference", "--scene", "/dev/zero", "--source", "0"],
    )
    .env("SHELLSIM_MAX_INPUT", "1M")
    .output()
    .unwrap();
    ran(out).refused(&["/dev/zero", "input limit"]);
}

/// `run` on the Cornell box, ratio 1, with `extra` arguments, in `dir`.
fn run_cornell(dir: &Path, extra: &[&str]) -> Ran {
    let scene = cornell();
    let mut args = vec!["run", "--scene", &scene, "--source", "1", "--ratio", "1"];
    args.extend_from_slice(extra);
    shellsim(dir, &args)
}

#[test]
fn a_vcd_scope_matching_nothing_is_an_error_not_an_empty_file() {
    let d = tempfile::tempdir().unwrap();
    let r = run_cornell(d.path(), &["--vcd", "w.vcd", "--vcd-scope", "no_such_unit"]);
    r.refused(&["--vcd-scope", "no_such_unit", "matches no signal"]);
    assert!(names(d.path()).is_empty(), "{:?}", names(d.path()));
    // A pattern that matches writes the pair.
    let r = run_cornell(d.path(), &["--vcd", "w.vcd", "--vcd-scope", "icu"]);
    assert_eq!(r.code, Some(0), "{}", r.shown());
    assert_eq!(names(d.path()), ["w.gtkw", "w.sucl", "w.vcd"]);
}

#[test]
fn an_fst_pack_for_a_vcd_is_an_error_not_a_silently_ignored_flag() {
    let d = tempfile::tempdir().unwrap();
    let r = run_cornell(d.path(), &["--vcd", "w.vcd", "--fst-pack", "lz4"]);
    r.refused(&["--fst-pack", "w.vcd", "FILE.fst"]);
    assert!(names(d.path()).is_empty(), "{:?}", names(d.path()));
    // With an FST it writes the pair.
    let r = run_cornell(d.path(), &["--wave", "w.fst", "--fst-pack", "lz4"]);
    assert_eq!(r.code, Some(0), "{}", r.shown());
    assert_eq!(names(d.path()), ["w.fst", "w.gtkw", "w.sucl"]);
}

#[test]
fn a_waveform_past_wave_limit_stops_the_run_and_leaves_nothing() {
    let d = tempfile::tempdir().unwrap();
    let r = run_cornell(d.path(), &["--vcd", "w.vcd", "--wave-limit", "1K"]);
    r.refused(&["--wave-limit", "--vcd-window", "--vcd-scope"]);
    assert!(names(d.path()).is_empty(), "{:?}", names(d.path()));
    // The default limit (2 GiB) lets the same run write its waveform.
    let r = run_cornell(d.path(), &["--vcd", "w.vcd"]);
    assert_eq!(r.code, Some(0), "{}", r.shown());
    assert!(std::fs::metadata(d.path().join("w.vcd")).unwrap().len() > 1024);
}

#[test]
fn the_gtkw_names_its_vcd_relative_to_itself() {
    let a = tempfile::tempdir().unwrap();
    let b = tempfile::tempdir().unwrap();
    for d in [a.path(), b.path()] {
        let r = run_cornell(d, &["--vcd", "sub/w.vcd"]);
        assert_eq!(r.code, Some(0), "{}", r.shown());
    }
    let ga = std::fs::read_to_string(a.path().join("sub/w.gtkw")).unwrap();
    let gb = std::fs::read_to_string(b.path().join("sub/w.gtkw")).unwrap();
    assert!(ga.contains("[dumpfile] \"w.vcd\"\n"), "{ga}");
    assert_eq!(ga, gb, "the save file depends on where it was written");
}
