//! "Giving way has time": a driver who gives way to a road user that
//! really goes first has decisions to spare.

use super::{Check, GIVE_WAY_SPARE_SHARE, GIVE_WAY_SPARE_TURNS, cells_of, label};
use crate::episode::Outcome;
use crate::policy::Expert;
use crate::scenario::{ScenarioKind, ScenarioSet, Tier};
use serde::Serialize;

/// How much time a driver who gives way has left on one cell: over the
/// expert's episodes in which the other road user really goes first (the
/// disposition the ego must give way to), the share that finish with at
/// least [`GIVE_WAY_SPARE_TURNS`] decisions to spare, and the fewest spare.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GiveWayCell {
    pub scenario: ScenarioKind,
    pub tier: Tier,
    pub episodes: usize,
    pub spare_share: f64,
    pub fewest_spare: Option<u32>,
}

/// Measure [`GiveWayCell`] on every cell, seeds `seeds`.
pub fn give_way_time(
    set: &ScenarioSet,
    scenarios: &[ScenarioKind],
    tiers: &[Tier],
    seeds: std::ops::Range<u64>,
) -> Vec<GiveWayCell> {
    let keys = cells_of(scenarios, tiers);
    crate::par::par_map(&keys, |&(scenario, tier)| {
        let config = set.get(scenario);
        let budget = config.common().turn_budget.get(tier);
        // Spare decisions of each episode the ego had to give way in (a
        // timeout or a collision has none).
        let spare: Vec<u32> = seeds
            .clone()
            .map(|seed| crate::episode::run_episode(config, tier, seed, &mut Expert))
            .filter(|r| !r.disposition.ego_should_go())
            .map(|r| match r.outcome {
                Outcome::Success => budget.saturating_sub(r.decisions.len() as u32),
                _ => 0,
            })
            .collect();
        let enough = spare.iter().filter(|&&s| s >= GIVE_WAY_SPARE_TURNS).count();
        GiveWayCell {
            scenario,
            tier,
            episodes: spare.len(),
            spare_share: enough as f64 / spare.len().max(1) as f64,
            fewest_spare: spare.iter().min().copied(),
        }
    })
}

/// A driver who yields correctly has time to finish: the expert's rules,
/// giving way to a road user that really goes first, keep at least
/// [`GIVE_WAY_SPARE_TURNS`] decisions to spare in >= 0.95 of those
/// episodes on every cell.
pub fn check_give_way_time(cells: &[GiveWayCell]) -> Check {
    let Some(worst) = cells.iter().min_by(|a, b| a.spare_share.total_cmp(&b.spare_share)) else {
        return Check::new("giving way has time", false, "no cells".into());
    };
    let per_cell: Vec<String> = cells
        .iter()
        .map(|c| {
            format!(
                "{} {:.2} (fewest {})",
                label(c.scenario, c.tier),
                c.spare_share,
                c.fewest_spare.map_or("-".into(), |f| f.to_string())
            )
        })
        .collect();
    Check::new(
        "giving way has time",
        cells.iter().all(|c| c.spare_share >= GIVE_WAY_SPARE_SHARE),
        format!(
            "expert giving way keeps >= {GIVE_WAY_SPARE_TURNS} decisions to spare: lowest {:.3} on {} (bar {GIVE_WAY_SPARE_SHARE:.2}); per cell share (fewest spare): {}",
            worst.spare_share,
            label(worst.scenario, worst.tier),
            per_cell.join(", ")
        ),
    )
}
