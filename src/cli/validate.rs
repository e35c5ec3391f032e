//! `negotiator validate`.
use std::process::ExitCode;

#[derive(Debug, clap::Args)]
pub struct ValidateArgs {}

impl ValidateArgs {
    pub fn run(self) -> anyhow::Result<ExitCode> {
        Ok(ExitCode::SUCCESS)
    }
}
