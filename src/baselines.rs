//! The baseline grid: every built-in policy on every scenario and tier,
//! summarised per cell with normal-approximation 95% CIs.

use crate::belief::{BeliefMetrics, BeliefSummary};
use crate::episode::{EpisodeRecord, Outcome, run_episode};
use crate::export::{self, Column, Field, Style, Table};
use crate::forecast::{ForecastMetrics, ForecastSummary, Reference, play_with_references};
use crate::par::par_map;
use crate::policy::PolicyKind;
use crate::scenario::{ScenarioKind, ScenarioSet, Tier};
use crate::stats::{Interval, normal_ci_mean, normal_ci_proportion};
use serde::{Deserialize, Serialize};

/// One (scenario, tier, policy) cell of the grid.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub struct Cell {
    pub scenario: ScenarioKind,
    pub tier: Tier,
    pub policy: PolicyKind,
}

/// Reward range seen for one outcome (for the reward-ordering invariant).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RewardSpan {
    pub count: usize,
    pub min: f64,
    pub max: f64,
}

impl Default for RewardSpan {
    fn default() -> Self {
        RewardSpan { count: 0, min: f64::INFINITY, max: f64::NEG_INFINITY }
    }
}

impl RewardSpan {
    fn add(&mut self, r: f64) {
        self.count += 1;
        self.min = self.min.min(r);
        self.max = self.max.max(r);
    }
}

/// Summary of one cell.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CellSummary {
    pub cell: Cell,
    pub n: usize,
    pub success: Interval,
    pub collision: Interval,
    pub timeout: Interval,
    pub reward: Interval,
    pub decision_correctness: Interval,
    /// Share of the committed episodes that committed before the evidence
    /// turn, and the mean turns from evidence to commitment otherwise.
    pub guess_rate: Interval,
    pub evidence_lag: Interval,
    pub spans: [RewardSpan; 3],
    /// The belief metrics of the beliefs the policy stated (see
    /// [`crate::policy::Policy::belief`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub belief: Option<BeliefSummary>,
}

impl CellSummary {
    pub fn from_records(cell: Cell, records: &[EpisodeRecord]) -> CellSummary {
        let n = records.len();
        let count = |o: Outcome| records.iter().filter(|r| r.outcome == o).count();
        let rewards: Vec<f64> = records.iter().map(|r| r.grades.reward).collect();
        let correctness: Vec<f64> = records.iter().map(|r| r.grades.decision_correctness).collect();
        let guesses: Vec<bool> = records.iter().filter_map(|r| r.timing.guessed()).collect();
        let lags: Vec<f64> = records.iter().filter_map(|r| r.timing.lag()).map(f64::from).collect();
        let mut spans = [RewardSpan::default(); 3];
        for r in records {
            spans[outcome_index(r.outcome)].add(r.grades.reward);
        }
        CellSummary {
            cell,
            n,
            success: normal_ci_proportion(count(Outcome::Success), n),
            collision: normal_ci_proportion(count(Outcome::Collision), n),
            timeout: normal_ci_proportion(count(Outcome::Timeout), n),
            reward: clamp(normal_ci_mean(&rewards), -1.0, 1.0),
            decision_correctness: clamp(normal_ci_mean(&correctness), 0.0, 1.0),
            guess_rate: normal_ci_proportion(guesses.iter().filter(|g| **g).count(), guesses.len()),
            evidence_lag: clamp(normal_ci_mean(&lags), 0.0, f64::INFINITY),
            spans,
            belief: {
                let metrics: Vec<BeliefMetrics> = records.iter().filter_map(EpisodeRecord::belief_metrics).collect();
                (!metrics.is_empty()).then(|| BeliefSummary::of(metrics.iter()))
            },
        }
    }

    pub fn span(&self, outcome: Outcome) -> RewardSpan {
        self.spans[outcome_index(outcome)]
    }
}

/// The grid as a table: one row per cell, every figure with its interval.
pub(crate) fn table(cells: &[CellSummary]) -> Table {
    let figure = |header: &str, key: &str, value: fn(&CellSummary) -> Interval| {
        Field::interval(Column::new(header, key).style(Style::Interval), value)
    };
    let fields: Vec<Field<CellSummary>> = [
        key_fields(),
        vec![
            figure("success", "success", |c| c.success),
            figure("collision", "collision", |c| c.collision),
            figure("timeout", "timeout", |c| c.timeout),
            figure("reward", "reward", |c| c.reward),
            figure("decision correctness", "decision_correctness", |c| c.decision_correctness),
            figure("guess rate", "guess_rate", |c| c.guess_rate),
            figure("lag (turns)", "evidence_lag", |c| c.evidence_lag),
        ],
    ]
    .into_iter()
    .flatten()
    .collect();
    Table::of("baselines", "", &fields, cells)
}

/// The columns that say which cell a row is, and how many episodes it has.
fn key_fields() -> Vec<Field<'static, CellSummary>> {
    use export::Cell;
    vec![
        Field::new(Column::new("scenario", "scenario").style(Style::Code), |c: &CellSummary| {
            Cell::text(c.cell.scenario.to_string())
        }),
        Field::new(Column::new("tier", "tier"), |c: &CellSummary| Cell::Int(c.cell.tier.number().into())),
        Field::new(Column::new("policy", "policy").style(Style::Code), |c: &CellSummary| {
            Cell::text(c.cell.policy.to_string())
        }),
        Field::new(Column::new("n", "n"), |c: &CellSummary| Cell::Int(c.n as u64)),
    ]
}

/// The belief table (`baselines --probe belief`): the belief metrics of
/// every cell's stated beliefs. The expert states the ideal observer's
/// belief and the cue follower its cue's, as references for a model's.
pub(crate) fn belief_table(cells: &[CellSummary]) -> Table {
    type Probed<'a> = (&'a CellSummary, &'a BeliefSummary);
    let probed: Vec<Probed> = cells.iter().filter_map(|c| Some((c, c.belief.as_ref()?))).collect();
    fn cell<'a>(p: &'a Probed<'_>) -> &'a CellSummary {
        p.0
    }
    fn belief<'a>(p: &'a Probed<'_>) -> &'a BeliefSummary {
        p.1
    }
    let fields: Vec<Field<Probed>> = [
        key_fields().into_iter().map(|f| f.of(cell)).collect::<Vec<_>>(),
        crate::belief::fields().into_iter().map(|f| f.of(belief)).collect(),
    ]
    .into_iter()
    .flatten()
    .collect();
    Table::of("baseline_beliefs", "", &fields, &probed)
}

/// One row of the forecast table (`baselines --probe forecast`): a
/// reference forecaster's scores along one cell's episodes, the cell's
/// policy driving.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ForecastCell {
    pub cell: Cell,
    pub reference: Reference,
    pub n: usize,
    pub forecast: ForecastSummary,
}

/// Play every cell of the grid with every reference forecaster along
/// (the episodes are the grid's: the forecasters only watch); rows come
/// back in grid order, then [`Reference::ALL`]'s.
pub fn run_forecast_grid(set: &ScenarioSet, spec: &GridSpec) -> Vec<ForecastCell> {
    let cells = grid_cells(spec);
    par_map(&cells, |&cell| {
        let config = set.get(cell.scenario);
        let mut policy = cell.policy.build();
        let scores: Vec<Vec<ForecastMetrics>> = (0..spec.episodes as u64)
            .map(|i| play_with_references(config, cell.tier, spec.seed_base.wrapping_add(i), policy.as_mut()).1)
            .collect();
        Reference::ALL
            .iter()
            .enumerate()
            .map(|(k, &reference)| ForecastCell {
                cell,
                reference,
                n: scores.len(),
                forecast: ForecastSummary::of(scores.iter().map(|s| &s[k])),
            })
            .collect::<Vec<_>>()
    })
    .into_iter()
    .flatten()
    .collect()
}

/// The forecast table: every reference's forecast scores per cell.
pub(crate) fn forecast_table(rows: &[ForecastCell]) -> Table {
    use export::Cell as Value;
    let keys = vec![
        Field::new(Column::new("scenario", "scenario").style(Style::Code), |r: &ForecastCell| {
            Value::text(r.cell.scenario.to_string())
        }),
        Field::new(Column::new("tier", "tier"), |r: &ForecastCell| Value::Int(r.cell.tier.number().into())),
        Field::new(Column::new("policy", "policy").style(Style::Code), |r: &ForecastCell| {
            Value::text(r.cell.policy.to_string())
        }),
        Field::new(Column::new("forecaster", "forecaster").style(Style::Code), |r: &ForecastCell| {
            Value::text(r.reference.to_string())
        }),
        Field::new(Column::new("n", "n"), |r: &ForecastCell| Value::Int(r.n as u64)),
    ];
    fn summary(r: &ForecastCell) -> &ForecastSummary {
        &r.forecast
    }
    let fields: Vec<Field<ForecastCell>> =
        keys.into_iter().chain(crate::forecast::metrics::fields().into_iter().map(|f| f.of(summary))).collect();
    let mut table = Table::of("baseline_forecasts", "", &fields, rows);
    table.note(crate::forecast::metrics::TABLE_NOTE);
    table
}

/// A normal-approximation interval cannot leave the metric's range.
fn clamp(i: Interval, lo: f64, hi: f64) -> Interval {
    Interval { estimate: i.estimate, lo: i.lo.clamp(lo, hi), hi: i.hi.clamp(lo, hi) }
}

fn outcome_index(o: Outcome) -> usize {
    match o {
        Outcome::Success => 0,
        Outcome::Collision => 1,
        Outcome::Timeout => 2,
    }
}

/// What to run.
#[derive(Debug, Clone)]
pub struct GridSpec {
    pub scenarios: Vec<ScenarioKind>,
    pub tiers: Vec<Tier>,
    pub policies: Vec<PolicyKind>,
    pub episodes: usize,
    pub seed_base: u64,
}

/// Play every episode of one cell: seeds `seed_base .. seed_base + n`.
pub fn run_cell(set: &ScenarioSet, cell: Cell, episodes: usize, seed_base: u64) -> Vec<EpisodeRecord> {
    let config = set.get(cell.scenario);
    let mut policy = cell.policy.build();
    (0..episodes as u64).map(|i| run_episode(config, cell.tier, seed_base.wrapping_add(i), policy.as_mut())).collect()
}

/// Run the grid on all cores; cells come back in grid order. `each` sees
/// every cell's records before they are dropped (the validator uses it).
pub fn run_grid(
    set: &ScenarioSet,
    spec: &GridSpec,
    each: &(dyn Fn(Cell, &[EpisodeRecord]) + Sync),
) -> Vec<CellSummary> {
    par_map(&grid_cells(spec), |&cell| {
        let records = run_cell(set, cell, spec.episodes, spec.seed_base);
        each(cell, &records);
        CellSummary::from_records(cell, &records)
    })
}

/// The grid's cells, in grid order (scenario, tier, policy).
fn grid_cells(spec: &GridSpec) -> Vec<Cell> {
    let mut cells = Vec::new();
    for &scenario in &spec.scenarios {
        for &tier in &spec.tiers {
            for &policy in &spec.policies {
                cells.push(Cell { scenario, tier, policy });
            }
        }
    }
    cells
}
