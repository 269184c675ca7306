//! `shellsim paper`: every figure of the paper and report.md in one command.

use crate::error::Result;
use std::path::PathBuf;

/// Arguments of `shellsim paper`.
#[derive(clap::Args, Debug, Clone)]
pub struct PaperArgs {
    /// Output directory: report.md, the figures (SVG) and their data (CSV).
    #[arg(long, default_value = "docs/paper")]
    pub out: PathBuf,
}

/// Runs `shellsim paper`.
pub fn run(a: &PaperArgs) -> Result<()> {
    crate::output::check_outputs(&[crate::output::Output::dir("--out", &a.out)])?;
    let start = std::time::Instant::now();
    crate::experiment::report::paper(&a.out)?;
    crate::output::outln!(
        "wrote {}/report.md ({:.0} s)",
        a.out.display(),
        start.elapsed().as_secs_f64()
    );
    Ok(())
}
