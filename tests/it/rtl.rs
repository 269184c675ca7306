//! The RTL against the model (issue 32): the Verilated ICU pipeline and DDA step agree with
//! the model bit for bit in every stage register and handshake at three widths, and a
//! one-bit change of a rounding or a tie rule in the RTL is caught and named by its stage.
//! Needs `verilator` on PATH (.ci/run installs it): without it these tests fail, naming it.

use shellsim::rtl::cosim::{self, build, replay_dda, replay_icu, Pressure};
use shellsim::rtl::layout::{Params, Unit};
use shellsim::rtl::vectors::{directed_and_random, random_dda};
use shellsim::rtl::SOURCES;
use shellsim_hw::config::{paper, MachineConfig};

fn config(frac: u32) -> MachineConfig {
    let mut c = paper();
    c.datapath.frac_bits = frac;
    c.datapath.t_frac_bits = frac;
    c
}

#[test]
fn the_rtl_equals_the_model_in_every_stage_at_8_12_and_16_bits() {
    use shellsim::scene::gen::{generate, Kind};
    for frac in [8, 12, 16] {
        let o = cosim::Options {
            cfg: config(frac),
            vectors: 150_000,
            scenes: vec![("scene2".into(), generate(Kind::Scene2, 1))],
            seed: frac as u64,
            pressure: Pressure {
                offer: 0.7,
                take: 0.6,
                seed: 3,
            },
            fst: None,
        };
        let (r, _) = cosim::run(&o, &mut |_| {}).unwrap_or_else(|e| panic!("F = {frac}: {e}"));
        assert_eq!(r.frac_bits, frac);
        let s = &r.sources;
        assert!(
            s.scenes > 1000 && s.stability > 1000 && s.directed > 10_000,
            "{s:?}"
        );
        let full = &r.runs[0];
        assert_eq!(full.vectors, 150_000);
        assert!(full.hits > 10_000, "{full:?}");
        // One job a cycle at full rate: the pipeline's depth is all that is added.
        assert!(full.cycles < full.vectors + 20, "{full:?}");
        let bp = &r.runs[1];
        assert!(
            bp.stalled_cycles > bp.vectors / 10,
            "back-pressure stalls: {bp:?}"
        );
        assert!(r.runs[2].unit == "dda" && r.runs[2].vectors > 30_000);
    }
}

/// The committed sources with `from` replaced by `to` in `file` (which must hold it once).
fn mutated(file: &str, from: &str, to: &str) -> Vec<(&'static str, String)> {
    SOURCES
        .iter()
        .map(|(n, t)| {
            if *n == file {
                assert_eq!(t.matches(from).count(), 1, "{from} in {n}");
                (*n, t.replace(from, to))
            } else {
                (*n, t.to_string())
            }
        })
        .collect()
}

fn icu_mutant_error(from: &str, to: &str) -> String {
    let p = Params::new(&config(12)).unwrap();
    let m = mutated("shellsim_icu.sv", from, to);
    let src: Vec<(&str, &str)> = m.iter().map(|(n, t)| (*n, t.as_str())).collect();
    let built = build(&p, Unit::Icu, false, &src).unwrap();
    let jobs = directed_and_random(&p, 20_000, 5, true);
    let e = replay_icu(&p, &built.binary, &jobs, Pressure::FULL, None, &|_| {
        String::new()
    })
    .expect_err("a mutated RTL must differ")
    .to_string();
    eprintln!("{e}");
    e
}

#[test]
fn rounding_point_a_without_its_half_lsb_is_named_in_the_shear_stage() {
    let e = icu_mutant_error("(SW+TW+1)'(1 << (F-1))", "(SW+TW+1)'(0 << (F-1))");
    assert!(e.contains("stage 1 `shear`"), "{e}");
    assert!(
        e.contains("field x") || e.contains("field y") || e.contains("field z"),
        "{e}"
    );
}

#[test]
fn rounding_point_b_truncating_is_named_in_the_first_divider_stage() {
    let e = icu_mutant_error(
        "c4_x = (XW'(r3_num) << (SHIFT_N + 1)) + (XW'(r3_den) << SHIFT_D);",
        "c4_x = (XW'(r3_num) << (SHIFT_N + 1));",
    );
    assert!(e.contains("`divide0`"), "{e}");
}

#[test]
fn the_top_left_rule_turned_is_named_in_the_edges_stage() {
    let e = icu_mutant_error(
        "!(dy > 0 || (dy == 0 && dx < 0))",
        "!(dy > 0 || (dy == 0 && dx > 0))",
    );
    assert!(e.contains("stage 2 `edges`"), "{e}");
}

#[test]
fn the_dda_tie_rule_turned_is_named_in_its_step() {
    let p = Params::new(&config(12)).unwrap();
    let m = mutated(
        "shellsim_dda.sv",
        "if (lhs < rhs) best",
        "if (lhs <= rhs) best",
    );
    let src: Vec<(&str, &str)> = m.iter().map(|(n, t)| (*n, t.as_str())).collect();
    let built = build(&p, Unit::Dda, false, &src).unwrap();
    let jobs = random_dda(&p, 20_000, 2);
    let e = replay_dda(&p, &built.binary, &jobs, Pressure::FULL, &|_| String::new())
        .expect_err("a mutated DDA must differ")
        .to_string();
    assert!(e.contains("`step`"), "{e}");
}

/// Values by signal name at each sample time, from a VCD (`vcd` crate), signals sharing an
/// id code included under each of their names.
fn samples(
    vcd_text: &[u8],
) -> std::collections::BTreeMap<u64, std::collections::HashMap<String, String>> {
    use std::collections::{BTreeMap, HashMap};
    let mut p = vcd::Parser::new(std::io::Cursor::new(vcd_text));
    let header = p.parse_header().unwrap();
    let mut names: HashMap<vcd::IdCode, Vec<String>> = HashMap::new();
    fn walk(items: &[vcd::ScopeItem], prefix: &str, names: &mut HashMap<vcd::IdCode, Vec<String>>) {
        for i in items {
            match i {
                vcd::ScopeItem::Scope(s) => {
                    walk(&s.items, &format!("{prefix}{}.", s.identifier), names)
                }
                vcd::ScopeItem::Var(v) => names
                    .entry(v.code)
                    .or_default()
                    .push(format!("{prefix}{}", v.reference)),
                _ => {}
            }
        }
    }
    walk(&header.items, "", &mut names);
    let mut now: HashMap<String, String> = HashMap::new();
    let mut out = BTreeMap::new();
    let mut time = 0u64;
    let binary = |v: &vcd::Vector| -> String {
        let s: String = v.iter().map(|b| b.to_string()).collect();
        let t = s.trim_start_matches('0');
        if t.is_empty() {
            "0".into()
        } else {
            t.into()
        }
    };
    for cmd in p {
        let (code, value) = match cmd.unwrap() {
            vcd::Command::Timestamp(t) => {
                out.insert(time, now.clone());
                time = t;
                continue;
            }
            vcd::Command::ChangeScalar(c, v) => (c, v.to_string()),
            vcd::Command::ChangeVector(c, v) => (c, binary(&v)),
            _ => continue,
        };
        for n in names.get(&code).into_iter().flatten() {
            now.insert(n.clone(), value.clone());
        }
    }
    out.insert(time, now);
    out
}

/// The side-by-side waveform: Verilator's FST of the RTL ICU holds, under the model's names,
/// the same stage values as the model's ICU at every cycle (read back by GTKWave's fst2vcd),
/// and the .gtkw names only signals the file has.
#[test]
fn the_side_by_side_waveform_shows_the_rtl_and_the_model_alike_stage_by_stage() {
    let dir = tempfile::tempdir().unwrap();
    let fst = dir.path().join("side.fst");
    let p = Params::new(&config(12)).unwrap();
    let built = build(&p, Unit::Icu, true, SOURCES).unwrap();
    let jobs = directed_and_random(&p, 3000, 9, false);
    let pr = Pressure {
        offer: 0.8,
        take: 0.5,
        seed: 4,
    };
    replay_icu(&p, &built.binary, &jobs, pr, Some(&fst), &|_| String::new()).unwrap();
    let out = std::process::Command::new("fst2vcd")
        .arg(&fst)
        .output()
        .expect("fst2vcd (GTKWave) runs: .ci/run installs it");
    assert!(out.status.success());
    // fst2vcd declares SystemVerilog `logic` and `int` variables, types the vcd crate predates.
    let text = String::from_utf8(out.stdout)
        .unwrap()
        .replace("$var logic ", "$var wire ")
        .replace("$var int ", "$var integer ");
    let by_time = samples(text.as_bytes());
    let depth = p.stages(Unit::Icu).len();
    let (mut compared, mut valid, mut hits) = (0, 0, 0);
    for (t, vals) in &by_time {
        for k in 0..depth {
            let mut sigs = vec!["valid", "ray", "patch"];
            if k + 1 == depth {
                sigs.push("t");
            }
            for s in sigs {
                let get = |scope: &str| {
                    vals.get(&format!("TOP.cosim_top.{scope}.stage_{k}.{s}"))
                        .cloned()
                };
                let (r, m) = (get("icu"), get("model_icu"));
                assert!(r.is_some(), "no RTL signal stage_{k}.{s} at {t}");
                assert_eq!(r, m, "stage {k} {s} at time {t}");
                compared += 1;
                valid += (s == "valid" && r.as_deref() == Some("1")) as u32;
                hits += (s == "t" && r.as_deref() != Some("0")) as u32;
            }
        }
    }
    assert!(
        by_time.len() > 3000 && valid > 5000 && hits > 100,
        "{} {valid} {hits}",
        by_time.len()
    );
    assert!(compared > 100_000);
    // Every signal the save file names is in the waveform.
    let gtkw = shellsim::rtl::side_by_side_gtkw(&p, &fst);
    let last = by_time.values().last().unwrap();
    for line in gtkw.lines().filter(|l| l.contains(" TOP.")) {
        let name = line.split(' ').nth(2).unwrap().split('[').next().unwrap();
        assert!(
            last.contains_key(name),
            "{name} of the .gtkw is not in the FST"
        );
    }
}

/// Yosys synthesizes the committed RTL and its report is read: a narrower datapath costs
/// fewer cells and flip-flops, and a second call is served from the cache unchanged.
#[test]
fn synthesis_reads_cells_flip_flops_and_depth_and_grows_with_the_width() {
    use shellsim::rtl::cost::synth_cost;
    let small = Params::new(&config(4)).unwrap();
    let wider = Params::new(&config(6)).unwrap();
    let a = synth_cost(&small, Unit::Icu, false).unwrap();
    let b = synth_cost(&wider, Unit::Icu, false).unwrap();
    assert!(
        a.cells > 5_000 && a.flip_flops > 300 && a.depth > 20,
        "{a:?}"
    );
    assert!(
        b.cells > a.cells && b.flip_flops > a.flip_flops,
        "{a:?} {b:?}"
    );
    assert_eq!(a.luts, None);
    assert_eq!(synth_cost(&small, Unit::Icu, false).unwrap(), a);
}

/// The CLI's messages: bad values and a missing Verilator are exit 2 with a message that says
/// what to do; `rtl` without `--out` names it.
#[test]
fn bad_values_and_a_missing_verilator_are_exit_2_with_a_message() {
    let run = |args: &[&str], path: Option<&str>| {
        let mut c = std::process::Command::new(env!("CARGO_BIN_EXE_shellsim"));
        c.args(args);
        if let Some(p) = path {
            c.env("PATH", p);
        }
        let o = c.output().unwrap();
        (
            o.status.code(),
            String::from_utf8_lossy(&o.stderr).to_string(),
        )
    };
    let (code, e) = run(&["cosim", "--vectors", "0"], None);
    assert_eq!(code, Some(2), "{e}");
    assert!(e.contains("--vectors 0"), "{e}");
    let (code, e) = run(&["cosim", "--offer", "1.5"], None);
    assert_eq!(code, Some(2), "{e}");
    assert!(e.contains("--offer 1.5 is not in (0, 1]"), "{e}");
    let (code, e) = run(&["rtl"], None);
    assert_eq!(code, Some(2), "{e}");
    assert!(e.contains("--out DIR"), "{e}");
    let empty = tempfile::tempdir().unwrap();
    let (code, e) = run(&["cosim", "--vectors", "1000"], empty.path().to_str());
    assert_eq!(code, Some(2), "{e}");
    assert!(e.contains("apt-get install verilator"), "{e}");
    let (code, e) = run(&["rtl", "cost"], empty.path().to_str());
    assert_eq!(code, Some(2), "{e}");
    assert!(e.contains("apt-get install yosys"), "{e}");
}
