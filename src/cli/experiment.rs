//! `shellsim experiment efficiency|workitem|speedup`.

use super::args::{MachineArgs, SceneSourceArgs};
use crate::error::Result;
use crate::experiment::outputs::{self, experiment, Which};
use crate::experiment::Workload;
use crate::output::{check_outputs, Output};
use std::path::PathBuf;

/// Arguments of `shellsim experiment`.
#[derive(clap::Args, Debug, Clone)]
pub struct ExperimentArgs {
    /// Which experiment.
    #[arg(value_enum)]
    pub which: Which,
    #[command(flatten)]
    pub input: SceneSourceArgs,
    #[command(flatten)]
    pub machine: MachineArgs,
    /// Output directory: WHICH-SCENE.csv and WHICH-SCENE.svg.
    #[arg(long, default_value = "out")]
    pub out: PathBuf,
}

/// Runs `shellsim experiment`.
pub fn run(a: &ExperimentArgs) -> Result<()> {
    let (scene, source) = a.input.load()?;
    let stem = outputs::stem_of_scene(a.which, &scene);
    check_outputs(&[
        Output::dir("--out", &a.out),
        Output::file("--out", &a.out.join(format!("{stem}.csv"))),
        Output::file("--out", &a.out.join(format!("{stem}.svg"))),
    ])?;
    let base = a.machine.load()?;
    let w = Workload {
        scene: &scene,
        file: a.input.path(),
        source,
        base: &base,
    };
    let out = experiment(a.which, &w)?;
    crate::output::out!("{}", out.summary);
    out.write(&a.out)?;
    crate::output::outln!(
        "wrote {}/{}.csv and .svg{}",
        a.out.display(),
        out.stem,
        if out.wall_svg.is_some() {
            " (and -wall.svg: wall seconds, which vary from run to run)"
        } else {
            ""
        }
    );
    Ok(())
}
