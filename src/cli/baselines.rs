//! `negotiator baselines`: the reference table of the non-LLM policies.

use super::parse_list;
use crate::baselines::{GridSpec, run_grid};
use crate::export::Format;
use crate::policy::PolicyKind;
use crate::probe::Probe;
use crate::scenario::{ScenarioKind, ScenarioSet, Tier};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Debug, clap::Args)]
pub struct BaselinesArgs {
    /// Episodes (seeds) per (scenario, tier, policy) cell.
    #[arg(short = 'n', long = "episodes", default_value_t = 200)]
    pub episodes: usize,
    /// Scenario name, a comma-separated list, or `all`.
    #[arg(long, default_value = "all")]
    pub scenario: String,
    /// Tier (1, 2, 3), a comma-separated list, or `all`.
    #[arg(long, default_value = "all")]
    pub tier: String,
    /// Policy name, a comma-separated list, or `all`.
    #[arg(long, default_value = "all")]
    pub policy: String,
    /// First seed; cell seeds are BASE .. BASE + n.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    #[arg(long, value_enum, default_value_t = Format::Table)]
    pub format: Format,
    /// Replace a built-in scenario with this TOML file (repeatable).
    #[arg(long = "scenario-file", value_name = "PATH")]
    pub scenario_files: Vec<PathBuf>,
    /// `belief`: print the belief-probe table instead (each policy's stated
    /// belief scored like a model's: the expert states the ideal
    /// observer's, the cue follower its cue's, random a uniform draw).
    /// `forecast`: print the forecast-probe table of the reference
    /// forecasters (constant velocity, rules, the same future under both
    /// intents) along each policy's episodes.
    #[arg(long, default_value = "none", value_parser = |s: &str| s.parse::<Probe>())]
    pub probe: Probe,
}

impl BaselinesArgs {
    pub fn run(self) -> anyhow::Result<ExitCode> {
        if self.episodes == 0 {
            return Err(super::usage("-n/--episodes: must be at least 1"));
        }
        if self.episodes as u64 > super::MAX_EPISODES {
            return Err(super::usage(format!(
                "-n/--episodes: at most {} episodes per cell, got {}",
                super::MAX_EPISODES,
                self.episodes
            )));
        }
        let spec = GridSpec {
            scenarios: parse_list(&self.scenario, &ScenarioKind::ALL, "--scenario")?,
            tiers: parse_list(&self.tier, &Tier::ALL, "--tier")?,
            policies: parse_list(&self.policy, &PolicyKind::ALL, "--policy")?,
            episodes: self.episodes,
            seed_base: self.seed,
        };
        if self.probe.belief && self.probe.forecast {
            return Err(super::usage("--probe: one probe's table at a time here (belief or forecast)"));
        }
        let set = ScenarioSet::with_overrides(&self.scenario_files)?;
        let table = if self.probe.forecast {
            crate::baselines::forecast_table(&crate::baselines::run_forecast_grid(&set, &spec))
        } else {
            let cells = run_grid(&set, &spec, &|_, _| {});
            if self.probe.belief { crate::baselines::belief_table(&cells) } else { crate::baselines::table(&cells) }
        };
        crate::redact::term::write_out(&self.format.exporter().render(&table))?;
        Ok(ExitCode::SUCCESS)
    }
}
