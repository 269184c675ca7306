//! The `shellsim` command line: parses arguments, runs a job, maps errors to exit status.

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    let cli = shellsim::cli::Cli::parse();
    match shellsim::cli::run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(e.exit_code() as u8)
        }
    }
}
