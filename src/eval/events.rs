//! What a run tells the outside world: [`Event`]s, handed to one
//! [`Reporter`] (the progress bar, plain lines, nothing, or JSON lines; see
//! [`super::progress`]). The library never prints; reporters decide what
//! an event looks like.

use crate::episode::Outcome;
use crate::rundir::RunStatus;
use crate::rundir::record::EpisodeKey;
use serde::Serialize;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering::Relaxed};
use std::time::{Duration, Instant};

/// Why a run stopped starting new episodes before its selection was done.
/// Variants are in order of precedence: a later one replaces an earlier one
/// (an outage after the budget ran out is reported as the outage).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(tag = "reason", rename_all = "snake_case")]
pub enum StopReason {
    /// `--max-total-tokens` was reached; episodes in flight finished.
    TokenBudget,
    /// `--max-cost` was reached; episodes in flight finished.
    CostBudget,
    /// `streak` episodes in a row ran out of retries: the endpoint looks down.
    Outage { streak: u32 },
    /// Too many turns were cut off by the completion-token limit (see
    /// [`super::truncation`]); episodes in flight were abandoned.
    Truncation { truncated: u64, turns: u64 },
    /// Ctrl-C; episodes in flight were abandoned.
    Interrupted,
    /// The endpoint refused the run (authentication, unknown model).
    Refused,
    /// The endpoint rejected a request, or the run itself failed (a task,
    /// the writer).
    Failed,
}

impl StopReason {
    fn rank(self) -> u8 {
        match self {
            StopReason::TokenBudget | StopReason::CostBudget => 0,
            StopReason::Outage { .. } => 1,
            StopReason::Truncation { .. } => 2,
            StopReason::Interrupted => 3,
            StopReason::Refused => 4,
            StopReason::Failed => 5,
        }
    }

    /// Whether `self` replaces `current` as the reason a run stopped.
    pub fn outranks(self, current: Option<StopReason>) -> bool {
        current.is_none_or(|c| self.rank() > c.rank())
    }
}

impl std::fmt::Display for StopReason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StopReason::TokenBudget => f.write_str("stopped by --max-total-tokens, or infrastructure errors"),
            StopReason::CostBudget => f.write_str("stopped by --max-cost, or infrastructure errors"),
            StopReason::Outage { streak } => {
                write!(f, "the endpoint looks down: stopped after {streak} consecutive infrastructure errors")
            }
            StopReason::Truncation { truncated, turns } => {
                write!(f, "stopped: {truncated} of {turns} turns were cut off by the token limit")
            }
            StopReason::Interrupted => f.write_str("interrupted"),
            StopReason::Refused => f.write_str("the endpoint refused the run"),
            StopReason::Failed => f.write_str("the run failed"),
        }
    }
}

/// One thing that happened in a run, in the order it happened. Serialised
/// as one JSON object per line by `--events json` (the schema is in
/// docs/eval.md).
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum Event {
    /// The run directory already held a run. `torn_bytes`: a torn last line
    /// cut off; `bad_lines`: complete lines that could not be read (kept,
    /// ignored).
    Resumed { run_dir: String, finished: usize, torn_bytes: u64, bad_lines: usize },
    /// What this invocation will do.
    Planned { run_dir: String, selected: usize, finished: usize, to_run: usize },
    /// An episode finished and its line was handed to the writer.
    EpisodeFinished {
        #[serde(flatten)]
        key: EpisodeKey,
        outcome: Outcome,
        reward: f64,
        turns: u32,
        tokens: u64,
        retries: u32,
    },
    /// An episode's retries ran out at `turn`: recorded in errors.jsonl,
    /// excluded from the scores, re-run by the next invocation.
    InfraError {
        #[serde(flatten)]
        key: EpisodeKey,
        turn: u32,
        error: String,
    },
    /// `streak` episodes in a row ran out of retries (followed by `stopped`).
    Outage { streak: u32, last_error: String },
    /// No new episode will be started.
    Stopped {
        #[serde(flatten)]
        reason: StopReason,
    },
    /// The run is over and run.json records it. The last event.
    Finished {
        status: RunStatus,
        stop: Option<StopReason>,
        /// Episodes finished by this invocation.
        episodes: u64,
        infra_errors: u64,
        /// Decision turns answered by this invocation.
        turns: u64,
        retries: u64,
        tokens: u64,
        /// Estimated USD of this invocation's episodes; `null` when the
        /// price is unknown.
        cost_usd: Option<f64>,
        wall_s: f64,
        /// Episodes of the selection still missing.
        missing: usize,
    },
}

/// Consumes a run's events.
pub trait Reporter {
    /// Called once before the first event with the counters the episode
    /// tasks update between events (tokens and retries as they happen), for
    /// displays that redraw on a timer.
    fn attach(&mut self, _live: Arc<Counters>) {}

    fn event(&mut self, event: &Event);
}

/// Counters shared by the episode tasks and the display.
#[derive(Debug, Default)]
pub struct Counters {
    pub done: AtomicU64,
    pub success: AtomicU64,
    pub infra_errors: AtomicU64,
    pub retries: AtomicU64,
    pub tokens: AtomicU64,
    pub turns: AtomicU64,
    /// Estimated spend in nano-dollars (an integer, so tasks add to it
    /// without a lock), and whether the model has a price at all.
    pub cost_nanousd: AtomicU64,
    pub priced: AtomicBool,
    /// The latest failed request's cause and when it happened, for the
    /// progress line (an outage shows why while it happens).
    pub last_error: std::sync::Mutex<Option<(Instant, String)>>,
}

impl Counters {
    pub fn record_error(&self, message: &str) {
        let mut last = self.last_error.lock().unwrap_or_else(|e| e.into_inner());
        *last = Some((Instant::now(), message.to_string()));
    }

    pub fn add_cost(&self, usd: f64) {
        self.cost_nanousd.fetch_add((usd * 1e9).round() as u64, Relaxed);
    }

    /// The spend so far, `None` when the price is unknown.
    pub fn cost(&self) -> Option<f64> {
        self.priced.load(Relaxed).then(|| self.cost_nanousd.load(Relaxed) as f64 / 1e9)
    }

    /// The latest failure, if it happened within the last 30 s.
    pub(crate) fn recent_error(&self) -> Option<String> {
        let last = self.last_error.lock().unwrap_or_else(|e| e.into_inner());
        last.as_ref().filter(|(at, _)| at.elapsed() < Duration::from_secs(30)).map(|(_, m)| m.clone())
    }
}
