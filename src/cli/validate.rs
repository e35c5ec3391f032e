//! `negotiator validate`: the benchmark's invariants, one line each.

use super::exit;
use crate::scenario::{ScenarioKind, ScenarioSet};
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
    /// Scenarios to check: all, or a comma-separated list (a line over
    /// several scenarios then reads only these).
    #[arg(long, default_value = "all")]
    pub scenario: String,
    /// Replace a built-in scenario with this TOML file (repeatable).
    #[arg(long = "scenario-file", value_name = "PATH")]
    pub scenario_files: Vec<PathBuf>,
    /// Episodes the blind-policy search may play per (scenario, tier) cell
    /// (a fixed, seeded budget; more searches harder).
    #[arg(long, default_value_t = crate::adversary::DEFAULT_BUDGET, value_name = "N")]
    pub search_budget: usize,
    /// Make every check gating, including any the built-in scenarios are
    /// known not to meet yet (printed as OPEN otherwise; docs/validate.md lists them).
    #[arg(long)]
    pub strict: bool,
    /// Print the checks as JSON.
    #[arg(long)]
    pub json: bool,
}

impl ValidateArgs {
    pub fn run(self) -> anyhow::Result<ExitCode> {
        if self.episodes == 0 {
            return Err(super::usage("-n/--episodes: must be at least 1"));
        }
        let scenarios = super::parse_list(&self.scenario, &ScenarioKind::ALL, "--scenario")?;
        let set = ScenarioSet::with_overrides(&self.scenario_files)?;
        if self.search_budget == 0 || self.search_budget > crate::adversary::MAX_BUDGET {
            return Err(super::usage(format!(
                "--search-budget: must be 1..={}, got {}",
                crate::adversary::MAX_BUDGET,
                self.search_budget
            )));
        }
        let checks = crate::validate::run(&set, &scenarios, self.episodes, self.seed, self.search_budget, self.strict);
        let mut out = String::new();
        if self.json {
            out.push_str(&serde_json::to_string_pretty(&checks)?);
            out.push('\n');
        } else {
            for c in &checks {
                out.push_str(&c.line());
                out.push('\n');
            }
        }
        let failed = checks.iter().filter(|c| c.failed()).count();
        let open: Vec<&str> = checks.iter().filter(|c| !c.pass && !c.gating).map(|c| c.name).collect();
        if !self.json {
            let passed = checks.iter().filter(|c| c.pass).count();
            out.push_str(&format!("{passed} passed, {failed} failed\n"));
            if !open.is_empty() {
                out.push_str(&format!("open (not gating without --strict): {}\n", open.join(", ")));
            }
        }
        crate::redact::term::write_out(&out)?;
        Ok(ExitCode::from(if failed == 0 { exit::SUCCESS } else { exit::FAILURE }))
    }
}
