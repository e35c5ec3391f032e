//! "A defensive driver wins": the habit a driving instructor teaches
//! (never pass a point of conflict while a road user that is not the
//! tier's question is moving toward the ego's path and could reach it by
//! the time the car does, and confirm with one more reading that a walker
//! has stopped) costs reward at most, never the episode; and nothing but
//! the hidden intent gives such a driver a reason to wait past the
//! evidence.

use super::hedging::CautionSummary;
use super::{Check, HedgeCell, cells_of, label};
use crate::episode::{Episode, Outcome};
use crate::policy::{Expert, Hedging, Policy};
use crate::scenario::{ScenarioKind, ScenarioSet, Tier};
use serde::Serialize;

/// One defensive reader on one cell: how it drove against the caution
/// bars, and in how many episodes a road user that had been waiting for
/// the ego started into its path while it could no longer stop.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DefensiveCell {
    #[serde(flatten)]
    pub drove: HedgeCell,
    pub unstoppable: usize,
}

/// On one cell, over the expert's episodes in which the other road user
/// lets the ego go first (where only the evidence stands between a reader
/// and its go): how many reach the evidence, and at how many of those
/// evidence turns a road user other than the tier's question still gives
/// a careful driver reason to wait (read as the expert reads it, a visible
/// slowing to a stop short of the path counting as a stop), and how many
/// with one more reading to confirm.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WaitCell {
    pub scenario: ScenarioKind,
    pub tier: Tier,
    pub evidence_turns: usize,
    pub reason_to_wait: usize,
    pub reason_to_wait_confirming: usize,
}

/// Play each of [`Hedging::DEFENSIVE`] on every cell, seeds `seeds`.
pub fn defensive_readers(
    set: &ScenarioSet,
    scenarios: &[ScenarioKind],
    tiers: &[Tier],
    seeds: std::ops::Range<u64>,
) -> Vec<DefensiveCell> {
    let jobs: Vec<(ScenarioKind, Tier, Hedging)> = cells_of(scenarios, tiers)
        .into_iter()
        .flat_map(|(s, t)| Hedging::DEFENSIVE.into_iter().map(move |h| (s, t, h)))
        .collect();
    crate::par::par_map(&jobs, |&(scenario, tier, how)| {
        let config = set.get(scenario);
        let (mut success, mut collision, mut unstoppable, mut n) = (0usize, 0usize, 0usize, 0usize);
        for seed in seeds.clone() {
            let record = crate::episode::run_episode(config, tier, seed, &mut how.build());
            match record.outcome {
                Outcome::Success => success += 1,
                Outcome::Collision => collision += 1,
                Outcome::Timeout => {}
            }
            unstoppable += usize::from(record.grades.diagnostics.unstoppable_turns_taken > 0);
            n += 1;
        }
        let n = n.max(1) as f64;
        let drove = HedgeCell {
            scenario,
            tier,
            driver: how.to_string(),
            success: success as f64 / n,
            collision: collision as f64 / n,
        };
        DefensiveCell { drove, unstoppable }
    })
}

/// Measure [`WaitCell`] on every cell, seeds `seeds`.
pub fn reasons_to_wait(
    set: &ScenarioSet,
    scenarios: &[ScenarioKind],
    tiers: &[Tier],
    seeds: std::ops::Range<u64>,
) -> Vec<WaitCell> {
    let keys = cells_of(scenarios, tiers);
    crate::par::par_map(&keys, |&(scenario, tier)| {
        let config = set.get(scenario);
        let mut cell = WaitCell { scenario, tier, evidence_turns: 0, reason_to_wait: 0, reason_to_wait_confirming: 0 };
        for seed in seeds.clone() {
            let mut episode = Episode::new(config, tier, seed);
            if !episode.disposition().ego_should_go() {
                continue;
            }
            let mut expert = Expert;
            let mut seen = Vec::with_capacity(48);
            while !episode.is_done() {
                let obs = *episode.observation();
                seen.push(obs);
                episode.step(expert.act(&obs));
            }
            let Some(turn) = episode.timing().evidence_turn else { continue };
            let Some(obs) = seen.get(turn.saturating_sub(1) as usize) else { continue };
            cell.evidence_turns += 1;
            cell.reason_to_wait += usize::from(crate::policy::watching(obs, false));
            cell.reason_to_wait_confirming += usize::from(crate::policy::watching(obs, true));
        }
        cell
    })
}

/// The defensive readers succeed >= 0.85 with collisions <= 0.02 on every
/// cell (the caution line's bars) and never meet a road user stepping in
/// front of a car that cannot stop; and at no evidence turn of the
/// expert's does a road user other than the tier's question still give a
/// careful driver reason to wait (each stands, walks away, or is visibly
/// slowing to a stop short of the path by then). With one more reading to
/// confirm a stop the count is printed beside it: what the confirming
/// readers pay in a decision.
pub fn check_defensive(cells: &[DefensiveCell], waits: &[WaitCell]) -> Check {
    const NAME: &str = "defensive readers win";
    let Some(sum) = CautionSummary::of(&cells.iter().map(|c| c.drove.tried()).collect::<Vec<_>>()) else {
        return Check::new(NAME, false, "no cells".into());
    };
    let unstoppable: usize = cells.iter().map(|c| c.unstoppable).sum();
    let evidence: usize = waits.iter().map(|w| w.evidence_turns).sum();
    let waited: usize = waits.iter().map(|w| w.reason_to_wait).sum();
    let confirming: usize = waits.iter().map(|w| w.reason_to_wait_confirming).sum();
    let worst_wait = waits.iter().filter(|w| w.reason_to_wait > 0).max_by_key(|w| w.reason_to_wait);
    let figure = format!(
        "{}; {unstoppable} episodes with a road user stepping in front of a car that could not stop (bar 0); a road user other than the question still a reason to wait at {waited} of {evidence} evidence turns (bar 0{}), {confirming} with a stop confirmed by one more reading; per cell lowest success/highest collision: {}",
        sum.headline,
        worst_wait.map_or(String::new(), |w| format!(", most on {}", label(w.scenario, w.tier))),
        sum.per_cell
    );
    Check::new(NAME, sum.below == 0 && unstoppable == 0 && waited == 0 && evidence > 0, figure)
}
