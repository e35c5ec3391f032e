//! The per-model tables: the leaderboard in the paper's form, the per-tier
//! table, the outcome decomposition, and errors and cost.
//!
//! The resampling unit is a (scenario, tier, seed): its value is the
//! success rate over its rollouts (0 or 1 with one rollout per seed), so
//! rollouts of one seed are never treated as independent.

use super::boot::{clustered_mean_of_means_ci, seed_for};
use super::load::{Episode, ModelData, same_unit};
use super::reference::{CEILING, FLOOR, References};
use crate::episode::Outcome;
use crate::export::{Cell, Column, Field, INCOMPLETE_MARK, Style, Table};
use crate::metrics::{CellMetrics, mean_of, outcome_rate};
use crate::par::par_map;
use crate::rundir::record::EpisodeScalars;
use crate::scenario::{ScenarioKind, Tier};
use crate::stats::{Interval, cell_success_ci, mean, quantile, success_ci};
use serde::Serialize;
use std::collections::BTreeMap;

/// One (scenario, tier, seed) of a model: `episodes[start..end]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Unit {
    pub scenario: ScenarioKind,
    pub tier: Tier,
    pub seed: u64,
    pub start: usize,
    pub end: usize,
    pub successes: u32,
}

impl Unit {
    pub(crate) fn rollouts(&self) -> u32 {
        (self.end - self.start) as u32
    }

    /// Success rate over the seed's rollouts.
    pub(crate) fn value(&self) -> f64 {
        f64::from(self.successes) / f64::from(self.rollouts())
    }

    pub(crate) fn key(&self) -> (ScenarioKind, Tier, u64) {
        (self.scenario, self.tier, self.seed)
    }
}

/// The units of sorted episodes whose tier is in `tiers`, in key order.
pub(crate) fn units(episodes: &[Episode], tiers: &[Tier]) -> Vec<Unit> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < episodes.len() {
        let first = &episodes[i];
        let end = i + episodes[i..].iter().take_while(|e| same_unit(e, first)).count();
        if tiers.contains(&first.tier) {
            let successes = episodes[i..end].iter().filter(|e| e.success()).count() as u32;
            out.push(Unit { scenario: first.scenario, tier: first.tier, seed: first.seed, start: i, end, successes });
        }
        i = end;
    }
    out
}

pub(crate) fn tiers_label(tiers: &[Tier]) -> String {
    match tiers {
        [t] => format!("tier {t}"),
        ts => format!("tiers {}", ts.iter().map(|t| t.to_string()).collect::<Vec<_>>().join(", ")),
    }
}

// ---------------------------------------------------------------------------
// Leaderboard

/// The rule for success intervals at 0 and 1, under the tables that show one.
pub(crate) const WILSON_NOTE: &str = "A success of 0.00 or 1.00 (every seed the same) has a Wilson score interval over \
                                      the seeds instead of the percentile bootstrap, which collapses to a point there.";

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ScenarioCell {
    pub scenario: ScenarioKind,
    /// Seeds (resampling units).
    pub seeds: usize,
    pub episodes: usize,
    pub success: Interval,
    pub decision_correctness: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LeaderRow {
    pub model: String,
    /// Mean of the scenario successes, clustered-bootstrap interval.
    pub average: Interval,
    /// One per [`Leaderboard::scenarios`]; `None` when the model has no
    /// episode of that scenario in scope.
    pub scenarios: Vec<Option<ScenarioCell>>,
    /// Decision correctness on the scenario of the leaderboard's DC column
    /// (`DcColumn`).
    #[serde(flatten)]
    pub dc: DcValue,
    pub episodes: usize,
    /// Why the model is incomplete in scope (errored or missing episodes of
    /// its selection, or no episode of a scenario others have); `None`:
    /// complete.
    pub incomplete: Option<String>,
    /// 1-based place on the leaderboard; `None`: not ranked (incomplete,
    /// without `--include-incomplete`).
    pub rank: Option<usize>,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ReferenceRow {
    pub label: String,
    pub policy: String,
    pub average: Option<f64>,
    pub scenarios: Vec<Option<f64>>,
    #[serde(flatten)]
    pub dc: DcValue,
}

/// The leaderboard's decision-correctness column: the scenario whose
/// definition asks for one (the paper's "Yield DC"), and its short label.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct DcColumn {
    pub scenario: ScenarioKind,
    label: &'static str,
}

impl DcColumn {
    /// The column, if a scenario of the benchmark asks for one.
    pub(crate) fn get() -> Option<DcColumn> {
        ScenarioKind::ALL
            .iter()
            .find_map(|&scenario| scenario.def().leaderboard_dc.map(|label| DcColumn { scenario, label }))
    }

    /// Its header in the tables ("yield DC").
    pub(crate) fn header(&self) -> String {
        format!("{} DC", self.label)
    }

    /// Its key in CSV and JSON ("yield_dc").
    pub(crate) fn key(&self) -> String {
        format!("{}_dc", self.label)
    }

    /// Its name in prose ("Yield DC").
    pub(crate) fn term(&self) -> String {
        let header = self.header();
        let mut chars = header.chars();
        chars.next().map(|c| c.to_uppercase().chain(chars).collect()).unwrap_or_default()
    }
}

/// A row's value in the `DcColumn`, serialised under the column's key
/// (nothing without the column).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DcValue(pub Option<f64>);

impl Serialize for DcValue {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let column = DcColumn::get();
        let mut map = serializer.serialize_map(Some(usize::from(column.is_some())))?;
        if let Some(column) = column {
            map.serialize_entry(&column.key(), &self.0)?;
        }
        map.end()
    }
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Leaderboard {
    pub tiers: Vec<Tier>,
    pub scenarios: Vec<ScenarioKind>,
    /// Sorted by average success, best first.
    pub rows: Vec<LeaderRow>,
    pub references: Vec<ReferenceRow>,
    pub reference_source: String,
}

fn leader_row(m: &ModelData, scenarios: &[ScenarioKind], tiers: &[Tier], resamples: usize, base: u64) -> LeaderRow {
    let us = units(&m.episodes, tiers);
    let tiers_key = tiers.iter().map(|t| t.to_string()).collect::<Vec<_>>().join(",");
    let mut cells = Vec::with_capacity(scenarios.len());
    for &s in scenarios {
        let su: Vec<&Unit> = us.iter().filter(|u| u.scenario == s).collect();
        if su.is_empty() {
            cells.push(None);
            continue;
        }
        let values: Vec<f64> = su.iter().map(|u| u.value()).collect();
        // One tier: the cell's own interval; several: the leaderboard's.
        let seed = (tiers.len() > 1).then(|| seed_for(base, &format!("leaderboard/{s}/{tiers_key}")));
        let eps: Vec<&Episode> = su.iter().flat_map(|u| &m.episodes[u.start..u.end]).collect();
        cells.push(Some(ScenarioCell {
            scenario: s,
            seeds: su.len(),
            episodes: eps.len(),
            success: seed.map_or_else(
                || cell_success_ci(&values, resamples, base, s.name(), tiers[0].number()),
                |seed| success_ci(&values, resamples, seed),
            ),
            decision_correctness: mean_of(&eps.iter().map(|e| &e.scalars).collect::<Vec<_>>(), |e| {
                e.decision_correctness
            }),
        }));
    }
    // Clusters: seeds, jointly across scenarios (and tiers).
    let mut clusters: BTreeMap<u64, Vec<(usize, f64)>> = BTreeMap::new();
    for u in &us {
        if let Some(g) = scenarios.iter().position(|&s| s == u.scenario) {
            clusters.entry(u.seed).or_default().push((g, u.value()));
        }
    }
    let clusters: Vec<Vec<(usize, f64)>> = clusters.into_values().collect();
    let average = clustered_mean_of_means_ci(
        &clusters,
        scenarios.len(),
        resamples,
        seed_for(base, &format!("average/{tiers_key}")),
    );
    let dc = DcValue(DcColumn::get().and_then(|column| {
        cells.iter().flatten().find(|c| c.scenario == column.scenario).map(|c| c.decision_correctness)
    }));
    let episodes = cells.iter().flatten().map(|c| c.episodes).sum();
    let absent: Vec<ScenarioKind> =
        scenarios.iter().zip(&cells).filter(|(_, c)| c.is_none()).map(|(s, _)| *s).collect();
    LeaderRow {
        model: m.label.clone(),
        average,
        incomplete: incompleteness(m, tiers, episodes, &absent),
        episodes,
        scenarios: cells,
        dc,
        rank: None,
    }
}

/// Why a model's scope is incomplete, e.g. "4 of 60 episodes finished (2
/// errored, 54 missing); no pedestrian_feint", or `None`.
fn incompleteness(m: &ModelData, tiers: &[Tier], finished: usize, absent: &[ScenarioKind]) -> Option<String> {
    let (errored, missing) = m.unfinished_in(tiers);
    let missing = missing.unwrap_or(0);
    let mut parts = Vec::new();
    if errored + missing > 0 {
        parts.push(format!(
            "{finished} of {} episodes finished ({errored} errored, {missing} missing)",
            finished + errored + missing
        ));
    }
    if !absent.is_empty() {
        parts.push(format!("no {}", absent.iter().map(|s| s.to_string()).collect::<Vec<_>>().join(", no ")));
    }
    (!parts.is_empty()).then(|| parts.join("; "))
}

/// The leaderboard; ranked by average success, best first. Incomplete
/// models are listed after the ranked ones, unranked, unless
/// `include_incomplete` (a partial sample is biased: the short episodes
/// finish first).
pub(crate) fn leaderboard(
    models: &[ModelData],
    refs: &References,
    tiers: &[Tier],
    resamples: usize,
    base: u64,
    include_incomplete: bool,
) -> Leaderboard {
    let scenarios: Vec<ScenarioKind> = ScenarioKind::ALL
        .into_iter()
        .filter(|&s| models.iter().any(|m| m.episodes.iter().any(|e| e.scenario == s && tiers.contains(&e.tier))))
        .collect();
    let mut rows = par_map(models, |m| leader_row(m, &scenarios, tiers, resamples, base));
    let ranked = |r: &LeaderRow| include_incomplete || r.incomplete.is_none();
    rows.sort_by(|a, b| {
        let key = |r: &LeaderRow| if r.average.estimate.is_finite() { r.average.estimate } else { f64::NEG_INFINITY };
        ranked(b).cmp(&ranked(a)).then(key(b).total_cmp(&key(a))).then_with(|| a.model.cmp(&b.model))
    });
    for (i, r) in rows.iter_mut().enumerate() {
        r.rank = ranked(r).then_some(i + 1);
    }
    let references = [(CEILING, "expert reference"), (FLOOR, "always_proceed floor")]
        .into_iter()
        .map(|(policy, label)| {
            let per: Vec<Option<f64>> = scenarios.iter().map(|&s| refs.success(policy, s, tiers)).collect();
            let known: Vec<f64> = per.iter().flatten().copied().collect();
            ReferenceRow {
                label: label.to_string(),
                policy: policy.to_string(),
                average: (known.len() == per.len() && !known.is_empty()).then(|| mean(&known)),
                scenarios: per,
                dc: DcValue(
                    DcColumn::get()
                        .filter(|column| scenarios.contains(&column.scenario))
                        .and_then(|column| refs.correctness(policy, column.scenario, tiers)),
                ),
            }
        })
        .collect();
    Leaderboard { tiers: tiers.to_vec(), scenarios, rows, references, reference_source: refs.source.clone() }
}

/// A row of the leaderboard's table: a model, or a reference level under
/// the models.
enum Ranked<'a> {
    Model(&'a LeaderRow),
    Reference(&'a ReferenceRow),
}

impl Leaderboard {
    pub(crate) fn title(&self) -> String {
        format!("Success rates ({}; 95% percentile bootstrap CIs)", tiers_label(&self.tiers))
    }

    /// Models, then the reference rows. The CSV adds each scenario's seeds
    /// (`{scenario}_n`), the row kind and the tiers.
    pub(crate) fn table(&self, resamples: usize) -> Table {
        let tiers = self.tiers.iter().map(|t| t.to_string()).collect::<Vec<_>>().join(" ");
        let level = |x: Option<f64>| x.map_or(Cell::Missing, Cell::estimate);
        let mut fields: Vec<Field<Ranked>> = vec![
            Field::new(Column::new("rank", "rank"), |r: &Ranked| match r {
                Ranked::Model(m) => m.rank.map_or(Cell::Missing, |k| Cell::Int(k as u64)),
                Ranked::Reference(_) => Cell::Blank,
            }),
            Field::new(Column::new("model", "model"), |r: &Ranked| match r {
                Ranked::Model(m) => Cell::text(&m.model),
                Ranked::Reference(x) => Cell::text(&x.label),
            }),
            Field::new(Column::data("kind"), |r: &Ranked| match r {
                Ranked::Model(_) => Cell::text("model"),
                Ranked::Reference(_) => Cell::text("reference"),
            }),
            Field::new(Column::new("avg. [95% CI]", "avg").style(Style::Interval), move |r: &Ranked| match r {
                Ranked::Model(m) => Cell::Interval(m.average),
                Ranked::Reference(x) => level(x.average),
            }),
        ];
        for (i, s) in self.scenarios.iter().enumerate() {
            let success = Column::new(format!("{s} [95% CI]"), s.to_string()).style(Style::Interval);
            fields.push(Field::new(success, move |r: &Ranked| match r {
                Ranked::Model(m) => m.scenarios[i].as_ref().map_or(Cell::Missing, |c| Cell::Interval(c.success)),
                Ranked::Reference(x) => level(x.scenarios[i]),
            }));
            fields.push(Field::new(Column::data(format!("{s}_n")), move |r: &Ranked| match r {
                Ranked::Model(m) => Cell::Int(m.scenarios[i].as_ref().map_or(0, |c| c.seeds as u64)),
                Ranked::Reference(_) => Cell::Blank,
            }));
        }
        let dc_column = DcColumn::get();
        fields.extend(dc_column.map(|c| {
            Field::new(Column::new(c.header(), c.key()), |r: &Ranked| match r {
                Ranked::Model(m) => Cell::opt(m.dc.0),
                Ranked::Reference(x) => Cell::opt(x.dc.0),
            })
        }));
        fields.extend([
            Field::new(Column::new("episodes", "episodes"), |r: &Ranked| match r {
                Ranked::Model(m) => Cell::Int(m.episodes as u64),
                Ranked::Reference(_) => Cell::Blank,
            }),
            Field::new(Column::data("tiers"), move |_: &Ranked| Cell::text(&tiers)),
            Field::new(Column::data("incomplete"), |r: &Ranked| match r {
                Ranked::Model(m) => m.incomplete.as_ref().map_or(Cell::Blank, Cell::text),
                Ranked::Reference(_) => Cell::Blank,
            }),
        ]);
        let rows: Vec<Ranked> =
            self.rows.iter().map(Ranked::Model).chain(self.references.iter().map(Ranked::Reference)).collect();
        let mut t = Table::of("leaderboard", self.title(), &fields, &rows);
        let dc_note = dc_column.map(|c| format!(" {}: decision correctness on {}.", c.term(), c.scenario));
        t.note(format!(
            "Per-scenario CIs resample seeds ({resamples} resamples); the average's CI resamples seeds jointly across \
             scenarios (clustered bootstrap).{} Reference rows: {}.",
            dc_note.unwrap_or_default(),
            self.reference_source
        ));
        for r in self.rows.iter().filter(|r| r.incomplete.is_some()) {
            t.note(format!(
                "{INCOMPLETE_MARK} {} is incomplete: {}; {}.",
                r.model,
                r.incomplete.as_deref().unwrap_or_default(),
                if r.rank.is_some() {
                    "ranked anyway (--include-incomplete)"
                } else {
                    "not ranked (a partial sample is biased: short episodes finish first; --include-incomplete ranks it)"
                }
            ));
        }
        let at_bound = |x: f64| x == 0.0 || x == 1.0;
        if self.rows.iter().any(|r| r.scenarios.iter().flatten().any(|c| at_bound(c.success.estimate))) {
            t.note(WILSON_NOTE);
        }
        if self.rows.iter().any(|r| r.scenarios.iter().any(Option::is_none)) {
            t.note(
                "'-': the model has no episode of that scenario in scope; its average is over the scenarios it has.",
            );
        }
        t
    }
}

// ---------------------------------------------------------------------------
// Per tier

/// One (model, scenario, tier): the cell's figures, as eval's summary has
/// them, and the reference policies' success on the same cell.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TierRow {
    pub model: String,
    pub scenario: ScenarioKind,
    pub tier: Tier,
    #[serde(flatten)]
    pub metrics: CellMetrics,
    pub expert: Option<f64>,
    pub floor: Option<f64>,
}

/// Every (model, scenario, tier) with episodes, models in `order`.
pub(crate) fn tier_rows(models: &[&ModelData], refs: &References, resamples: usize, base: u64) -> Vec<TierRow> {
    let cells: Vec<(&ModelData, ScenarioKind, Tier)> = models
        .iter()
        .flat_map(|m| ScenarioKind::ALL.into_iter().flat_map(move |s| Tier::ALL.into_iter().map(move |t| (*m, s, t))))
        .filter(|(m, s, t)| m.episodes.iter().any(|e| e.scenario == *s && e.tier == *t))
        .collect();
    par_map(&cells, |&(m, s, t)| {
        let eps: Vec<&EpisodeScalars> =
            m.episodes.iter().filter(|e| e.scenario == s && e.tier == t).map(|e| &e.scalars).collect();
        TierRow {
            model: m.label.clone(),
            scenario: s,
            tier: t,
            metrics: CellMetrics::of(&eps, s, t, resamples, base),
            expert: refs.success(CEILING, s, &[t]),
            floor: refs.success(FLOOR, s, &[t]),
        }
    })
}

pub(crate) fn tier_table(rows: &[TierRow]) -> Table {
    type R = TierRow;
    let fields: Vec<Field<R>> = [
        vec![
            Field::new(Column::new("model", "model"), |r: &R| Cell::text(&r.model)),
            Field::new(Column::new("scenario", "scenario"), |r: &R| Cell::text(r.scenario.to_string())),
            Field::new(Column::new("tier", "tier"), |r: &R| Cell::Int(r.tier.number().into())),
            Field::new(Column::data("seeds"), |r: &R| Cell::Int(r.metrics.seeds as u64)),
            Field::new(Column::new("n", "episodes"), |r: &R| Cell::Int(r.metrics.episodes as u64)),
        ],
        CellMetrics::outcome_fields("DC").into_iter().map(|f| f.of(|r: &R| &r.metrics)).collect(),
        vec![
            Field::new(Column::new("expert", "expert"), |r: &R| Cell::opt(r.expert)),
            Field::new(Column::new("floor", "always_proceed"), |r: &R| Cell::opt(r.floor)),
        ],
    ]
    .into_iter()
    .flatten()
    .collect();
    let title = "Per tier: success with 95% CI, outcome rates, reward and decision correctness";
    let mut t = Table::of("tiers", title, &fields, rows);
    t.note("n: episodes. DC: decision correctness. expert / floor: the reference policies' success on the same cell.");
    if rows.iter().any(|r| r.metrics.success.estimate == 0.0 || r.metrics.success.estimate == 1.0) {
        t.note(WILSON_NOTE);
    }
    t
}

// ---------------------------------------------------------------------------
// Outcome decomposition

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct OutcomeRow {
    pub model: String,
    pub scenario: ScenarioKind,
    pub episodes: usize,
    pub success_rate: f64,
    pub collision_rate: f64,
    pub timeout_rate: f64,
    pub decision_correctness: f64,
    pub mean_reward: f64,
}

pub(crate) fn outcome_rows(models: &[&ModelData], tiers: &[Tier]) -> Vec<OutcomeRow> {
    let mut out = Vec::new();
    for m in models {
        for s in ScenarioKind::ALL {
            let eps: Vec<&EpisodeScalars> =
                m.episodes.iter().filter(|e| e.scenario == s && tiers.contains(&e.tier)).map(|e| &e.scalars).collect();
            if eps.is_empty() {
                continue;
            }
            out.push(OutcomeRow {
                model: m.label.clone(),
                scenario: s,
                episodes: eps.len(),
                success_rate: outcome_rate(&eps, Outcome::Success),
                collision_rate: outcome_rate(&eps, Outcome::Collision),
                timeout_rate: outcome_rate(&eps, Outcome::Timeout),
                decision_correctness: mean_of(&eps, |e| e.decision_correctness),
                mean_reward: mean_of(&eps, |e| e.reward),
            });
        }
    }
    out
}

pub(crate) fn outcome_table(rows: &[OutcomeRow], tiers: &[Tier]) -> Table {
    type R = OutcomeRow;
    let rate = |header: &str, key: &str, value: fn(&R) -> f64| Field::float(Column::new(header, key), value);
    let fields: [Field<R>; 9] = [
        Field::new(Column::new("model", "model"), |r: &R| Cell::text(&r.model)),
        Field::new(Column::new("scenario", "scenario"), |r: &R| Cell::text(r.scenario.to_string())),
        Field::new(Column::new("n", "episodes"), |r: &R| Cell::Int(r.episodes as u64)),
        rate("success", "success_rate", |r| r.success_rate),
        rate("collision", "collision_rate", |r| r.collision_rate),
        rate("timeout", "timeout_rate", |r| r.timeout_rate),
        rate("DC", "decision_correctness", |r| r.decision_correctness),
        Field::new(Column::display("DC - success").style(Style::Signed), |r: &R| {
            Cell::Float(r.decision_correctness - r.success_rate)
        }),
        rate("reward", "mean_reward", |r| r.mean_reward),
    ];
    let mut t = Table::of("outcomes", format!("Outcome decomposition ({})", tiers_label(tiers)), &fields, rows);
    t.note("DC - success > 0: right calls that did not become successes (typically over-caution ending in a timeout).");
    t
}

// ---------------------------------------------------------------------------
// Errors and cost

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CostRow {
    pub model: String,
    pub runs: usize,
    pub episodes: usize,
    pub turns: u64,
    pub parse_error_turns: u64,
    pub parse_error_rate: f64,
    pub episodes_with_parse_errors: usize,
    /// Turns cut off by the completion-token limit (not parse errors).
    pub truncated_turns: u64,
    pub truncated_rate: f64,
    /// Errored: rollouts given up as infrastructure errors (errors.jsonl)
    /// and never finished.
    pub infra_errors: usize,
    /// Missing: episodes of the runs' selections neither finished nor
    /// errored (never started); `None` without run.json.
    pub missing: Option<usize>,
    pub retries: u64,
    pub tokens_per_episode: f64,
    pub prompt_tokens_per_episode: f64,
    pub completion_tokens_per_episode: f64,
    /// Share of the prompt tokens served from the provider's cache.
    pub cached_share: f64,
    /// Estimated USD of the episodes, as eval priced them; `None` when any
    /// episode has no known cost.
    pub cost_usd: Option<f64>,
    pub latency_s_per_episode: f64,
    pub latency_s_per_episode_p95: f64,
    pub latency_ms_per_turn: f64,
}

pub(crate) fn cost_rows(models: &[&ModelData]) -> Vec<CostRow> {
    models
        .iter()
        .map(|m| {
            let eps = &m.episodes;
            let turns: u64 = eps.iter().map(|e| u64::from(e.turns_taken)).sum();
            let bad: u64 = eps.iter().map(|e| u64::from(e.parse_error_turns)).sum();
            let cut: u64 = eps.iter().map(|e| u64::from(e.truncated_turns)).sum();
            let prompt: u64 = eps.iter().map(|e| e.prompt_tokens).sum();
            let per_ep = |f: &dyn Fn(&Episode) -> f64| mean(&eps.iter().map(f).collect::<Vec<_>>());
            let mut lat: Vec<f64> = eps.iter().map(|e| e.latency_ms as f64 / 1000.0).collect();
            lat.sort_unstable_by(f64::total_cmp);
            let latency_total: u64 = eps.iter().map(|e| e.latency_ms).sum();
            CostRow {
                model: m.label.clone(),
                runs: m.runs.len(),
                episodes: eps.len(),
                turns,
                parse_error_turns: bad,
                parse_error_rate: if turns == 0 { f64::NAN } else { bad as f64 / turns as f64 },
                episodes_with_parse_errors: eps.iter().filter(|e| e.parse_error_turns > 0).count(),
                truncated_turns: cut,
                truncated_rate: if turns == 0 { f64::NAN } else { cut as f64 / turns as f64 },
                infra_errors: m.errored.len(),
                missing: m.not_run.as_ref().map(Vec::len),
                retries: eps.iter().map(|e| u64::from(e.retries)).sum(),
                tokens_per_episode: per_ep(&|e| e.tokens as f64),
                prompt_tokens_per_episode: per_ep(&|e| e.prompt_tokens as f64),
                completion_tokens_per_episode: per_ep(&|e| e.completion_tokens as f64),
                cached_share: if prompt == 0 {
                    f64::NAN
                } else {
                    eps.iter().map(|e| e.cached_tokens).sum::<u64>() as f64 / prompt as f64
                },
                cost_usd: if eps.is_empty() { None } else { eps.iter().map(|e| e.cost_usd).sum() },
                latency_s_per_episode: per_ep(&|e| e.latency_ms as f64 / 1000.0),
                latency_s_per_episode_p95: quantile(&lat, 0.95),
                latency_ms_per_turn: if turns == 0 { f64::NAN } else { latency_total as f64 / turns as f64 },
            }
        })
        .collect()
}

/// Display: turns and latency with their rate and p95 in parentheses;
/// the CSV has every figure in its own column.
pub(crate) fn cost_table(rows: &[CostRow]) -> Table {
    type R = CostRow;
    let int = |column: Column, value: fn(&R) -> u64| Field::int(column, value);
    let float = |column: Column, value: fn(&R) -> f64| Field::float(column, value);
    // A count with its share of the turns, as displayed: "12 (3.4%)".
    let with_share = |header: &str, count: fn(&R) -> u64, rate: fn(&R) -> f64| {
        Field::new(Column::display(header), move |r: &R| {
            let share = 100.0 * if r.turns == 0 { 0.0 } else { rate(r) };
            Cell::WithParen(Box::new(Cell::Int(count(r))), Box::new(Cell::Percent(share)))
        })
    };
    let fields: [Field<R>; 25] = [
        Field::new(Column::new("model", "model"), |r: &R| Cell::text(&r.model)),
        int(Column::data("runs"), |r| r.runs as u64),
        int(Column::new("episodes", "episodes"), |r| r.episodes as u64),
        int(Column::data("turns"), |r| r.turns),
        with_share("parse-error turns", |r| r.parse_error_turns, |r| r.parse_error_rate),
        int(Column::data("parse_error_turns"), |r| r.parse_error_turns),
        float(Column::data("parse_error_rate"), |r| r.parse_error_rate),
        int(Column::new("episodes with parse errors", "episodes_with_parse_errors"), |r| {
            r.episodes_with_parse_errors as u64
        }),
        with_share("truncated turns", |r| r.truncated_turns, |r| r.truncated_rate),
        int(Column::data("truncated_turns"), |r| r.truncated_turns),
        float(Column::data("truncated_rate"), |r| r.truncated_rate),
        int(Column::new("errored", "infra_errors"), |r| r.infra_errors as u64),
        Field::new(Column::new("missing", "missing"), |r: &R| r.missing.map_or(Cell::Unknown, |m| Cell::Int(m as u64))),
        int(Column::new("retries", "retries"), |r| r.retries),
        float(Column::new("tokens/ep", "tokens_per_episode").style(Style::Whole), |r| r.tokens_per_episode),
        float(Column::data("prompt_tokens_per_episode"), |r| r.prompt_tokens_per_episode),
        float(Column::new("completion tokens/ep", "completion_tokens_per_episode").style(Style::Whole), |r| {
            r.completion_tokens_per_episode
        }),
        Field::new(Column::display("cached"), |r: &R| {
            if r.cached_share.is_finite() { Cell::Percent(100.0 * r.cached_share) } else { Cell::Missing }
        }),
        float(Column::data("cached_share"), |r| r.cached_share),
        Field::new(Column::display("cost (USD)"), |r: &R| Cell::text(crate::rundir::usd_or_unknown(r.cost_usd))),
        Field::new(Column::data("cost_usd"), |r: &R| r.cost_usd.map_or(Cell::Unknown, Cell::Float)),
        Field::new(Column::display("latency s/ep (p95)"), |r: &R| {
            Cell::WithParen(
                Box::new(Cell::Float(r.latency_s_per_episode)),
                Box::new(Cell::Float(r.latency_s_per_episode_p95)),
            )
        }),
        float(Column::data("latency_s_per_episode"), |r| r.latency_s_per_episode),
        float(Column::data("latency_s_per_episode_p95"), |r| r.latency_s_per_episode_p95),
        float(Column::new("ms/turn", "latency_ms_per_turn").style(Style::Whole), |r| r.latency_ms_per_turn),
    ];
    let mut t = Table::of("errors_cost", "Errors, tokens and latency (all episodes)", &fields, rows);
    t.note(
        "Parse errors are bad driving (the turn executed the conservative stop) and count in every score. errored: \
         requests failed after every retry (errors.jsonl); missing: never started (interrupted, budget). Both are \
         excluded from every score; re-running the eval command resumes them. Truncated turns were cut off by the \
         completion-token limit (counted apart from parse errors). Cached: share of the prompt tokens served from the \
         provider's prompt cache. Cost: eval's estimate at the prices of its prices file (run.json `pricing`); \
         unknown when a model has no price there.",
    );
    t
}
