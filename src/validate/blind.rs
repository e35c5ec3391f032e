//! The lines that play against a policy that never looks: the search for
//! a blind plan that wins anyway, and the road users' gap acceptance over
//! its plans and every built-in policy.

use super::{ANTI_GAMING_MARGIN, CONSTANT_CORRECTNESS, Check, find, label};
use crate::adversary;
use crate::adversary::{Score, SearchSpec, TRAIN_SEED_BASE};
use crate::baselines::{Cell, CellSummary};
use crate::policy::PolicyKind;
use crate::scenario::{ScenarioKind, ScenarioSet, Tier};
use serde::Serialize;

/// What the blind-policy search found on one cell, measured on held-out
/// seeds.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BlindCell {
    pub scenario: ScenarioKind,
    pub tier: Tier,
    /// The best blind policy by training success, as text.
    pub best: String,
    pub train: Score,
    pub held_out: Score,
    /// The most correct blind policy, as text, and its held-out score.
    pub best_correctness: String,
    pub held_out_correctness: Score,
    pub episodes_searched: usize,
}

/// Search every cell for a blind policy (the adversary's budget per cell),
/// then measure its finding on the held-out seeds `seeds`.
pub fn search_blind(
    set: &ScenarioSet,
    scenarios: &[ScenarioKind],
    tiers: &[Tier],
    seeds: std::ops::Range<u64>,
    budget: usize,
) -> Vec<BlindCell> {
    let held: Vec<u64> = seeds.collect();
    let mut out = Vec::new();
    for &scenario in scenarios {
        for &tier in tiers {
            let config = set.get(scenario);
            let spec = SearchSpec { budget, train_seed_base: TRAIN_SEED_BASE, search_seed: 1 };
            let f = adversary::search(config, tier, spec);
            out.push(BlindCell {
                scenario,
                tier,
                best: f.best.to_string(),
                train: f.train,
                held_out: adversary::evaluate(config, tier, &f.best, &held),
                best_correctness: f.best_correctness.to_string(),
                held_out_correctness: adversary::evaluate(config, tier, &f.best_correctness, &held),
                episodes_searched: f.episodes,
            });
        }
    }
    out
}

/// On every cell the expert's success exceeds the searched blind policy's
/// held-out success by >= 0.30, and the most correct blind policy found
/// scores <= 0.60 decision correctness on the held-out seeds.
pub fn check_blind_play_loses(cells: &[CellSummary], blind: &[BlindCell]) -> Check {
    let mut worst: Option<(f64, String)> = None;
    let mut most_correct: Option<(f64, String)> = None;
    let mut episodes = 0usize;
    for b in blind {
        episodes += b.episodes_searched;
        let c = b.held_out_correctness.correctness;
        if most_correct.as_ref().is_none_or(|(m, _)| c > *m) {
            most_correct = Some((c, label(b.scenario, b.tier)));
        }
        let Some(e) = find(cells, b.scenario, b.tier, PolicyKind::Expert) else { continue };
        let margin = e.success.estimate - b.held_out.success;
        if worst.as_ref().is_none_or(|(w, _)| margin < *w) {
            worst = Some((
                margin,
                format!(
                    "{}: expert {:.3} - blind {:.3} = {margin:.3} ({})",
                    label(b.scenario, b.tier),
                    e.success.estimate,
                    b.held_out.success,
                    b.best
                ),
            ));
        }
    }
    let success_ok = worst.as_ref().is_some_and(|(m, _)| *m >= ANTI_GAMING_MARGIN);
    let correctness_ok = most_correct.as_ref().is_some_and(|(c, _)| *c <= CONSTANT_CORRECTNESS);
    let figure = match (worst, most_correct) {
        (Some(w), Some(c)) => format!(
            "smallest margin {} (bar {ANTI_GAMING_MARGIN:.2}); blind correctness max {:.3} on {} (bar {CONSTANT_CORRECTNESS:.2}); {episodes} episodes searched",
            w.1, c.0, c.1
        ),
        _ => "no cells searched".into(),
    };
    Check::new("blind play loses", success_ok && correctness_ok, figure)
}

/// Road users accept gaps as people do: across the built-in policies'
/// episodes (`unstoppable` per cell: episodes in which a road user that
/// had waited for the ego started into its path while the ego could no
/// longer stop comfortably) and the blind search's best policies, none.
pub fn check_gap_acceptance(unstoppable: &[(Cell, usize)], blind: &[BlindCell]) -> Check {
    let mut episodes = 0usize;
    // (count, where), the largest first.
    let mut found: Vec<(usize, String)> = unstoppable
        .iter()
        .filter(|(_, n)| *n > 0)
        .map(|(cell, n)| (*n, format!("{} on {}", cell.policy, label(cell.scenario, cell.tier))))
        .collect();
    // Per scenario, so that a reader sees which worlds meet the line.
    let mut by_scenario: Vec<(ScenarioKind, usize)> = ScenarioKind::ALL
        .iter()
        .filter(|&&k| unstoppable.iter().any(|(c, _)| c.scenario == k) || blind.iter().any(|b| b.scenario == k))
        .map(|&k| (k, 0))
        .collect();
    let mut add = |kind: ScenarioKind, n: usize| {
        if let Some(entry) = by_scenario.iter_mut().find(|(k, _)| *k == kind) {
            entry.1 += n;
        }
    };
    for (cell, n) in unstoppable {
        add(cell.scenario, *n);
    }
    for b in blind {
        // The most correct plan is often the best one: its episodes count once.
        let distinct = b.best_correctness != b.best;
        let plans = [("best blind", &b.held_out, true), ("most correct blind", &b.held_out_correctness, distinct)];
        for (which, score, _) in plans.into_iter().filter(|p| p.2) {
            episodes += score.episodes;
            if score.unstoppable_turns_taken > 0 {
                add(b.scenario, score.unstoppable_turns_taken);
                found.push((score.unstoppable_turns_taken, format!("{which} on {}", label(b.scenario, b.tier))));
            }
        }
    }
    found.sort_by(|a, b| b.0.cmp(&a.0).then_with(|| a.1.cmp(&b.1)));
    let total: usize = found.iter().map(|(n, _)| n).sum();
    let examples: Vec<String> = found.iter().take(4).map(|(n, at)| format!("{at} x{n}")).collect();
    let cells = unstoppable.len();
    let figure = if examples.is_empty() {
        format!(
            "0 episodes in which a waiting road user started into an ego that could no longer stop ({cells} policy cells, {episodes} blind episodes)"
        )
    } else {
        let per: Vec<String> = by_scenario.iter().map(|(k, n)| format!("{k} {n}")).collect();
        format!(
            "{total} episodes in which a waiting road user started into an ego that could no longer stop ({}), most on {}",
            per.join(", "),
            examples.join("; ")
        )
    };
    Check::new("road users accept gaps", total == 0 && (cells > 0 || episodes > 0), figure)
}
