//! The belief table of `report`: for runs made with `eval --probe belief`,
//! one row per (model, scenario, tier) with the belief metrics of
//! `belief`. Models without the probe have no row; a report with
//! no probe run has no belief table.

use super::load::ModelData;
use crate::belief::BeliefSummary;
use crate::export::{Cell, Column, Field, Style, Table};
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
    let fields: Vec<Field<BeliefRow>> = [
        vec![
            Field::new(Column::new("model", "model"), |r: &BeliefRow| Cell::text(r.model.clone())),
            Field::new(Column::new("scenario", "scenario").style(Style::Code), |r: &BeliefRow| {
                Cell::text(r.scenario.to_string())
            }),
            Field::new(Column::new("tier", "tier"), |r: &BeliefRow| Cell::Int(r.tier.number().into())),
            Field::new(Column::new("n", "episodes"), |r: &BeliefRow| Cell::Int(r.episodes as u64)),
        ],
        crate::belief::fields().into_iter().map(|f| f.of(|r: &BeliefRow| &r.belief)).collect(),
    ]
    .into_iter()
    .flatten()
    .collect();
    let mut t = Table::of("belief", "Belief probe", &fields, rows);
    t.note(crate::belief::TABLE_NOTE);
    t
}
