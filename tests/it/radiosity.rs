//! The whole radiosity job: the form-factor matrix on all three models (row sums, no
//! escape, reciprocity, fixed = machine entry for entry, fixed against float explained by
//! the check classes), the solution (the grey box's analytic power, Gauss-Seidel against
//! shooting), thread-count independence through the CLI, the PNG decoded, bad input.

use crate::common;

use shellsim::fixed::check::check;
use shellsim::fixed::records::HostFixed;
use shellsim::radiosity::matrix::{self, FormMatrix, MatrixSpec, Model};
use shellsim::radiosity::render::{self, Camera};
use shellsim::radiosity::solve::{self, Method, SolveParams, System};
use shellsim::reference::rays::Directions;
use shellsim::reference::tracer::Tracer;
use shellsim::scene::{Scene, Spectrum};
use std::path::{Path, PathBuf};
use std::process::Command;

fn spec(model: Model, rays: usize, sources: std::ops::Range<u32>) -> MatrixSpec {
    MatrixSpec {
        model,
        rays,
        directions: Directions::Rings,
        seed: 1,
        sources,
    }
}

fn compute(scene: &Scene, file: &Path, s: &MatrixSpec) -> FormMatrix {
    let cfg = shellsim::config::built_in();
    matrix::compute(scene, file, cfg, s, false).unwrap_or_else(|e| panic!("{e}"))
}

/// The sources a case covers: all of them, except scene2 on the machine (the first 24).
fn sources(file: &str, model: Model, n: usize) -> std::ops::Range<u32> {
    if file == "scene2.json" && model == Model::Machine {
        0..24
    } else {
        0..n as u32
    }
}

/// Every row sums to 1 and, in these closed scenes, no ray of any model escapes (the
/// fixed-point models start a ray an LSB inside its source and off its plane:
/// `HostFixed::ray_from`).
fn row_sums_are_one(file: &str, model: Model) {
    let scene = common::load(file);
    let path = common::scene_path(file);
    let s = spec(model, 969, sources(file, model, scene.patches.len()));
    let m = compute(&scene, &path, &s);
    let repro = format!(
        "shellsim matrix --scene scenes/{file} --model {}",
        model.name()
    );
    for r in &m.rows {
        assert!(
            (r.sum() - 1.0).abs() < 1e-12,
            "row {}: {} ({repro})",
            r.source,
            r.sum()
        );
        assert_eq!(r.escaped, 0.0, "row {} escapes ({repro})", r.source);
    }
}

mod row_sums {
    use super::*;
    testcases! { row_sums_are_one;
        scene1_float => "scene1.json", Model::Float;
        scene1_fixed => "scene1.json", Model::Fixed;
        scene1_machine => "scene1.json", Model::Machine;
        scene2_float => "scene2.json", Model::Float;
        scene2_fixed => "scene2.json", Model::Fixed;
        scene2_machine => "scene2.json", Model::Machine;
        cornell_float => "cornell.json", Model::Float;
        cornell_fixed => "cornell.json", Model::Fixed;
        cornell_machine => "cornell.json", Model::Machine;
    }
}

/// The machine's matrix equals the untimed model's entry for entry (bit for bit), and no
/// row has a mismatch.
fn fixed_equals_machine(file: &str) {
    let scene = common::load(file);
    let path = common::scene_path(file);
    let src = sources(file, Model::Machine, scene.patches.len());
    let a = compute(&scene, &path, &spec(Model::Fixed, 969, src.clone()));
    let b = compute(&scene, &path, &spec(Model::Machine, 969, src));
    assert_eq!(
        a.rows, b.rows,
        "shellsim matrix --scene scenes/{file} --model machine"
    );
    assert!(b.machine.iter().all(|m| m.mismatches_vs_fixed == 0));
    assert_eq!(a.matrix_market(), b.matrix_market());
}

mod fixed_equals_machine {
    use super::*;
    testcases! { fixed_equals_machine;
        scene1 => "scene1.json";
        cornell => "cornell.json";
        scene2_first_rows => "scene2.json";
    }
}

/// The fixed-point scene and the float tracer of `scene` on the built-in configuration
/// (its cell size resolved for the scene).
fn models(scene: &Scene, path: &Path) -> (HostFixed, Tracer) {
    let cfg = shellsim::config::built_in();
    let cell = shellsim::config::cell_size(cfg.machine.cell_size, scene.size());
    (
        HostFixed::new(scene, path, cfg.datapath, cell).unwrap(),
        Tracer::new(scene, cell).unwrap(),
    )
}

/// Every difference between the fixed and float matrices comes from rays `check` explains:
/// no row has an unexplained mismatch.
fn fixed_vs_float_explained(file: &str) {
    let scene = common::load(file);
    let path = common::scene_path(file);
    let (host, tracer) = models(&scene, &path);
    let s = spec(Model::Fixed, 969, 0..scene.patches.len() as u32);
    for i in s.sources.clone() {
        let set = matrix::rays_of(&scene, &s, i);
        let c = check(&tracer, &host, &set, i, Default::default());
        assert_eq!(
            c.unexplained_mismatches, 0,
            "shellsim check --scene scenes/{file} --source {i} --rays 969 --seed 1"
        );
    }
}

mod fixed_vs_float {
    use super::*;
    testcases! { fixed_vs_float_explained;
        scene1 => "scene1.json";
        cornell => "cornell.json";
        scene2 => "scene2.json";
    }
}

/// Reciprocity A_i F_ij = A_j F_ji over the whole matrix, within 5 standard errors of the
/// difference: with the pooled estimate G = (A_i F_ij + A_j F_ji)/2 of both sides, each
/// side counts hits of probability p = G/A over N rays, so |A_i F_ij − A_j F_ji| ≤
/// 5 √(A_i G (1 − G/A_i)/N + A_j G (1 − G/A_j)/N) + 1e-12 (binomial; the ring directions
/// and stratified origins do better than independent samples). Pooling keeps an entry that
/// no ray hit (a rare event) from claiming zero error.
fn reciprocity(file: &str, model: Model, rays: usize) {
    let scene = common::load(file);
    let path = common::scene_path(file);
    let m = compute(
        &scene,
        &path,
        &spec(model, rays, 0..scene.patches.len() as u32),
    );
    let f = m.dense();
    let a: Vec<f64> = scene.patches.iter().map(|p| p.area()).collect();
    let n = rays as f64;

    for i in 0..m.n {
        for j in i + 1..m.n {
            let d = (a[i] * f[i][j] - a[j] * f[j][i]).abs();
            let g = 0.5 * (a[i] * f[i][j] + a[j] * f[j][i]);
            let side = |ak: f64| ak * g * (1.0 - (g / ak).min(1.0)) / n;
            let bound = 5.0 * (side(a[i]) + side(a[j])).sqrt() + 1e-12;
            assert!(
                d <= bound,
                "A{i} F{i}{j} = {} vs A{j} F{j}{i} = {}: {d} > {bound} (shellsim matrix --scene scenes/{file} --model {} --rays {rays})",
                a[i] * f[i][j],
                a[j] * f[j][i],
                model.name()
            );
        }
    }
}

mod reciprocity {
    use super::*;
    testcases! { reciprocity;
        scene1_float => "scene1.json", Model::Float, 3876;
        cornell_float => "cornell.json", Model::Float, 3876;
        cornell_machine => "cornell.json", Model::Machine, 3876;
    }
}

/// The unit cube (every wall ρ = 0.5) with `emitting` walls of E = 1, its matrix on `model`.
fn grey_box(model: Model, emitting: &[usize]) -> (Scene, FormMatrix) {
    let mut scene = common::unit_cube();
    for &k in emitting {
        scene.patches[k].emission = Spectrum::Grey(1.0);
    }
    let m = compute(&scene, Path::new("unit-cube"), &spec(model, 3876, 0..6));
    (scene, m)
}

/// A closed grey box (nothing escapes, no back side is hit, in every model). The `power`
/// system's energy balance is exact: total power Σ A B = Σ A E / (1 − ρ) to solver
/// tolerance with every wall emitting (12) and with one (2). The `gather` system is exact
/// for uniform emission — B = E / (1 − ρ) = 2 on every patch, since every row sums to 1 —
/// and off by the matrix's departure from reciprocity (a few % at 3876 rays per wall) in
/// the one-emitter power, which the test bounds.
fn grey_box_energy(model: Model) {
    let power = |scene: &Scene, s: &solve::Solution| -> f64 {
        scene
            .patches
            .iter()
            .zip(&s.b)
            .map(|(p, b)| p.area() * b[0])
            .sum()
    };
    let g = SolveParams::default();
    let p = SolveParams {
        system: System::Power,
        ..g
    };
    let (scene, m) = grey_box(model, &[0, 1, 2, 3, 4, 5]);
    for r in &m.rows {
        assert_eq!((r.escaped, r.back), (0.0, 0.0), "row {}", r.source);
    }
    let s = solve::solve(&m, &scene, g).unwrap();
    for b in &s.b {
        for c in b {
            assert!((c - 2.0).abs() <= 1e-10, "gather: {c} vs E/(1−ρ) = 2");
        }
    }
    let s = solve::solve(&m, &scene, p).unwrap();
    let total = power(&scene, &s);
    assert!((total - 12.0).abs() < 1e-10, "power: Σ A B = {total} vs 12");
    let (scene, m) = grey_box(model, &[1]);
    let s = solve::solve(&m, &scene, p).unwrap();
    assert!(s.converged);
    let total = power(&scene, &s);
    assert!((total - 2.0).abs() < 1e-10, "power: Σ A B = {total} vs 2");
    assert!(s.energy.imbalance.abs() < 1e-10, "{:?}", s.energy);
    let s = solve::solve(&m, &scene, g).unwrap();
    assert!(s.converged);
    let total = power(&scene, &s);
    assert!((total - 2.0).abs() < 0.04, "gather: Σ A B = {total} vs 2");
    assert!(s.energy.imbalance.abs() < 0.02, "{:?}", s.energy);
}

mod grey_box {
    use super::*;
    testcases! { grey_box_energy;
        float => Model::Float;
        fixed => Model::Fixed;
        machine => Model::Machine;
    }
}

/// Gauss-Seidel and Southwell shooting reach the same solution to the tolerance.
fn gauss_seidel_agrees_with_shooting(file: &str, system: System) {
    let scene = common::load(file);
    let path = common::scene_path(file);
    let m = compute(
        &scene,
        &path,
        &spec(Model::Float, 969, 0..scene.patches.len() as u32),
    );
    let p = SolveParams {
        system,
        ..SolveParams::default()
    };
    let gs = solve::solve(&m, &scene, p).unwrap();
    let sh = solve::solve(
        &m,
        &scene,
        SolveParams {
            method: Method::Shoot,
            ..p
        },
    )
    .unwrap();
    assert!(
        gs.converged && sh.converged,
        "{} {}",
        gs.residual,
        sh.residual
    );
    let scale = gs.b.iter().flatten().fold(0.0f64, |a, &x| a.max(x));
    for (x, y) in gs.b.iter().zip(&sh.b) {
        for c in 0..3 {
            assert!((x[c] - y[c]).abs() <= 1e-9 * scale, "{x:?} vs {y:?}");
        }
    }
}

mod gauss_seidel_vs_shooting {
    use super::*;
    testcases! { gauss_seidel_agrees_with_shooting;
        cornell_power => "cornell.json", System::Power;
        scene2_power => "scene2.json", System::Power;
        cornell_gather => "cornell.json", System::Gather;
        scene2_gather => "scene2.json", System::Gather;
    }
}

fn shellsim(args: &[&str], threads: &str) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_shellsim"))
        .args(args)
        .env("RAYON_NUM_THREADS", threads)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap()
}

fn files(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut v: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .filter(|e| e.as_ref().unwrap().path().is_file())
        .map(|e| {
            let p = e.unwrap().path();
            let b = std::fs::read(&p).unwrap();
            (PathBuf::from(p.file_name().unwrap()), b)
        })
        .collect();
    v.sort();
    v
}

/// `matrix` and `radiosity --compare` on 1 and 2 threads write the same bytes.
fn thread_count_changes_no_byte(file: &str) {
    let tmp = tempfile::tempdir().unwrap();
    let scene = format!("scenes/{file}");
    for t in ["1", "2"] {
        let d = tmp.path().join(t);
        let mtx = d.join("m.mtx");
        let o = shellsim(
            &[
                "matrix",
                "--scene",
                &scene,
                "--model",
                "machine",
                "--out",
                mtx.to_str().unwrap(),
            ],
            t,
        );
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let o = shellsim(
            &[
                "radiosity",
                "--scene",
                &scene,
                "--compare",
                "float,machine",
                "--shading",
                "smooth",
                "--size",
                "96x64",
                "--out",
                d.join("r").to_str().unwrap(),
            ],
            t,
        );
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let (a, b) = (tmp.path().join("1"), tmp.path().join("2"));
    assert_eq!(
        files(&a),
        files(&b),
        "matrix outputs differ between 1 and 2 threads"
    );
    assert_eq!(
        files(&a.join("r")),
        files(&b.join("r")),
        "radiosity outputs differ"
    );
}

mod thread_count {
    use super::*;
    testcases! { thread_count_changes_no_byte;
        cornell => "cornell.json";
        scene1 => "scene1.json";
    }
}

/// The written PNG decodes to the asked size and its brightest pixel shows an emitter.
fn png_shows_the_emitter_brightest(file: &str) {
    let tmp = tempfile::tempdir().unwrap();
    let o = shellsim(
        &[
            "radiosity",
            "--scene",
            &format!("scenes/{file}"),
            "--size",
            "120x90",
            "--out",
            tmp.path().to_str().unwrap(),
        ],
        "2",
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let img = image::open(tmp.path().join("image.png")).unwrap().to_rgb8();
    assert_eq!(img.dimensions(), (120, 90));
    let scene = common::load(file);
    let tracer = Tracer::new(
        &scene,
        shellsim::config::cell_size(shellsim::config::built_in().machine.cell_size, scene.size()),
    )
    .unwrap();
    let up = render::up_axis(&scene, &common::scene_path(file)).0;
    let hits = render::cast(&tracer, &Camera::default_for(&scene, up), 120, 90);
    let lum = |p: &image::Rgb<u8>| p.0.iter().map(|&c| c as u32).sum::<u32>();
    let (k, _) = img
        .pixels()
        .enumerate()
        .max_by_key(|(k, p)| (lum(p), std::cmp::Reverse(*k)))
        .unwrap();
    let id = hits.hits[k].expect("the brightest pixel sees a patch").0;
    assert!(
        scene.patches[id as usize].emission.is_nonzero(),
        "brightest pixel shows patch {id}"
    );
    let emitters = hits
        .hits
        .iter()
        .filter(|h| h.is_some_and(|(id, _)| scene.patches[id as usize].emission.is_nonzero()))
        .count();
    assert!(emitters > 0);
}

mod png {
    use super::*;
    testcases! { png_shows_the_emitter_brightest;
        cornell => "cornell.json";
        scene2 => "scene2.json";
    }
}

/// Bad input ends with exit status 2 and a message naming the file or option and the fault.
fn bad_input(args: &[&str], expect: &[&str]) {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let mut a: Vec<String> = args
        .iter()
        .map(|s| s.replace("{tmp}", tmp.path().to_str().unwrap()))
        .collect();
    if a.iter().any(|s| s.contains("nan.mtx")) {
        std::fs::write(
            tmp.path().join("nan.mtx"),
            "%%MatrixMarket matrix coordinate real general\n18 18 1\n1 2 NaN\n",
        )
        .unwrap();
    }
    if a.iter().any(|s| s.contains("s1.mtx")) {
        let o = shellsim(
            &[
                "matrix",
                "--scene",
                "scenes/scene1.json",
                "--model",
                "float",
                "--out",
                &format!("{}/s1.mtx", tmp.path().display()),
            ],
            "2",
        );
        assert!(o.status.success());
    }
    a.extend(["--out".to_string(), out.to_str().unwrap().to_string()]);
    let refs: Vec<&str> = a.iter().map(|s| s.as_str()).collect();
    let o = shellsim(&refs, "2");
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    for e in expect {
        assert!(err.contains(e), "{args:?}: {err:?} lacks {e:?}");
    }
    assert!(!out.exists(), "{args:?} wrote output");
}

mod bad_input {
    use super::*;
    testcases! { bad_input;
        matrix_of_another_scene => &["radiosity", "--scene", "scenes/cornell.json", "--matrix", "{tmp}/s1.mtx"], &["s1.mtx", "another scene"];
        nan_entry => &["radiosity", "--scene", "scenes/cornell.json", "--matrix", "{tmp}/nan.mtx"], &["nan.mtx", "entry (1, 2)", "NaN"];
        camera_too_few_numbers => &["radiosity", "--scene", "scenes/cornell.json", "--camera", "0,0,0,1,1,1"], &["--camera", "want 10"];
        camera_not_a_number => &["radiosity", "--scene", "scenes/cornell.json", "--camera", "0,0,x,1,1,1,0,0,1,60"], &["--camera", "\"x\" is not a number"];
        camera_nan => &["radiosity", "--scene", "scenes/cornell.json", "--camera", "0,0,NaN,1,1,1,0,0,1,60"], &["--camera", "NaN is not finite"];
        camera_up_parallel => &["radiosity", "--scene", "scenes/cornell.json", "--camera", "0.5,0.9,0.5,0.5,0.1,0.5,0,1,0,60"], &["--camera", "parallel"];
        compare_unknown_model => &["radiosity", "--scene", "scenes/cornell.json", "--compare", "float,gpu"], &["--compare", "float, fixed, machine"];
        sources_out_of_range => &["matrix", "--scene", "scenes/cornell.json", "--model", "float", "--sources", "5..99"], &["--sources", "5..99 (TO excluded)", "patches 0..=17"];
        sources_inclusive_form => &["matrix", "--scene", "scenes/cornell.json", "--model", "float", "--sources", "5..=9"], &["--sources", "TO is excluded"];
        tol_nan => &["radiosity", "--scene", "scenes/cornell.json", "--tol", "NaN"], &["--tol", "NaN"];
    }
}

/// `radiosity --matrix` on the file `matrix` wrote solves to the same radiosity, byte for
/// byte, as `radiosity` computing the matrix itself (Matrix Market keeps every f64 exactly).
fn matrix_file_round_trip(file: &str, model: &str) {
    let tmp = tempfile::tempdir().unwrap();
    let scene = format!("scenes/{file}");
    let t = |p: &str| tmp.path().join(p).to_str().unwrap().to_string();
    let o = shellsim(
        &[
            "matrix",
            "--scene",
            &scene,
            "--model",
            model,
            "--out",
            &t("m.mtx"),
        ],
        "2",
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = shellsim(
        &[
            "radiosity",
            "--scene",
            &scene,
            "--matrix",
            &t("m.mtx"),
            "--size",
            "32x32",
            "--out",
            &t("a"),
        ],
        "2",
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = shellsim(
        &[
            "radiosity",
            "--scene",
            &scene,
            "--model",
            model,
            "--size",
            "32x32",
            "--out",
            &t("b"),
        ],
        "2",
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in ["radiosity.csv", "image.png"] {
        assert_eq!(
            std::fs::read(tmp.path().join("a").join(f)).unwrap(),
            std::fs::read(tmp.path().join("b").join(f)).unwrap(),
            "{f}: shellsim radiosity --scene {scene} --matrix m.mtx"
        );
    }
}

mod matrix_file {
    use super::*;
    testcases! { matrix_file_round_trip;
        cornell_machine => "cornell.json", "machine";
        scene1_fixed => "scene1.json", "fixed";
    }
}

/// Issue 30: `radiosity --compare` judges the difference in noise units — exit 0 between
/// the machine and the float reference on scene1 at the default width, exit 1 naming the
/// patches at 7 fractional bits, where the fixed point shifts scene1's small patches.
#[test]
fn compare_fails_beyond_the_noise_naming_the_patches() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r");
    let o = out.to_str().unwrap();
    let ok = shellsim(
        &[
            "radiosity",
            "--scene",
            "scenes/scene1.json",
            "--compare",
            "float,machine",
            "--out",
            o,
        ],
        "2",
    );
    assert!(
        ok.status.success(),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    let toml = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("hw/configs/paper.toml"),
    )
    .unwrap()
    .replace("frac_bits = 12 ", "frac_bits = 7 ");
    let hw = dir.path().join("f7.toml");
    std::fs::write(&hw, toml).unwrap();
    let bad = shellsim(
        &[
            "radiosity",
            "--scene",
            "scenes/scene1.json",
            "--compare",
            "float,fixed",
            "--hw",
            hw.to_str().unwrap(),
            "--out",
            o,
        ],
        "2",
    );
    let e = String::from_utf8_lossy(&bad.stderr);
    assert_eq!(bad.status.code(), Some(1), "{e}");
    assert!(
        e.contains("more than 3 noise units on") && e.contains("patches ("),
        "{e}"
    );
}

/// `c` (shellsim, or a wrapper that runs it) asked for one float row of 2×10⁷ rays of
/// `scene` into `out`.
fn twenty_million_rays(mut c: Command, scene: &Path, out: &Path) -> std::process::Output {
    c.args(["matrix", "--scene"])
        .arg(scene)
        .args([
            "--model",
            "float",
            "--rays",
            "20000000",
            "--sources",
            "0..1",
            "--out",
        ])
        .arg(out)
        .output()
        .unwrap()
}

/// A matrix whose rays cannot fit the memory limit is refused before anything is
/// allocated (exit 2, naming `--rays`, the estimate and the limit), and nothing is written;
/// one that fits announces its plan and the size of the `.mtx` before writing it.
#[test]
fn matrix_memory_is_estimated_and_announced() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.mtx");
    let scene = common::scene_path("scene2.json");
    let mut c = Command::new(env!("CARGO_BIN_EXE_shellsim"));
    c.env("SHELLSIM_MAX_MEMORY", "1G");
    let o = twenty_million_rays(c, &scene, &out);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("--rays 20000000"), "{err}");
    assert!(err.contains("more than the limit of 1.1 GB"), "{err}");
    assert!(!out.exists());
    let o = shellsim(
        &[
            "matrix",
            "--scene",
            scene.to_str().unwrap(),
            "--model",
            "float",
            "--sources",
            "0..10",
            "--out",
            out.to_str().unwrap(),
        ],
        "2",
    );
    let said = String::from_utf8_lossy(&o.stdout);
    assert_eq!(o.status.code(), Some(0), "{said}");
    assert!(said.contains("memory: about "), "{said}");
    let bytes = std::fs::metadata(&out).unwrap().len() as f64;
    let announced = said
        .lines()
        .find_map(|l| l.strip_prefix(&format!("writing {}: ", out.display())))
        .unwrap_or_else(|| panic!("no writing line: {said}"));
    // "N nonzeros, about 12.3 kB": the estimate within 25 % of the file.
    let (num, unit) = announced
        .split("about ")
        .nth(1)
        .and_then(|a| a.split_once(' '))
        .unwrap();
    let scale = match unit {
        "B" => 1.0,
        "kB" => 1e3,
        "MB" => 1e6,
        _ => 1e9,
    };
    let est = num.parse::<f64>().unwrap() * scale;
    assert!((est / bytes - 1.0).abs() < 0.25, "{est} vs {bytes}");
}

/// Under an address-space limit (`ulimit -v`, as a batch system sets it) the limit is the
/// smaller of it and the default: the 20 M-ray row is refused with exit 2 naming that
/// limit, not aborted by a failed allocation.
#[test]
fn the_address_space_limit_binds_the_memory_estimate() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.mtx");
    let scene = common::scene_path("scene2.json");
    let mut c = Command::new("bash");
    c.args(["-c", "ulimit -v 2000000 && exec \"$0\" \"$@\""])
        .arg(env!("CARGO_BIN_EXE_shellsim"))
        .env_remove("SHELLSIM_MAX_MEMORY");
    let o = twenty_million_rays(c, &scene, &out);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("more than the limit of 2.0 GB"), "{err}");
    assert!(err.contains("ulimit -v"), "{err}");
    assert!(!out.exists());
}

/// `matrix --model machine --sample K`: the form factors are every row's, byte for byte
/// those of the full machine matrix (the untimed model's, which the machine equals), and
/// the full run's total cycles lie inside the sampled estimate's 95 % interval; a sample
/// the design cannot take is refused.
#[test]
fn a_sampled_machine_matrix_brackets_the_full_run() {
    use shellsim::radiosity::matrix::compute;
    use shellsim::radiosity::sample::compute_sampled;
    let (scene, cfg, spec) = box_machine_matrix();
    let n = scene.patches.len() as u32;
    let path = Path::new("box-4");
    let full = compute(&scene, path, &cfg, &spec, false).unwrap();
    let truth: u64 = full.machine.iter().map(|m| m.cycles).sum();
    let (m, t) = compute_sampled(&scene, path, &cfg, &spec, 24, 1).unwrap();
    assert_eq!(m.matrix_market(), full.matrix_market());
    assert_eq!((t.sampled, t.strata, t.mismatches_vs_fixed), (24, 12, 0));
    assert!(
        (t.cycles_estimate - truth as f64).abs() <= t.cycles_ci95,
        "{} ± {} against {truth}",
        t.cycles_estimate,
        t.cycles_ci95
    );
    for k in [3, 2, 2 * n as usize] {
        let e = compute_sampled(&scene, path, &cfg, &spec, k, 1).unwrap_err();
        assert!(e.to_string().contains("want an even number"), "{e}");
    }
}

/// The 96-patch box's whole matrix on the machine model, 969 rings rays a row, paper.toml.
fn box_machine_matrix() -> (
    shellsim::Scene,
    shellsim_hw::config::MachineConfig,
    shellsim::radiosity::matrix::MatrixSpec,
) {
    let scene = shellsim::scene::gen::corpus::subdivided_box(4, glam::DVec3::ONE, false);
    let n = scene.patches.len() as u32;
    let spec = shellsim::radiosity::matrix::MatrixSpec {
        model: shellsim::radiosity::matrix::Model::Machine,
        rays: 969,
        directions: shellsim::reference::rays::Directions::Rings,
        seed: 1,
        sources: 0..n,
    };
    (scene, *shellsim::config::built_in(), spec)
}

/// `matrix --model machine --timing queue`: the same matrix as the cycle model's (every row
/// from the untimed model, which the machine equals), each row's cycles from the queueing
/// network within 5 % of the cycle model's and the total within 2 %.
#[test]
fn a_queue_timed_machine_matrix_matches_the_cycle_model() {
    use shellsim::radiosity::matrix::{compute, compute_timed};
    let (scene, cfg, spec) = box_machine_matrix();
    let path = Path::new("box-4");
    let full = compute(&scene, path, &cfg, &spec, false).unwrap();
    let q = compute_timed(&scene, path, &cfg, &spec, false, true).unwrap();
    assert_eq!(q.matrix_market(), full.matrix_market());
    assert_eq!(q.machine.len(), full.machine.len());
    let (mut tc, mut tq) = (0u64, 0u64);
    for (k, (c, e)) in full.machine.iter().zip(&q.machine).enumerate() {
        let err = (e.cycles as f64 - c.cycles as f64).abs() / c.cycles as f64;
        assert!(
            err <= 0.05,
            "row {k}: queue {} vs cycle {}",
            e.cycles,
            c.cycles
        );
        assert_eq!(e.jobs, c.jobs, "row {k}");
        tc += c.cycles;
        tq += e.cycles;
    }
    let err = (tq as f64 - tc as f64).abs() / tc as f64;
    assert!(err <= 0.02, "total: queue {tq} vs cycle {tc}");
}
