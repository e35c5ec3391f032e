//! The figures of one (scenario, tier) cell of finished episodes: one
//! computation and one set of names. `eval`'s summary (summary.json,
//! summary.md) and `report`'s per-tier table (report.json `tier_rows`,
//! tiers.csv) both show a [`CellMetrics`], so the two cannot disagree on a
//! run (a test holds them equal).

use crate::belief::BeliefSummary;
use crate::episode::{Outcome, evidence_lag, guess_rate};
use crate::rundir::record::EpisodeScalars;
use crate::scenario::{ScenarioKind, Tier};
use crate::stats::{Interval, cell_success_ci, mean};
use serde::{Deserialize, Serialize};

/// Percentile bootstrap resamples for a cell's success interval: eval's
/// summary uses this many, and a report at least this many
/// (docs/report.md, "Statistics").
pub const RESAMPLES: usize = 10_000;

/// One cell's figures over its finished episodes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CellMetrics {
    /// Finished episodes scored.
    pub episodes: usize,
    /// Seeds with a finished episode (the resampling units).
    #[serde(default)]
    pub seeds: usize,
    /// Rollouts per seed (the most any seed has).
    #[serde(default)]
    pub rollouts: u32,
    /// Success rate with a 95% percentile bootstrap interval over seeds
    /// (Wilson when every seed is 0, or every seed is 1).
    pub success: Interval,
    pub collision_rate: f64,
    pub timeout_rate: f64,
    pub mean_reward: f64,
    pub decision_correctness: f64,
    /// Share of committed episodes that committed before the evidence turn
    /// (a guess).
    pub guess_rate: f64,
    /// Mean turns from the evidence to the commitment, over the episodes
    /// that did not guess.
    pub evidence_lag: f64,
    /// Fraction of decision turns whose reply could not be read (cut-off
    /// replies excepted: they are `truncated_rate`).
    pub parse_error_rate: f64,
    /// Fraction of decision turns cut off by the completion-token limit
    /// (`finish_reason: "length"`).
    #[serde(default)]
    pub truncated_rate: f64,
    pub tokens_per_episode: f64,
    /// Belief-probe runs: the belief metrics of the cell.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub belief: Option<BeliefSummary>,
    /// Forecast-probe runs: the forecast metrics of the cell.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub forecast: Option<crate::forecast::ForecastSummary>,
}

impl CellMetrics {
    /// The figures of `eps`, the cell's finished episodes. A seed is one
    /// resampling unit (its value: its success rate over its rollouts, which
    /// are not independent), resampled with the cell's own seed derived from
    /// `base`, so the interval is a pure function of the episodes.
    pub fn of(eps: &[&EpisodeScalars], scenario: ScenarioKind, tier: Tier, resamples: usize, base: u64) -> Self {
        let (per_seed, rollouts) = seed_rates(eps);
        let turns: u64 = eps.iter().map(|e| u64::from(e.turns_taken)).sum();
        let per_turn = |count: u64| if turns == 0 { f64::NAN } else { count as f64 / turns as f64 };
        CellMetrics {
            episodes: eps.len(),
            seeds: per_seed.len(),
            rollouts,
            success: cell_success_ci(&per_seed, resamples, base, scenario.name(), tier.number()),
            collision_rate: outcome_rate(eps, Outcome::Collision),
            timeout_rate: outcome_rate(eps, Outcome::Timeout),
            mean_reward: mean_of(eps, |e| e.reward),
            decision_correctness: mean_of(eps, |e| e.decision_correctness),
            guess_rate: guess_rate(eps.iter().map(|e| e.timing)),
            evidence_lag: evidence_lag(eps.iter().map(|e| e.timing)),
            parse_error_rate: per_turn(eps.iter().map(|e| u64::from(e.parse_error_turns)).sum()),
            truncated_rate: per_turn(eps.iter().map(|e| u64::from(e.truncated_turns)).sum()),
            tokens_per_episode: mean_of(eps, |e| e.tokens as f64),
            belief: eps
                .iter()
                .any(|e| e.belief.is_some())
                .then(|| BeliefSummary::of(eps.iter().filter_map(|e| e.belief.as_ref()))),
            forecast: eps
                .iter()
                .any(|e| e.forecast.is_some())
                .then(|| crate::forecast::ForecastSummary::of(eps.iter().filter_map(|e| e.forecast.as_ref()))),
        }
    }
}

impl CellMetrics {
    /// The outcome figures as table fields (their keys are the field
    /// names), for any table that shows a cell's metrics.
    pub(crate) fn outcome_fields(correctness_header: &str) -> Vec<crate::export::Field<'static, CellMetrics>> {
        use crate::export::{Column, Field, Style};
        type F = Field<'static, CellMetrics>;
        vec![
            F::interval(Column::new("success [95% CI]", "success").style(Style::Interval), |m| m.success),
            F::float(Column::new("collision", "collision_rate"), |m| m.collision_rate),
            F::float(Column::new("timeout", "timeout_rate"), |m| m.timeout_rate),
            F::float(Column::new("reward", "mean_reward"), |m| m.mean_reward),
            F::float(Column::new(correctness_header, "decision_correctness"), |m| m.decision_correctness),
        ]
    }
}

/// The share of `eps` that ended in `outcome` (NaN for none).
pub fn outcome_rate(eps: &[&EpisodeScalars], outcome: Outcome) -> f64 {
    if eps.is_empty() {
        return f64::NAN;
    }
    eps.iter().filter(|e| e.outcome == outcome).count() as f64 / eps.len() as f64
}

/// The mean of `f` over `eps` (NaN for none).
pub fn mean_of(eps: &[&EpisodeScalars], f: impl Fn(&EpisodeScalars) -> f64) -> f64 {
    mean(&eps.iter().map(|e| f(e)).collect::<Vec<_>>())
}

/// Per seed, in seed order, its success rate over its rollouts; and the
/// most rollouts any seed has.
fn seed_rates(eps: &[&EpisodeScalars]) -> (Vec<f64>, u32) {
    let mut by_seed: std::collections::BTreeMap<u64, (u32, u32)> = std::collections::BTreeMap::new();
    for e in eps {
        let (wins, n) = by_seed.entry(e.seed).or_default();
        *wins += u32::from(e.outcome == Outcome::Success);
        *n += 1;
    }
    let most = by_seed.values().map(|&(_, n)| n).max().unwrap_or(0);
    (by_seed.into_values().map(|(wins, n)| f64::from(wins) / f64::from(n)).collect(), most)
}

/// What a probe's tables read of it, the run summary's and the report's:
/// its metrics per episode, pooled per cell, and its own columns. The
/// filtering, the key columns and the tables themselves are shared
/// (`report::probe_rows`, `eval`'s summary); each probe gives only
/// its own fields.
pub trait ProbeMetrics: std::fmt::Debug + Clone + 'static {
    /// One episode's metrics, as its record carries them.
    type Episode: Copy + 'static;
    /// A cell's, pooled over its episodes.
    type Summary: Clone + std::fmt::Debug + serde::Serialize;
    /// The table's id, and the key its summary is written under.
    const KEY: &'static str;
    const TITLE: &'static str;
    /// What the table's note says of the probe's columns.
    const NOTE: &'static str;
    fn of_episode(e: &EpisodeScalars) -> Option<Self::Episode>;
    fn of_cell(m: &CellMetrics) -> Option<&Self::Summary>;
    fn pool(episodes: &[Self::Episode]) -> Self::Summary;
}

/// A probe's own columns, for its tables.
pub(crate) trait ProbeColumns: ProbeMetrics {
    fn fields() -> Vec<crate::export::Field<'static, Self::Summary>>;
}

/// The belief probe's tables.
#[derive(Debug, Clone)]
pub struct BeliefProbe;

impl ProbeMetrics for BeliefProbe {
    type Episode = crate::belief::BeliefMetrics;
    type Summary = crate::belief::BeliefSummary;
    const KEY: &'static str = "belief";
    const TITLE: &'static str = "Belief probe";
    const NOTE: &'static str = crate::belief::TABLE_NOTE;
    fn of_episode(e: &EpisodeScalars) -> Option<Self::Episode> {
        e.belief
    }
    fn of_cell(m: &CellMetrics) -> Option<&Self::Summary> {
        m.belief.as_ref()
    }
    fn pool(episodes: &[Self::Episode]) -> Self::Summary {
        crate::belief::BeliefSummary::of(episodes.iter())
    }
}

impl ProbeColumns for BeliefProbe {
    fn fields() -> Vec<crate::export::Field<'static, Self::Summary>> {
        crate::belief::fields()
    }
}

/// The forecast probe's tables.
#[derive(Debug, Clone)]
pub struct ForecastProbe;

impl ProbeMetrics for ForecastProbe {
    type Episode = crate::forecast::ForecastMetrics;
    type Summary = crate::forecast::ForecastSummary;
    const KEY: &'static str = "forecast";
    const TITLE: &'static str = "Forecast probe";
    const NOTE: &'static str = crate::forecast::metrics::TABLE_NOTE;
    fn of_episode(e: &EpisodeScalars) -> Option<Self::Episode> {
        e.forecast
    }
    fn of_cell(m: &CellMetrics) -> Option<&Self::Summary> {
        m.forecast.as_ref()
    }
    fn pool(episodes: &[Self::Episode]) -> Self::Summary {
        crate::forecast::ForecastSummary::of(episodes.iter())
    }
}

impl ProbeColumns for ForecastProbe {
    fn fields() -> Vec<crate::export::Field<'static, Self::Summary>> {
        crate::forecast::metrics::fields()
    }
}
