//! `negotiator import-inspect`: an Inspect AI eval log of the negotiator
//! task as a run directory, so that `report` ranks, pairs and plots it
//! beside `eval`'s runs (`report` also reads the logs themselves).

use super::usage;
use crate::inspect_log;
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

impl ImportInspectArgs {
    pub fn run(self) -> anyhow::Result<ExitCode> {
        if !self.log.is_file() {
            return Err(usage(format!("{}: no such log file", self.log.display())));
        }
        let imported = inspect_log::read(&self.log)?;
        inspect_log::write(&imported, &self.output)?;
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
