//! The fleet: episodes in flight up to the concurrency, the order they are
//! started in, and the reasons a run stops starting new ones (budgets,
//! outages, truncation, Ctrl-C or `play`'s quit).

use super::events::{Event, Reporter, StopReason};
use super::prepare::Prepared;
use super::rollout::{EpisodeError, EpisodeResult, play};
use super::store::WriteMsg;
use super::{Ctx, EvalError, EvalOptions, interrupted, now_rfc3339, truncation};
use crate::grading::Outcome;
use crate::llm::LlmError;
use crate::llm::profile::{rejected_parameter, remedy_for};
use crate::rundir::record::{EpisodeKey, EpisodeScalars, InfraErrorRecord};
use crate::scenario::{ScenarioKind, Tier};
use std::collections::HashMap;
use std::sync::atomic::Ordering::Relaxed;
use tokio::task::JoinSet;
/// Consecutive infrastructure errors (no episode finishing in between)
/// after which no new episode is started: each has already spent its whole
/// retry schedule, so the endpoint is down and carrying on would only burn
/// hours of backoff. Smaller runs use their concurrency (at least 3).
pub(super) const OUTAGE_STREAK: u32 = 8;

/// How `drive` ended.
pub(super) struct Drove {
    pub(super) stop: Option<StopReason>,
    /// The endpoint refused or rejected a request.
    pub(super) fatal: Option<LlmError>,
    /// An episode task failed.
    pub(super) failure: Option<EvalError>,
}

/// The state of `drive` between episodes.
pub(super) struct Driver<'a> {
    pub(super) run: &'a mut Prepared,
    pub(super) reporter: &'a mut dyn Reporter,
    pub(super) drove: Drove,
    pub(super) tokens_spent: u64,
    /// USD spent by this invocation's finished episodes.
    pub(super) cost_spent: f64,
    /// Infrastructure errors since the last finished episode.
    pub(super) infra_streak: u32,
    /// None with --allow-truncation.
    pub(super) truncation: Option<truncation::TruncationGuard>,
    pub(super) outage_streak: u32,
}

impl Driver<'_> {
    /// Record `reason` (and report it) unless a more serious one already holds.
    pub(super) fn stop(&mut self, reason: StopReason) {
        if reason.outranks(self.drove.stop) {
            self.drove.stop = Some(reason);
            self.reporter.event(&Event::Stopped { reason });
        }
    }

    /// A finished episode: hand its line to the writer and count it. False
    /// if the writer is gone (its error is reported by `finalize`).
    pub(super) fn finished(&mut self, key: EpisodeKey, scalars: EpisodeScalars, line: String) -> bool {
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
    pub(super) fn context_overflow(&mut self, key: EpisodeKey, turn: u32, error: LlmError) {
        let message = error.to_string();
        self.record_infra_error(key, turn, &message);
        self.reporter.event(&Event::InfraError { key, turn, error: message });
        if self.drove.fatal.is_none() {
            self.drove.fatal = Some(error);
        }
        self.stop(StopReason::Refused);
    }

    /// Count an unfinished episode and append it to errors.jsonl.
    pub(super) fn record_infra_error(&mut self, key: EpisodeKey, turn: u32, message: &str) {
        let counters = &self.run.ctx.counters;
        counters.infra_errors.fetch_add(1, Relaxed);
        counters.done.fetch_add(1, Relaxed);
        self.run.invocation.infra_errors += 1;
        let rec = InfraErrorRecord::new(key, turn, message.to_string(), now_rfc3339());
        let _ = self.run.writer.tx.send(WriteMsg::InfraError(serde_json::to_string(&rec).expect("serialises")));
    }

    /// An episode whose retries ran out: record it in errors.jsonl, and
    /// stop starting episodes once too many in a row failed.
    pub(super) fn infra_error(&mut self, key: EpisodeKey, turn: u32, message: String) {
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
pub(super) async fn drive(run: &mut Prepared, reporter: &mut dyn Reporter) -> Drove {
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
pub(super) fn truncation_guard(
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

/// The error of a run the endpoint refused or rejected, with a hint at the
/// likely cause.
pub(super) fn fatal_error(e: LlmError, ctx: &Ctx, dir: &std::path::Path) -> EvalError {
    let hint = match &e {
        // Pictures sent to an endpoint that does not take them: name the flag.
        LlmError::Permanent { status: 400 | 404 | 415 | 422, message } | LlmError::Refused { status: 400 | 404 | 415 | 422, message }
            if ctx.options.config.pictures.is_some() && rejects_images(message) =>
        {
            format!(
                " (the endpoint does not take the pictures of --observation {}: use a vision model, or run with --observation text)",
                ctx.options.config.observation()
            )
        }
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

/// Whether an error body says the model or server takes no images, as
/// providers word it: OpenAI's "image_url is only supported by certain
/// models", vLLM's "is not a multimodal model", llama.cpp's "image input is
/// not supported", Ollama's "does not support images", OpenRouter's "No
/// endpoints found that support image input".
pub(super) fn rejects_images(body: &str) -> bool {
    let b = body.to_ascii_lowercase();
    [
        "image_url",
        "image input",
        "images",
        "multimodal",
        "vision",
        "image content",
        "image_parse_error",
        "invalid image",
    ]
    .iter()
    .any(|w| b.contains(w))
}

/// Which episode to start next. Cells (scenario, tier) start round-robin;
/// once a cell has finished episodes, the cell with the longest mean episode
/// (in turns) so far goes first. Starting long episodes early shortens the
/// tail of a run, when fewer episodes than `-c` are left in flight (a
/// longest-processing-time-first heuristic that learns lengths as it goes,
/// since a model's episode lengths are not known in advance). Within a cell,
/// keys keep their order. The order never changes an episode's result.
pub(super) struct Scheduler {
    pub(super) cells: Vec<(std::collections::VecDeque<EpisodeKey>, u64, u64)>,
    pub(super) index: HashMap<(ScenarioKind, Tier), usize>,
    pub(super) next_unobserved: usize,
}

impl Scheduler {
    pub(super) fn new(keys: Vec<EpisodeKey>) -> Scheduler {
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

    pub(super) fn observe(&mut self, key: EpisodeKey, turns: u32) {
        if let Some(&i) = self.index.get(&(key.scenario, key.tier)) {
            self.cells[i].1 += turns as u64;
            self.cells[i].2 += 1;
        }
    }

    pub(super) fn next_key(&mut self) -> Option<EpisodeKey> {
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

#[cfg(test)]
mod tests {
    use super::*;

    fn key(scenario: ScenarioKind, seed: u64) -> EpisodeKey {
        EpisodeKey { scenario, tier: Tier::T1, seed, rollout: 0 }
    }

    #[test]
    #[allow(non_upper_case_globals)]
    fn scheduler_interleaves_then_prefers_long_cells() {
        const YieldStandoff: ScenarioKind = ScenarioKind::YieldStandoff;
        const ContestedMerge: ScenarioKind = ScenarioKind::ContestedMerge;
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
}
