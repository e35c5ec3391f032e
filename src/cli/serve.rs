//! `negotiator serve` (placeholder until written).
use std::process::ExitCode;

#[derive(Debug, clap::Args)]
pub struct ServeArgs {}

impl ServeArgs {
    pub fn run(self) -> anyhow::Result<ExitCode> {
        Err(super::usage("'negotiator serve' is not available yet"))
    }
}
