//! The forecast probe's scores: one episode's ([`ForecastMetrics`], in the
//! record next to the grades) and a cell's ([`ForecastSummary`]).
//!
//! A forecast made at a decision is scored at each horizon that the
//! episode reached (a turn whose horizon passes the episode's end is not
//! scored), per road user:
//! - under the true intent, against where the road user really was;
//! - under the other intent, against where it was in the twin world under
//!   the other disposition, driven by the same ego;
//! - the constant-velocity forecast from the same observation, on the same
//!   points, is the floor the skill is measured against (1 - error / its
//!   error);
//! - before the evidence turn, the separation: how far apart the forecast
//!   puts the two intents at 2 s, against how far apart the two worlds
//!   really were.

use super::{AtHorizons, Forecast, HORIZONS_S};
use crate::episode::ForecastTruth;
use crate::scenario::ScenarioKind;
use serde::{Deserialize, Serialize};

/// The decisions from the evidence turn that the error-by-turn figure
/// shows (the ends gather every earlier and later one).
pub const OFFSETS: std::ops::RangeInclusive<i32> = -4..=6;
const OFFSET_BINS: usize = 11;

/// One decision offset from the evidence turn: the 1 s forecasts made then,
/// summed (episodes with an evidence turn only).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct OffsetSums {
    pub points: u32,
    pub error_true_sum_m: f64,
    pub error_other_sum_m: f64,
    pub cv_error_true_sum_m: f64,
}

/// The bin of a decision `offset` turns from the evidence turn.
fn offset_bin(offset: i64) -> usize {
    let (lo, hi) = (i64::from(*OFFSETS.start()), i64::from(*OFFSETS.end()));
    (offset.clamp(lo, hi) - lo) as usize
}

/// A mean error below this (m) is no error: floating point's.
const NO_ERROR_M: f64 = 1e-9;

/// One decision as the forecast metrics see it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ForecastTurn {
    pub turn: u32,
    pub time_s: f64,
    /// The forecast stated (None: missing or malformed, a probe parse
    /// error).
    pub forecast: Option<Forecast>,
    /// The constant-velocity forecast from the same observation.
    pub constant_velocity: Vec<AtHorizons>,
}

/// One episode's forecast scores: sums over the scored points (a decision
/// and a road user, per horizon), so that cells pool them exactly.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct ForecastMetrics {
    /// Decisions with a readable forecast, and without one.
    pub stated_turns: u32,
    pub probe_errors: u32,
    /// Scored points per horizon (1 s, 2 s).
    pub points: [u32; 2],
    /// Absolute errors (m), summed over the points: the forecast under the
    /// true intent and under the other, and the constant-velocity
    /// forecast against each.
    pub error_true_sum_m: [f64; 2],
    pub error_other_sum_m: [f64; 2],
    pub cv_error_true_sum_m: [f64; 2],
    pub cv_error_other_sum_m: [f64; 2],
    /// Before the evidence turn, per road user with a 2 s truth: how far
    /// apart the forecast put the two intents at 2 s, and how far apart
    /// the two worlds were (m), summed; `separation_points` counts them.
    pub separation_points: u32,
    pub separation_stated_sum_m: f64,
    pub separation_real_sum_m: f64,
    /// The 1 s errors by the decision's offset from the evidence turn
    /// ([`OFFSETS`]; the error-by-turn figure).
    #[serde(default)]
    pub by_offset: [OffsetSums; OFFSET_BINS],
}

/// Decisions between two forecast truths a horizon apart.
fn decisions_ahead(horizon_s: f64) -> usize {
    (horizon_s / crate::observation::HISTORY_SPACING_S).round() as usize
}

impl ForecastMetrics {
    /// Score one episode: `truths` from [`crate::episode::Episode::forecast_truth`],
    /// `lets_you_go` the truth of the hidden disposition, `evidence_turn`
    /// the first turn whose observation told the dispositions apart.
    pub fn compute(
        kind: ScenarioKind,
        turns: &[ForecastTurn],
        truths: &[ForecastTruth],
        lets_you_go: bool,
        evidence_turn: Option<u32>,
    ) -> ForecastMetrics {
        let relative = kind.def().tracks_relative_to_ego;
        let at = |time_s: f64| truths.iter().position(|t| (t.time_s - time_s).abs() < 1e-6);
        let mut m = ForecastMetrics::default();
        for turn in turns {
            match &turn.forecast {
                Some(_) => m.stated_turns += 1,
                None => m.probe_errors += 1,
            }
            let Some(f) = turn.forecast.as_ref() else { continue };
            let Some(i) = at(turn.time_s) else { continue };
            let now = &truths[i];
            let before_evidence = evidence_turn.is_none_or(|e| turn.turn < e);
            for (k, &h) in HORIZONS_S.iter().enumerate() {
                let Some(then) = truths.get(i + decisions_ahead(h)) else { continue };
                if (then.time_s - (turn.time_s + h)).abs() > 1e-6 {
                    continue;
                }
                // In the decision's frame where positions move with the ego.
                let shift = if relative { then.ego_travel_m - now.ego_travel_m } else { 0.0 };
                let roads = then.actual.len().min(then.other.len()).min(turn.constant_velocity.len());
                for r in 0..roads {
                    let (real_true, real_other) = (then.actual[r] + shift, then.other[r] + shift);
                    let (Some(said_true), Some(said_other)) =
                        (f.under(lets_you_go).get(r), f.under(!lets_you_go).get(r))
                    else {
                        continue;
                    };
                    let cv = turn.constant_velocity[r][k];
                    m.points[k] += 1;
                    m.error_true_sum_m[k] += (said_true[k] - real_true).abs();
                    m.error_other_sum_m[k] += (said_other[k] - real_other).abs();
                    m.cv_error_true_sum_m[k] += (cv - real_true).abs();
                    m.cv_error_other_sum_m[k] += (cv - real_other).abs();
                    if let (Some(e), 0) = (evidence_turn, k) {
                        let bin = &mut m.by_offset[offset_bin(i64::from(turn.turn) - i64::from(e))];
                        bin.points += 1;
                        bin.error_true_sum_m += (said_true[k] - real_true).abs();
                        bin.error_other_sum_m += (said_other[k] - real_other).abs();
                        bin.cv_error_true_sum_m += (cv - real_true).abs();
                    }
                    if before_evidence && k == HORIZONS_S.len() - 1 {
                        m.separation_points += 1;
                        m.separation_stated_sum_m += (f.lets_you_go[r][k] - f.does_not[r][k]).abs();
                        m.separation_real_sum_m += (real_true - real_other).abs();
                    }
                }
            }
        }
        m
    }
}

/// A cell's forecast scores, pooled over its episodes' points.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ForecastSummary {
    /// Scored points per horizon.
    pub points: [u64; 2],
    /// Mean absolute error (m) per horizon, under the true intent and the
    /// other, and the constant-velocity forecast's on the same points.
    pub error_true_m: [f64; 2],
    pub error_other_m: [f64; 2],
    pub cv_error_true_m: [f64; 2],
    pub cv_error_other_m: [f64; 2],
    /// 1 - error / constant-velocity error, per horizon (NaN when the
    /// constant-velocity error is 0).
    pub skill_true: [f64; 2],
    pub skill_other: [f64; 2],
    /// Before the evidence: the mean separation the forecasts put between
    /// the intents at 2 s, and the worlds' own (m).
    pub separation_stated_m: f64,
    pub separation_real_m: f64,
    /// Probe parse errors per decision.
    pub probe_error_rate: f64,
    /// The 1 s errors by decision offset from the evidence turn.
    pub by_offset: Vec<OffsetBin>,
}

/// One offset of [`ForecastSummary::by_offset`]: mean absolute errors (m)
/// of the 1 s forecasts made that many decisions from the evidence turn
/// (NaN without points).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct OffsetBin {
    /// Decisions from the evidence turn; the first and last bins gather
    /// every earlier and later one.
    pub offset: i32,
    pub points: u64,
    pub error_true_m: f64,
    pub error_other_m: f64,
    pub cv_error_true_m: f64,
}

impl OffsetBin {
    /// Bins pooled over several summaries, point-weighted (exact: each
    /// mean times its points is its sum).
    pub fn pool<'a>(offset: i32, bins: impl Iterator<Item = &'a OffsetBin>) -> OffsetBin {
        let (mut points, mut t, mut o, mut c) = (0u64, 0.0, 0.0, 0.0);
        for b in bins.filter(|b| b.offset == offset && b.points > 0) {
            let n = b.points as f64;
            points += b.points;
            (t, o, c) = (t + n * b.error_true_m, o + n * b.error_other_m, c + n * b.cv_error_true_m);
        }
        let mean = |x: f64| if points == 0 { f64::NAN } else { x / points as f64 };
        OffsetBin { offset, points, error_true_m: mean(t), error_other_m: mean(o), cv_error_true_m: mean(c) }
    }
}

impl ForecastSummary {
    pub fn of<'a>(episodes: impl Iterator<Item = &'a ForecastMetrics> + Clone) -> ForecastSummary {
        let ratio = |num: f64, den: f64| if den == 0.0 { f64::NAN } else { num / den };
        let points: [u64; 2] = [0, 1].map(|k| episodes.clone().map(|m| u64::from(m.points[k])).sum());
        let mean = |f: fn(&ForecastMetrics) -> [f64; 2]| {
            [0, 1].map(|k| ratio(episodes.clone().map(|m| f(m)[k]).sum(), points[k] as f64))
        };
        let error_true_m = mean(|m| m.error_true_sum_m);
        let error_other_m = mean(|m| m.error_other_sum_m);
        let cv_error_true_m = mean(|m| m.cv_error_true_sum_m);
        let cv_error_other_m = mean(|m| m.cv_error_other_sum_m);
        // Against a constant-velocity error of nothing (a road user that
        // kept its speed) there is no skill to measure.
        let skill =
            |e: [f64; 2], cv: [f64; 2]| [0, 1].map(|k| if cv[k] < NO_ERROR_M { f64::NAN } else { 1.0 - e[k] / cv[k] });
        let separation_points: f64 = episodes.clone().map(|m| f64::from(m.separation_points)).sum();
        let stated: f64 = episodes.clone().map(|m| f64::from(m.stated_turns)).sum();
        let errors: f64 = episodes.clone().map(|m| f64::from(m.probe_errors)).sum();
        ForecastSummary {
            points,
            skill_true: skill(error_true_m, cv_error_true_m),
            skill_other: skill(error_other_m, cv_error_other_m),
            error_true_m,
            error_other_m,
            cv_error_true_m,
            cv_error_other_m,
            separation_stated_m: ratio(episodes.clone().map(|m| m.separation_stated_sum_m).sum(), separation_points),
            separation_real_m: ratio(episodes.clone().map(|m| m.separation_real_sum_m).sum(), separation_points),
            probe_error_rate: ratio(errors, stated + errors),
            by_offset: OFFSETS
                .enumerate()
                .map(|(i, offset)| {
                    let points: u64 = episodes.clone().map(|m| u64::from(m.by_offset[i].points)).sum();
                    let mean = |f: fn(&OffsetSums) -> f64| {
                        ratio(episodes.clone().map(|m| f(&m.by_offset[i])).sum(), points as f64)
                    };
                    OffsetBin {
                        offset,
                        points,
                        error_true_m: mean(|b| b.error_true_sum_m),
                        error_other_m: mean(|b| b.error_other_sum_m),
                        cv_error_true_m: mean(|b| b.cv_error_true_sum_m),
                    }
                })
                .collect(),
        }
    }
}

/// The forecast metrics as table fields: what every forecast table shows
/// after its key columns.
pub(crate) fn fields() -> Vec<crate::export::Field<'static, ForecastSummary>> {
    use crate::export::{Column, Field};
    type F = Field<'static, ForecastSummary>;
    let field = |header: &str, key: &str, value: fn(&ForecastSummary) -> f64| F::float(Column::new(header, key), value);
    vec![
        field("error 1 s", "error_true_1s_m", |s| s.error_true_m[0]),
        field("error 2 s", "error_true_2s_m", |s| s.error_true_m[1]),
        field("skill 2 s", "skill_true_2s", |s| s.skill_true[1]),
        field("other 1 s", "error_other_1s_m", |s| s.error_other_m[0]),
        field("other 2 s", "error_other_2s_m", |s| s.error_other_m[1]),
        field("other skill 2 s", "skill_other_2s", |s| s.skill_other[1]),
        field("separation", "separation_stated_m", |s| s.separation_stated_m),
        field("real separation", "separation_real_m", |s| s.separation_real_m),
        field("probe errors", "probe_error_rate", |s| s.probe_error_rate),
    ]
}

/// The note under every forecast table: what the columns mean.
pub const TABLE_NOTE: &str = "forecast = where the other road user will be 1 s and 2 s after the decision, \
under each intent. Error: mean absolute error (m) under the true intent, against the episode's true positions \
(never the noisy readings); other: under the other intent, against the twin world under the other disposition \
driven by the same ego. Skill: 1 - error / the constant-velocity forecast's error on the same points. \
Separation: before the evidence, how far apart the forecast put the two intents at 2 s; real separation: how \
far apart the two worlds were.";

#[cfg(test)]
mod tests {
    use super::*;

    fn truth(time_s: f64, ego_travel_m: f64, actual: f64, other: f64) -> ForecastTruth {
        ForecastTruth { time_s, ego_travel_m, actual: vec![actual], other: vec![other], revealed: actual != other }
    }

    fn turn(turn: u32, time_s: f64, lets: AtHorizons, not: AtHorizons, cv: AtHorizons) -> ForecastTurn {
        ForecastTurn {
            turn,
            time_s,
            forecast: Some(Forecast { lets_you_go: vec![lets], does_not: vec![not] }),
            constant_velocity: vec![cv],
        }
    }

    #[test]
    fn a_forecast_is_scored_at_each_horizon_the_episode_reached() {
        let kind = crate::scenario::ScenarioKind::ALL[0];
        // Positions at 0.0 .. 2.5 s; the two worlds part after 1.0 s.
        let truths: Vec<ForecastTruth> =
            (0..6).map(|i| f64::from(i) * 0.5).map(|t| truth(t, 0.0, 10.0 - t, 10.0 - t.min(1.0))).collect();
        // At 0.0 s: right under both intents; the constant-velocity
        // forecast is right under the true one only.
        let exact = turn(1, 0.0, [9.0, 8.0], [9.0, 9.0], [9.0, 8.0]);
        // At 1.0 s: the 2 s horizon (3.0 s) is past the end: not scored.
        let late = turn(3, 1.0, [8.0, 7.0], [9.0, 9.0], [8.0, 7.0]);
        let m = ForecastMetrics::compute(kind, &[exact, late], &truths, true, Some(3));
        assert_eq!(m.points, [2, 1]);
        assert_eq!((m.error_true_sum_m, m.error_other_sum_m), ([0.0, 0.0], [0.0, 0.0]));
        assert_eq!(m.cv_error_other_sum_m, [0.0 + 1.0, 1.0]);
        // Before the evidence (turn 1 only): stated 1 m apart at 2 s, as
        // the worlds were.
        assert_eq!((m.separation_points, m.separation_stated_sum_m, m.separation_real_sum_m), (1, 1.0, 1.0));
        let s = ForecastSummary::of([m].iter());
        assert_eq!(s.skill_other, [1.0, 1.0]);
        assert!(s.skill_true[0].is_nan(), "constant velocity is exact there: no skill to measure");
        // A missing forecast is a probe error, and scores nothing.
        let missing = ForecastTurn { forecast: None, ..turn(2, 0.5, [0.0; 2], [0.0; 2], [0.0; 2]) };
        let m = ForecastMetrics::compute(kind, &[missing], &truths, true, None);
        assert_eq!((m.probe_errors, m.points), (1, [0, 0]));
    }

    #[test]
    fn positions_measured_from_the_ego_are_scored_in_the_decisions_frame() {
        let merge = crate::scenario::ScenarioKind::ALL.into_iter().find(|k| k.def().tracks_relative_to_ego).unwrap();
        // A car 5 m ahead at 10 m/s beside an ego at 10 m/s: its position
        // relative to the ego stays 5, but from where the ego was at the
        // decision it is 15 m ahead 1 s later.
        let truths: Vec<ForecastTruth> =
            (0..3).map(|i| truth(f64::from(i) * 0.5, f64::from(i) * 5.0, 5.0, 5.0)).collect();
        let f = turn(1, 0.0, [15.0, 25.0], [15.0, 25.0], [15.0, 25.0]);
        let m = ForecastMetrics::compute(merge, &[f], &truths, false, None);
        assert_eq!((m.points, m.error_true_sum_m), ([1, 0], [0.0, 0.0]));
    }
}
