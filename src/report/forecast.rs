//! The forecast table of `report`: for runs made with `eval --probe
//! forecast`, one row per (model, scenario, tier) with the forecast
//! metrics, and the reference forecasters' rows on the same cells (along
//! the expert's episodes, seeds 0-199, computed in-process: constant
//! velocity, the rules forecaster, the same future under both intents).
//! Models without the probe have no row; a report with no probe run has no
//! forecast table.

use super::load::ModelData;
use super::probe_rows::ProbeRow;
use crate::baselines::{GridSpec, run_forecast_grid};
use crate::export::Table;
use crate::metrics::ForecastProbe;
use crate::policy::PolicyKind;
use crate::scenario::{ScenarioKind, ScenarioSet, Tier};

/// What marks a reference forecaster's row (the table's note says it).
const REFERENCE_MARK: &str = "*";

/// Episodes (seeds from 0) of the reference rows.
const REFERENCE_EPISODES: usize = 200;

/// A row of the forecast table: a model's, or a reference forecaster's.
pub type ForecastRow = ProbeRow<ForecastProbe>;

/// Every (model, scenario, tier) cell with forecast metrics, then the
/// references' rows on the same cells.
pub(crate) fn rows(models: &[&ModelData]) -> Vec<ForecastRow> {
    let mut out = super::probe_rows::rows::<ForecastProbe>(models);
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
                summary: r.forecast,
            })
        })
        .collect()
}

/// The forecast table, its note saying what marks a reference's row.
pub(crate) fn table(rows: &[ForecastRow]) -> Table {
    let more = format!(
        "{REFERENCE_MARK}: a reference forecaster, along the expert's episodes (seeds 0-{}).",
        REFERENCE_EPISODES - 1
    );
    super::probe_rows::table(rows, Some(&more))
}
