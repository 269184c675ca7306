//! `shellsim explore slurm`: the scripts that run a sweep as a Slurm job array —
//! `explore.sbatch` (`--array=0-(N-1)`, task K computes shard K/N into `DIR/shard-K`),
//! `merge.sbatch` (joins the shards into `DIR/merged`) and `submit.sh` (submits the array,
//! then the merge with `--dependency=afterok` on it, and prints both job ids). Every path in
//! them is absolute, so they run from any directory on any node that sees the same files.

use crate::error::{Error, Result};
use crate::output::write_atomic;
use std::path::{Path, PathBuf};

/// The most array tasks.
pub const MAX_TASKS: usize = 100_000;

/// `s` quoted for the shell (single quotes).
fn quote(p: &Path) -> String {
    format!("'{}'", p.display().to_string().replace('\'', "'\\''"))
}

/// The absolute form of an existing `path`.
fn absolute(path: &Path, what: &str) -> Result<PathBuf> {
    std::fs::canonicalize(path)
        .map_err(|e| Error::input(path, what, format!("cannot find it: {e}")))
}

/// The scripts' texts: (explore.sbatch, merge.sbatch, submit.sh), for `tasks` tasks of
/// the spec `space` into `out`, run by `bin` (all absolute).
pub fn scripts(space: &Path, tasks: usize, out: &Path, bin: &Path) -> (String, String, String) {
    let (q_space, q_out, q_bin) = (quote(space), quote(out), quote(bin));
    let logs = quote(&out.join("logs"));
    let explore = format!(
        "#!/bin/bash\n\
         # shellsim explore: shard $SLURM_ARRAY_TASK_ID of {tasks} (written by `shellsim explore slurm`).\n\
         #SBATCH --job-name=shellsim-explore\n\
         #SBATCH --array=0-{last}\n\
         #SBATCH --ntasks=1\n\
         #SBATCH --output={logs_raw}/explore-%A_%a.out\n\
         set -euo pipefail\n\
         exec {q_bin} explore run --space {q_space} --out {q_out}/shard-\"$SLURM_ARRAY_TASK_ID\" --shard \"$SLURM_ARRAY_TASK_ID/{tasks}\"\n",
        last = tasks - 1,
        logs_raw = out.join("logs").display(),
    );
    let shards: Vec<String> = (0..tasks)
        .map(|k| quote(&out.join(format!("shard-{k}"))))
        .collect();
    let merge = format!(
        "#!/bin/bash\n\
         # shellsim explore: merge the {tasks} shards into merged/ (written by `shellsim explore slurm`).\n\
         #SBATCH --job-name=shellsim-explore-merge\n\
         #SBATCH --ntasks=1\n\
         #SBATCH --output={logs_raw}/merge-%j.out\n\
         set -euo pipefail\n\
         exec {q_bin} explore merge --out {merged} {}\n",
        shards.join(" "),
        logs_raw = out.join("logs").display(),
        merged = quote(&out.join("merged")),
    );
    let submit = format!(
        "#!/bin/bash\n\
         # Submits the sweep's job array, then its merge once every task has succeeded.\n\
         # Prints the two job ids: `array JOBID` and `merge JOBID`.\n\
         set -euo pipefail\n\
         mkdir -p {logs}\n\
         array=$(sbatch --parsable {explore})\n\
         array=${{array%%;*}}\n\
         merge=$(sbatch --parsable --dependency=afterok:\"$array\" {merge})\n\
         merge=${{merge%%;*}}\n\
         echo \"array $array\"\n\
         echo \"merge $merge\"\n",
        explore = quote(&out.join("explore.sbatch")),
        merge = quote(&out.join("merge.sbatch")),
    );
    (explore, merge, submit)
}

/// Writes the three scripts into `out` (created), paths made absolute; `bin` defaults to
/// this executable. Returns the directory's absolute path.
pub fn write(space: &Path, tasks: usize, out: &Path, bin: Option<&Path>) -> Result<PathBuf> {
    if !(1..=MAX_TASKS).contains(&tasks) {
        return Err(Error::param(
            "tasks",
            format!("{tasks} is out of range (1..={MAX_TASKS})"),
        ));
    }
    let space = absolute(space, "file")?;
    let bin = match bin {
        Some(b) => absolute(b, "file")?,
        None => std::env::current_exe().map_err(|e| Error::io(Path::new("shellsim"), e))?,
    };
    std::fs::create_dir_all(out.join("logs")).map_err(|e| Error::io(out, e))?;
    let out = absolute(out, "directory")?;
    let (explore, merge, submit) = scripts(&space, tasks, &out, &bin);
    write_atomic(&out.join("explore.sbatch"), explore.as_bytes())?;
    write_atomic(&out.join("merge.sbatch"), merge.as_bytes())?;
    let sub = out.join("submit.sh");
    write_atomic(&sub, submit.as_bytes())?;
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&sub, std::fs::Permissions::from_mode(0o755))
        .map_err(|e| Error::io(&sub, e))?;
    Ok(out)
}
