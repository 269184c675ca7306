//! `shellsim size`: the smallest machine that meets a form-factor accuracy target, written
//! as a configuration (usable with `--hw`) and a report (markdown and JSON).

use super::args::{MachineArgs, SceneSourceArgs};
use crate::error::{Error, Result};
use crate::output::{check_outputs, write_atomic, write_json, Output};
use crate::paper::PAPER_RAYS;
use crate::size::{markdown, size, toml, Against, SizeSpec};
use std::path::PathBuf;

/// Arguments of `shellsim size`.
#[derive(clap::Args, Debug)]
pub struct SizeArgs {
    #[command(flatten)]
    pub input: SceneSourceArgs,
    /// The base configuration (timing, balancing, policies are kept); default the built-in
    /// paper.toml.
    #[command(flatten)]
    pub machine: MachineArgs,
    /// The accuracy target: the largest form-factor error over patches.
    #[arg(long, allow_hyphen_values = true)]
    pub target_error: f64,
    /// What the error is measured against: the float model on the same rays (what the
    /// hardware's formats add) or a float reference of 16× the rays (the total error).
    #[arg(long, value_enum, default_value_t = Against::Float)]
    pub against: Against,
    /// Hi_Low_Ratio of the machine's run: 969 × ratio ring rays.
    #[arg(long, default_value_t = 1, conflicts_with = "rays")]
    pub ratio: usize,
    /// The machine's ray count instead of --ratio (a multiple of 969).
    #[arg(long)]
    pub rays: Option<usize>,
    /// The machine must finish within this many cycles: sizes clusters and CTUs.
    #[arg(long)]
    pub max_cycles: Option<u64>,
    /// Buffers: the cycles may exceed an unbounded machine's by this fraction.
    #[arg(long, default_value_t = 0.01)]
    pub tolerance: f64,
    /// Let the sized machine be larger than the base configuration where that buys cycles
    /// (clusters, CTUs, buffer capacity); without it the base is the ceiling. Fractional
    /// bits follow --target-error either way.
    #[arg(long)]
    pub allow_larger: bool,
    /// Write machine.toml, size.md and size.json here.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Runs `shellsim size`.
pub fn run(a: &SizeArgs) -> Result<()> {
    if let Some(dir) = &a.out {
        let files = ["machine.toml", "size.md", "size.json"];
        let mut outs = vec![Output::dir("--out", dir)];
        outs.extend(files.iter().map(|f| Output::file("--out", &dir.join(f))));
        check_outputs(&outs)?;
    }
    let (scene, source) = a.input.load()?;
    let base = a.machine.load()?;
    let ratio = match a.rays {
        Some(n) if n == 0 || n % PAPER_RAYS != 0 => {
            return Err(Error::Usage(format!(
                "--rays {n} is not a positive multiple of {PAPER_RAYS} (the machine casts {PAPER_RAYS} × ratio rays)"
            )))
        }
        Some(n) => n / PAPER_RAYS,
        None => a.ratio,
    };
    if !(a.tolerance.is_finite() && (0.0..=1.0).contains(&a.tolerance)) {
        return Err(Error::Usage(format!(
            "--tolerance {} is not a fraction in 0..=1",
            a.tolerance
        )));
    }
    let spec = SizeSpec {
        source,
        target_error: a.target_error,
        against: a.against,
        ratio,
        max_cycles: a.max_cycles,
        tolerance: a.tolerance,
        allow_larger: a.allow_larger,
    };
    let r = size(&scene, a.input.path(), &base, &spec)?;
    let md = markdown(&r);
    if let Some(dir) = &a.out {
        write_atomic(&dir.join("machine.toml"), toml(&r).as_bytes())?;
        write_atomic(&dir.join("size.md"), md.as_bytes())?;
        write_json(&dir.join("size.json"), &r)?;
    }
    crate::output::out!("{md}");
    Ok(())
}
