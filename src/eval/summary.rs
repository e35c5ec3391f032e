//! The run's leaderboard: per scenario and tier, over the finished episodes
//! of the selection. Infrastructure errors are excluded from every score and
//! shown as their own column.

use crate::export::{Cell, Column, Exporter, Field, MarkdownExporter, Style, Table, f2};
use crate::metrics::{BeliefProbe, ForecastProbe, ProbeColumns, ProbeMetrics};
use crate::metrics::{CellMetrics, RESAMPLES};
use crate::rundir::record::EpisodeScalars;
use crate::scenario::{ScenarioKind, Tier};
use crate::stats::mean;
use serde::{Deserialize, Serialize};

/// One (scenario, tier) of the selection: its figures over the finished
/// episodes, and how many of the selection's episodes are missing.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CellSummary {
    pub scenario: ScenarioKind,
    pub tier: Tier,
    #[serde(flatten)]
    pub metrics: CellMetrics,
    /// Episodes of the selection not finished (infrastructure errors, or not
    /// started: token budget, interruption). Excluded from every score.
    pub missing: usize,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    pub model: String,
    pub cells: Vec<CellSummary>,
    /// Mean of the cells' success rates (cells with episodes only).
    pub mean_success: f64,
    pub episodes: usize,
    pub missing: usize,
    /// Token totals over the scored episodes, as the provider reported
    /// them: prompt (of which served from its cache), completion (of which
    /// reasoning).
    #[serde(default)]
    pub prompt_tokens: u64,
    #[serde(default)]
    pub cached_tokens: u64,
    #[serde(default)]
    pub completion_tokens: u64,
    #[serde(default)]
    pub reasoning_tokens: u64,
    /// Estimated cost of the scored episodes in USD; `null` when any of
    /// them has no known price.
    #[serde(default)]
    pub cost_usd: Option<f64>,
    /// The date of the prices used (`null`: unknown).
    #[serde(default)]
    pub prices_as_of: Option<String>,
}

/// `cells`: for each (scenario, tier) of the selection, the finished
/// episodes' scalars in key order and the number of missing episodes.
pub fn summarize(model: &str, cells: &[(ScenarioKind, Tier, Vec<EpisodeScalars>, usize)]) -> Summary {
    let out: Vec<CellSummary> = cells
        .iter()
        .map(|(scenario, tier, eps, missing)| {
            let eps: Vec<&EpisodeScalars> = eps.iter().collect();
            // With the cell's fixed seed (base 0): a summary equals the
            // report's interval for the cell.
            let metrics = CellMetrics::of(&eps, *scenario, *tier, RESAMPLES, 0);
            CellSummary { scenario: *scenario, tier: *tier, metrics, missing: *missing }
        })
        .collect();
    let sum = |part: fn(&EpisodeScalars) -> u64| cells.iter().flat_map(|c| c.2.iter()).map(part).sum::<u64>();
    let scored: Vec<f64> = out.iter().filter(|c| c.metrics.episodes > 0).map(|c| c.metrics.success.estimate).collect();
    Summary {
        model: model.to_string(),
        mean_success: mean(&scored),
        episodes: out.iter().map(|c| c.metrics.episodes).sum(),
        missing: out.iter().map(|c| c.missing).sum(),
        prompt_tokens: sum(|e| e.prompt_tokens),
        cached_tokens: sum(|e| e.cached_tokens),
        completion_tokens: sum(|e| e.completion_tokens),
        reasoning_tokens: sum(|e| e.reasoning_tokens),
        cost_usd: cells.iter().flat_map(|c| c.2.iter()).map(|e| e.cost_usd).sum(),
        prices_as_of: None,
        cells: out,
    }
}

/// The leaderboard as a table: one row per (scenario, tier).
pub(crate) fn table(summary: &Summary) -> Table {
    let metric = |header: &str, key: &str, value: fn(&CellMetrics) -> f64| {
        Field::float(Column::new(header, key), move |s: &CellSummary| value(&s.metrics))
    };
    let fields: Vec<Field<CellSummary>> = [
        key_fields(),
        vec![
            Field::new(Column::display("n (seeds x rollouts)"), |s: &CellSummary| {
                Cell::text(format!("{}x{}", s.metrics.seeds, s.metrics.rollouts))
            }),
            Field::new(Column::data("episodes"), |s: &CellSummary| Cell::Int(s.metrics.episodes as u64)),
            Field::new(Column::data("seeds"), |s: &CellSummary| Cell::Int(s.metrics.seeds as u64)),
        ],
        CellMetrics::outcome_fields("correctness").into_iter().map(|f| f.of(|s: &CellSummary| &s.metrics)).collect(),
        vec![
            metric("guess rate", "guess_rate", |m: &CellMetrics| m.guess_rate),
            metric("lag (turns)", "evidence_lag", |m: &CellMetrics| m.evidence_lag),
            metric("parse errors", "parse_error_rate", |m: &CellMetrics| m.parse_error_rate),
            metric("truncated", "truncated_rate", |m: &CellMetrics| m.truncated_rate),
            Field::new(Column::new("tokens/ep", "tokens_per_episode").style(Style::Whole), |s: &CellSummary| {
                Cell::Float(s.metrics.tokens_per_episode)
            }),
            Field::new(Column::new("missing", "missing"), |s: &CellSummary| Cell::Int(s.missing as u64)),
        ],
    ]
    .into_iter()
    .flatten()
    .collect();
    Table::of("summary", "", &fields, &summary.cells)
}

/// The columns that say which cell a row is.
fn key_fields() -> Vec<Field<'static, CellSummary>> {
    vec![
        Field::new(Column::new("scenario", "scenario"), |s: &CellSummary| Cell::text(s.scenario.to_string())),
        Field::new(Column::new("tier", "tier"), |s: &CellSummary| Cell::Int(s.tier.number().into())),
    ]
}

/// A probe's table of a probe run: one row per (scenario, tier) with the
/// probe's metrics (None when no cell has any).
pub(crate) fn probe_table<P: ProbeColumns>(summary: &Summary) -> Option<Table> {
    type Probed<'a, P> = (&'a CellSummary, &'a <P as ProbeMetrics>::Summary);
    let probed: Vec<Probed<P>> = summary.cells.iter().filter_map(|c| Some((c, P::of_cell(&c.metrics)?))).collect();
    let fields: Vec<Field<Probed<P>>> = [
        key_fields().into_iter().map(|f| f.of(|p: &Probed<P>| p.0)).collect(),
        vec![Field::new(Column::new("n", "episodes"), |(c, _): &Probed<P>| Cell::Int(c.metrics.episodes as u64))],
        P::fields().into_iter().map(|f| f.of(|p: &Probed<P>| p.1)).collect(),
    ]
    .into_iter()
    .flatten()
    .collect();
    let mut t = Table::of(P::KEY, P::TITLE, &fields, &probed);
    t.note(P::NOTE);
    (!probed.is_empty()).then_some(t)
}

/// `summary.md` and the table printed at the end of a run: the model, the
/// leaderboard in Markdown, the probe tables of a probe run, and the totals.
pub fn render(summary: &Summary) -> String {
    let belief = [probe_table::<BeliefProbe>(summary), probe_table::<ForecastProbe>(summary)]
        .into_iter()
        .flatten()
        .map(|t| format!("\n{}", MarkdownExporter { heading_level: 2 }.render(&t)))
        .collect::<String>();
    format!(
        "model: {}\n\n{}{belief}\nmean success over cells: {}; {} episodes scored, {} missing\n\
         tokens: {} prompt ({} cached, {}), {} completion ({} reasoning)\n{}\n",
        summary.model,
        MarkdownExporter { heading_level: 2 }.render(&table(summary)),
        f2(summary.mean_success),
        summary.episodes,
        summary.missing,
        summary.prompt_tokens,
        summary.cached_tokens,
        if summary.prompt_tokens == 0 {
            "-".to_string()
        } else {
            format!("{:.0}%", 100.0 * summary.cached_tokens as f64 / summary.prompt_tokens as f64)
        },
        summary.completion_tokens,
        summary.reasoning_tokens,
        cost_line(summary)
    )
}

/// The estimated spend, dated, or why it is unknown.
fn cost_line(summary: &Summary) -> String {
    match (summary.cost_usd, &summary.prices_as_of) {
        (Some(c), Some(date)) => {
            format!("estimated cost: {} (an estimate, at the prices of {date} in the prices file)", crate::rundir::usd(c))
        }
        _ => "estimated cost: unknown (no price for this model and endpoint in the prices file: add one with --prices-file)"
            .to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::episode::Outcome;

    fn ep(seed: u64, outcome: Outcome, parse_error_turns: u32) -> EpisodeScalars {
        EpisodeScalars {
            schema_version: crate::rundir::SCHEMA_VERSION,
            scenario: ScenarioKind::PedestrianFeint,
            tier: Tier::T2,
            seed,
            rollout: 0,
            disposition: crate::scenario::pedestrian_feint::CROSSER,
            outcome,
            reward: match outcome {
                Outcome::Success => 0.9,
                Outcome::Collision => -1.0,
                Outcome::Timeout => 0.0,
            },
            decision_correctness: 0.5,
            timing: Default::default(),
            belief: None,
            forecast: None,
            turns_taken: 10,
            parse_error_turns,
            tokens: 1000,
            prompt_tokens: 900,
            completion_tokens: 100,
            truncated_turns: 2,
            reasoning_tokens: 60,
            cached_tokens: 450,
            cost_usd: Some(0.01),
            latency_ms: 10,
            retries: 0,
        }
    }

    #[test]
    fn cell_figures() {
        let eps = vec![
            ep(0, Outcome::Success, 0),
            ep(1, Outcome::Collision, 5),
            ep(2, Outcome::Timeout, 0),
            ep(3, Outcome::Success, 0),
        ];
        let s = summarize("m", &[(ScenarioKind::PedestrianFeint, Tier::T2, eps, 2)]);
        let c = &s.cells[0].metrics;
        assert_eq!((c.episodes, s.cells[0].missing), (4, 2));
        assert_eq!(c.success.estimate, 0.5);
        assert!(c.success.lo < 0.5 && c.success.hi > 0.5);
        assert_eq!((c.collision_rate, c.timeout_rate), (0.25, 0.25));
        assert_eq!(c.parse_error_rate, 5.0 / 40.0);
        assert_eq!(c.truncated_rate, 8.0 / 40.0, "truncation is its own rate");
        assert_eq!((s.prompt_tokens, s.cached_tokens, s.completion_tokens, s.reasoning_tokens), (3600, 1800, 400, 240));
        assert_eq!(c.tokens_per_episode, 1000.0);
        assert!((c.mean_reward - 0.2).abs() < 1e-12);
        let table = render(&s);
        assert!(table.contains("tokens: 3600 prompt (1800 cached, 50%), 400 completion (240 reasoning)"), "{table}");
        assert!(table.contains("estimated cost: unknown (no price"), "not dated, so not shown as a price: {table}");
        let mut priced = s.clone();
        priced.prices_as_of = Some("2025-11-20".into());
        assert!((priced.cost_usd.unwrap() - 0.04).abs() < 1e-12);
        assert!(render(&priced).contains("estimated cost: $0.0400 (an estimate, at the prices of 2025-11-20"));
        // One episode without a known cost makes the whole sum unknown.
        let mut unpriced = ep(9, Outcome::Success, 0);
        unpriced.cost_usd = None;
        let partial =
            summarize("m", &[(ScenarioKind::PedestrianFeint, Tier::T2, vec![ep(0, Outcome::Success, 0), unpriced], 0)]);
        assert_eq!(partial.cost_usd, None);
        assert!(table.contains("| pedestrian_feint | 2 | 4x1 | 0.50 ["), "{table}");
        // Deterministic: the same episodes give the same summary.
        let again = summarize(
            "m",
            &[(
                ScenarioKind::PedestrianFeint,
                Tier::T2,
                vec![
                    ep(0, Outcome::Success, 0),
                    ep(1, Outcome::Collision, 5),
                    ep(2, Outcome::Timeout, 0),
                    ep(3, Outcome::Success, 0),
                ],
                2,
            )],
        );
        assert_eq!(serde_json::to_string(&s).unwrap(), serde_json::to_string(&again).unwrap());
    }

    #[test]
    fn rollouts_of_a_seed_are_one_unit() {
        // 4 seeds x 2 rollouts that agree within a seed: per-seed rates 1, 1, 0, 0.
        let o = [Outcome::Success, Outcome::Timeout];
        let eps: Vec<EpisodeScalars> =
            [(0, 0, 0), (0, 1, 0), (1, 0, 0), (1, 1, 0), (2, 0, 1), (2, 1, 1), (3, 0, 1), (3, 1, 1)]
                .iter()
                .map(|&(seed, rollout, k)| EpisodeScalars { rollout, ..ep(seed, o[k], 0) })
                .collect();
        let s = summarize("m", &[(ScenarioKind::PedestrianFeint, Tier::T2, eps, 0)]);
        let c = &s.cells[0].metrics;
        assert_eq!((c.episodes, c.seeds, c.rollouts), (8, 4, 2));
        // The interval is the bootstrap of the 4 seed rates, not of the 8 episodes.
        let seed = crate::stats::cell_seed(0, ScenarioKind::PedestrianFeint.name(), Tier::T2.number());
        assert_eq!(c.success, crate::stats::bootstrap_mean_ci(&[1.0, 1.0, 0.0, 0.0], RESAMPLES, seed));
        let per_episode = crate::stats::bootstrap_mean_ci(&[1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0], RESAMPLES, seed);
        assert!(c.success.hi - c.success.lo > per_episode.hi - per_episode.lo, "{c:?} {per_episode:?}");
        assert!(render(&s).contains("| pedestrian_feint | 2 | 4x2 | 0.50 ["), "{}", render(&s));
        // Every seed a success: Wilson over the 4 seeds, not [1, 1].
        let all: Vec<EpisodeScalars> = (0..4).map(|seed| ep(seed, Outcome::Success, 0)).collect();
        let s = summarize("m", &[(ScenarioKind::PedestrianFeint, Tier::T2, all, 0)]);
        assert_eq!(s.cells[0].metrics.success, crate::stats::wilson_ci(4.0, 4.0));
    }

    #[test]
    fn empty_cells_render_dashes() {
        let s = summarize("m", &[(ScenarioKind::YieldStandoff, Tier::T1, vec![], 3)]);
        assert!(render(&s).contains("| yield_standoff | 1 | 0x0 | - | - |"), "{}", render(&s));
        assert!(s.mean_success.is_nan());
    }
}
