//! "Hedging readers win": people who slow from the first decision, read a
//! decision late and go softly at first; and the caution bars' summary
//! that the hedging and defensive lines share.

use super::{CAUTIOUS_COLLISION, CAUTIOUS_SUCCESS, Check, HEDGE_BRAKES_MPS2, HEDGE_FROM_START, label};
use crate::episode::Outcome;
use crate::policy::{Expert, Hedging};
use crate::scenario::{ScenarioKind, ScenarioSet, Tier};
use serde::Serialize;

/// How one careful way of driving ([`Hedging`]) fares on one cell.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HedgeCell {
    pub scenario: ScenarioKind,
    pub tier: Tier,
    /// The way of driving, in words.
    pub driver: String,
    pub success: f64,
    pub collision: f64,
}

/// The ways of driving the hedging line tries on one cell whose evidence
/// comes by `evidence_s` (s): on the scenarios where people hedge from the
/// first decision, braking at every level of [`HEDGE_BRAKES_MPS2`] for
/// every duration from one decision up to the evidence time plus one
/// decision, then reading on time, a decision late, and a decision late
/// with a first go that holds speed; on every scenario, `expert_cautious`
/// a decision late with a first go that holds speed.
pub fn hedging_drivers(scenario: ScenarioKind, evidence_s: f64) -> Vec<Hedging> {
    let mut drivers = vec![Hedging::cautious_late_soft()];
    if !HEDGE_FROM_START.contains(&scenario) {
        return drivers;
    }
    let step = crate::observation::HISTORY_SPACING_S;
    let longest = ((evidence_s + step) / step).round() as usize;
    for brake in HEDGE_BRAKES_MPS2 {
        for k in 1..=longest.max(1) {
            let hedge_s = k as f64 * step;
            drivers.extend([
                Hedging::on_time(brake, hedge_s),
                Hedging::late(brake, hedge_s),
                Hedging::late_soft(brake, hedge_s),
            ]);
        }
    }
    drivers
}

/// The cell's evidence time (s): the 95th percentile, over the expert's
/// episodes on `seeds`, of the time of the first turn whose scene differs
/// between the dispositions (when the evidence could have come).
fn evidence_time(config: &crate::scenario::ScenarioConfig, tier: Tier, seeds: std::ops::Range<u64>) -> f64 {
    let mut times: Vec<f64> = seeds
        .filter_map(|seed| crate::episode::run_episode(config, tier, seed, &mut Expert).timing.evidence_turn)
        .map(|turn| f64::from(turn.saturating_sub(1)) * crate::observation::HISTORY_SPACING_S)
        .collect();
    times.sort_by(f64::total_cmp);
    times.get(((times.len() as f64 - 1.0) * 0.95).round() as usize).copied().unwrap_or(0.0)
}

/// Play every way of driving of [`hedging_drivers`] on every cell, seeds
/// `seeds`.
pub fn hedging_readers(
    set: &ScenarioSet,
    scenarios: &[ScenarioKind],
    tiers: &[Tier],
    seeds: std::ops::Range<u64>,
) -> Vec<HedgeCell> {
    let mut jobs = Vec::new();
    for &scenario in scenarios {
        for &tier in tiers {
            let evidence_s = evidence_time(set.get(scenario), tier, seeds.clone());
            jobs.extend(hedging_drivers(scenario, evidence_s).into_iter().map(|h| (scenario, tier, h)));
        }
    }
    crate::par::par_map(&jobs, |&(scenario, tier, how)| {
        let config = set.get(scenario);
        let (mut success, mut collision, mut n) = (0usize, 0usize, 0usize);
        for seed in seeds.clone() {
            let mut driver = how.build();
            match crate::episode::run_episode(config, tier, seed, &mut driver).outcome {
                Outcome::Success => success += 1,
                Outcome::Collision => collision += 1,
                Outcome::Timeout => {}
            }
            n += 1;
        }
        let n = n.max(1) as f64;
        HedgeCell {
            scenario,
            tier,
            driver: how.to_string(),
            success: success as f64 / n,
            collision: collision as f64 / n,
        }
    })
}

/// People hedge from the first decision: every way of driving of
/// [`hedging_drivers`] succeeds >= 0.85 with collisions <= 0.02 on its
/// cells (the caution line's bars).
pub fn check_hedging(cells: &[HedgeCell]) -> Check {
    match CautionSummary::of(&cells.iter().map(HedgeCell::tried).collect::<Vec<_>>()) {
        Some(sum) => Check::new(
            "hedging readers win",
            sum.below == 0,
            format!("{}; per cell lowest success/highest collision: {}", sum.headline, sum.per_cell),
        ),
        None => Check::new("hedging readers win", false, "no cells".into()),
    }
}

impl HedgeCell {
    pub(super) fn tried(&self) -> Tried<'_> {
        Tried {
            scenario: self.scenario,
            tier: self.tier,
            driver: &self.driver,
            success: self.success,
            collision: self.collision,
        }
    }
}

/// One way of driving on one cell, held to the caution bars.
pub(super) struct Tried<'a> {
    scenario: ScenarioKind,
    tier: Tier,
    driver: &'a str,
    success: f64,
    collision: f64,
}

/// What a line that holds ways of driving to the caution bars
/// ([`CAUTIOUS_SUCCESS`], [`CAUTIOUS_COLLISION`]) prints of them.
pub(super) struct CautionSummary {
    /// How many fall below a bar.
    pub(super) below: usize,
    /// The lowest success and the highest collision rate, each with the
    /// way of driving and the cell, and how many fall below a bar.
    pub(super) headline: String,
    /// Per cell, the lowest success and the highest collision rate of any
    /// way of driving tried there.
    pub(super) per_cell: String,
}

impl CautionSummary {
    pub(super) fn of(tried: &[Tried]) -> Option<CautionSummary> {
        let lowest = tried.iter().min_by(|a, b| a.success.total_cmp(&b.success))?;
        let worst_collision = tried.iter().max_by(|a, b| a.collision.total_cmp(&b.collision))?;
        let below = tried.iter().filter(|c| c.success < CAUTIOUS_SUCCESS || c.collision > CAUTIOUS_COLLISION).count();
        let mut keys: Vec<(ScenarioKind, Tier)> = tried.iter().map(|c| (c.scenario, c.tier)).collect();
        keys.dedup();
        let per_cell: Vec<String> = keys
            .iter()
            .map(|&(s, t)| {
                let here = tried.iter().filter(|c| (c.scenario, c.tier) == (s, t));
                let (low, high) = here.fold((1.0f64, 0.0f64), |(l, h), c| (l.min(c.success), h.max(c.collision)));
                format!("{} {low:.2}/{high:.2}", label(s, t))
            })
            .collect();
        let headline = format!(
            "lowest success {:.3} ({} on {}, bar {CAUTIOUS_SUCCESS:.2}); highest collision {:.3} ({} on {}, bar {CAUTIOUS_COLLISION:.2}); {below} of {} drivers below a bar",
            lowest.success,
            lowest.driver,
            label(lowest.scenario, lowest.tier),
            worst_collision.collision,
            worst_collision.driver,
            label(worst_collision.scenario, worst_collision.tier),
            tried.len(),
        );
        Some(CautionSummary { below, headline, per_cell: per_cell.join(", ") })
    }
}
