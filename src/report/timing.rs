//! Evidence timing per (model, scenario) over the leaderboard scope: the
//! guess rate (share of the episodes with a commitment whose commitment
//! turn came before the evidence turn, or had no evidence at all) and the
//! evidence-to-commitment lag in turns (mean over the episodes that
//! committed at or after the evidence), with the expert's as reference
//! (from the baseline table, averaged over the scope's tiers like its
//! success). Success beside them shows which models win by luck.

use super::load::ModelData;
use super::reference::{CEILING, References};
use crate::episode::{evidence_lag, guess_rate};
use crate::export::{Cell, Column, Field, Style, Table};
use crate::scenario::{ScenarioKind, Tier};
use crate::stats::{Interval, wilson_ci};
use serde::Serialize;

#[derive(Debug, Clone, Serialize)]
pub struct TimingRow {
    pub model: String,
    pub scenario: ScenarioKind,
    /// Episodes in scope.
    pub episodes: usize,
    /// Episodes with a commitment (the guess rate's denominator).
    pub committed: usize,
    /// Committed before the evidence (or without any).
    pub guesses: usize,
    /// Wilson 95% interval over the committed episodes; NaN when none.
    pub guess_rate: Interval,
    /// Mean turns from evidence to commitment; NaN when no episode
    /// committed at or after the evidence.
    pub evidence_lag: f64,
    /// Share of the episodes in scope that succeeded.
    pub success: f64,
    pub expert_guess_rate: Option<f64>,
    pub expert_evidence_lag: Option<f64>,
}

/// One row per (model, scenario) with a timed episode in `tiers`, models in the
/// given order, scenarios in their canonical order.
pub(crate) fn rows(models: &[&ModelData], refs: &References, tiers: &[Tier]) -> Vec<TimingRow> {
    let mut out = Vec::new();
    for m in models {
        for scenario in ScenarioKind::ALL {
            let eps: Vec<_> = m.episodes.iter().filter(|e| e.scenario == scenario && tiers.contains(&e.tier)).collect();
            // Runs written before evidence timing was recorded (schema < 2)
            // have neither turn on any line: no row rather than a row of
            // zeros.
            if eps.iter().all(|e| e.timing.evidence_turn.is_none() && e.timing.commitment_turn.is_none()) {
                continue;
            }
            let guessed: Vec<bool> = eps.iter().filter_map(|e| e.timing.guessed()).collect();
            let guesses = guessed.iter().filter(|g| **g).count();
            let mut rate = wilson_ci(guesses as f64, guessed.len() as f64);
            rate.estimate = guess_rate(eps.iter().map(|e| e.timing));
            out.push(TimingRow {
                model: m.label.clone(),
                scenario,
                episodes: eps.len(),
                committed: guessed.len(),
                guesses,
                guess_rate: rate,
                evidence_lag: evidence_lag(eps.iter().map(|e| e.timing)),
                success: eps.iter().filter(|e| e.success()).count() as f64 / eps.len() as f64,
                expert_guess_rate: refs.guess_rate(CEILING, scenario, tiers),
                expert_evidence_lag: refs.evidence_lag(CEILING, scenario, tiers),
            });
        }
    }
    out
}

fn finite(x: f64) -> Cell {
    if x.is_finite() { Cell::Float(x) } else { Cell::Missing }
}

pub(crate) fn table(rows: &[TimingRow], tiers: &[Tier]) -> Table {
    type R = TimingRow;
    let fields: [Field<R>; 9] = [
        Field::new(Column::new("model", "model"), |r: &R| Cell::text(r.model.clone())),
        Field::new(Column::new("scenario", "scenario").style(Style::Code), |r: &R| Cell::text(r.scenario.to_string())),
        Field::new(Column::new("episodes", "episodes"), |r: &R| Cell::Int(r.episodes as u64)),
        Field::new(Column::new("committed", "committed"), |r: &R| Cell::Int(r.committed as u64)),
        Field::new(Column::new("guess rate", "guess_rate").style(Style::Interval), |r: &R| {
            if r.committed == 0 { Cell::Missing } else { Cell::Interval(r.guess_rate) }
        }),
        Field::new(Column::new("expert guess", "expert_guess_rate"), |r: &R| Cell::opt(r.expert_guess_rate)),
        Field::new(Column::new("lag (turns)", "evidence_lag"), |r: &R| finite(r.evidence_lag)),
        Field::new(Column::new("expert lag", "expert_evidence_lag"), |r: &R| Cell::opt(r.expert_evidence_lag)),
        Field::new(Column::new("success", "success"), |r: &R| Cell::Float(r.success)),
    ];
    let title = format!("Evidence timing ({})", super::tables::tiers_label(tiers));
    let mut t = Table::of("timing", title, &fields, rows);
    t.note(
        "Guess rate: share of the episodes with a commitment whose commitment \
         turn came before the evidence turn, or that had no evidence; 95% Wilson interval. Lag: mean turns from the \
         evidence to the commitment over the others. Expert: the baseline table's expert, averaged over the tiers. \
         A high success with a high guess rate is luck.",
    );
    t
}
