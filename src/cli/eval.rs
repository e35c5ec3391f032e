//! `negotiator eval`: flags, validation, and the run's exit code.
//!
//! Run directory: `--output DIR` (default `results/`) is the parent;
//! the run's own directory is `DIR/<model>-<config hash>` (the model id made
//! directory-safe, and the first 8 hex digits of the hash of everything that
//! changes how an episode plays: model, request parameters, history window,
//! system prompt, scenario parameters). So the same command always lands in
//! the same directory and resumes it, and changing the temperature starts a
//! new run instead of mixing two. `--run-name NAME` picks the directory name
//! explicitly; an existing run there with another configuration is refused.

use super::{exit, parse_list, usage};
use crate::eval::EvalOptions;
use crate::eval::config::{Endpoint, EndpointsFile, ModelAlias};
use crate::eval::events::{Reporter, StopReason};
use crate::eval::prices::Prices;
use crate::eval::progress::{Bar, JsonLines, Lines, Quiet};
use crate::llm::profile::{BuiltParams, RequestProfile, build_params};
use crate::llm::{ClientConfig, RetryPolicy};
use crate::probe::Probe;
use crate::rundir::sanitize_name;
use crate::rundir::{
    HistoryWindow, ImageDetail, ObservationMode, PictureSettings, Pricing, RunConfig, Selection, Shard,
};
use crate::scenario::{ScenarioKind, ScenarioSet, Tier};
use reqwest::header::{HeaderMap, HeaderName, HeaderValue};
use serde_json::{Map, Value};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

#[derive(Debug, clap::Args)]
pub struct EvalArgs {
    /// Model id sent to the endpoint, or a model alias from the endpoints
    /// file (which then also picks the endpoint).
    #[arg(long)]
    pub model: String,
    /// A named endpoint from the endpoints file (openai, openrouter, vllm,
    /// ollama, local, ...).
    #[arg(long)]
    pub endpoint: Option<String>,
    /// Base URL of an OpenAI-compatible API (overrides the endpoint's),
    /// e.g. http://127.0.0.1:8765/v1.
    #[arg(long)]
    pub base_url: Option<String>,
    /// Environment variable holding the API key (overrides the endpoint's).
    /// The key is sent as a Bearer token and never written anywhere.
    #[arg(long)]
    pub api_key_var: Option<String>,
    /// Endpoints file to use instead of the built-in configs/endpoints.toml.
    #[arg(long)]
    pub endpoints_file: Option<PathBuf>,
    /// Prices file laid over the built-in configs/prices.toml: its models
    /// replace or add prices (USD per million tokens).
    #[arg(long)]
    pub prices_file: Option<PathBuf>,
    /// Scenarios: all, or a comma-separated list.
    #[arg(long, default_value = "all")]
    pub scenario: String,
    /// Tiers: all, or a comma-separated list of 1, 2, 3.
    #[arg(long, default_value = "1")]
    pub tier: String,
    /// Seeds per scenario and tier.
    #[arg(short = 'n', long = "seeds", default_value_t = 200)]
    pub seeds: u64,
    /// Rollouts per seed (they differ only through the model's sampling).
    #[arg(short = 'r', long = "rollouts", default_value_t = 1)]
    pub rollouts: u32,
    /// Episodes in flight at once.
    #[arg(short = 'c', long = "concurrency", default_value_t = 32)]
    pub concurrency: usize,
    /// First seed; seeds are BASE .. BASE+n-1.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    #[arg(long)]
    pub temperature: Option<f64>,
    /// Completion-token limit, sent under the request profile's field
    /// (max_tokens or max_completion_tokens). Thinking counts inside it.
    #[arg(long)]
    pub max_tokens: Option<u64>,
    /// Request profile from the endpoints file (default: the endpoint's,
    /// or the one its model_profiles pick for --model).
    #[arg(long)]
    pub profile: Option<String>,
    /// Ask for a reasoning effort (low, medium, high, ...), spelled the way
    /// the request profile says.
    #[arg(long)]
    pub reasoning_effort: Option<String>,
    /// Extra request parameters as a JSON object, merged into every request
    /// (e.g. '{"top_p": 0.9, "seed": 1}').
    #[arg(long)]
    pub sampling_args: Option<String>,
    /// Extra request header 'Name: value' (repeatable). Only header names
    /// are recorded in run.json.
    #[arg(long = "header")]
    pub headers: Vec<String>,
    /// History sent to the model: full, or last:K earlier turns.
    #[arg(long, default_value = "full", value_parser = parse_history)]
    pub history: HistoryWindow,
    /// Add a probe to every answer: `belief` asks for the probability that
    /// the other road user lets the ego pass first; `forecast` asks where
    /// it will be 1 s and 2 s from now if it lets the ego go first and if
    /// it does not; `belief,forecast` asks both. A probe run is its own
    /// run (and leaderboard row); the action is scored as without it.
    #[arg(long, default_value = "none", value_parser = parse_probe)]
    pub probe: Probe,
    /// What each user turn shows: text (the scene text), image (a 512 x 512
    /// bird's-eye picture of the scene and one line naming the turn) or
    /// both (the picture beside the text). A picture run is its own run
    /// (and leaderboard row); the endpoint must take images (exit 3 if not).
    #[arg(long, value_enum, default_value_t = ObservationMode::Text)]
    pub observation: ObservationMode,
    /// The pictures' `detail` (OpenAI's low is 85 tokens, high 255 for this
    /// size; other providers ignore it).
    #[arg(long, value_enum, default_value_t = ImageDetail::Auto)]
    pub image_detail: ImageDetail,
    /// Keep pictures only in the last K user turns (the current one
    /// included), to bound cost; older turns carry a one-line stand-in (or
    /// their text under `both`). Default: every turn keeps its picture.
    #[arg(long, value_name = "K")]
    pub image_history: Option<u32>,
    /// Ask for a response format: json_object (or text).
    #[arg(long, value_parser = ["json_object", "text"])]
    pub response_format: Option<String>,
    /// Parent directory of run directories.
    #[arg(long, default_value = "results")]
    pub output: PathBuf,
    /// Run directory name under --output (default: <model>-<config hash>).
    #[arg(long)]
    pub run_name: Option<String>,
    /// Retries per request after the first attempt.
    #[arg(long, default_value_t = 10)]
    pub max_retries: u32,
    /// Longest reply (and reasoning) kept, in bytes: a longer one is cut
    /// there, stored and sent back cut, flagged `reply_capped` and scored as
    /// a parse error. The HTTP body is read up to 16x this plus 64 KiB.
    #[arg(long, default_value_t = crate::llm::DEFAULT_MAX_REPLY_BYTES)]
    pub max_reply_bytes: usize,
    /// Per-request timeout in seconds.
    #[arg(long, default_value_t = 120.0)]
    pub request_timeout: f64,
    /// First retry backoff in milliseconds (doubled per retry, jittered).
    #[arg(long, default_value_t = 500)]
    pub backoff_base_ms: u64,
    /// Cap on the exponential backoff in seconds.
    #[arg(long, default_value_t = 60.0)]
    pub backoff_max: f64,
    /// Stop starting episodes once this invocation has spent this many
    /// tokens (episodes in flight finish).
    #[arg(long)]
    pub max_total_tokens: Option<u64>,
    /// Stop starting episodes once this invocation's estimated spend
    /// reaches this many US dollars (episodes in flight finish). Needs a
    /// known price for the model.
    #[arg(long, value_name = "USD")]
    pub max_cost: Option<f64>,
    /// Score turns cut off by the completion-token limit instead of
    /// stopping the run when more than 2% of the first 50 episodes' turns are.
    #[arg(long)]
    pub allow_truncation: bool,
    /// Run shard K of N: seed index i runs when i mod N = K-1. `auto`
    /// reads a Slurm job array's or a Kubernetes Indexed Job's index.
    #[arg(long)]
    pub shard: Option<String>,
    /// Shard count for `--shard auto` in a Kubernetes Indexed Job (its
    /// `completions`); overrides Slurm's array count.
    #[arg(long, env = "NEGOTIATOR_SHARD_COUNT")]
    pub shard_count: Option<u64>,
    /// Scenario parameter file replacing the built-in one it declares
    /// (repeatable).
    #[arg(long = "scenario-file")]
    pub scenario_files: Vec<PathBuf>,
    /// Leave plan-view trajectories out of rollouts.jsonl.
    #[arg(long)]
    pub no_trajectories: bool,
    /// Seconds between plain progress lines (--events lines, or auto when
    /// stderr is not a terminal).
    #[arg(long, default_value_t = 5.0)]
    pub progress_interval: f64,
    /// What stderr shows while the run goes: auto (a progress bar on a
    /// terminal, plain lines otherwise), bar, lines, json (one JSON object
    /// per event, for other tools), or none.
    #[arg(long, value_enum, default_value_t = Events::Auto)]
    pub events: Events,
    /// No progress output (the same as --events none).
    #[arg(long, short = 'q', conflicts_with = "events")]
    pub quiet: bool,
    /// Print the plan (episodes, expected turns and tokens from the
    /// expert's play of the same seeds, estimated cost and wall time) and
    /// the exact first request, key redacted; send nothing, write nothing.
    #[arg(long)]
    pub dry_run: bool,
    /// Seconds per turn assumed by --dry-run's wall-time estimate (default:
    /// 1 s, plus the profile's expected reasoning at 100 tokens/s).
    #[arg(long, value_name = "SECONDS", requires = "dry_run")]
    pub assume_latency: Option<f64>,
}

/// `--events`: which reporter shows the run on stderr.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Events {
    Auto,
    Bar,
    Lines,
    Json,
    None,
}

fn positive_secs(x: f64, flag: &str) -> anyhow::Result<Duration> {
    if x.is_finite() && x > 0.0 && x < 1e7 {
        Ok(Duration::from_secs_f64(x))
    } else {
        Err(usage(format!("{flag}: expected a positive number of seconds, got {x}")))
    }
}

/// Where the requests go: `--model`, `--endpoint` and `--base-url`
/// resolved against the endpoints file.
struct Target {
    /// The model id sent to the endpoint.
    model: String,
    /// `--model` named an alias of the endpoints file.
    alias: Option<ModelAlias>,
    endpoint: Option<Endpoint>,
    base_url: String,
    /// The request profile for this model, and its name.
    profile_name: String,
    profile: RequestProfile,
}

impl EvalArgs {
    /// Validate the flags into options, one concern per step (in the order
    /// the flags' errors are reported), and where `--shard auto` found the
    /// shard (for the line `run` prints). Errors are usage errors (exit 2).
    pub fn options(&self) -> anyhow::Result<(EvalOptions, Option<String>)> {
        let target = self.target()?;
        let api_key_var =
            self.api_key_var.clone().or_else(|| target.endpoint.as_ref().and_then(|e| e.api_key_env.clone()));
        // A dry run sends nothing: a key not set yet is noted, not refused.
        let api_key = match api_key(api_key_var.as_deref()) {
            Err(_) if self.dry_run => None,
            key => key?,
        };
        let headers = self.headers(target.endpoint.as_ref())?;
        let built = self.request_params(&target)?;
        let history = self.history;
        let (selection, shard_source) = self.selection()?;
        if self.concurrency == 0 {
            return Err(usage("-c: must be at least 1"));
        }
        let scenario_set = ScenarioSet::with_overrides(&self.scenario_files)?;
        let pricing = self.prices()?.lookup(&target.base_url, &target.model);
        let max_cost_usd = self.max_cost_checked(pricing.as_ref(), &target)?;
        let pictures = self.pictures()?;
        let config = RunConfig {
            model: target.model,
            request_params: built.params,
            history,
            prompt_hash: crate::instructions::prompt_hash(self.probe, self.observation),
            scenarios_hash: scenario_set.config_hash(),
            endpoint: crate::redact::url_without_userinfo(&target.base_url),
            probe: self.probe,
            human: None,
            pictures,
        };
        let run_name = self.run_name(&config)?;
        let retry = RetryPolicy {
            max_retries: self.max_retries,
            base: Duration::from_millis(self.backoff_base_ms),
            max_backoff: positive_secs(self.backoff_max, "--backoff-max")?,
            ..RetryPolicy::default()
        };
        let options = EvalOptions {
            config,
            client: ClientConfig {
                base_url: target.base_url.trim_end_matches('/').to_string(),
                api_key,
                headers,
                request_timeout: positive_secs(self.request_timeout, "--request-timeout")?,
                retry,
                max_reply_bytes: self.max_reply_bytes_checked()?,
            },
            api_key_var,
            profile_name: target.profile_name,
            profile: target.profile,
            params_dropped: built.dropped,
            params_forced: built.forced,
            scenario_set,
            selection,
            concurrency: self.concurrency,
            run_dir: self.output.join(run_name),
            max_total_tokens: self.max_total_tokens,
            max_cost_usd,
            pricing,
            allow_truncation: self.allow_truncation,
            trajectories: !self.no_trajectories,
            interrupt: None,
        };
        Ok((options, shard_source))
    }

    /// The endpoints file, then the model (an alias names an endpoint and
    /// a model id), the endpoint and the base URL.
    fn target(&self) -> anyhow::Result<Target> {
        let file = match &self.endpoints_file {
            Some(p) => {
                let text =
                    std::fs::read_to_string(p).map_err(|e| usage(format!("--endpoints-file {}: {e}", p.display())))?;
                EndpointsFile::parse(&p.display().to_string(), &text).map_err(|e| usage(e.to_string()))?
            }
            None => EndpointsFile::builtin(),
        };
        // --model may be an alias that names an endpoint and a model id. It
        // is applied (id, sampling, endpoint) and combines with --base-url
        // (a mirror of its endpoint) or with --endpoint naming its own
        // endpoint; another --endpoint is refused rather than silently
        // sending the alias name as a model id.
        let alias = file.models.get(&self.model);
        if let (Some(a), Some(e)) = (alias, &self.endpoint)
            && a.endpoint != *e
        {
            return Err(usage(format!(
                "--model '{}' is an alias for '{}' on endpoint '{}', not on --endpoint {e}; give --model {} --endpoint {e} to use that id there",
                self.model, a.id, a.endpoint, a.id
            )));
        }
        let alias = alias.cloned();
        let model = alias.as_ref().map_or(self.model.clone(), |a| a.id.clone());
        if model.trim().is_empty() {
            return Err(usage("--model: empty model name"));
        }
        let endpoint_name = self.endpoint.clone().or_else(|| alias.as_ref().map(|a| a.endpoint.clone()));
        let endpoint = match &endpoint_name {
            Some(name) => Some(file.endpoint(name).map_err(|e| usage(format!("--endpoint: {e}")))?.clone()),
            None => None,
        };
        let base_url = match (&self.base_url, &endpoint) {
            (Some(u), _) => u.clone(),
            (None, Some(e)) => e.base_url.clone(),
            (None, None) => {
                return Err(usage(format!(
                    "--model '{}' is not an alias in the endpoints file: give --endpoint NAME or --base-url URL (known endpoints: {})",
                    self.model,
                    file.endpoints.keys().cloned().collect::<Vec<_>>().join(", ")
                )));
            }
        };
        let parsed_url = reqwest::Url::parse(&base_url).map_err(|e| usage(format!("--base-url '{base_url}': {e}")))?;
        if !matches!(parsed_url.scheme(), "http" | "https") {
            return Err(usage(format!("--base-url '{base_url}': expected an http or https URL")));
        }
        let (profile_name, profile) = file
            .profile_for(self.profile.as_deref(), alias.as_ref(), endpoint.as_ref(), &model)
            .map_err(|e| usage(e.to_string()))?;
        Ok(Target { model, alias, endpoint, base_url, profile_name, profile })
    }

    /// The endpoint's headers, then `--header` ones (values marked
    /// sensitive, so they are never printed).
    fn headers(&self, endpoint: Option<&Endpoint>) -> anyhow::Result<HeaderMap> {
        let mut headers = HeaderMap::new();
        let endpoint_headers = endpoint.map(|e| e.headers.clone()).unwrap_or_default();
        let flag_headers = self.headers.iter().map(|h| {
            h.split_once(':')
                .map(|(k, v)| (k.trim().to_string(), v.trim().to_string()))
                .ok_or_else(|| usage(format!("--header '{}': expected 'Name: value'", clip_header(h))))
        });
        for kv in endpoint_headers.into_iter().map(Ok).chain(flag_headers) {
            let (k, v) = kv?;
            let name = HeaderName::from_bytes(k.as_bytes())
                .map_err(|_| usage(format!("--header: invalid header name '{k}'")))?;
            let mut value =
                HeaderValue::from_str(&v).map_err(|_| usage(format!("--header {k}: invalid header value")))?;
            value.set_sensitive(true);
            headers.insert(name, value);
        }
        Ok(headers)
    }

    /// Request parameters: endpoint defaults, alias defaults, then flags,
    /// shaped by the request profile.
    fn request_params(&self, target: &Target) -> anyhow::Result<BuiltParams> {
        let mut configured: Map<String, Value> =
            target.endpoint.as_ref().map(|e| e.sampling.clone()).unwrap_or_default();
        if let Some(a) = &target.alias {
            configured.extend(a.sampling.clone());
        }
        let mut flags: Map<String, Value> = Map::new();
        if let Some(raw) = &self.sampling_args {
            match serde_json::from_str::<Value>(raw) {
                Ok(Value::Object(m)) => flags.extend(m),
                Ok(_) => return Err(usage("--sampling-args: expected a JSON object")),
                Err(e) => return Err(usage(format!("--sampling-args: {e}"))),
            }
        }
        if let Some(t) = self.temperature {
            if !(t.is_finite() && t >= 0.0) {
                return Err(usage(format!("--temperature: expected a non-negative number, got {t}")));
            }
            flags.insert("temperature".into(), Value::from(t));
        }
        if let Some(m) = self.max_tokens {
            if m == 0 {
                return Err(usage("--max-tokens: must be at least 1"));
            }
            flags.remove("max_completion_tokens");
            flags.insert("max_tokens".into(), Value::from(m));
        }
        if let Some(f) = &self.response_format {
            flags.insert("response_format".into(), serde_json::json!({ "type": f }));
        }
        for reserved in ["model", "messages", "stream", "n"] {
            if flags.contains_key(reserved) || configured.contains_key(reserved) {
                return Err(usage(format!("--sampling-args: '{reserved}' is set by negotiator itself")));
            }
        }
        build_params(&target.profile_name, &target.profile, &configured, &flags, self.reasoning_effort.as_deref())
            .map_err(|e| usage(e.to_string()))
    }

    /// The built-in prices, with `--prices-file` laid over them.
    fn prices(&self) -> anyhow::Result<Prices> {
        let mut prices = Prices::builtin();
        if let Some(p) = &self.prices_file {
            let text = std::fs::read_to_string(p).map_err(|e| usage(format!("--prices-file {}: {e}", p.display())))?;
            prices.overlay(&p.display().to_string(), &text).map_err(|e| usage(format!("--prices-file {e}")))?;
        }
        Ok(prices)
    }

    /// `--max-cost`: a positive number of dollars, and a price to count
    /// them with (a budget on an unknown cost would never stop anything).
    fn max_cost_checked(&self, pricing: Option<&Pricing>, target: &Target) -> anyhow::Result<Option<f64>> {
        let Some(usd) = self.max_cost else { return Ok(None) };
        if !(usd.is_finite() && usd > 0.0) {
            return Err(usage(format!("--max-cost: expected a positive number of US dollars, got {usd}")));
        }
        if pricing.is_none() {
            return Err(usage(format!(
                "--max-cost: no price for model '{}' at {} in the prices file, so the spend cannot be counted; add one with --prices-file",
                target.model,
                crate::redact::url_without_userinfo(&target.base_url)
            )));
        }
        Ok(Some(usd))
    }

    /// Which episodes to play, and where `--shard auto` found the shard.
    fn selection(&self) -> anyhow::Result<(Selection, Option<String>)> {
        let (shard, source): (Shard, Option<String>) = match self.shard.as_deref().map(str::trim) {
            Some("auto") => {
                let (shard, source) =
                    crate::eval::shard_auto::shard_from_scheduler(|k| std::env::var(k).ok(), self.shard_count)
                        .map_err(usage)?;
                (shard, Some(source))
            }
            Some(s) => (s.parse().map_err(|e| usage(format!("--shard: {e}")))?, None),
            None => (Shard::WHOLE, None),
        };
        let scenarios = parse_list(&self.scenario, &ScenarioKind::ALL, "--scenario")?;
        let tiers = parse_list(&self.tier, &Tier::ALL, "--tier")?;
        if self.seeds == 0 {
            return Err(usage("-n: must be at least 1"));
        }
        if self.rollouts == 0 {
            return Err(usage("-r: must be at least 1"));
        }
        let episodes = (scenarios.len() as u64 * tiers.len() as u64)
            .checked_mul(self.seeds)
            .and_then(|x| x.checked_mul(u64::from(self.rollouts)));
        if episodes.is_none_or(|e| e > super::MAX_EPISODES) {
            return Err(usage(format!(
                "-n {} x -r {} over {} scenario(s) and {} tier(s) selects more than {} episodes; split it with --seed and --shard",
                self.seeds,
                self.rollouts,
                scenarios.len(),
                tiers.len(),
                super::MAX_EPISODES
            )));
        }
        let selection =
            Selection { base_seed: self.seed, rollouts: self.rollouts, scenarios, seeds: self.seeds, shard, tiers };
        Ok((selection, source))
    }

    /// `--observation`, `--image-detail` and `--image-history` as the run's
    /// picture settings (none for a text run, which takes neither flag).
    fn pictures(&self) -> anyhow::Result<Option<PictureSettings>> {
        if self.observation == ObservationMode::Text {
            if self.image_history.is_some() || self.image_detail != ImageDetail::Auto {
                return Err(usage(
                    "--image-detail and --image-history apply to pictures: add --observation image or --observation both",
                ));
            }
            return Ok(None);
        }
        if self.image_history == Some(0) {
            return Err(usage("--image-history: must be at least 1 (the current turn's picture)"));
        }
        Ok(Some(PictureSettings {
            observation: self.observation,
            detail: self.image_detail,
            history: self.image_history,
        }))
    }

    /// `--max-reply-bytes`, between 1 KiB and 64 MiB.
    fn max_reply_bytes_checked(&self) -> anyhow::Result<usize> {
        let n = self.max_reply_bytes;
        if !(1024..=64 << 20).contains(&n) {
            return Err(usage(format!("--max-reply-bytes: expected 1024 to 67108864 bytes, got {n}")));
        }
        Ok(n)
    }

    /// `--run-name`, or `<model>-<config hash>`.
    fn run_name(&self, config: &RunConfig) -> anyhow::Result<String> {
        match &self.run_name {
            Some(n) if n.is_empty() || n.contains(['/', '\\']) || n == "." || n == ".." => {
                Err(usage(format!("--run-name '{n}': expected a plain directory name")))
            }
            Some(n) => Ok(n.clone()),
            None => Ok(format!("{}-{}", sanitize_name(&config.model), &config.hash()[..8])),
        }
    }

    /// The reporter `--events` / `--quiet` ask for.
    fn reporter(&self) -> anyhow::Result<Box<dyn Reporter>> {
        let interval = positive_secs(self.progress_interval, "--progress-interval")?;
        let events = if self.quiet { Events::None } else { self.events };
        Ok(match events {
            Events::Auto if std::io::stderr().is_terminal() => Box::new(Bar::default()),
            Events::Auto | Events::Lines => Box::new(Lines::new(interval)),
            Events::Bar => Box::new(Bar::default()),
            Events::Json => Box::new(JsonLines::stderr()),
            Events::None => Box::new(Quiet),
        })
    }

    pub fn run(self) -> anyhow::Result<ExitCode> {
        let (options, shard_source) = self.options()?;
        register_secrets(&options);
        if let Some(source) = shard_source.filter(|_| !self.quiet) {
            crate::redact::eline!("shard {} (from the {source})", options.selection.shard);
        }
        if self.dry_run {
            return self.dry_run(&options);
        }
        let mut reporter = self.reporter()?;
        if !self.quiet {
            for line in options.profile_notes() {
                crate::redact::eline!("{line}");
            }
        }
        let limit = crate::llm::profile::TOKEN_LIMIT_FIELDS
            .iter()
            .find_map(|f| options.config.request_params.get(*f).and_then(Value::as_u64).map(|n| (*f, n)));
        let runtime = tokio::runtime::Builder::new_multi_thread().enable_all().build()?;
        // Whether an error is a refusal or bad input is decided in one place
        // (`super::exit_code_for`).
        let outcome = runtime.block_on(crate::eval::run(options, reporter.as_mut()))?;
        crate::redact::term::out(&crate::eval::summary::render(&outcome.summary));
        crate::redact::term::out(&format!("results: {}\n", outcome.run_dir.display()));
        if let Some(StopReason::Truncation { truncated, turns }) = outcome.stop {
            return Err(usage(crate::eval::truncation::stop_message(truncated, turns, limit)));
        }
        if outcome.missing == 0 {
            return Ok(ExitCode::SUCCESS);
        }
        // With --events json, stderr stays JSON: the finished event says it.
        if self.events != Events::Json {
            let why = outcome.stop.map_or_else(|| "infrastructure errors".to_string(), |s| s.to_string());
            crate::redact::eline!(
                "{} episode(s) missing ({why}); they are excluded from the scores above. Re-run the same command to resume them.",
                outcome.missing
            );
        }
        Ok(ExitCode::from(exit::FAILURE))
    }
}

impl EvalArgs {
    /// `--dry-run`: the plan and the first request, on stdout through the
    /// redaction choke point. Reads the run directory (if any) to leave out
    /// finished episodes; sends and writes nothing.
    fn dry_run(&self, options: &EvalOptions) -> anyhow::Result<ExitCode> {
        let latency = match self.assume_latency {
            Some(s) if !(s.is_finite() && s > 0.0 && s < 1e6) => {
                return Err(usage(format!("--assume-latency: expected a positive number of seconds, got {s}")));
            }
            s => s,
        };
        let mut finished = std::collections::HashSet::new();
        let rollouts = options.run_dir.join(crate::rundir::ROLLOUTS);
        if rollouts.exists() {
            crate::rundir::lines::read_rollouts(&rollouts, |s, _| {
                finished.insert(s.key());
            })
            .map_err(|e| anyhow::anyhow!("{}: {e}", rollouts.display()))?;
        }
        for line in options.profile_notes() {
            crate::redact::eline!("{line}");
        }
        let plan = crate::eval::plan::plan(options, &finished, latency);
        crate::redact::term::out(&crate::eval::plan::render(&plan, options));
        if let Some(request) = crate::eval::plan::first_request(options, &finished) {
            crate::redact::term::out(&format!(
                "\nfirst request (exactly as it would be sent; secrets redacted{}):\n{request}",
                if options.config.pictures.is_some() { ", each picture's base64 shortened to its length" } else { "" }
            ));
        }
        Ok(ExitCode::SUCCESS)
    }
}

/// Every credential the options hold, registered with the redactor before
/// anything is sent or printed: the URL's userinfo, the header values (never
/// recorded; scrubbed wherever an endpoint echoes them back), the key.
fn register_secrets(options: &EvalOptions) {
    crate::redact::register_url_userinfo(&options.client.base_url);
    for value in options.client.headers.values() {
        if let Ok(v) = value.to_str() {
            crate::redact::register_secret(v.trim());
        }
    }
    if let Some(key) = &options.client.api_key {
        crate::redact::register_secret(key);
    }
}

/// The API key from the variable `var` names (required when named).
fn api_key(var: Option<&str>) -> anyhow::Result<Option<String>> {
    let Some(var) = var else { return Ok(None) };
    match std::env::var(var) {
        Ok(v) if !v.trim().is_empty() => Ok(Some(v.trim().to_string())),
        _ => Err(usage(format!(
            "the API key variable ${var} is not set (export {var}=... or choose another with --api-key-var)"
        ))),
    }
}

fn clip_header(h: &str) -> String {
    // Never echo a possible credential back in full.
    let start: String = h.chars().take(6).collect();
    if start.len() < h.len() { format!("{start}...") } else { start }
}

fn parse_history(s: &str) -> Result<HistoryWindow, String> {
    s.parse().map_err(|e: <HistoryWindow as std::str::FromStr>::Err| e.to_string())
}

fn parse_probe(s: &str) -> Result<Probe, String> {
    s.parse()
}
