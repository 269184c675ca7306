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
    replay_icu(&p, &built.binary, &jobs, Pressure::FULL, None, &|_| {
        String::new()
    })
    .expect_err("a mutated RTL must differ")
    .to_string()
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
