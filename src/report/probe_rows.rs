//! The probe tables of `report`, shared by the belief and the forecast
//! probe: for runs made with `eval --probe`, one row per (model, scenario,
//! tier) with the probe's metrics. Models without the probe have no row; a
//! report with no probe run has no table. Each probe gives only its own
//! columns ([`ProbeMetrics`]).

use super::load::ModelData;
use crate::export::{Cell, Column, Field, Style, Table};
use crate::metrics::{ProbeColumns, ProbeMetrics};
use crate::scenario::{ScenarioKind, Tier};
use serde::ser::{Serialize, SerializeStruct, Serializer};

/// One (model, scenario, tier) cell of a probe table.
#[derive(Debug, Clone)]
pub struct ProbeRow<P: ProbeMetrics> {
    /// The model (or, for the forecast, a reference forecaster's name and
    /// its mark).
    pub model: String,
    pub scenario: ScenarioKind,
    pub tier: Tier,
    /// Episodes with the probe's metrics.
    pub episodes: usize,
    pub summary: P::Summary,
}

/// As `report.json` has always written it: the summary under the probe's
/// own key (`"belief"`, `"forecast"`).
impl<P: ProbeMetrics> Serialize for ProbeRow<P> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut row = serializer.serialize_struct("ProbeRow", 5)?;
        row.serialize_field("model", &self.model)?;
        row.serialize_field("scenario", &self.scenario)?;
        row.serialize_field("tier", &self.tier)?;
        row.serialize_field("episodes", &self.episodes)?;
        row.serialize_field(P::KEY, &self.summary)?;
        row.end()
    }
}

/// Every (model, scenario, tier) cell with the probe's metrics, in model
/// order, then scenario and tier order.
pub(crate) fn rows<P: ProbeMetrics>(models: &[&ModelData]) -> Vec<ProbeRow<P>> {
    let mut out = Vec::new();
    for m in models {
        for scenario in ScenarioKind::ALL {
            for tier in Tier::ALL {
                let metrics: Vec<P::Episode> = m
                    .episodes
                    .iter()
                    .filter(|e| e.scenario == scenario && e.tier == tier)
                    .filter_map(|e| P::of_episode(e))
                    .collect();
                if !metrics.is_empty() {
                    out.push(ProbeRow {
                        model: m.label.clone(),
                        scenario,
                        tier,
                        episodes: metrics.len(),
                        summary: P::pool(&metrics),
                    });
                }
            }
        }
    }
    out
}

/// The metrics of every probed episode of one model, pooled over its cells.
pub(crate) fn pooled<P: ProbeMetrics>(model: &ModelData) -> Option<P::Summary> {
    let metrics: Vec<P::Episode> = model.episodes.iter().filter_map(|e| P::of_episode(e)).collect();
    (!metrics.is_empty()).then(|| P::pool(&metrics))
}

/// The probe's table: the row's key columns, then the probe's own; its
/// note, then `more` (if any).
pub(crate) fn table<P: ProbeColumns>(rows: &[ProbeRow<P>], more: Option<&str>) -> Table {
    let fields: Vec<Field<ProbeRow<P>>> = [
        vec![
            Field::new(Column::new("model", "model"), |r: &ProbeRow<P>| Cell::text(r.model.clone())),
            Field::new(Column::new("scenario", "scenario").style(Style::Code), |r: &ProbeRow<P>| {
                Cell::text(r.scenario.to_string())
            }),
            Field::new(Column::new("tier", "tier"), |r: &ProbeRow<P>| Cell::Int(r.tier.number().into())),
            Field::new(Column::new("n", "episodes"), |r: &ProbeRow<P>| Cell::Int(r.episodes as u64)),
        ],
        P::fields().into_iter().map(|f| f.of(|r: &ProbeRow<P>| &r.summary)).collect(),
    ]
    .into_iter()
    .flatten()
    .collect();
    let mut t = Table::of(P::KEY, P::TITLE, &fields, rows);
    t.note(match more {
        Some(more) => format!("{} {more}", P::NOTE),
        None => P::NOTE.to_string(),
    });
    t
}
