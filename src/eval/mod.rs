//! `negotiator eval`: play episodes with a language model as the policy
//! (SPEC section 7).
//!
//! Layout: [`config`] (endpoints file), [`prompt`] (system prompt, history
//! window), [`store`] (resume, the single writer), [`summary`]
//! (leaderboard), [`events`] (what a run reports, and the reporter trait),
//! [`progress`] (the reporters: bar, plain lines, quiet, JSON lines). What
//! the run directory holds is defined in [`crate::rundir`].
//!
//! Flow: list the selected episode keys, drop the ones `rollouts.jsonl`
//! already holds, run the rest with at most `concurrency` episodes in flight
//! (a `JoinSet` bounded by its length), hand each finished episode to the
//! writer thread as one line, then summarise every finished episode of the
//! selection.

pub mod config;
pub mod events;
pub mod plan;
pub mod prices;
pub mod progress;
pub mod prompt;
pub mod shard_auto;
pub mod store;
pub mod summary;
pub mod truncation;

use crate::action::{parse_action, parse_belief};
use crate::belief::{BeliefMetrics, BeliefTurn, Probe};
use crate::episode::{Episode, EpisodeRecord, Outcome};
use crate::llm::profile::{rejected_parameter, remedy_for};
use crate::llm::{ChatMessage, ChatRequest, Client, ClientConfig, Completion, LlmError, Role, Usage};
use crate::observation::render_scene;
use crate::rundir::record::{EpisodeKey, EpisodeScalars, InfraErrorRecord, RolloutRecord, TurnRecord};
use crate::rundir::{
    self, Endpoint, Invocation, RunConfig, RunInfo, RunStatus, SCHEMA_VERSION, Selection, Settings, Totals,
};
use crate::scenario::{ScenarioKind, ScenarioSet, Tier};
use events::Counters;
use events::{Event, Reporter, StopReason};
use prompt::History;
use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicU32, Ordering::Relaxed};
use std::time::{Instant, SystemTime};
use store::{StoreError, WriteMsg, Writer};
use tokio::task::JoinSet;

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

/// Consecutive infrastructure errors (no episode finishing in between)
/// after which no new episode is started: each has already spent its whole
/// retry schedule, so the endpoint is down and carrying on would only burn
/// hours of backoff. Smaller runs use their concurrency (at least 3).
const OUTAGE_STREAK: u32 = 8;

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

/// A finished episode's summary scalars and its line, or why it did not finish.
type EpisodeResult = Result<(EpisodeScalars, String), EpisodeError>;

/// Why an episode did not finish.
enum EpisodeError {
    /// Retries ran out: recorded, excluded, re-run next time.
    Infra { turn: u32, message: String },
    /// The endpoint refuses the run: stop everything.
    Fatal(LlmError),
    /// The conversation outgrew the model's context at `turn`: recorded in
    /// errors.jsonl, missing from the scores; no new episode is started,
    /// the ones in flight finish.
    ContextOverflow { turn: u32, error: LlmError },
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

/// One request before the fleet starts: the first turn of the first
/// episode still to play (that episode then uses the answer, so nothing is
/// paid twice). A dead endpoint (connection refused, DNS, TLS), a wrong key
/// or model, a request the endpoint rejects, or an unrequested event stream
/// ends the run here within seconds with one line, instead of every episode
/// spending its whole retry schedule. Transient HTTP statuses (429, 5xx)
/// are retried as usual; if they run out, that episode is an infrastructure
/// error like any other and the outage rule takes over.
async fn preflight(run: &Prepared) -> Result<(), LlmError> {
    let Some(&key) = run.todo.first() else { return Ok(()) };
    let ctx = &run.ctx;
    let opts = &ctx.options;
    let episode = Episode::new(opts.scenario_set.get(key.scenario), key.tier, key.seed);
    let scene = ChatMessage::new(Role::User, render_scene(episode.observation()));
    let history = History::default();
    let messages = history.messages(ctx.system(key.scenario), opts.config.history, &scene);
    let request = ChatRequest { model: &opts.config.model, messages: &messages, params: &opts.config.request_params };
    let on_retry = |message: &str| {
        ctx.counters.retries.fetch_add(1, Relaxed);
        ctx.counters.record_error(message);
    };
    match ctx.client.preflight(&request, on_retry).await {
        Ok(c) => *ctx.first_turn.lock().unwrap_or_else(|e| e.into_inner()) = Some((key, Ok(c))),
        Err(e @ LlmError::Exhausted { .. }) => {
            *ctx.first_turn.lock().unwrap_or_else(|e| e.into_inner()) = Some((key, Err(e)))
        }
        Err(e) => return Err(e),
    }
    Ok(())
}

/// The action of a reply, with the transport's verdicts added: a reply cut
/// at the size cap, or not valid UTF-8, is the model's bad output and
/// drives as the conservative stop, like any other parse error.
fn parse_reply(completion: &Completion, max_reply_bytes: usize) -> crate::action::ParsedAction {
    let mut parsed = parse_action(completion.content.as_deref().unwrap_or(""));
    let mut flagged = Vec::new();
    if completion.capped {
        flagged.push(crate::action::ActionParseError::Oversized { limit: max_reply_bytes });
    }
    if completion.invalid_utf8 {
        flagged.push(crate::action::ActionParseError::InvalidUtf8);
    }
    if !flagged.is_empty() {
        parsed.action = crate::action::Action::CONSERVATIVE;
        parsed.errors.splice(0..0, flagged);
    }
    parsed
}

/// A run directory ready to play: resumed, checked, run.json marked running.
struct Prepared {
    started: Instant,
    dir: PathBuf,
    /// The selection's keys, in order.
    selection: Vec<EpisodeKey>,
    /// The keys still to play, in order.
    todo: Vec<EpisodeKey>,
    /// Finished episodes of the directory, this invocation's included.
    finished: HashMap<EpisodeKey, EpisodeScalars>,
    info: RunInfo,
    invocation: Invocation,
    /// run.json totals of the earlier invocations.
    prev_totals: Totals,
    ctx: Arc<Ctx>,
    writer: Writer,
    /// The exclusive lock on the run directory, released when dropped.
    lock: std::fs::File,
}

/// Open (or create) the run directory, resume what it holds, refuse a
/// changed configuration, and record the invocation as running.
fn prepare(
    mut options: EvalOptions,
    counters: Arc<Counters>,
    reporter: &mut dyn Reporter,
) -> Result<Prepared, EvalError> {
    let started = Instant::now();
    let started_at = now_rfc3339();
    let dir = options.run_dir.clone();
    std::fs::create_dir_all(&dir).map_err(|source| StoreError::Io { path: dir.display().to_string(), source })?;

    // Held until the run is finalized (and released by the OS on a crash).
    let lock = store::lock_dir(&dir)?;
    let previous = rundir::read_run_info(&dir)?;
    let loaded = store::load_rollouts(&dir.join(rundir::ROLLOUTS))?;
    // A run made before the endpoint was part of a run's identity resumes
    // under its recorded identity (its hash stays the one its lines carry).
    if previous.as_ref().is_some_and(|p| p.config.endpoint.is_empty()) {
        options.config.endpoint.clear();
    }
    store::check_config(&dir, previous.as_ref(), &loaded, &options.config)?;
    let run_dir = dir.display().to_string();
    if previous.is_some() || !loaded.finished.is_empty() || loaded.torn_bytes > 0 || loaded.bad_lines > 0 {
        reporter.event(&Event::Resumed {
            run_dir: run_dir.clone(),
            finished: loaded.finished.len(),
            torn_bytes: loaded.torn_bytes,
            bad_lines: loaded.bad_lines,
        });
    }

    let selection = options.selection.keys();
    let todo: Vec<EpisodeKey> = selection.iter().copied().filter(|k| !loaded.finished.contains_key(k)).collect();
    reporter.event(&Event::Planned {
        run_dir,
        selected: selection.len(),
        finished: selection.len() - todo.len(),
        to_run: todo.len(),
    });

    let hash = options.config.hash();
    let info = running_info(&options, &dir, previous.as_ref(), loaded.finished.len(), started_at);
    let (invocation, prev_totals) = (info.last_invocation.clone(), info.totals.clone());
    rundir::write_run_info(&dir, &info)?;

    let client = Client::new(options.client.clone()).map_err(|e| EvalError::Client(e.to_string()))?;
    let ctx = Arc::new(Ctx {
        client,
        systems: ScenarioKind::ALL
            .iter()
            .map(|&k| (k, ChatMessage::new(Role::System, prompt::system_prompt(options.config.probe, k))))
            .collect(),
        hash,
        counters,
        options,
        first_turn: std::sync::Mutex::new(None),
    });
    let writer = Writer::start(&dir)?;
    Ok(Prepared {
        started,
        dir,
        selection,
        todo,
        finished: loaded.finished,
        info,
        invocation,
        prev_totals,
        ctx,
        writer,
        lock,
    })
}

/// run.json at the start of an invocation: the invocation running, the
/// earlier invocations' totals carried over.
fn running_info(
    options: &EvalOptions,
    dir: &std::path::Path,
    previous: Option<&RunInfo>,
    finished: usize,
    started_at: String,
) -> RunInfo {
    let invocation = Invocation {
        started_at: started_at.clone(),
        ended_at: None,
        status: RunStatus::Running,
        selection: options.selection.clone(),
        endpoint: options.endpoint(),
        settings: options.settings(),
        episodes: 0,
        infra_errors: 0,
        retries: 0,
        tokens: 0,
        turns: 0,
        cost_usd: options.pricing.as_ref().map(|_| 0.0),
        wall_s: 0.0,
    };
    RunInfo {
        schema_version: SCHEMA_VERSION,
        run_name: dir.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(),
        config: options.config.clone(),
        config_hash: options.config.hash(),
        crate_version: env!("CARGO_PKG_VERSION").to_string(),
        git_revision: git_revision(),
        started_at: previous.map(|p| p.started_at.clone()).unwrap_or(started_at),
        ended_at: None,
        invocations: previous.map_or(0, |p| p.invocations) + 1,
        last_invocation: invocation,
        totals: Totals { episodes: finished as u64, ..previous.map(|p| p.totals.clone()).unwrap_or_default() },
        pricing: options.pricing.clone(),
    }
}

/// How `drive` ended.
struct Drove {
    stop: Option<StopReason>,
    /// The endpoint refused or rejected a request.
    fatal: Option<LlmError>,
    /// An episode task failed.
    failure: Option<EvalError>,
}

/// The state of `drive` between episodes.
struct Driver<'a> {
    run: &'a mut Prepared,
    reporter: &'a mut dyn Reporter,
    drove: Drove,
    tokens_spent: u64,
    /// USD spent by this invocation's finished episodes.
    cost_spent: f64,
    /// Infrastructure errors since the last finished episode.
    infra_streak: u32,
    /// None with --allow-truncation.
    truncation: Option<truncation::TruncationGuard>,
    outage_streak: u32,
}

impl Driver<'_> {
    /// Record `reason` (and report it) unless a more serious one already holds.
    fn stop(&mut self, reason: StopReason) {
        if reason.outranks(self.drove.stop) {
            self.drove.stop = Some(reason);
            self.reporter.event(&Event::Stopped { reason });
        }
    }

    /// A finished episode: hand its line to the writer and count it. False
    /// if the writer is gone (its error is reported by `finalize`).
    fn finished(&mut self, key: EpisodeKey, scalars: EpisodeScalars, line: String) -> bool {
        let counters = &self.run.ctx.counters;
        self.infra_streak = 0;
        if self.run.writer.tx.send(WriteMsg::Rollout(line)).is_err() {
            self.stop(StopReason::Failed);
            return false;
        }
        counters.done.fetch_add(1, Relaxed);
        if scalars.outcome == Outcome::Success {
            counters.success.fetch_add(1, Relaxed);
        }
        self.tokens_spent += scalars.tokens;
        self.cost_spent += scalars.cost_usd.unwrap_or(0.0);
        self.run.invocation.episodes += 1;
        self.run.invocation.tokens += scalars.tokens;
        if let Some(c) = self.run.invocation.cost_usd.as_mut() {
            *c += scalars.cost_usd.unwrap_or(0.0);
        }
        self.run.finished.insert(key, scalars);
        self.reporter.event(&Event::EpisodeFinished {
            key,
            outcome: scalars.outcome,
            reward: scalars.reward,
            turns: scalars.turns_taken,
            tokens: scalars.tokens,
            retries: scalars.retries,
        });
        if self.run.ctx.options.max_total_tokens.is_some_and(|b| self.tokens_spent >= b) {
            self.stop(StopReason::TokenBudget);
        }
        if self.run.ctx.options.max_cost_usd.is_some_and(|b| self.cost_spent >= b) {
            self.stop(StopReason::CostBudget);
        }
        if let Some(guard) = self.truncation.as_mut()
            && let truncation::Verdict::Stop { truncated, turns } =
                guard.observe(scalars.turns_taken, scalars.truncated_turns)
        {
            self.stop(StopReason::Truncation { truncated, turns });
        }
        true
    }

    /// An episode whose conversation outgrew the model's context: record it
    /// in errors.jsonl (it stays missing, never silently out of the
    /// denominator), start no new episode, and let the ones in flight finish
    /// so that no paid-for work is thrown away. The run then ends as refused.
    fn context_overflow(&mut self, key: EpisodeKey, turn: u32, error: LlmError) {
        let message = error.to_string();
        self.record_infra_error(key, turn, &message);
        self.reporter.event(&Event::InfraError { key, turn, error: message });
        if self.drove.fatal.is_none() {
            self.drove.fatal = Some(error);
        }
        self.stop(StopReason::Refused);
    }

    /// Count an unfinished episode and append it to errors.jsonl.
    fn record_infra_error(&mut self, key: EpisodeKey, turn: u32, message: &str) {
        let counters = &self.run.ctx.counters;
        counters.infra_errors.fetch_add(1, Relaxed);
        counters.done.fetch_add(1, Relaxed);
        self.run.invocation.infra_errors += 1;
        let rec = InfraErrorRecord {
            schema_version: SCHEMA_VERSION,
            scenario: key.scenario,
            tier: key.tier,
            seed: key.seed,
            rollout: key.rollout,
            turn,
            error: message.to_string(),
            at: now_rfc3339(),
        };
        let _ = self.run.writer.tx.send(WriteMsg::InfraError(serde_json::to_string(&rec).expect("serialises")));
    }

    /// An episode whose retries ran out: record it in errors.jsonl, and
    /// stop starting episodes once too many in a row failed.
    fn infra_error(&mut self, key: EpisodeKey, turn: u32, message: String) {
        self.record_infra_error(key, turn, &message);
        self.infra_streak += 1;
        self.reporter.event(&Event::InfraError { key, turn, error: message.clone() });
        let outage = StopReason::Outage { streak: self.infra_streak };
        if self.infra_streak >= self.outage_streak && outage.outranks(self.drove.stop) {
            self.reporter.event(&Event::Outage { streak: self.infra_streak, last_error: message });
            self.stop(outage);
        }
    }
}

/// Play the episodes still to do, at most `concurrency` at a time, handing
/// each finished one to the writer, until all are done or something stops
/// the run (budget, outage, Ctrl-C, a refusal, a failure).
async fn drive(run: &mut Prepared, reporter: &mut dyn Reporter) -> Drove {
    let ctx = run.ctx.clone();
    let concurrency = ctx.options.concurrency.max(1);
    let mut pending = Scheduler::new(std::mem::take(&mut run.todo));
    let mut set: JoinSet<(EpisodeKey, EpisodeResult)> = JoinSet::new();
    let mut driver = Driver {
        run,
        reporter,
        drove: Drove { stop: None, fatal: None, failure: None },
        tokens_spent: 0,
        cost_spent: 0.0,
        infra_streak: 0,
        truncation: None,
        outage_streak: OUTAGE_STREAK.min(concurrency as u32).max(3),
    };
    let (guard, primed_stop) = truncation_guard(&ctx.options, &driver.run.finished, driver.run.selection.len());
    driver.truncation = guard;
    if let Some(stop) = primed_stop {
        driver.stop(stop);
    }
    let ctrl_c = tokio::signal::ctrl_c();
    tokio::pin!(ctrl_c);
    let interrupt = ctx.options.interrupt.clone();
    loop {
        while set.len() < concurrency && driver.drove.stop.is_none() {
            let Some(key) = pending.next_key() else { break };
            let ctx = ctx.clone();
            set.spawn(async move { (key, play(&ctx, key).await) });
        }
        let joined = tokio::select! {
            j = set.join_next() => j,
            _ = &mut ctrl_c => {
                set.abort_all();
                driver.stop(StopReason::Interrupted);
                break;
            }
            _ = interrupted(&interrupt) => {
                set.abort_all();
                driver.stop(StopReason::Interrupted);
                break;
            }
        };
        let Some(joined) = joined else { break };
        let (key, result) = match joined {
            Ok(r) => r,
            Err(e) => {
                set.abort_all();
                driver.drove.failure = Some(EvalError::Task(e.to_string()));
                driver.stop(StopReason::Failed);
                break;
            }
        };
        match result {
            Ok((scalars, line)) => {
                pending.observe(key, scalars.turns_taken);
                if !driver.finished(key, scalars, line) {
                    // Stop spending tokens on episodes that cannot be stored.
                    set.abort_all();
                    break;
                }
                if matches!(driver.drove.stop, Some(StopReason::Truncation { .. })) {
                    // Pause the fleet: every turn in flight is likely cut
                    // off too; those episodes re-run on the next invocation.
                    set.abort_all();
                    break;
                }
            }
            Err(EpisodeError::Infra { turn, message }) => driver.infra_error(key, turn, message),
            Err(EpisodeError::ContextOverflow { turn, error }) => driver.context_overflow(key, turn, error),
            Err(EpisodeError::Fatal(e)) => {
                set.abort_all();
                let refused = matches!(e, LlmError::Refused { .. });
                driver.drove.fatal = Some(e);
                driver.stop(if refused { StopReason::Refused } else { StopReason::Failed });
                break;
            }
        }
    }
    // Let aborted tasks wind down before the writer closes.
    while set.join_next().await.is_some() {}
    driver.drove
}

/// The truncation rule's counter, primed with the episodes already stored
/// (they are the run's first), and the stop they already call for (a
/// resumed run that broke the rule stops before playing); none with
/// --allow-truncation.
fn truncation_guard(
    options: &EvalOptions,
    finished: &HashMap<EpisodeKey, EpisodeScalars>,
    selected: usize,
) -> (Option<truncation::TruncationGuard>, Option<StopReason>) {
    if options.allow_truncation {
        return (None, None);
    }
    let mut guard = truncation::TruncationGuard::new(selected as u64, crate::sim::MAX_TURNS);
    let mut stored: Vec<&EpisodeScalars> = finished.values().collect();
    stored.sort_by_key(|s| s.key());
    for s in stored {
        if let truncation::Verdict::Stop { truncated, turns } = guard.observe(s.turns_taken, s.truncated_turns) {
            return (Some(guard), Some(StopReason::Truncation { truncated, turns }));
        }
    }
    (Some(guard), None)
}

/// Close the writer, record the invocation's totals and status in
/// run.json, report the end, then either return the error that stopped the
/// run or write the summary of every finished episode of the selection.
fn finalize(run: Prepared, drove: Drove, reporter: &mut dyn Reporter) -> Result<RunOutcome, EvalError> {
    let Prepared {
        started,
        dir,
        selection,
        finished,
        mut info,
        mut invocation,
        prev_totals,
        ctx,
        writer,
        lock: _lock,
        ..
    } = run;
    let write_result = writer.finish();
    invocation.retries = ctx.counters.retries.load(Relaxed);
    invocation.turns = ctx.counters.turns.load(Relaxed);
    invocation.wall_s = started.elapsed().as_secs_f64();
    invocation.ended_at = Some(now_rfc3339());

    let mut summary = summarize_selection(&ctx.options.config.model, &selection, &finished);
    summary.prices_as_of = ctx.options.pricing.as_ref().map(|p| p.as_of.clone());
    let missing = summary.missing;
    invocation.status = match drove.stop {
        Some(StopReason::Refused) => RunStatus::Refused,
        Some(StopReason::Failed) => RunStatus::Failed,
        _ if write_result.is_err() => RunStatus::Failed,
        Some(StopReason::Interrupted) => RunStatus::Interrupted,
        _ if missing == 0 => RunStatus::Finished,
        _ => RunStatus::Incomplete,
    };
    let status = invocation.status;
    info.totals = Totals {
        episodes: finished.len() as u64,
        infra_errors: prev_totals.infra_errors + invocation.infra_errors,
        missing: missing as u64,
        retries: prev_totals.retries + invocation.retries,
        tokens: finished.values().map(|s| s.tokens).sum(),
        cost_usd: finished.values().map(|s| s.cost_usd).sum(),
        wall_s: prev_totals.wall_s + invocation.wall_s,
    };
    info.ended_at = invocation.ended_at.clone();
    let inv = &invocation;
    let end = Event::Finished {
        status,
        stop: drove.stop,
        episodes: inv.episodes,
        infra_errors: inv.infra_errors,
        turns: inv.turns,
        retries: inv.retries,
        tokens: inv.tokens,
        cost_usd: inv.cost_usd,
        wall_s: inv.wall_s,
        missing,
    };
    info.last_invocation = invocation;
    rundir::write_run_info(&dir, &info)?;
    reporter.event(&end);
    write_result?;
    if let Some(f) = drove.failure {
        return Err(f);
    }
    if let Some(e) = drove.fatal {
        return Err(fatal_error(e, &ctx, &dir));
    }
    let json = serde_json::to_vec_pretty(&summary).expect("summary serialises");
    rundir::write_atomic(&dir.join("summary.json"), &json)?;
    rundir::write_atomic(&dir.join("summary.md"), summary::render(&summary).as_bytes())?;
    Ok(RunOutcome { summary, run_dir: dir, missing, status, stop: drove.stop })
}

/// The summary over every finished episode of the selection, in key order
/// (the missing ones counted per cell).
fn summarize_selection(
    model: &str,
    selection: &[EpisodeKey],
    finished: &HashMap<EpisodeKey, EpisodeScalars>,
) -> summary::Summary {
    let mut by_cell: Vec<(ScenarioKind, Tier, Vec<EpisodeScalars>, usize)> = Vec::new();
    let mut index: HashMap<(ScenarioKind, Tier), usize> = HashMap::new();
    for key in selection {
        let i = *index.entry((key.scenario, key.tier)).or_insert_with(|| {
            by_cell.push((key.scenario, key.tier, Vec::new(), 0));
            by_cell.len() - 1
        });
        match finished.get(key) {
            Some(s) => by_cell[i].2.push(*s),
            None => by_cell[i].3 += 1,
        }
    }
    summary::summarize(model, &by_cell)
}

/// The error of a run the endpoint refused or rejected, with a hint at the
/// likely cause.
fn fatal_error(e: LlmError, ctx: &Ctx, dir: &std::path::Path) -> EvalError {
    let hint = match &e {
        LlmError::Refused { status: 401 | 403, .. } => match &ctx.options.api_key_var {
            Some(var) => format!(" (check the API key in ${var})"),
            None => " (no API key was sent: give --api-key-var or --endpoint)".to_string(),
        },
        LlmError::Refused { status: 404, .. } => {
            format!(" (check --model '{}' and the base URL {})", ctx.options.config.model, ctx.client.url())
        }
        // A 400 naming a parameter: the request profile or a flag is wrong
        // for this model; say which setting changes it.
        LlmError::Permanent { status: 400 | 422, message } => {
            if let Some(p) = rejected_parameter(message, &ctx.options.config.request_params) {
                let msg = format!(
                    "{e} (the endpoint rejects '{p}': {}); the run was stopped, finished episodes are kept in {}",
                    remedy_for(&p, &ctx.options.profile_name),
                    dir.display()
                );
                return EvalError::BadParameter(msg);
            }
            " (the endpoint rejects the request itself: check --sampling-args, --response-format and --max-tokens)"
                .to_string()
        }
        LlmError::ContextOverflow { .. } => " (the overflowing episode is recorded in errors.jsonl and stays missing; \
             re-run with --history last:K, e.g. --history last:4, to bound the conversation: a new run directory, since \
             the history window is part of the configuration)"
            .to_string(),
        _ => String::new(),
    };
    let msg = format!("{e}{hint}; the run was stopped, finished episodes are kept in {}", dir.display());
    match e {
        LlmError::Refused { .. }
        | LlmError::ContextOverflow { .. }
        | LlmError::Unreachable { .. }
        | LlmError::UnrequestedStream { .. }
        | LlmError::Permanent { .. } => EvalError::Refused(msg),
        LlmError::Exhausted { .. } => EvalError::Rejected(msg),
    }
}

/// Which episode to start next. Cells (scenario, tier) start round-robin;
/// once a cell has finished episodes, the cell with the longest mean episode
/// (in turns) so far goes first. Starting long episodes early shortens the
/// tail of a run, when fewer episodes than `-c` are left in flight (a
/// longest-processing-time-first heuristic that learns lengths as it goes,
/// since a model's episode lengths are not known in advance). Within a cell,
/// keys keep their order. The order never changes an episode's result.
struct Scheduler {
    cells: Vec<(std::collections::VecDeque<EpisodeKey>, u64, u64)>,
    index: HashMap<(ScenarioKind, Tier), usize>,
    next_unobserved: usize,
}

impl Scheduler {
    fn new(keys: Vec<EpisodeKey>) -> Scheduler {
        let mut s = Scheduler { cells: Vec::new(), index: HashMap::new(), next_unobserved: 0 };
        for key in keys {
            let i = *s.index.entry((key.scenario, key.tier)).or_insert_with(|| {
                s.cells.push((Default::default(), 0, 0));
                s.cells.len() - 1
            });
            s.cells[i].0.push_back(key);
        }
        s
    }

    fn observe(&mut self, key: EpisodeKey, turns: u32) {
        if let Some(&i) = self.index.get(&(key.scenario, key.tier)) {
            self.cells[i].1 += turns as u64;
            self.cells[i].2 += 1;
        }
    }

    fn next_key(&mut self) -> Option<EpisodeKey> {
        let unobserved: Vec<usize> =
            (0..self.cells.len()).filter(|&i| self.cells[i].2 == 0 && !self.cells[i].0.is_empty()).collect();
        let i = if unobserved.is_empty() {
            (0..self.cells.len()).filter(|&i| !self.cells[i].0.is_empty()).max_by(|&a, &b| {
                let mean = |i: usize| self.cells[i].1 as f64 / self.cells[i].2 as f64;
                mean(a).total_cmp(&mean(b)).then(b.cmp(&a))
            })?
        } else {
            self.next_unobserved += 1;
            unobserved[(self.next_unobserved - 1) % unobserved.len()]
        };
        self.cells[i].0.pop_front()
    }
}

/// Play one episode to its end; return its summary scalars and its line.
async fn play(ctx: &Ctx, key: EpisodeKey) -> EpisodeResult {
    let opts = &ctx.options;
    let started = Instant::now();
    let mut episode = Episode::new(opts.scenario_set.get(key.scenario), key.tier, key.seed);
    if opts.trajectories {
        episode.record_trajectory();
    }
    let mut history = History::default();
    let mut turns: Vec<TurnRecord> = Vec::new();
    let retries = AtomicU32::new(0);
    // Priced per turn, so turns without usage are priced at their estimate.
    let mut cost: Option<f64> = opts.pricing.as_ref().map(|_| 0.0);
    while !episode.is_done() {
        let turn = episode.observation().turn;
        let scene = ChatMessage::new(Role::User, render_scene(episode.observation()));
        let messages = history.messages(ctx.system(key.scenario), opts.config.history, &scene);
        let request =
            ChatRequest { model: &opts.config.model, messages: &messages, params: &opts.config.request_params };
        let on_retry = |message: &str| {
            retries.fetch_add(1, Relaxed);
            ctx.counters.retries.fetch_add(1, Relaxed);
            ctx.counters.record_error(message);
        };
        let answer = match ctx.take_first_turn(key) {
            Some(pre) => {
                // Retries of the preflight belong to this episode.
                let extra = pre.as_ref().map_or(opts.client.retry.max_retries, |c| c.attempts.saturating_sub(1));
                retries.fetch_add(extra, Relaxed);
                pre
            }
            None => ctx.client.chat(&request, on_retry).await,
        };
        let completion = match answer {
            Ok(c) => c,
            Err(e @ LlmError::Exhausted { .. }) => {
                return Err(EpisodeError::Infra { turn, message: e.to_string() });
            }
            Err(e @ LlmError::ContextOverflow { .. }) => return Err(EpisodeError::ContextOverflow { turn, error: e }),
            Err(e) => return Err(EpisodeError::Fatal(e)),
        };
        let sent_bytes: usize = messages.iter().map(|m| m.content.len()).sum();
        drop(messages);
        let parsed = parse_reply(&completion, ctx.options.client.max_reply_bytes);
        let (tokens, estimated) = turn_tokens(&completion, sent_bytes);
        if let (Some(total), Some(pricing)) = (cost.as_mut(), opts.pricing.as_ref()) {
            let (prompt, cached, output) = billed_tokens(&completion, sent_bytes);
            let usd = pricing.cost(prompt, cached, output);
            *total += usd;
            ctx.counters.add_cost(usd);
        }
        ctx.counters.tokens.fetch_add(tokens, Relaxed);
        ctx.counters.turns.fetch_add(1, Relaxed);
        let ideal_belief = episode.ideal_belief();
        let (belief, belief_error) = match opts.config.probe {
            Probe::None => (None, None),
            Probe::Belief => match parse_belief(completion.content.as_deref().unwrap_or("")) {
                Ok(b) => (Some(b), None),
                Err(e) => (None, Some(e)),
            },
        };
        episode.step(parsed.action);
        let answer = prompt::history_answer(&completion.answer);
        let truncated = completion.finish_reason.as_deref() == Some("length");
        turns.push(TurnRecord {
            turn,
            scene: scene.content.clone(),
            reply: completion.content,
            reasoning: completion.reasoning,
            finish_reason: completion.finish_reason,
            action: parsed.action,
            action_reasoning: parsed.reasoning,
            parse_errors: parsed.errors,
            truncated,
            reasoning_tokens: completion.usage.map_or(0, |u| u.reasoning()),
            cached_tokens: completion.usage.map_or(0, |u| u.cached()),
            usage: completion.usage,
            tokens,
            tokens_estimated: estimated,
            reply_capped: completion.capped,
            latency_ms: completion.latency.as_millis() as u64,
            attempts: completion.attempts,
            after_resolution: false,
            ideal_belief: Some(ideal_belief),
            belief,
            belief_error,
        });
        history.push(scene, answer);
    }
    let graded = episode.finish();
    for (t, d) in turns.iter_mut().zip(&graded.decisions) {
        t.after_resolution = d.after_resolution;
    }
    let record = rollout_record(ctx, key, graded, turns, (retries.load(Relaxed), cost), started);
    let line = serde_json::to_string(&record).expect("a rollout record serialises");
    Ok((EpisodeScalars::from(&record), line))
}

/// Tokens of one turn: the reported total, or (no usage reported) an
/// estimate of ~4 bytes per token over the request and the reply, so
/// budgets and tokens/episode stay meaningful. The flag says which.
fn turn_tokens(completion: &Completion, sent_bytes: usize) -> (u64, bool) {
    match completion.usage.and_then(|u| u.total()) {
        Some(t) => (t, false),
        None => (((sent_bytes + completion.content.as_ref().map_or(0, String::len)) / 4) as u64, true),
    }
}

/// The tokens a turn is billed for: (prompt, of which cached, output with
/// hidden reasoning), as reported, or (no usage reported) estimated like
/// [`turn_tokens`] at ~4 bytes per token, none of them cached.
fn billed_tokens(completion: &Completion, sent_bytes: usize) -> (u64, u64, u64) {
    match completion.usage {
        Some(u) if u.prompt_tokens.is_some() || u.completion_tokens.is_some() => {
            (u.prompt_tokens.unwrap_or(0), u.cached(), u.billed_output())
        }
        _ => ((sent_bytes / 4) as u64, 0, (completion.content.as_ref().map_or(0, String::len) / 4) as u64),
    }
}

/// The line of a finished episode: its grades and its transcript, with the
/// per-episode sums of the turns.
fn rollout_record(
    ctx: &Ctx,
    key: EpisodeKey,
    graded: EpisodeRecord,
    turns: Vec<TurnRecord>,
    (retries, cost_usd): (u32, Option<f64>),
    started: Instant,
) -> RolloutRecord {
    let belief = (ctx.options.config.probe == Probe::Belief).then(|| {
        let turns: Vec<BeliefTurn> = turns
            .iter()
            .map(|t| BeliefTurn {
                turn: t.turn,
                stated: t.belief,
                ideal: t.ideal_belief.unwrap_or(0.5),
                maneuver: t.parse_errors.is_empty().then_some(t.action.maneuver),
                open: !t.after_resolution,
            })
            .collect();
        BeliefMetrics::compute(&turns, graded.disposition.ego_should_go(), graded.timing.evidence_turn)
    });
    let usage = |part: fn(&Usage) -> Option<u64>| -> u64 {
        turns.iter().filter_map(|t| t.usage.as_ref()).map(|u| part(u).unwrap_or(0)).sum()
    };
    RolloutRecord {
        schema_version: SCHEMA_VERSION,
        model: ctx.options.config.model.clone(),
        config_hash: ctx.hash.clone(),
        scenario: key.scenario,
        tier: key.tier,
        seed: key.seed,
        rollout: key.rollout,
        disposition: graded.disposition,
        outcome: graded.outcome,
        reward: graded.grades.reward,
        decision_correctness: graded.grades.decision_correctness,
        timing: graded.timing,
        belief,
        diagnostics: graded.grades.diagnostics,
        turns_taken: turns.len() as u32,
        // A cut-off reply is counted as truncated, not as a parse error.
        parse_error_turns: turns.iter().filter(|t| !t.parse_errors.is_empty() && !t.truncated).count() as u32,
        tokens: turns.iter().map(|t| t.tokens).sum(),
        prompt_tokens: usage(|u| u.prompt_tokens),
        // Billed output: thinking that only the total reports counts too.
        completion_tokens: usage(|u| u.completion_tokens.map(|c| c + u.hidden_reasoning())),
        truncated_turns: turns.iter().filter(|t| t.truncated).count() as u32,
        reasoning_tokens: turns.iter().map(|t| t.reasoning_tokens).sum(),
        cached_tokens: turns.iter().map(|t| t.cached_tokens).sum(),
        cost_usd,
        latency_ms: turns.iter().map(|t| t.latency_ms).sum(),
        retries,
        wall_ms: started.elapsed().as_millis() as u64,
        finished_at: now_rfc3339(),
        turns,
        trajectory: graded.trajectory,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    fn key(scenario: ScenarioKind, seed: u64) -> EpisodeKey {
        EpisodeKey { scenario, tier: Tier::T1, seed, rollout: 0 }
    }

    #[test]
    fn scheduler_interleaves_then_prefers_long_cells() {
        use ScenarioKind::*;
        let keys: Vec<EpisodeKey> =
            [YieldStandoff, ContestedMerge].iter().flat_map(|&s| (0..4).map(move |i| key(s, i))).collect();
        let mut s = Scheduler::new(keys);
        let a = s.next_key().unwrap();
        let b = s.next_key().unwrap();
        assert_eq!((a.scenario, a.seed, b.scenario, b.seed), (YieldStandoff, 0, ContestedMerge, 0));
        s.observe(a, 10);
        // YieldStandoff is observed, ContestedMerge not yet: explore it.
        assert_eq!(s.next_key().unwrap(), key(ContestedMerge, 1));
        s.observe(b, 30);
        // Both observed: the longer cell first, until it runs dry.
        assert_eq!(s.next_key().unwrap(), key(ContestedMerge, 2));
        assert_eq!(s.next_key().unwrap(), key(ContestedMerge, 3));
        assert_eq!(s.next_key().unwrap(), key(YieldStandoff, 1));
        assert_eq!(s.next_key().unwrap(), key(YieldStandoff, 2));
        assert_eq!(s.next_key().unwrap(), key(YieldStandoff, 3));
        assert_eq!(s.next_key(), None);
    }

    #[test]
    fn rfc3339_formats_known_instants() {
        let at = |s: u64| rfc3339(SystemTime::UNIX_EPOCH + Duration::from_secs(s));
        assert_eq!(at(0), "1970-01-01T00:00:00Z");
        assert_eq!(at(951_782_400), "2000-02-29T00:00:00Z");
        assert_eq!(at(1_700_000_000), "2023-11-14T22:13:20Z");
    }
}
