//! pass^k for runs with several rollouts per seed (`eval -r R`, R > 1):
//! the mean over seeds of C(c, k) / C(R, k), c the seed's successes among
//! its R rollouts (`crate::stats::mean_pass_hat_k`) — the chance that k
//! rollouts drawn from the seed's all succeed. Only seeds with all R
//! rollouts count; the others are excluded and their number shown.

use super::load::ModelData;
use super::tables::{tiers_label, units};
use crate::export::{Cell, Column, Field, Table};
use crate::scenario::{ScenarioKind, Tier};
use crate::stats::mean_pass_hat_k;
use serde::Serialize;

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PassKRow {
    pub model: String,
    /// A scenario name, or "all".
    pub scope: String,
    /// Rollouts per seed.
    pub r: u32,
    /// Seeds with all r rollouts (used).
    pub seeds: usize,
    /// Seeds with fewer than r rollouts (excluded).
    pub excluded: usize,
    /// pass^k for k = 1 ..= r.
    pub pass: Vec<f64>,
}

/// Rows for every model with r > 1: all scenarios, then each scenario.
pub(crate) fn pass_k_rows(models: &[&ModelData], tiers: &[Tier]) -> Vec<PassKRow> {
    let mut out = Vec::new();
    for m in models.iter().filter(|m| m.rollouts > 1) {
        let r = m.rollouts;
        let us = units(&m.episodes, tiers);
        let scopes: Vec<Option<ScenarioKind>> = std::iter::once(None)
            .chain(ScenarioKind::ALL.into_iter().filter(|s| us.iter().any(|u| u.scenario == *s)).map(Some))
            .collect();
        for scope in scopes {
            let chosen: Vec<_> = us.iter().filter(|u| scope.is_none_or(|s| u.scenario == s)).collect();
            let full: Vec<(usize, usize)> =
                chosen.iter().filter(|u| u.rollouts() == r).map(|u| (u.successes as usize, r as usize)).collect();
            out.push(PassKRow {
                model: m.label.clone(),
                scope: scope.map_or("all".into(), |s| s.to_string()),
                r,
                seeds: full.len(),
                excluded: chosen.len() - full.len(),
                pass: (1..=r as usize).map(|k| mean_pass_hat_k(&full, k)).collect(),
            });
        }
    }
    out
}

pub(crate) fn pass_k_table(rows: &[PassKRow], tiers: &[Tier]) -> Table {
    let max_r = rows.iter().map(|r| r.r).max().unwrap_or(1) as usize;
    type R = PassKRow;
    let mut fields: Vec<Field<R>> = vec![
        Field::new(Column::new("model", "model"), |r: &R| Cell::text(&r.model)),
        Field::new(Column::new("scenario", "scenario"), |r: &R| Cell::text(&r.scope)),
        Field::new(Column::new("r", "r"), |r: &R| Cell::Int(r.r.into())),
        Field::new(Column::new("seeds used", "seeds"), |r: &R| Cell::Int(r.seeds as u64)),
        Field::new(Column::new("seeds excluded", "excluded"), |r: &R| Cell::Int(r.excluded as u64)),
    ];
    fields.extend((1..=max_r).map(|k| {
        Field::new(Column::new(format!("pass^{k}"), format!("pass_{k}")), move |r: &R| {
            r.pass.get(k - 1).map_or(Cell::Blank, |&p| Cell::Float(p))
        })
    }));
    let title = format!("pass^k over seeds with all r rollouts ({})", tiers_label(tiers));
    let mut t = Table::of("pass_k", title, &fields, rows);
    t.note(
        "pass^k = mean over seeds of C(c, k) / C(r, k), c successes among the seed's r rollouts: the chance that k \
         rollouts of one seed all succeed. Seeds missing a rollout are excluded (counted above).",
    );
    t
}
