//! The lines of `rollouts.jsonl` (one [`RolloutRecord`] per finished
//! episode) and `errors.jsonl` (one [`InfraErrorRecord`] per rollout given
//! up), and [`EpisodeScalars`], the one read-side view of a rollout line.

use crate::action::{Action, ActionParseError};
use crate::belief::BeliefMetrics;
use crate::episode::{EpisodeRecord, EvidenceTiming, Outcome, TrajectoryPoint};
use crate::forecast::ForecastMetrics;
use crate::grading::Diagnostics;
use crate::llm::Usage;
use crate::scenario::{Disposition, ScenarioKind, Tier};
use serde::{Deserialize, Serialize};

/// What identifies a rollout. The episode is fully determined by
/// (scenario, tier, seed); rollouts of the same seed differ only through
/// the model's sampling.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub struct EpisodeKey {
    pub scenario: ScenarioKind,
    pub tier: Tier,
    pub seed: u64,
    pub rollout: u32,
}

impl std::fmt::Display for EpisodeKey {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} tier {} seed {} rollout {}", self.scenario, self.tier, self.seed, self.rollout)
    }
}

/// One decision turn of the transcript.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TurnRecord {
    /// 1-based decision index.
    pub turn: u32,
    /// The scene text of this decision. Under `--observation image` the
    /// model was shown the picture drawn from it (and one line) instead;
    /// under `both`, the picture and this text.
    pub scene: String,
    /// The raw reply content as received (`null` when the provider sent
    /// none). Includes any `<think>` block.
    pub reply: Option<String>,
    /// Provider reasoning (`reasoning_content` / `reasoning`) and `<think>`
    /// contents. Stored only: never scored, never sent back.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reasoning: Option<String>,
    pub finish_reason: Option<String>,
    /// The action executed (the conservative stop when `parse_errors` is
    /// not empty).
    pub action: Action,
    /// The `reasoning` field of the model's JSON answer, if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub action_reasoning: Option<String>,
    pub parse_errors: Vec<ActionParseError>,
    /// Usage as reported by the endpoint (`null` when it sent none).
    pub usage: Option<Usage>,
    /// Tokens counted for this turn: the reported total, or an estimate of
    /// (request + reply bytes) / 4 when the endpoint reports no usage.
    pub tokens: u64,
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub tokens_estimated: bool,
    /// The reply was cut at `--max-reply-bytes` (stored and resent cut; a
    /// parse error).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub reply_capped: bool,
    /// The reply ended with `finish_reason: "length"`: cut off by the
    /// completion-token limit (its parse errors are not counted as such).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub truncated: bool,
    /// Reasoning tokens of this turn (`llm::Usage::reasoning`).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub reasoning_tokens: u64,
    /// Prompt tokens served from the provider's cache (`llm::Usage::cached`).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub cached_tokens: u64,
    /// Pictures in this turn's request (`--observation image|both`: this
    /// turn's and those the image history keeps).
    #[serde(default, skip_serializing_if = "is_zero_u32")]
    pub pictures: u32,
    /// Input tokens of those pictures, by the prices file's rule for the
    /// model (OpenAI's tiles when it has none); part of the prompt tokens.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub image_tokens: u64,
    /// Wall time of the successful request (ms).
    pub latency_ms: u64,
    /// Requests made for this turn (1 = no retry).
    pub attempts: u32,
    /// Whether the go / give-way question was already settled (privileged,
    /// from the simulator; used by decision correctness).
    pub after_resolution: bool,
    /// Privileged: the ideal observer's belief that the other road user
    /// lets the ego pass first, given this turn's scene (absent before
    /// schema 3).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ideal_belief: Option<f64>,
    /// Belief-probe runs: the belief the reply stated, or why none could be
    /// read (a probe parse error; the action is unaffected).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub belief: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub belief_error: Option<crate::action::BeliefParseError>,
    /// Forecast-probe runs: the forecast the reply stated, or why none
    /// could be read (a probe parse error; the action is unaffected).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub forecast: Option<crate::forecast::Forecast>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub forecast_error: Option<crate::action::ForecastParseError>,
}

/// One finished episode. The scalars come before the transcript (`turns`),
/// which readers rely on to parse only a line's head (see
/// [`super::lines::parse_scalars`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RolloutRecord {
    /// [`super::SCHEMA_VERSION`] when written; 0 for lines without it.
    #[serde(default)]
    pub schema_version: u32,
    pub model: String,
    pub config_hash: String,
    pub scenario: ScenarioKind,
    pub tier: Tier,
    pub seed: u64,
    pub rollout: u32,
    /// Privileged: the hidden disposition of this episode.
    pub disposition: Disposition,
    pub outcome: Outcome,
    pub reward: f64,
    pub decision_correctness: f64,
    /// Privileged: the evidence turn, the commitment turn, the go / give-way
    /// choice and who entered the conflict first (absent before schema 2).
    #[serde(default, flatten)]
    pub timing: EvidenceTiming,
    /// Belief-probe runs: the episode's belief metrics.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub belief: Option<BeliefMetrics>,
    /// Forecast-probe runs: the episode's forecast metrics.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub forecast: Option<ForecastMetrics>,
    pub diagnostics: Diagnostics,
    /// Decisions taken.
    pub turns_taken: u32,
    /// Decisions whose reply could not be read (executed as the
    /// conservative stop).
    pub parse_error_turns: u32,
    pub tokens: u64,
    pub prompt_tokens: u64,
    pub completion_tokens: u64,
    /// Turns cut off by the completion-token limit (`finish_reason: "length"`).
    #[serde(default)]
    pub truncated_turns: u32,
    /// Reasoning tokens (part of the completion tokens).
    #[serde(default)]
    pub reasoning_tokens: u64,
    /// Prompt tokens served from the provider's prompt cache.
    #[serde(default)]
    pub cached_tokens: u64,
    /// Estimated cost in USD, summed over the turns at the run's
    /// [`super::Pricing`]; absent when the price is unknown (never 0 for
    /// "unknown").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cost_usd: Option<f64>,
    /// Sum of the successful requests' latencies (ms).
    pub latency_ms: u64,
    /// Failed requests retried during this episode.
    pub retries: u32,
    /// Wall time from the episode's start to its end (ms), backoff included.
    pub wall_ms: u64,
    pub finished_at: String,
    pub turns: Vec<TurnRecord>,
    /// Plan-view positions at every decision (for trajectory plots).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trajectory: Option<Vec<TrajectoryPoint>>,
    /// Forecast-probe runs, privileged: where the forecast's road users
    /// were at every decision, in the episode and in its twin under the
    /// other disposition (what the forecasts were scored against).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub forecast_truth: Vec<crate::episode::ForecastTruth>,
}

/// The probes' scores of one episode (each None without its probe).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ProbeScores {
    pub belief: Option<BeliefMetrics>,
    pub forecast: Option<ForecastMetrics>,
    pub forecast_truth: Vec<crate::episode::ForecastTruth>,
}

/// What a rollout line says beyond the episode itself: who played it,
/// under which configuration, and what it cost.
#[derive(Debug, Clone, PartialEq)]
pub struct Provenance {
    pub model: String,
    pub config_hash: String,
    /// Failed requests retried during the episode.
    pub retries: u32,
    pub cost_usd: Option<f64>,
    pub wall_ms: u64,
    pub finished_at: String,
}

impl RolloutRecord {
    pub fn key(&self) -> EpisodeKey {
        EpisodeKey { scenario: self.scenario, tier: self.tier, seed: self.seed, rollout: self.rollout }
    }

    /// The line of a graded episode: its grades, its transcript (each turn
    /// marked settled or open from the grader's decisions) and the
    /// per-episode sums of the turns. The one place those sums are made,
    /// whoever played the episode (`eval`, or an imported Inspect run).
    pub fn assemble(
        key: EpisodeKey,
        graded: EpisodeRecord,
        mut turns: Vec<TurnRecord>,
        probes: ProbeScores,
        from: Provenance,
    ) -> RolloutRecord {
        for (t, d) in turns.iter_mut().zip(&graded.decisions) {
            t.after_resolution = d.after_resolution;
        }
        let usage = |part: fn(&Usage) -> Option<u64>| -> u64 {
            turns.iter().filter_map(|t| t.usage.as_ref()).map(|u| part(u).unwrap_or(0)).sum()
        };
        RolloutRecord {
            schema_version: super::SCHEMA_VERSION,
            model: from.model,
            config_hash: from.config_hash,
            scenario: key.scenario,
            tier: key.tier,
            seed: key.seed,
            rollout: key.rollout,
            disposition: graded.disposition,
            outcome: graded.outcome,
            reward: graded.grades.reward,
            decision_correctness: graded.grades.decision_correctness,
            timing: graded.timing,
            belief: probes.belief,
            forecast: probes.forecast,
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
            cost_usd: from.cost_usd,
            latency_ms: turns.iter().map(|t| t.latency_ms).sum(),
            retries: from.retries,
            wall_ms: from.wall_ms,
            finished_at: from.finished_at,
            turns,
            trajectory: graded.trajectory,
            forecast_truth: probes.forecast_truth,
        }
    }
}

/// The per-episode numbers summaries and reports need, read from the head
/// of a rollout line without its transcript (serde skips the other fields).
/// Fields added after version 0 default, so old lines stay readable.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct EpisodeScalars {
    #[serde(default)]
    pub schema_version: u32,
    pub scenario: ScenarioKind,
    pub tier: Tier,
    pub seed: u64,
    pub rollout: u32,
    pub disposition: Disposition,
    pub outcome: Outcome,
    pub reward: f64,
    pub decision_correctness: f64,
    #[serde(default, flatten)]
    pub timing: EvidenceTiming,
    #[serde(default)]
    pub belief: Option<BeliefMetrics>,
    #[serde(default)]
    pub forecast: Option<ForecastMetrics>,
    pub turns_taken: u32,
    pub parse_error_turns: u32,
    pub tokens: u64,
    #[serde(default)]
    pub prompt_tokens: u64,
    #[serde(default)]
    pub completion_tokens: u64,
    #[serde(default)]
    pub truncated_turns: u32,
    #[serde(default)]
    pub reasoning_tokens: u64,
    #[serde(default)]
    pub cached_tokens: u64,
    #[serde(default)]
    pub cost_usd: Option<f64>,
    #[serde(default)]
    pub latency_ms: u64,
    #[serde(default)]
    pub retries: u32,
}

impl EpisodeScalars {
    pub fn key(&self) -> EpisodeKey {
        EpisodeKey { scenario: self.scenario, tier: self.tier, seed: self.seed, rollout: self.rollout }
    }

    pub fn success(&self) -> bool {
        self.outcome == Outcome::Success
    }
}

impl From<&RolloutRecord> for EpisodeScalars {
    fn from(r: &RolloutRecord) -> Self {
        EpisodeScalars {
            schema_version: r.schema_version,
            scenario: r.scenario,
            tier: r.tier,
            seed: r.seed,
            rollout: r.rollout,
            disposition: r.disposition,
            outcome: r.outcome,
            reward: r.reward,
            decision_correctness: r.decision_correctness,
            timing: r.timing,
            belief: r.belief,
            forecast: r.forecast,
            turns_taken: r.turns_taken,
            parse_error_turns: r.parse_error_turns,
            tokens: r.tokens,
            prompt_tokens: r.prompt_tokens,
            completion_tokens: r.completion_tokens,
            truncated_turns: r.truncated_turns,
            reasoning_tokens: r.reasoning_tokens,
            cached_tokens: r.cached_tokens,
            cost_usd: r.cost_usd,
            latency_ms: r.latency_ms,
            retries: r.retries,
        }
    }
}

/// A rollout whose retries ran out: appended to `errors.jsonl`, never to
/// `rollouts.jsonl`, and re-run by the next invocation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InfraErrorRecord {
    /// [`super::SCHEMA_VERSION`] when written; 0 for lines without it.
    #[serde(default)]
    pub schema_version: u32,
    pub scenario: ScenarioKind,
    pub tier: Tier,
    pub seed: u64,
    pub rollout: u32,
    /// The turn whose request failed.
    pub turn: u32,
    pub error: String,
    pub at: String,
}

impl InfraErrorRecord {
    /// The record of `key` given up at `turn` for `error`, at time `at`.
    pub fn new(key: EpisodeKey, turn: u32, error: String, at: String) -> InfraErrorRecord {
        InfraErrorRecord {
            schema_version: super::SCHEMA_VERSION,
            scenario: key.scenario,
            tier: key.tier,
            seed: key.seed,
            rollout: key.rollout,
            turn,
            error,
            at,
        }
    }

    pub fn key(&self) -> EpisodeKey {
        EpisodeKey { scenario: self.scenario, tier: self.tier, seed: self.seed, rollout: self.rollout }
    }
}

fn is_zero(n: &u64) -> bool {
    *n == 0
}

fn is_zero_u32(n: &u32) -> bool {
    *n == 0
}
