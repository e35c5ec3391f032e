//! `negotiator baselines`.
use std::process::ExitCode;

#[derive(Debug, clap::Args)]
pub struct BaselinesArgs {}

impl BaselinesArgs {
    pub fn run(self) -> anyhow::Result<ExitCode> {
        Ok(ExitCode::SUCCESS)
    }
}
