//! `negotiator eval` (placeholder until written).
use std::process::ExitCode;

#[derive(Debug, clap::Args)]
pub struct EvalArgs {}

impl EvalArgs {
    pub fn run(self) -> anyhow::Result<ExitCode> {
        Err(super::usage("'negotiator eval' is not available yet"))
    }
}
