//! `negotiator play`: a person drives the benchmark's episodes.
use super::{parse_list, usage};
use crate::eval::EvalOptions;
use crate::llm::{ClientConfig, RetryPolicy};
use crate::play::PlayOptions;
use crate::redact::eline;
use crate::rundir::{HistoryWindow, HumanSettings, RunConfig, RunStatus, Selection, Shard};
use crate::scenario::{ScenarioKind, ScenarioSet, Tier};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

#[derive(Debug, clap::Args)]
pub struct PlayArgs {
    /// Scenario name, a comma-separated list, or `all`.
    #[arg(long, default_value = "all")]
    pub scenario: String,
    /// Tier (1, 2, 3), a comma-separated list, or `all`.
    #[arg(long, default_value = "all")]
    pub tier: String,
    /// Seeds per (scenario, tier): the same seeds `eval -n N --seed B` plays.
    #[arg(short = 'n', long = "episodes", default_value_t = 2)]
    pub seeds: u64,
    /// First seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Your name: the run is recorded as the model `human:NAME`.
    #[arg(long)]
    pub name: String,
    /// Directory of run directories (as `eval --output`).
    #[arg(long, default_value = "results")]
    pub output: PathBuf,
    /// Make each turn real-time: after this many seconds the last answer is
    /// held (a firm stop before any answer). Untimed by default, as a model
    /// is. Part of the run's configuration.
    #[arg(long, value_name = "SECONDS")]
    pub turn_seconds: Option<f64>,
    /// `text` (the scene text the model reads), `plan` (adds a plan view:
    /// more than the model sees, so its own leaderboard row) or `picture`
    /// (what `eval --observation image` shows a model: each turn's picture
    /// written to a file the screen names, and one line).
    #[arg(long, default_value = "text", value_parser = ["text", "plan", "picture"])]
    pub view: String,
    /// Show each episode's outcome and the other road user's intent right
    /// after it (its own leaderboard row).
    #[arg(long)]
    pub feedback: bool,
    /// Practise on seeds outside the benchmark's range, with feedback;
    /// nothing is kept.
    #[arg(long)]
    pub practice: bool,
}

/// `--view picture`: the run shows pictures as `eval --observation image`
/// does (no settings for the other views).
fn picture_settings(view: &str) -> Option<crate::rundir::PictureSettings> {
    use crate::rundir::{ImageDetail, ObservationMode, PictureSettings};
    (view == "picture").then_some(PictureSettings {
        observation: ObservationMode::Image,
        detail: ImageDetail::Auto,
        history: None,
    })
}

impl PlayArgs {
    fn options(&self) -> anyhow::Result<PlayOptions> {
        let name = self.name.trim();
        if name.is_empty() || name.len() > 64 || name.chars().any(|c| c.is_control()) {
            return Err(usage(format!("--name '{name}': expected 1 to 64 printable characters")));
        }
        let plan_view = self.view == "plan";
        let line_mode = !(std::io::stdin().is_terminal() && std::io::stdout().is_terminal());
        if let Some(t) = self.turn_seconds {
            if !(t.is_finite() && (0.5..=3600.0).contains(&t)) {
                return Err(usage(format!("--turn-seconds: expected 0.5 to 3600 seconds, got {t}")));
            }
            if line_mode {
                return Err(usage("--turn-seconds needs a terminal (standard input and output are not one)"));
            }
        }
        let scenarios = parse_list(&self.scenario, &ScenarioKind::ALL, "--scenario")?;
        let tiers = parse_list(&self.tier, &Tier::ALL, "--tier")?;
        if !(1..=1000).contains(&self.seeds) {
            return Err(usage(format!("-n: expected 1 to 1000 seeds, got {}", self.seeds)));
        }
        let mut selection =
            Selection { base_seed: self.seed, rollouts: 1, scenarios, seeds: self.seeds, shard: Shard::WHOLE, tiers };
        let feedback = self.feedback || self.practice;
        if self.practice {
            selection = crate::play::practice_selection(selection);
        } else if self.seed.saturating_add(self.seeds) > crate::play::PRACTICE_SEED_BASE {
            return Err(usage(format!("--seed: seeds from {} on are practice seeds", crate::play::PRACTICE_SEED_BASE)));
        }
        let scenario_set = ScenarioSet::default();
        let pictures = picture_settings(&self.view);
        let observation = pictures.map_or(crate::rundir::ObservationMode::Text, |p| p.observation);
        let config = RunConfig {
            model: format!("human:{name}"),
            request_params: Default::default(),
            history: HistoryWindow::Full,
            prompt_hash: crate::instructions::prompt_hash(crate::probe::Probe::NONE, observation),
            scenarios_hash: scenario_set.config_hash(),
            endpoint: "terminal".to_string(),
            probe: crate::probe::Probe::NONE,
            human: Some(HumanSettings { turn_seconds: self.turn_seconds, view: self.view.clone(), feedback }),
            pictures,
        };
        let run_dir = if self.practice {
            std::env::temp_dir().join(format!("negotiator-practice-{}", std::process::id()))
        } else {
            let model = crate::rundir::sanitize_name(&config.model);
            self.output.join(format!("{model}-{}", &config.hash()[..8]))
        };
        let eval = EvalOptions {
            config,
            client: ClientConfig {
                base_url: String::new(),
                api_key: None,
                headers: Default::default(),
                // A person may think as long as they like.
                request_timeout: Duration::from_secs(7 * 24 * 3600),
                retry: RetryPolicy { max_retries: 0, ..RetryPolicy::default() },
                max_reply_bytes: crate::llm::DEFAULT_MAX_REPLY_BYTES,
            },
            api_key_var: None,
            profile_name: "generic".to_string(),
            profile: crate::llm::profile::RequestProfile::generic(),
            params_dropped: Vec::new(),
            params_forced: Vec::new(),
            scenario_set,
            selection,
            concurrency: 1,
            run_dir,
            max_total_tokens: None,
            max_cost_usd: None,
            pricing: None,
            allow_truncation: false,
            trajectories: true,
            interrupt: None,
        };
        Ok(PlayOptions {
            eval,
            name: name.to_string(),
            feedback,
            plan_view,
            picture_file: pictures
                .map(|_| std::env::temp_dir().join(format!("negotiator-play-{}-picture.png", std::process::id()))),
            turn_seconds: self.turn_seconds,
            line_mode,
            practice: self.practice,
        })
    }

    pub fn run(self) -> anyhow::Result<ExitCode> {
        let options = self.options()?;
        let run_dir = options.eval.run_dir.clone();
        let practice = options.practice;
        let outcome = crate::play::run(options)?;
        let out = |line: &str| crate::redact::term::out(&format!("{line}\n"));
        if outcome.missing == 0 {
            out(&format!("All episodes played: mean success {:.2}.", crate::play::mean_success(&run_dir)));
            for line in crate::play::summary_lines(&run_dir) {
                out(&line);
            }
        } else {
            let played = crate::play::summary_lines(&run_dir).len().saturating_sub(1);
            out(&format!("Saved: {played} episodes played, {} to go. Run the same command to go on.", outcome.missing));
        }
        if practice {
            out("(practice: nothing was kept)");
        } else {
            out(&format!("results: {}", run_dir.display()));
        }
        if matches!(outcome.status, RunStatus::Failed | RunStatus::Refused) {
            eline!("the run failed: see {}", run_dir.join(crate::rundir::RUN_JSON).display());
            return Ok(ExitCode::from(super::exit::ERROR));
        }
        Ok(ExitCode::SUCCESS)
    }
}
