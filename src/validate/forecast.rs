//! The forecast probe's references: the rules forecaster beats constant
//! velocity, and the twin stays with the episode until the reveal.

use super::{Check, cells_of, label};
use crate::policy::PolicyKind;
use crate::scenario::{ScenarioKind, ScenarioSet, Tier};
use serde::Serialize;

/// The forecast probe's rules forecaster against constant velocity on one
/// cell, along every built-in policy's episodes, and the twin's check.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ForecastCell {
    pub scenario: ScenarioKind,
    pub tier: Tier,
    /// Under the true intent: the rules forecaster's and the
    /// constant-velocity forecast's mean absolute errors (m) and skill,
    /// at 1 s and 2 s.
    pub rules: crate::forecast::ForecastSummary,
    /// Decisions before the reveal, and how many of them had the twin
    /// under the other disposition anywhere but where the episode was.
    pub before_reveal: usize,
    pub twin_apart: usize,
}

/// Play every built-in policy on every cell, seeds `seeds`, with the
/// reference forecasters along; gather the rules forecaster's scores and
/// compare the twin with the episode before the reveal.
pub fn forecast_references(
    set: &ScenarioSet,
    scenarios: &[ScenarioKind],
    tiers: &[Tier],
    seeds: std::ops::Range<u64>,
) -> Vec<ForecastCell> {
    use crate::forecast::{ForecasterKind, Reference};
    let rules = Reference::ALL
        .iter()
        .position(|r| *r == Reference::Forecaster(ForecasterKind::Rules))
        .expect("the rules forecaster is a reference");
    let keys = cells_of(scenarios, tiers);
    crate::par::par_map(&keys, |&(scenario, tier)| {
        let config = set.get(scenario);
        let (mut scores, mut before_reveal, mut twin_apart) = (Vec::new(), 0, 0);
        for kind in PolicyKind::ALL {
            let mut policy = kind.build();
            for seed in seeds.clone() {
                let (_, s, truths) =
                    crate::forecast::play_with_references_and_truth(config, tier, seed, policy.as_mut());
                scores.push(s[rules]);
                for t in truths.iter().filter(|t| !t.revealed) {
                    before_reveal += 1;
                    let same = t.actual.iter().zip(&t.other).all(|(a, b)| a.to_bits() == b.to_bits());
                    twin_apart += usize::from(!same);
                }
            }
        }
        ForecastCell {
            scenario,
            tier,
            rules: crate::forecast::ForecastSummary::of(scores.iter()),
            before_reveal,
            twin_apart,
        }
    })
}

/// The forecast's references anchor its scale: under the true intent, the
/// rules forecaster (each scenario's road-user model, from the public
/// scene) beats constant velocity on every cell at both horizons (every
/// cell's road user moves as its intent makes it); and the twin under the
/// other disposition is where the episode is at every decision before the
/// reveal, bit for bit.
pub fn check_forecast(cells: &[ForecastCell]) -> Check {
    let skill = |c: &ForecastCell| c.rules.skill_true[0].min(c.rules.skill_true[1]);
    let worst = cells.iter().min_by(|a, b| skill(a).total_cmp(&skill(b)));
    let beats = !cells.is_empty() && cells.iter().all(|c| skill(c) > 0.0);
    let (before, apart): (usize, usize) =
        cells.iter().fold((0, 0), |(b, a), c| (b + c.before_reveal, a + c.twin_apart));
    let per_cell: Vec<String> = cells
        .iter()
        .map(|c| {
            format!(
                "{} {:.2}/{:.2} m vs {:.2}/{:.2}",
                label(c.scenario, c.tier),
                c.rules.error_true_m[0],
                c.rules.error_true_m[1],
                c.rules.cv_error_true_m[0],
                c.rules.cv_error_true_m[1]
            )
        })
        .collect();
    let figure = format!(
        "rules forecaster's lowest skill over constant velocity {} (bar > 0); twin apart from the episode before \
         the reveal at {apart} of {before} decisions (bar 0); per cell error at 1 s/2 s, rules vs constant velocity: {}",
        worst.map_or("none".to_string(), |c| format!("{:.2} on {}", skill(c), label(c.scenario, c.tier))),
        per_cell.join(", ")
    );
    Check::new("forecast references", beats && apart == 0 && before > 0, figure)
}
