//! `negotiator import-inspect`: an Inspect AI eval log of the negotiator
//! task as a run directory, so that `report` ranks, pairs and plots it
//! beside `eval`'s runs (`report` also reads the logs themselves).

use super::usage;
use crate::inspect_log::{self, InspectLogError};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Debug, clap::Args)]
pub struct ImportInspectArgs {
    /// The Inspect eval log (`.eval` or `.json`) of a `negotiator/negotiator` run.
    #[arg(value_name = "LOG")]
    pub log: PathBuf,
    /// The run directory to write (created; it must not hold a run already).
    #[arg(long, short = 'o', value_name = "DIR")]
    pub output: PathBuf,
}

/// A log that cannot be read as the task's, or an output that is taken, is
/// the user's input (exit 2); failing to read or write a file is not.
pub(super) fn input_error(e: InspectLogError) -> anyhow::Error {
    match e {
        InspectLogError::Io { .. } | InspectLogError::RunDir(_) => anyhow::Error::new(e),
        other => usage(other.to_string()),
    }
}

impl ImportInspectArgs {
    pub fn run(self) -> anyhow::Result<ExitCode> {
        if !self.log.is_file() {
            return Err(usage(format!("{}: no such log file", self.log.display())));
        }
        let imported = inspect_log::read(&self.log).map_err(input_error)?;
        inspect_log::write(&imported, &self.output).map_err(input_error)?;
        let info = &imported.info;
        crate::redact::eline!(
            "imported {} episodes of {} ({} unfinished) into {}",
            imported.rollouts.len(),
            info.config.model,
            imported.unfinished.len(),
            self.output.display()
        );
        Ok(ExitCode::SUCCESS)
    }
}
