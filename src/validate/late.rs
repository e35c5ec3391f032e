//! The lines on evidence and reaction time: the expert never needs to
//! guess, and a reader a decision or two late still succeeds.

use super::{Check, FOLLOWS_EVIDENCE, LATE_READER, MAX_SLACK_LAG, TWO_LATE_READER, cells_of, label};
use crate::episode::{EvidenceTiming, Outcome};
use crate::policy::ExpertLate;
use crate::scenario::{ScenarioKind, ScenarioSet, Tier};
use serde::Serialize;

/// The expert commits at or after the evidence turn in >= 0.95 of its
/// committed episodes: it never needs to guess. `timings` are the expert's.
pub fn check_follows_evidence(timings: &[EvidenceTiming]) -> Check {
    let guesses: Vec<bool> = timings.iter().filter_map(|t| t.guessed()).collect();
    let informed = guesses.iter().filter(|g| !**g).count();
    let share = if guesses.is_empty() { 0.0 } else { informed as f64 / guesses.len() as f64 };
    Check::new(
        "decisions follow evidence",
        !guesses.is_empty() && share >= FOLLOWS_EVIDENCE,
        format!(
            "expert commits at or after the evidence turn in {informed} of {} episodes ({share:.3}, bar {FOLLOWS_EVIDENCE:.2})",
            guesses.len()
        ),
    )
}

/// How late a reader of one cell may be: the expert's success when it reads
/// the other road users one and two decisions late, and the *reading
/// slack* of each seed.
///
/// The slack of a seed is the longest delay, in seconds, with which the
/// expert's own rules still succeed on that seed at every delay up to it
/// (0.5 s per decision, tried up to [`MAX_SLACK_LAG`] decisions): how long
/// after the evidence a reader can still act on it. A seed the expert
/// itself fails has slack 0 and counts in the 5th percentile.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LateCell {
    pub scenario: ScenarioKind,
    pub tier: Tier,
    pub one_late: f64,
    pub two_late: f64,
    pub slack_median_s: f64,
    pub slack_p5_s: f64,
}

/// Measure [`LateCell`] on every cell, seeds `seeds`.
pub fn late_readers(
    set: &ScenarioSet,
    scenarios: &[ScenarioKind],
    tiers: &[Tier],
    seeds: std::ops::Range<u64>,
) -> Vec<LateCell> {
    let keys = cells_of(scenarios, tiers);
    crate::par::par_map(&keys, |&(scenario, tier)| {
        let config = set.get(scenario);
        // Per seed, whether the expert succeeds at each delay 0 ..= MAX_SLACK_LAG.
        let outcomes: Vec<Vec<bool>> = seeds
            .clone()
            .map(|seed| {
                (0..=MAX_SLACK_LAG)
                    .map(|lag| {
                        let mut policy = ExpertLate::new(lag);
                        crate::episode::run_episode(config, tier, seed, &mut policy).outcome == Outcome::Success
                    })
                    .collect()
            })
            .collect();
        let n = outcomes.len().max(1) as f64;
        let share = |lag: usize| outcomes.iter().filter(|o| o[lag]).count() as f64 / n;
        let mut slack: Vec<f64> = outcomes
            .iter()
            .map(|o| {
                let ok = o.iter().take_while(|&&s| s).count();
                // `ok` delays (0 .. ok-1) succeed: the longest is ok - 1.
                ok.saturating_sub(1) as f64 * crate::observation::HISTORY_SPACING_S
            })
            .collect();
        slack.sort_by(f64::total_cmp);
        let pick = |q: f64| slack.get(((slack.len() as f64 - 1.0) * q).round() as usize).copied().unwrap_or(0.0);
        LateCell {
            scenario,
            tier,
            one_late: share(1),
            two_late: share(2),
            slack_median_s: pick(0.5),
            slack_p5_s: pick(0.05),
        }
    })
}

/// The expert reading one decision late succeeds >= 0.85 on every cell,
/// and two decisions late >= 0.60: evidence comes with slack.
pub fn check_late_reader(late: &[LateCell]) -> Check {
    let worst = |f: fn(&LateCell) -> f64| {
        late.iter().map(|c| (f(c), label(c.scenario, c.tier))).min_by(|a, b| a.0.total_cmp(&b.0))
    };
    let (Some(one), Some(two)) = (worst(|c| c.one_late), worst(|c| c.two_late)) else {
        return Check::new("late reader succeeds", false, "no cells".into());
    };
    let cells: Vec<String> = late
        .iter()
        .map(|c| {
            format!(
                "{} {:.2}/{:.2} slack {:.1}/{:.1} s",
                label(c.scenario, c.tier),
                c.one_late,
                c.two_late,
                c.slack_median_s,
                c.slack_p5_s
            )
        })
        .collect();
    Check::new(
        "late reader succeeds",
        one.0 >= LATE_READER && two.0 >= TWO_LATE_READER,
        format!(
            "expert_late lowest {:.3} on {} (bar {LATE_READER:.2}); two decisions late lowest {:.3} on {} (bar {TWO_LATE_READER:.2}); per cell one/two late, slack median/p5: {}",
            one.0,
            one.1,
            two.0,
            two.1,
            cells.join(", ")
        ),
    )
}
