//! `shellsim stability`: every adversarial case on every model, against bit width.

use super::args::{parse_bits_range, MachineArgs};
use crate::error::Result;
use crate::output::{check_outputs, Output};
use crate::stability::{self, report, Options};
use std::path::PathBuf;

/// Arguments of `shellsim stability`.
#[derive(clap::Args, Debug)]
pub struct StabilityArgs {
    /// Fractional bits of the fixed-point model, A..=B (the configuration's
    /// own width is always run too).
    #[arg(long, value_name = "A..=B", default_value = "8..=16", value_parser = parse_bits_range)]
    pub frac_bits: (u32, u32),
    /// The cases, comma-separated (default: all; an unknown name's error lists them).
    #[arg(long, value_name = "NAMES", value_delimiter = ',')]
    pub cases: Vec<String>,
    /// Rays per case.
    #[arg(long, default_value_t = 400)]
    pub rays: usize,
    /// Seed of every case's generator.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Output directory: stability.csv, stability.md, stability.svg.
    #[arg(long)]
    pub out: PathBuf,
    #[command(flatten)]
    pub machine: MachineArgs,
}

impl StabilityArgs {
    /// The command line that regenerates a report (for its header).
    fn command(&self) -> String {
        let mut c = format!(
            "shellsim stability --frac-bits {}..={} --rays {} --seed {}",
            self.frac_bits.0, self.frac_bits.1, self.rays, self.seed
        );
        if !self.cases.is_empty() {
            c.push_str(&format!(" --cases {}", self.cases.join(",")));
        }
        if let Some(h) = &self.machine.hw {
            c.push_str(&format!(" --hw {}", h.display()));
        }
        c.push_str(&format!(" --out {}", self.out.display()));
        c
    }
}

/// Runs `shellsim stability`.
pub fn run(a: &StabilityArgs) -> Result<()> {
    let mut outs = vec![Output::dir("--out", &a.out)];
    outs.extend(
        report::paths(&a.out)
            .iter()
            .map(|p| Output::file("--out", p)),
    );
    check_outputs(&outs)?;
    let opts = Options {
        cases: if a.cases.is_empty() {
            stability::all_cases()
        } else {
            a.cases.clone()
        },
        rays: a.rays,
        seed: a.seed,
        bits: a.frac_bits.0..=a.frac_bits.1,
        config: a.machine.load()?,
    };
    let r = stability::run(&opts)?;
    for w in r.cases.iter().flat_map(|c| &c.warnings) {
        eprintln!("warning: {w}");
    }
    crate::output::outln!(
        "{:<20} {:>11} {:>6} {:>7} {:>11} {:>6} {:>9} {:>10}",
        "case",
        "model",
        "rays",
        "differ",
        "unexplained",
        "leaks",
        "overflow",
        "mism./dl."
    );
    for c in &r.cases {
        for m in [
            stability::Model::Float,
            stability::Model::Fixed,
            stability::Model::Machine,
            stability::Model::MachineMin,
        ] {
            if let Some(row) = report::find(c, m, r.default_bits) {
                let k = &row.counts;
                crate::output::outln!(
                    "{:<20} {:>11} {:>6} {:>7} {:>11} {:>6} {:>9} {:>10}",
                    c.name,
                    m.name(),
                    k.rays,
                    k.differ,
                    k.classes.unexplained,
                    k.leaks.map_or("-".into(), |x| x.to_string()),
                    k.overflow.map_or("-".into(), |x| x.to_string()),
                    match (k.machine_mismatches, k.deadlocks) {
                        (Some(x), Some(y)) => format!("{x}/{y}"),
                        _ => "-".into(),
                    }
                );
            }
        }
    }
    report::write(&a.out, &r, &a.command())?;
    crate::output::outln!(
        "wrote {}/stability.csv, .md and .svg (F = {}..={}, default {})",
        a.out.display(),
        r.bits[0],
        r.bits.last().unwrap(),
        r.default_bits
    );
    report::verdict(&r)
}
