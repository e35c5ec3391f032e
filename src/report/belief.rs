//! The belief table of `report`: for runs made with `eval --probe belief`,
//! one row per (model, scenario, tier) with the belief metrics of
//! `belief`. Models without the probe have no row; a report with
//! no probe run has no belief table.

use super::load::ModelData;
use crate::belief::BeliefSummary;
use crate::export::{Cell, Column, Style, Table};
use crate::scenario::{ScenarioKind, Tier};
use serde::Serialize;

#[derive(Debug, Clone, Serialize)]
pub struct BeliefRow {
    pub model: String,
    pub scenario: ScenarioKind,
    pub tier: Tier,
    /// Episodes with belief metrics.
    pub episodes: usize,
    pub belief: BeliefSummary,
}

/// Every (model, scenario, tier) cell with belief metrics, in model order,
/// then scenario and tier order.
pub(crate) fn rows(models: &[&ModelData]) -> Vec<BeliefRow> {
    let mut out = Vec::new();
    for m in models {
        for scenario in ScenarioKind::ALL {
            for tier in Tier::ALL {
                let metrics: Vec<_> = m
                    .episodes
                    .iter()
                    .filter(|e| e.scenario == scenario && e.tier == tier)
                    .filter_map(|e| e.belief)
                    .collect();
                if !metrics.is_empty() {
                    out.push(BeliefRow {
                        model: m.label.clone(),
                        scenario,
                        tier,
                        episodes: metrics.len(),
                        belief: BeliefSummary::of(metrics.iter()),
                    });
                }
            }
        }
    }
    out
}

/// The metrics of every belief episode of one model, pooled over its cells
/// (for the reliability diagram).
pub(crate) fn pooled(model: &ModelData) -> Option<BeliefSummary> {
    let metrics: Vec<_> = model.episodes.iter().filter_map(|e| e.belief).collect();
    (!metrics.is_empty()).then(|| BeliefSummary::of(metrics.iter()))
}

pub(crate) fn table(rows: &[BeliefRow]) -> Table {
    let mut columns = vec![
        Column::new("model", "model"),
        Column::new("scenario", "scenario").style(Style::Code),
        Column::new("tier", "tier"),
        Column::new("n", "episodes"),
    ];
    columns.extend(crate::belief::columns());
    let mut t = Table::new("belief", "Belief probe", columns);
    for r in rows {
        let mut row = vec![
            Cell::text(r.model.clone()),
            Cell::text(r.scenario.to_string()),
            Cell::Int(r.tier.number().into()),
            Cell::Int(r.episodes as u64),
        ];
        row.extend(crate::belief::cells(&r.belief));
        t.push(row);
    }
    t.note(crate::belief::TABLE_NOTE);
    t
}
