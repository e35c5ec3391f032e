//! `negotiator validate`: the benchmark's invariants, one line each.

use super::exit;
use crate::scenario::ScenarioSet;
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Debug, clap::Args)]
pub struct ValidateArgs {
    /// Seeds per (scenario, tier, policy) cell.
    #[arg(short = 'n', long = "episodes", default_value_t = 200)]
    pub episodes: usize,
    /// First seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Replace a built-in scenario with this TOML file (repeatable).
    #[arg(long = "scenario-file", value_name = "PATH")]
    pub scenario_files: Vec<PathBuf>,
    /// Print the checks as JSON.
    #[arg(long)]
    pub json: bool,
}

impl ValidateArgs {
    pub fn run(self) -> anyhow::Result<ExitCode> {
        if self.episodes == 0 {
            return Err(super::usage("-n/--episodes: must be at least 1"));
        }
        let set = ScenarioSet::with_overrides(&self.scenario_files)?;
        let checks = crate::validate::run(&set, self.episodes, self.seed);
        let mut out = std::io::stdout().lock();
        if self.json {
            serde_json::to_writer_pretty(&mut out, &checks)?;
            writeln!(out)?;
        } else {
            for c in &checks {
                writeln!(out, "{}", c.line())?;
            }
        }
        let failed = checks.iter().filter(|c| !c.pass).count();
        if !self.json {
            writeln!(out, "{} passed, {failed} failed", checks.len() - failed)?;
        }
        Ok(ExitCode::from(if failed == 0 { exit::SUCCESS } else { exit::FAILURE }))
    }
}
