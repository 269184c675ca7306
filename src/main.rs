//! The `shellsim` command line: parses arguments, runs a job, maps errors to exit status
//! (0 ok, 1 a check failed, 2 bad input or usage, 130/143 interrupted).

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    let cli = shellsim::cli::Cli::parse();
    shellsim::output::install_signal_handlers();
    let result = shellsim::cli::run(cli);
    // A closed or full standard output loses the printed lines, never the files: it is
    // reported after them (exit status 1) unless the run failed in its own right.
    let result = result.and_then(|()| shellsim::output::stdout_result());
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            let msg = shellsim::error::escape_controls(&e.to_string(), true);
            let _ =
                std::io::Write::write_fmt(&mut std::io::stderr(), format_args!("error: {msg}\n"));
            ExitCode::from(e.exit_code() as u8)
        }
    }
}
