//! `negotiator eval`: play episodes with a language model as the policy
//! (docs/eval.md).
//!
//! Layout: [`config`] (endpoints file), [`prompt`] (system prompt, history
//! window), [`store`] (resume, the single writer), [`summary`]
//! (leaderboard), [`events`] (what a run reports, and the reporter trait),
//! [`progress`] (the reporters: bar, plain lines, quiet, JSON lines). What
//! the run directory holds is defined in [`crate::rundir`]. A run's three
//! phases are one file each: `prepare` (directory, lock, resume, run.json,
//! preflight), `fleet` (episodes in flight, stop reasons) with `rollout`
//! (one episode against the endpoint and its record), and `finish`
//! (totals, status, summary); this file holds the options, the errors and
//! [`run`], which calls them in order.
//!
//! Flow: list the selected episode keys, drop the ones `rollouts.jsonl`
//! already holds, run the rest with at most `concurrency` episodes in flight
//! (a `JoinSet` bounded by its length), hand each finished episode to the
//! writer thread as one line, then summarise every finished episode of the
//! selection.

pub mod config;
pub mod events;
mod finish;
mod fleet;
pub mod plan;
mod prepare;
pub mod prices;
pub mod progress;
pub mod prompt;
mod rollout;
pub mod shard_auto;
pub mod store;
pub mod summary;
pub mod truncation;

use crate::llm::{ChatMessage, Client, ClientConfig, Completion, LlmError};
use crate::rundir::record::EpisodeKey;
use crate::rundir::{self, Endpoint, RunConfig, RunStatus, Selection, Settings};
use crate::scenario::{ScenarioKind, ScenarioSet};
use events::Counters;
use events::{Event, Reporter, StopReason};
use finish::finalize;
use fleet::{Drove, drive};
use prepare::{preflight, prepare};
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicU32, Ordering::Relaxed};
use std::time::SystemTime;
use store::StoreError;

/// Everything a run needs, validated.
#[derive(Debug)]
pub struct EvalOptions {
    pub config: RunConfig,
    pub client: ClientConfig,
    /// Name of the API-key variable, for messages and run.json (never the key).
    pub api_key_var: Option<String>,
    /// The request profile that shaped `config.request_params`.
    pub profile_name: String,
    pub profile: crate::llm::profile::RequestProfile,
    /// Configured fields the profile left out, and flag fields sent although
    /// the profile does not list them (printed before the run).
    pub params_dropped: Vec<String>,
    pub params_forced: Vec<String>,
    pub scenario_set: ScenarioSet,
    pub selection: Selection,
    pub concurrency: usize,
    pub run_dir: PathBuf,
    pub max_total_tokens: Option<u64>,
    /// `--max-cost`: a soft budget in USD, like `max_total_tokens`.
    pub max_cost_usd: Option<f64>,
    /// The prices this model is billed at; `None` when unknown.
    pub pricing: Option<rundir::Pricing>,
    /// Score cut-off turns instead of stopping the run (see [`truncation`]).
    pub allow_truncation: bool,
    /// Keep plan-view trajectories in each line (for plots).
    pub trajectories: bool,
    /// A stop signal besides Ctrl-C (`negotiator play`'s quit key, when the
    /// terminal is in raw mode and Ctrl-C is a key): notified once, it ends
    /// the run as interrupted, episodes in flight abandoned.
    pub interrupt: Option<Arc<tokio::sync::Notify>>,
}

/// Resolves when `interrupt` is notified (never without one).
async fn interrupted(interrupt: &Option<Arc<tokio::sync::Notify>>) {
    match interrupt {
        Some(n) => n.notified().await,
        None => std::future::pending().await,
    }
}

impl EvalOptions {
    /// The input tokens of one picture sent by this run: by the prices
    /// file's rule for the model, or OpenAI's tiles when it has none (0
    /// for a text run).
    pub fn tokens_per_picture(&self) -> u64 {
        let Some(p) = self.config.pictures else { return 0 };
        let rule = self.pricing.as_ref().and_then(|p| p.image_tokens).unwrap_or(rundir::ImageTokenRule::OPENAI_TILES);
        rule.tokens(crate::picture::SIZE_PX, crate::picture::SIZE_PX, p.detail)
    }

    /// Lines telling what the request profile changed, printed before a run.
    pub fn profile_notes(&self) -> Vec<String> {
        let mut out = Vec::new();
        if !self.params_dropped.is_empty() {
            out.push(format!(
                "note: request profile '{}' leaves out {} (the model does not take it)",
                self.profile_name,
                self.params_dropped.join(", ")
            ));
        }
        if !self.params_forced.is_empty() {
            out.push(format!(
                "note: sending {} because a flag asked, although request profile '{}' does not list it",
                self.params_forced.join(", "),
                self.profile_name
            ));
        }
        out
    }

    /// run.json's `endpoint`: names only, never the key or header values.
    fn endpoint(&self) -> Endpoint {
        Endpoint {
            api_key_env: self.api_key_var.clone(),
            base_url: crate::redact::url_without_userinfo(&self.client.base_url),
            header_names: self.client.headers.keys().map(|k| k.as_str().to_string()).collect(),
            profile: Some(self.profile_name.clone()),
        }
    }

    fn settings(&self) -> Settings {
        Settings {
            backoff_base_ms: self.client.retry.base.as_millis() as u64,
            backoff_max_s: self.client.retry.max_backoff.as_secs_f64(),
            concurrency: self.concurrency,
            max_retries: self.client.retry.max_retries,
            max_total_tokens: self.max_total_tokens,
            max_cost_usd: self.max_cost_usd,
            request_timeout_s: self.client.request_timeout.as_secs_f64(),
        }
    }
}

/// How a run ended.
#[derive(Debug)]
pub struct RunOutcome {
    pub summary: summary::Summary,
    pub run_dir: PathBuf,
    /// Episodes of the selection still missing (re-run the command).
    pub missing: usize,
    /// As recorded in run.json.
    pub status: RunStatus,
    /// Why the run stopped starting episodes early, if it did.
    pub stop: Option<StopReason>,
}

#[derive(Debug, thiserror::Error)]
pub enum EvalError {
    #[error(transparent)]
    Store(#[from] StoreError),
    #[error("{0}")]
    Refused(String),
    #[error("{0}")]
    Rejected(String),
    /// The endpoint rejected a parameter of the request: a usage error.
    #[error("{0}")]
    BadParameter(String),
    #[error("building the HTTP client: {0}")]
    Client(String),
    #[error("an episode task failed: {0}")]
    Task(String),
}

impl From<rundir::RunDirError> for EvalError {
    fn from(e: rundir::RunDirError) -> Self {
        EvalError::Store(e.into())
    }
}

struct Ctx {
    client: Client,
    options: EvalOptions,
    /// The system prompt of each scenario (they differ only by the probe's
    /// question).
    systems: Vec<(ScenarioKind, ChatMessage)>,
    hash: String,
    counters: Arc<Counters>,
    /// The preflight request's outcome: the answer to the first turn of
    /// that episode, used by it instead of asking again.
    first_turn: std::sync::Mutex<Option<(EpisodeKey, Result<Completion, LlmError>)>>,
}

impl Ctx {
    fn system(&self, kind: ScenarioKind) -> &ChatMessage {
        &self.systems.iter().find(|(k, _)| *k == kind).expect("every scenario has a system prompt").1
    }

    /// The preflight's answer, if `key`'s first turn was the preflight.
    fn take_first_turn(&self, key: EpisodeKey) -> Option<Result<Completion, LlmError>> {
        let mut slot = self.first_turn.lock().unwrap_or_else(|e| e.into_inner());
        if slot.as_ref().is_some_and(|(k, _)| *k == key) { slot.take().map(|(_, r)| r) } else { None }
    }
}

/// Current UTC time as RFC 3339 (`2025-01-31T12:00:00Z`).
pub fn now_rfc3339() -> String {
    rfc3339(SystemTime::now())
}

pub fn rfc3339(t: SystemTime) -> String {
    let secs = t.duration_since(SystemTime::UNIX_EPOCH).map(|d| d.as_secs() as i64).unwrap_or(0);
    let (days, rem) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    // Civil date from days since 1970-01-01 (Howard Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!("{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z", rem / 3600, rem % 3600 / 60, rem % 60)
}

/// `git rev-parse HEAD` where the command runs, or "unknown".
pub fn git_revision() -> String {
    std::process::Command::new("git")
        .args(["rev-parse", "HEAD"])
        .stderr(std::process::Stdio::null())
        .output()
        .ok()
        .filter(|o| o.status.success())
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "unknown".to_string())
}

/// Run (or resume) an evaluation, telling `reporter` what happens. The
/// three phases are `prepare` (directory, resume, run.json), `drive`
/// (the episodes) and `finalize` (totals, status, summary).
pub async fn run(options: EvalOptions, reporter: &mut dyn Reporter) -> Result<RunOutcome, EvalError> {
    let counters = Arc::new(Counters::default());
    counters.priced.store(options.pricing.is_some(), Relaxed);
    reporter.attach(counters.clone());
    let mut run = prepare(options, counters, reporter)?;
    let interrupt = run.ctx.options.interrupt.clone();
    let first = tokio::select! {
        r = preflight(&run) => Some(r),
        _ = interrupted(&interrupt) => None,
    };
    let drove = match first {
        Some(Ok(())) => drive(&mut run, reporter).await,
        Some(Err(e)) => {
            reporter.event(&Event::Stopped { reason: StopReason::Refused });
            Drove { stop: Some(StopReason::Refused), fatal: Some(e), failure: None }
        }
        None => {
            reporter.event(&Event::Stopped { reason: StopReason::Interrupted });
            Drove { stop: Some(StopReason::Interrupted), fatal: None, failure: None }
        }
    };
    finalize(run, drove, reporter)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn rfc3339_formats_known_instants() {
        let at = |s: u64| rfc3339(SystemTime::UNIX_EPOCH + Duration::from_secs(s));
        assert_eq!(at(0), "1970-01-01T00:00:00Z");
        assert_eq!(at(951_782_400), "2000-02-29T00:00:00Z");
        assert_eq!(at(1_700_000_000), "2023-11-14T22:13:20Z");
    }
}
