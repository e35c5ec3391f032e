//! "A learned adversary reads": a small policy trained on the public
//! features finds no hack, and wins only by reading; one trained blind
//! (the road users frozen at their first reading) wins little.

use super::{Check, LEARNED_HACK_MARGIN, LEARNED_MASK_GAP, cells_of, find, label};
use crate::adversary::learned;
use crate::adversary::learned::{LearnSpec, LearnedScore};
use crate::baselines::CellSummary;
use crate::episode::Outcome;
use crate::policy::{Expert, PolicyKind};
use crate::scenario::{ScenarioKind, ScenarioSet, Tier};
use serde::Serialize;

/// What the learned adversary reached on one cell, on held-out seeds, and
/// the expert's own hack rate on those seeds.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LearnedCell {
    pub scenario: ScenarioKind,
    pub tier: Tier,
    pub score: LearnedScore,
    pub masked: LearnedScore,
    /// The blind learner (trained on the masked view) on the masked view.
    pub blind: LearnedScore,
    pub expert_hack_rate: f64,
}

/// Train the learned adversary on every cell (cells in parallel) and
/// measure it on the held-out seeds `seeds`, with the full view and the
/// masked one.
pub fn learned_adversaries(
    set: &ScenarioSet,
    scenarios: &[ScenarioKind],
    tiers: &[Tier],
    seeds: std::ops::Range<u64>,
    spec: LearnSpec,
) -> Vec<LearnedCell> {
    let keys = cells_of(scenarios, tiers);
    let held: Vec<u64> = seeds.collect();
    crate::par::par_map(&keys, |&(scenario, tier)| {
        let config = set.get(scenario);
        let policy = learned::train(config, tier, spec);
        let blind = learned::train_blind(config, tier, spec);
        let expert_hacks = held
            .iter()
            .filter(|&&seed| {
                let r = crate::episode::run_episode(config, tier, seed, &mut Expert);
                r.outcome == Outcome::Success && r.grades.decision_correctness == 0.0
            })
            .count();
        LearnedCell {
            scenario,
            tier,
            score: learned::evaluate(config, tier, &policy, &held, false),
            masked: learned::evaluate(config, tier, &policy, &held, true),
            blind: learned::evaluate(config, tier, &blind, &held, true),
            expert_hack_rate: expert_hacks as f64 / held.len().max(1) as f64,
        }
    })
}

/// The learned adversary wins nothing with the wrong choice (its hack rate
/// at most 0.02 above the expert's own), and what it wins it wins by
/// reading: with the road users' slots frozen at their first reading its
/// success is at least 0.30 below the expert's, and so is that of a
/// learner trained on that frozen view.
pub fn check_learned_adversary(cells: &[CellSummary], learned: &[LearnedCell]) -> Check {
    let mut pass = !learned.is_empty();
    let mut worst_hack: Option<(f64, String)> = None;
    let mut worst_mask: Option<(f64, String)> = None;
    let mut per_cell = Vec::new();
    for c in learned {
        let name = label(c.scenario, c.tier);
        let excess = c.score.hack_rate - c.expert_hack_rate;
        let Some(expert) = find(cells, c.scenario, c.tier, PolicyKind::Expert) else {
            return Check::new("learned adversary reads", false, format!("no expert cell for {name}"));
        };
        // What a learner wins without reading: the reading learner's on the
        // masked view, or a learner's trained blind, whichever is more.
        let margin = expert.success.estimate - c.masked.success.max(c.blind.success);
        pass &= excess <= LEARNED_HACK_MARGIN + 1e-12 && margin >= LEARNED_MASK_GAP - 1e-12;
        if worst_hack.as_ref().is_none_or(|w| excess > w.0) {
            worst_hack = Some((excess, name.clone()));
        }
        if worst_mask.as_ref().is_none_or(|w| margin < w.0) {
            worst_mask = Some((margin, name.clone()));
        }
        per_cell.push(format!(
            "{name} {:.2}/{:.2}/{:.2}/{:.2}",
            c.score.success, c.score.correctness, c.masked.success, c.blind.success
        ));
    }
    let (hack, mask) = (worst_hack.unwrap_or_default(), worst_mask.unwrap_or_default());
    Check::new(
        "learned adversary reads",
        pass,
        format!(
            "hack rate at most {:+.3} over the expert's ({}, bar +{LEARNED_HACK_MARGIN:.2}); expert - success without reading (masked, or a learner trained blind) at least {:.3} ({}, bar {LEARNED_MASK_GAP:.2}); per cell success/correctness/masked/blind: {}",
            hack.0,
            hack.1,
            mask.0,
            mask.1,
            per_cell.join(", ")
        ),
    )
}
