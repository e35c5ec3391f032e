//! Text against picture: when a report holds one model id under two
//! observations (`eval --observation text|image|both`), a paired comparison
//! per (scenario, tier) cell on the seeds both have: the same episodes,
//! seed for seed, read from the text and from the picture.
//!
//! Per cell and pair: success and decision correctness under each
//! observation (on the lowest rollout index both have for a seed, so the
//! pairs stay independent), success's 95% Wilson intervals, and the exact
//! two-sided McNemar test on the discordant seeds (one observation
//! succeeded, the other failed), with the verdict rule of the paired
//! table: a difference only when McNemar p < 0.05.

use super::load::{Episode, ModelData};
use super::paired::{ALPHA, FEW_DISCORDANT};
use crate::export::{Cell, Column, Field, Style, Table};
use crate::rundir::ObservationMode;
use crate::scenario::{ScenarioKind, Tier};
use crate::stats::{Interval, mcnemar_exact, wilson_ci};
use serde::Serialize;

/// One model, two observations, one cell.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ObservationRow {
    /// The model id.
    pub model: String,
    /// The two runs' labels (as in the leaderboard).
    pub label_a: String,
    pub label_b: String,
    pub a: ObservationMode,
    pub b: ObservationMode,
    pub scenario: ScenarioKind,
    pub tier: Tier,
    /// Seeds both runs finished.
    pub seeds: usize,
    pub success_a: Interval,
    pub success_b: Interval,
    pub correctness_a: f64,
    pub correctness_b: f64,
    /// Seeds where A succeeded and B failed, and the reverse.
    pub a_only: usize,
    pub b_only: usize,
    pub mcnemar_p: f64,
    pub verdict: String,
}

/// Every (model, pair of observations, cell) with shared seeds, models in
/// the order given (leaderboard order), observations text, image, both.
pub(crate) fn rows(models: &[&ModelData], tiers: &[Tier]) -> Vec<ObservationRow> {
    let mut out = Vec::new();
    for (i, a) in models.iter().enumerate() {
        for b in &models[i + 1..] {
            if a.model != b.model || a.observation == b.observation {
                continue;
            }
            let (a, b) = if (a.observation as u8) < (b.observation as u8) { (a, b) } else { (b, a) };
            for scenario in ScenarioKind::ALL {
                for &tier in tiers {
                    if let Some(row) = cell(a, b, scenario, tier) {
                        out.push(row);
                    }
                }
            }
        }
    }
    out
}

/// The first rollout of each seed of a cell, by seed.
fn first_rollouts(m: &ModelData, scenario: ScenarioKind, tier: Tier) -> std::collections::BTreeMap<u64, &Episode> {
    let mut by_seed = std::collections::BTreeMap::new();
    for e in m.episodes.iter().filter(|e| e.scenario == scenario && e.tier == tier) {
        by_seed
            .entry(e.seed)
            .and_modify(|k: &mut &Episode| {
                if e.rollout < k.rollout {
                    *k = e
                }
            })
            .or_insert(e);
    }
    by_seed
}

fn cell(a: &ModelData, b: &ModelData, scenario: ScenarioKind, tier: Tier) -> Option<ObservationRow> {
    let (ea, eb) = (first_rollouts(a, scenario, tier), first_rollouts(b, scenario, tier));
    let shared: Vec<(&Episode, &Episode)> = ea.iter().filter_map(|(s, x)| eb.get(s).map(|y| (*x, *y))).collect();
    if shared.is_empty() {
        return None;
    }
    let n = shared.len();
    let count = |f: &dyn Fn(&(&Episode, &Episode)) -> bool| shared.iter().filter(|p| f(p)).count();
    let (wins_a, wins_b) = (count(&|(x, _)| x.success()), count(&|(_, y)| y.success()));
    let a_only = count(&|(x, y)| x.success() && !y.success());
    let b_only = count(&|(x, y)| !x.success() && y.success());
    let mean = |f: &dyn Fn(&(&Episode, &Episode)) -> f64| shared.iter().map(f).sum::<f64>() / n as f64;
    let mcnemar_p = mcnemar_exact(a_only, b_only);
    let few =
        if a_only + b_only < FEW_DISCORDANT { format!(", only {} discordant", a_only + b_only) } else { String::new() };
    let verdict = match (mcnemar_p < ALPHA, wins_a.cmp(&wins_b)) {
        (true, std::cmp::Ordering::Greater) => format!("{} better{few}", a.observation),
        (true, std::cmp::Ordering::Less) => format!("{} better{few}", b.observation),
        _ => format!("no significant difference{few}"),
    };
    Some(ObservationRow {
        model: a.model.clone(),
        label_a: a.label.clone(),
        label_b: b.label.clone(),
        a: a.observation,
        b: b.observation,
        scenario,
        tier,
        seeds: n,
        success_a: wilson_ci(wins_a as f64, n as f64),
        success_b: wilson_ci(wins_b as f64, n as f64),
        correctness_a: mean(&|(x, _)| x.decision_correctness),
        correctness_b: mean(&|(_, y)| y.decision_correctness),
        a_only,
        b_only,
        mcnemar_p,
        verdict,
    })
}

pub(crate) fn table(rows: &[ObservationRow]) -> Table {
    type R = ObservationRow;
    let fields: Vec<Field<R>> = vec![
        Field::new(Column::new("model", "model"), |r: &R| Cell::text(&r.model)),
        Field::new(Column::new("A", "a"), |r: &R| Cell::text(r.a.name())),
        Field::new(Column::new("B", "b"), |r: &R| Cell::text(r.b.name())),
        Field::new(Column::new("scenario", "scenario"), |r: &R| Cell::text(r.scenario.name())),
        Field::new(Column::new("tier", "tier"), |r: &R| Cell::Int(r.tier.number().into())),
        Field::int(Column::new("shared seeds", "seeds"), |r: &R| r.seeds as u64),
        Field::interval(Column::new("success A [95% CI]", "success_a").style(Style::Interval), |r: &R| r.success_a),
        Field::interval(Column::new("success B [95% CI]", "success_b").style(Style::Interval), |r: &R| r.success_b),
        Field::float(Column::new("correctness A", "correctness_a"), |r: &R| r.correctness_a),
        Field::float(Column::new("correctness B", "correctness_b"), |r: &R| r.correctness_b),
        Field::int(Column::new("A only", "a_only"), |r: &R| r.a_only as u64),
        Field::int(Column::new("B only", "b_only"), |r: &R| r.b_only as u64),
        Field::new(Column::new("McNemar p", "mcnemar_p").style(Style::PValue), |r: &R| Cell::Float(r.mcnemar_p)),
        Field::new(Column::new("verdict", "verdict"), |r: &R| Cell::text(&r.verdict)),
    ];
    let mut t = Table::of("observations", "Text against picture, paired on shared seeds", &fields, rows);
    t.note(format!(
        "One model id under two observations (eval --observation): per (scenario, tier), the seeds both runs \
         finished, each seed's lowest shared rollout. Success with 95% Wilson intervals; correctness: mean decision \
         correctness. A only / B only: seeds one observation won and the other lost, for the exact McNemar test; a \
         difference is named only when p < {ALPHA}; fewer than {FEW_DISCORDANT} discordant seeds are flagged."
    ));
    t
}
