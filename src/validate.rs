//! The benchmark's invariants (SPEC section 6). Each check is a function of
//! its inputs so that tests can inject the fault it guards against and see
//! it fail.

use crate::baselines::{Cell, CellSummary, GridSpec, run_grid};
use crate::episode::{Episode, Outcome};
use crate::observation::{Observation, parse_scene, render_scene};
use crate::policy::{Expert, Policy, PolicyKind};
use crate::scenario::{ScenarioKind, ScenarioSet, Tier};
use serde::Serialize;

/// Bars from SPEC section 6.
pub const SOLVABLE_TIER1: f64 = 0.95;
pub const SOLVABLE_ANY: f64 = 0.85;
pub const ANTI_GAMING_MARGIN: f64 = 0.30;
pub const BITE_MARGIN: f64 = 0.30;
pub const TIER1_CUE_FOLLOWER_WITHIN: f64 = 0.20;
pub const EXPERT_CORRECTNESS: f64 = 0.90;
pub const CONSTANT_CORRECTNESS: f64 = 0.60;

/// The outcome of one invariant.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Check {
    pub name: &'static str,
    pub pass: bool,
    /// The deciding figure, for the one-line report.
    pub figure: String,
}

impl Check {
    pub fn line(&self) -> String {
        format!("{:<5} {:<22} {}", if self.pass { "PASS" } else { "FAIL" }, self.name, self.figure)
    }
}

fn find(cells: &[CellSummary], scenario: ScenarioKind, tier: Tier, policy: PolicyKind) -> Option<&CellSummary> {
    cells.iter().find(|c| c.cell == Cell { scenario, tier, policy })
}

fn cell_keys(cells: &[CellSummary]) -> Vec<(ScenarioKind, Tier)> {
    let mut keys: Vec<_> = cells.iter().map(|c| (c.cell.scenario, c.cell.tier)).collect();
    keys.sort();
    keys.dedup();
    keys
}

fn label(s: ScenarioKind, t: Tier) -> String {
    format!("{s}/t{t}")
}

/// Expert success >= 0.95 on tier 1 and >= 0.85 on every tier.
pub fn check_solvable(cells: &[CellSummary]) -> Check {
    let mut worst: Option<(f64, String)> = None;
    let mut pass = true;
    for (s, t) in cell_keys(cells) {
        let Some(e) = find(cells, s, t, PolicyKind::Expert) else { continue };
        let bar = if t == Tier::T1 { SOLVABLE_TIER1 } else { SOLVABLE_ANY };
        let slack = e.success.estimate - bar;
        pass &= slack >= 0.0;
        if worst.as_ref().is_none_or(|(w, _)| slack < *w) {
            worst =
                Some((slack, format!("expert success {:.3} on {} (bar {bar:.2})", e.success.estimate, label(s, t))));
        }
    }
    Check {
        name: "solvable",
        pass: pass && worst.is_some(),
        figure: worst.map_or("no expert cells".into(), |w| format!("lowest: {}", w.1)),
    }
}

/// On every cell the expert beats every state-ignorant policy by >= 0.30.
pub fn check_anti_gaming(cells: &[CellSummary]) -> Check {
    let mut worst: Option<(f64, String)> = None;
    for (s, t) in cell_keys(cells) {
        let Some(e) = find(cells, s, t, PolicyKind::Expert) else { continue };
        for p in PolicyKind::STATE_IGNORANT {
            let Some(c) = find(cells, s, t, p) else { continue };
            let margin = e.success.estimate - c.success.estimate;
            if worst.as_ref().is_none_or(|(w, _)| margin < *w) {
                worst = Some((margin, format!("expert - {p} = {margin:.3} on {}", label(s, t))));
            }
        }
    }
    let pass = worst.as_ref().is_some_and(|(m, _)| *m >= ANTI_GAMING_MARGIN);
    Check {
        name: "anti-gaming",
        pass,
        figure: worst.map_or("no cells".into(), |w| format!("smallest margin: {} (bar {ANTI_GAMING_MARGIN:.2})", w.1)),
    }
}

/// On tier 3 (bluff / pause-then-dart / merge bluff) the cue follower is
/// >= 0.30 below the expert; on tier 1 it is within 0.20.
pub fn check_tiers_bite(cells: &[CellSummary]) -> Check {
    let mut pass = true;
    let mut parts = Vec::new();
    let mut seen = false;
    for (s, t) in cell_keys(cells) {
        if t == Tier::T2 {
            continue;
        }
        let (Some(e), Some(c)) = (find(cells, s, t, PolicyKind::Expert), find(cells, s, t, PolicyKind::CueFollower))
        else {
            continue;
        };
        seen = true;
        let gap = e.success.estimate - c.success.estimate;
        let ok = if t == Tier::T3 { gap >= BITE_MARGIN } else { gap <= TIER1_CUE_FOLLOWER_WITHIN };
        pass &= ok;
        parts.push(format!("{} {gap:+.2}", label(s, t)));
    }
    Check {
        name: "tiers bite",
        pass: pass && seen,
        figure: format!(
            "expert - cue_follower: {} (tier 3 >= {BITE_MARGIN:.2}, tier 1 <= {TIER1_CUE_FOLLOWER_WITHIN:.2})",
            parts.join(", ")
        ),
    }
}

/// Every collision < every timeout < every success, over all episodes.
pub fn check_reward_ordering(cells: &[CellSummary]) -> Check {
    let agg = |o: Outcome| {
        cells
            .iter()
            .map(|c| c.span(o))
            .filter(|s| s.count > 0)
            .fold((f64::INFINITY, f64::NEG_INFINITY, 0usize), |acc, s| {
                (acc.0.min(s.min), acc.1.max(s.max), acc.2 + s.count)
            })
    };
    let (_, c_max, c_n) = agg(Outcome::Collision);
    let (t_min, t_max, t_n) = agg(Outcome::Timeout);
    let (s_min, _, s_n) = agg(Outcome::Success);
    // Compare only outcomes that occurred.
    let collision_below = c_n == 0 || (t_n > 0 && c_max < t_min) || (t_n == 0 && (s_n == 0 || c_max < s_min));
    let timeout_below = t_n == 0 || s_n == 0 || t_max < s_min;
    Check {
        name: "reward ordering",
        pass: collision_below && timeout_below && c_n + t_n + s_n > 0,
        figure: format!(
            "collision max {c_max:.3} < timeout [{t_min:.3}, {t_max:.3}] < success min {s_min:.3} over {} episodes",
            c_n + t_n + s_n
        ),
    }
}

/// Expert decision correctness >= 0.90 and every constant policy <= 0.60,
/// on every cell.
pub fn check_correctness(cells: &[CellSummary]) -> Check {
    let mut expert_min = f64::INFINITY;
    let mut constant_max = f64::NEG_INFINITY;
    let mut where_e = String::new();
    let mut where_c = String::new();
    for c in cells {
        let dc = c.decision_correctness.estimate;
        if c.cell.policy == PolicyKind::Expert && dc < expert_min {
            expert_min = dc;
            where_e = label(c.cell.scenario, c.cell.tier);
        }
        if PolicyKind::CONSTANT.contains(&c.cell.policy) && dc > constant_max {
            constant_max = dc;
            where_c = format!("{} on {}", c.cell.policy, label(c.cell.scenario, c.cell.tier));
        }
    }
    Check {
        name: "correctness honest",
        pass: expert_min >= EXPERT_CORRECTNESS && constant_max <= CONSTANT_CORRECTNESS,
        figure: format!(
            "expert min {expert_min:.3} ({where_e}, bar {EXPERT_CORRECTNESS:.2}); constant max {constant_max:.3} ({where_c}, bar {CONSTANT_CORRECTNESS:.2})"
        ),
    }
}

/// How the hidden-disposition check turns an episode into the text a model
/// would read. The real one renders the public observation; tests pass a
/// leaky one to see the check fail.
pub type SceneText<'a> = &'a (dyn Fn(&Episode) -> String + Sync);

/// For every seed, play the expert under one disposition, replay its
/// actions under the other, and compare the texts of every turn before the
/// reveal (at least the first). Also collects observations for the round trip.
pub fn check_hidden_disposition(
    set: &ScenarioSet,
    scenarios: &[ScenarioKind],
    tiers: &[Tier],
    seeds: std::ops::Range<u64>,
    text: SceneText,
) -> (Check, Vec<Observation>) {
    let mut compared = 0usize;
    let mut failures = Vec::new();
    let mut observations = Vec::new();
    for &s in scenarios {
        let [d0, d1] = s.dispositions();
        for &t in tiers {
            for seed in seeds.clone() {
                let config = set.get(s);
                let mut a = Episode::with_disposition(config, t, seed, d0);
                let mut b = Episode::with_disposition(config, t, seed, d1);
                let mut expert = Expert;
                let mut first = true;
                loop {
                    let before_reveal = !a.revealed() && !b.revealed();
                    if first || before_reveal {
                        compared += 1;
                        if text(&a) != text(&b) && failures.len() < 3 {
                            failures.push(format!("{}/t{t} seed {seed} turn {}", s, a.observation().turn));
                        }
                    }
                    observations.push(*a.observation());
                    first = false;
                    if a.is_done() || b.is_done() || !before_reveal {
                        break;
                    }
                    let action = expert.act(a.observation());
                    a.step(action);
                    b.step(action);
                }
            }
        }
    }
    let pass = failures.is_empty() && compared > 0;
    let figure = if pass {
        format!("{compared} pre-reveal observations byte-identical under both dispositions")
    } else {
        format!("{} differ, e.g. {}", failures.len(), failures.join("; "))
    };
    (Check { name: "hidden disposition", pass, figure }, observations)
}

/// Parsing the rendered text gives back the observation, to the printed
/// precision.
pub fn check_round_trip(observations: &[Observation], render: &dyn Fn(&Observation) -> String) -> Check {
    let mut bad = 0usize;
    let mut example = String::new();
    for o in observations {
        let ok = match parse_scene(&render(o)) {
            Ok(parsed) => parsed == o.rounded(),
            Err(e) => {
                if example.is_empty() {
                    example = e.to_string();
                }
                false
            }
        };
        if !ok {
            bad += 1;
            if example.is_empty() {
                example = format!("{} turn {}", o.scenario, o.turn);
            }
        }
    }
    Check {
        name: "text carries the state",
        pass: bad == 0 && !observations.is_empty(),
        figure: if bad == 0 {
            format!("{} observations round-trip through the scene text", observations.len())
        } else {
            format!("{bad} of {} do not round-trip, e.g. {example}", observations.len())
        },
    }
}

/// Run every invariant at `n` seeds per cell.
pub fn run(set: &ScenarioSet, n: usize, seed_base: u64) -> Vec<Check> {
    let spec = GridSpec {
        scenarios: ScenarioKind::ALL.to_vec(),
        tiers: Tier::ALL.to_vec(),
        policies: PolicyKind::ALL.to_vec(),
        episodes: n,
        seed_base,
    };
    let cells = run_grid(set, &spec, &|_, _| {});
    let seeds = seed_base..seed_base + n as u64;
    let (hidden, observations) =
        check_hidden_disposition(set, &ScenarioKind::ALL, &Tier::ALL, seeds, &|e: &Episode| {
            render_scene(e.observation())
        });
    vec![
        check_solvable(&cells),
        check_anti_gaming(&cells),
        check_tiers_bite(&cells),
        hidden,
        check_round_trip(&observations, &render_scene),
        check_reward_ordering(&cells),
        check_correctness(&cells),
    ]
}
