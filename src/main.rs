//! `negotiator`: parse, dispatch, print `Error: ...`, exit.

use clap::Parser;
use negotiator::cli::{self, Cli, exit};
use std::process::ExitCode;

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            // --help and --version are not errors.
            let code = if e.use_stderr() { exit::USAGE } else { exit::SUCCESS };
            let _ = e.print();
            return ExitCode::from(code);
        }
    };
    match cli::run(cli) {
        Ok(code) => code,
        Err(e) if cli::is_broken_pipe(&e) => ExitCode::SUCCESS,
        Err(e) => {
            negotiator::redact::term::err_line(&format!("Error: {e:#}"));
            ExitCode::from(cli::exit_code_for(&e))
        }
    }
}
