//! `shellsim explore run|merge|slurm`: a design-space sweep with its fronts, sharded runs
//! and their merge, and the Slurm job-array scripts.

use crate::error::{Error, Result};
use crate::explore::{self, slurm, spec, Shard};
use crate::output::{check_outputs, outln, Output};
use clap::Subcommand;
use std::path::PathBuf;

#[derive(Subcommand, Debug)]
pub enum ExploreCmd {
    /// Measure every design point of a spec (or one shard of them) into a directory:
    /// points.csv, points.json, host.csv and, unsharded, front.csv, the charts and
    /// report.md. Points already in the directory are kept.
    Run(RunArgs),
    /// Join shard directories of one spec into the unsharded run's result.
    Merge(MergeArgs),
    /// Write a Slurm job array (explore.sbatch), its merge job (merge.sbatch) and
    /// submit.sh, which submits both (the merge `afterok` on the array).
    Slurm(SlurmArgs),
}

/// Arguments of `shellsim explore run`.
#[derive(clap::Args, Debug)]
pub struct RunArgs {
    /// The sweep spec (TOML).
    #[arg(long)]
    pub space: PathBuf,
    /// The output directory.
    #[arg(long)]
    pub out: PathBuf,
    /// Compute only shard K of N (the points whose index is K mod N); default from
    /// SLURM_ARRAY_TASK_ID and SLURM_ARRAY_TASK_COUNT when they are set.
    #[arg(long, value_name = "K/N", value_parser = Shard::parse)]
    pub shard: Option<Shard>,
    /// Time the machine points at this level instead of the spec's `timing`: `cycle`, `queue`
    /// (the queueing network), or `auto` (the network, then the cycle model only for the
    /// points that may reach the front; unsharded). Part of the spec's hash.
    #[arg(long, value_enum)]
    pub timing: Option<spec::Timing>,
}

/// Arguments of `shellsim explore merge`.
#[derive(clap::Args, Debug)]
pub struct MergeArgs {
    /// The merged result's directory.
    #[arg(long)]
    pub out: PathBuf,
    /// The shard directories.
    #[arg(required = true)]
    pub shards: Vec<PathBuf>,
}

/// Arguments of `shellsim explore slurm`.
#[derive(clap::Args, Debug)]
pub struct SlurmArgs {
    /// The sweep spec (TOML).
    #[arg(long)]
    pub space: PathBuf,
    /// Array tasks (shards).
    #[arg(long)]
    pub tasks: usize,
    /// Where the scripts, the shards (shard-K) and the merged result (merged) go.
    #[arg(long)]
    pub out: PathBuf,
    /// The shellsim binary the jobs run (default: this one).
    #[arg(long)]
    pub bin: Option<PathBuf>,
}

/// Runs `shellsim explore ...`.
pub fn run(c: &ExploreCmd) -> Result<()> {
    match c {
        ExploreCmd::Run(a) => {
            check_outputs(&explore::outputs("--out", &a.out))?;
            let shard = match a.shard {
                Some(s) => Some(s),
                None => Shard::from_slurm().map_err(Error::Usage)?,
            };
            let mut s = spec::load(&a.space)?;
            if let Some(t) = a.timing {
                s = s.with_timing(t);
            }
            let r = explore::run(&s, &a.out, shard, true)?;
            outln!(
                "{}: {} points{} ({} measured, {} already there) into {}",
                a.space.display(),
                r.points,
                r.shard
                    .map_or(String::new(), |s| format!(" of shard {}/{}", s.k, s.n)),
                r.computed,
                r.resumed,
                a.out.display()
            );
        }
        ExploreCmd::Merge(a) => {
            check_outputs(&explore::outputs("--out", &a.out))?;
            let n = explore::merge(&a.out, &a.shards)?;
            outln!(
                "merged {} shards: {n} points into {}",
                a.shards.len(),
                a.out.display()
            );
        }
        ExploreCmd::Slurm(a) => {
            let mut outs = vec![Output::dir("--out", &a.out)];
            outs.extend(
                ["explore.sbatch", "merge.sbatch", "submit.sh"]
                    .iter()
                    .map(|f| Output::file("--out", &a.out.join(f))),
            );
            check_outputs(&outs)?;
            let s = spec::load(&a.space)?;
            if s.timing == spec::Timing::Auto && a.tasks > 1 {
                return Err(Error::Usage(format!(
                    "{}: timing = \"auto\" screens each scene's machine points together, so it runs unsharded: use --tasks 1, or timing = \"cycle\" or \"queue\"",
                    a.space.display()
                )));
            }
            explore::check_points(&s)?;
            let dir = slurm::write(&a.space, a.tasks, &a.out, a.bin.as_deref())?;
            outln!(
                "wrote {0}/explore.sbatch ({1} tasks), {0}/merge.sbatch and {0}/submit.sh",
                dir.display(),
                a.tasks
            );
        }
    }
    Ok(())
}
