//! Preparing a run: the run directory, its lock, resuming what it holds,
//! refusing a changed configuration, run.json marked running, and the one
//! preflight request.

use super::events::{Counters, Event, Reporter};
use super::prompt::{History, SceneMessage};
use super::store::{StoreError, Writer};
use super::{Ctx, EvalError, EvalOptions, git_revision, now_rfc3339, prompt, store};
use crate::episode::Episode;
use crate::llm::{ChatMessage, ChatRequest, Client, LlmError, Role};
use crate::rundir;
use crate::rundir::record::{EpisodeKey, EpisodeScalars};
use crate::rundir::{Invocation, RunInfo, RunStatus, SCHEMA_VERSION, Totals};
use crate::scenario::ScenarioKind;
use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::Ordering::Relaxed;
use std::time::Instant;
/// One request before the fleet starts: the first turn of the first
/// episode still to play (that episode then uses the answer, so nothing is
/// paid twice). A dead endpoint (connection refused, DNS, TLS), a wrong key
/// or model, a request the endpoint rejects, or an unrequested event stream
/// ends the run here within seconds with one line, instead of every episode
/// spending its whole retry schedule. Transient HTTP statuses (429, 5xx)
/// are retried as usual; if they run out, that episode is an infrastructure
/// error like any other and the outage rule takes over.
pub(super) async fn preflight(run: &Prepared) -> Result<(), LlmError> {
    let Some(&key) = run.todo.first() else { return Ok(()) };
    let ctx = &run.ctx;
    let opts = &ctx.options;
    let episode = Episode::new(opts.scenario_set.get(key.scenario), key.tier, key.seed);
    let scene = SceneMessage::new(episode.observation(), opts.config.pictures)
        .map_err(|e| LlmError::Permanent { status: 0, message: e.to_string() })?;
    let history = History::default();
    let messages = history.messages(ctx.system(key.scenario), opts.config.history, None, &scene.message);
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

/// A run directory ready to play: resumed, checked, run.json marked running.
pub(super) struct Prepared {
    pub(super) started: Instant,
    pub(super) dir: PathBuf,
    /// The selection's keys, in order.
    pub(super) selection: Vec<EpisodeKey>,
    /// The keys still to play, in order.
    pub(super) todo: Vec<EpisodeKey>,
    /// Finished episodes of the directory, this invocation's included.
    pub(super) finished: HashMap<EpisodeKey, EpisodeScalars>,
    pub(super) info: RunInfo,
    pub(super) invocation: Invocation,
    /// run.json totals of the earlier invocations.
    pub(super) prev_totals: Totals,
    pub(super) ctx: Arc<Ctx>,
    pub(super) writer: Writer,
    /// The exclusive lock on the run directory, released when dropped.
    pub(super) lock: std::fs::File,
}

/// Open (or create) the run directory, resume what it holds, refuse a
/// changed configuration, and record the invocation as running.
pub(super) fn prepare(
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
            .map(|&k| {
                (
                    k,
                    ChatMessage::new(
                        Role::System,
                        prompt::system_prompt(options.config.probe, k, options.config.observation()),
                    ),
                )
            })
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
pub(super) fn running_info(
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
        imported_from: None,
    }
}
