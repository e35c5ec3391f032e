//! The forecast table of `report`: for runs made with `eval --probe
//! forecast`, one row per (model, scenario, tier) with the forecast
//! metrics, and the reference forecasters' rows on the same cells (along
//! the expert's episodes, seeds 0-199, computed in-process: constant
//! velocity, the rules forecaster, the same future under both intents).
//! Models without the probe have no row; a report with no probe run has no
//! forecast table.

use super::load::ModelData;
use crate::baselines::{GridSpec, run_forecast_grid};
use crate::export::{Cell, Column, Field, Style, Table};
use crate::forecast::ForecastSummary;
use crate::policy::PolicyKind;
use crate::scenario::{ScenarioKind, ScenarioSet, Tier};
use serde::Serialize;

/// What marks a reference forecaster's row (the table's note says it).
const REFERENCE_MARK: &str = "*";

/// Episodes (seeds from 0) of the reference rows.
const REFERENCE_EPISODES: usize = 200;

#[derive(Debug, Clone, Serialize)]
pub struct ForecastRow {
    /// The model, or a reference forecaster's name and `*`.
    pub model: String,
    pub scenario: ScenarioKind,
    pub tier: Tier,
    /// Episodes with forecast metrics.
    pub episodes: usize,
    pub forecast: ForecastSummary,
}

/// Every (model, scenario, tier) cell with forecast metrics, in model
/// order, then scenario and tier order; then the references' rows on the
/// same cells.
pub(crate) fn rows(models: &[&ModelData]) -> Vec<ForecastRow> {
    let mut out = Vec::new();
    for m in models {
        for scenario in ScenarioKind::ALL {
            for tier in Tier::ALL {
                let metrics: Vec<_> = m
                    .episodes
                    .iter()
                    .filter(|e| e.scenario == scenario && e.tier == tier)
                    .filter_map(|e| e.forecast)
                    .collect();
                if !metrics.is_empty() {
                    out.push(ForecastRow {
                        model: m.label.clone(),
                        scenario,
                        tier,
                        episodes: metrics.len(),
                        forecast: ForecastSummary::of(metrics.iter()),
                    });
                }
            }
        }
    }
    let mut cells: Vec<(ScenarioKind, Tier)> = out.iter().map(|r| (r.scenario, r.tier)).collect();
    cells.sort();
    cells.dedup();
    out.extend(references(&cells));
    out
}

/// The reference forecasters' rows on `cells`.
fn references(cells: &[(ScenarioKind, Tier)]) -> Vec<ForecastRow> {
    let set = ScenarioSet::default();
    cells
        .iter()
        .flat_map(|&(scenario, tier)| {
            let spec = GridSpec {
                scenarios: vec![scenario],
                tiers: vec![tier],
                policies: vec![PolicyKind::Expert],
                episodes: REFERENCE_EPISODES,
                seed_base: 0,
            };
            run_forecast_grid(&set, &spec).into_iter().map(move |r| ForecastRow {
                model: format!("{}{REFERENCE_MARK}", r.reference),
                scenario,
                tier,
                episodes: r.n,
                forecast: r.forecast,
            })
        })
        .collect()
}

pub(crate) fn table(rows: &[ForecastRow]) -> Table {
    let fields: Vec<Field<ForecastRow>> = [
        vec![
            Field::new(Column::new("model", "model"), |r: &ForecastRow| Cell::text(r.model.clone())),
            Field::new(Column::new("scenario", "scenario").style(Style::Code), |r: &ForecastRow| {
                Cell::text(r.scenario.to_string())
            }),
            Field::new(Column::new("tier", "tier"), |r: &ForecastRow| Cell::Int(r.tier.number().into())),
            Field::new(Column::new("n", "episodes"), |r: &ForecastRow| Cell::Int(r.episodes as u64)),
        ],
        crate::forecast::metrics::fields().into_iter().map(|f| f.of(|r: &ForecastRow| &r.forecast)).collect(),
    ]
    .into_iter()
    .flatten()
    .collect();
    let mut t = Table::of("forecast", "Forecast probe", &fields, rows);
    t.note(format!(
        "{} {REFERENCE_MARK}: a reference forecaster, along the expert's episodes (seeds 0-{}).",
        crate::forecast::metrics::TABLE_NOTE,
        REFERENCE_EPISODES - 1
    ));
    t
}
