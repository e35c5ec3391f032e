//! The benchmark's invariants (docs/validate.md). Each check is a function of
//! its inputs so that tests can inject the fault it guards against and see
//! it fail.

mod defensive;

pub use defensive::{DefensiveCell, WaitCell, check_defensive, defensive_readers, reasons_to_wait};

use crate::adversary::learned::{self, LearnSpec, LearnedScore};
use crate::adversary::{self, Score, SearchSpec, TRAIN_SEED_BASE};
use crate::baselines::{Cell, CellSummary, GridSpec, run_grid};
use crate::episode::{Episode, EvidenceTiming, Outcome};
use crate::observation::{Observation, parse_scene, render_scene};
use crate::policy::{Expert, ExpertLate, Hedging, Policy, PolicyKind};
use crate::scenario::{ScenarioKind, ScenarioSet, Tier};
use serde::Serialize;

/// The bars (docs/validate.md).
pub const SOLVABLE_TIER1: f64 = 0.95;
pub const SOLVABLE_ANY: f64 = 0.85;
pub const ANTI_GAMING_MARGIN: f64 = 0.30;
pub const BITE_MARGIN: f64 = 0.30;
pub const TIER1_CUE_FOLLOWER_WITHIN: f64 = 0.20;
pub const EXPERT_CORRECTNESS: f64 = 0.90;
pub const CONSTANT_CORRECTNESS: f64 = 0.60;
pub const FOLLOWS_EVIDENCE: f64 = 0.95;
pub const LATE_READER: f64 = 0.85;
pub const TWO_LATE_READER: f64 = 0.60;
/// The cautious readers' bars: success and collision rate on every cell.
pub const CAUTIOUS_SUCCESS: f64 = 0.85;
pub const CAUTIOUS_COLLISION: f64 = 0.02;
/// The learned adversary's bars: its hack rate at most this above the
/// expert's own, and its masked success at least this below the expert's.
pub const LEARNED_HACK_MARGIN: f64 = 0.02;
pub const LEARNED_MASK_GAP: f64 = 0.30;
/// The longest reading delay the slack measurement tries (decisions).
pub const MAX_SLACK_LAG: usize = 6;
/// The hedging readers' braking levels (m/s^2): every tenth from 1.0 to 1.6.
pub const HEDGE_BRAKES_MPS2: [f64; 7] = [1.0, 1.1, 1.2, 1.3, 1.4, 1.5, 1.6];
/// The scenarios where people hedge from the first decision. On the merge,
/// dropping back on the ramp is itself giving the lane car its turn, so
/// hedging there means easing off only while unsure (`expert_cautious`).
pub const HEDGE_FROM_START: [ScenarioKind; 2] = [ScenarioKind::YieldStandoff, ScenarioKind::PedestrianFeint];
/// Road users move as people do: no pedestrian crosses slower than this
/// (m/s; the 15th percentile of older pedestrians' walking speed is 0.92,
/// of younger ones' 1.15, and the MUTCD's design speed 1.2) ...
pub const SLOWEST_CROSSING_MPS: f64 = 0.9;
/// ... a walker takes at least this long (s) to come to rest from its pace,
/// so that a reading can show it slowing (even a rapid stop on a signal
/// takes young adults 0.46 s from 1.29 m/s, older ones 0.57 s, Tirosh and
/// Sparrow 2004; a planned stop at a kerb is no sharper) ...
pub const QUICKEST_STOP_S: f64 = 0.5;
/// ... a pedestrian who follows another across sets out within this (s)
/// of it, and walks beside it (neighbours of a crossing pedestrian follow
/// it, Faria, Krause and Krause 2010; a group walks abreast at one pace,
/// Moussaïd et al. 2010) ...
pub const WIDEST_FOLLOW_S: f64 = 1.0;
/// ... no car brakes harder than this (m/s^2) on an open road (what
/// lifting off the accelerator slows a car by) ...
pub const OPEN_ROAD_BRAKE_MPS2: f64 = 0.5;
/// A driver who gives way to a road user that really goes first keeps at
/// least this many decisions to spare ...
pub const GIVE_WAY_SPARE_TURNS: u32 = 2;
/// ... in at least this share of those episodes.
pub const GIVE_WAY_SPARE_SHARE: f64 = 0.95;

/// The outcome of one invariant.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Check {
    pub name: &'static str,
    pub pass: bool,
    /// The deciding figure, for the one-line report.
    pub figure: String,
    /// Whether a failure fails `validate`. An invariant the built-in
    /// scenarios are known not to meet yet is reported as OPEN instead
    /// (`validate --strict` makes every check gating).
    pub gating: bool,
}

impl Check {
    fn new(name: &'static str, pass: bool, figure: String) -> Check {
        Check { name, pass, figure, gating: true }
    }

    pub fn line(&self) -> String {
        let status = match (self.pass, self.gating) {
            (true, _) => "PASS",
            (false, true) => "FAIL",
            (false, false) => "OPEN",
        };
        format!("{status:<5} {:<26} {}", self.name, self.figure)
    }

    /// A failure that fails the run.
    pub fn failed(&self) -> bool {
        !self.pass && self.gating
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

/// Every (scenario, tier) cell of `scenarios` by `tiers`, in that order.
fn cells_of(scenarios: &[ScenarioKind], tiers: &[Tier]) -> Vec<(ScenarioKind, Tier)> {
    scenarios.iter().flat_map(|&s| tiers.iter().map(move |&t| (s, t))).collect()
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
    Check::new(
        "solvable",
        pass && worst.is_some(),
        worst.map_or("no expert cells".into(), |w| format!("lowest: {}", w.1)),
    )
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
    Check::new(
        "anti-gaming",
        pass,
        worst.map_or("no cells".into(), |w| format!("smallest margin: {} (bar {ANTI_GAMING_MARGIN:.2})", w.1)),
    )
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
    Check::new(
        "tiers bite",
        pass && seen,
        format!(
            "expert - cue_follower: {} (tier 3 >= {BITE_MARGIN:.2}, tier 1 <= {TIER1_CUE_FOLLOWER_WITHIN:.2})",
            parts.join(", ")
        ),
    )
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
    Check::new(
        "reward ordering",
        collision_below && timeout_below && c_n + t_n + s_n > 0,
        format!(
            "collision max {c_max:.3} < timeout [{t_min:.3}, {t_max:.3}] < success min {s_min:.3} over {} episodes",
            c_n + t_n + s_n
        ),
    )
}

/// Expert decision correctness >= 0.90 and every constant policy <= 0.60,
/// on every cell (the searched blind policies are held to the same bar by
/// [`check_blind_play_loses`]).
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
    Check::new(
        "correctness honest",
        expert_min >= EXPERT_CORRECTNESS && constant_max <= CONSTANT_CORRECTNESS,
        format!(
            "expert min {expert_min:.3} ({where_e}, bar {EXPERT_CORRECTNESS:.2}); constant max {constant_max:.3} ({where_c}, bar {CONSTANT_CORRECTNESS:.2})"
        ),
    )
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
    let mut differing = 0usize;
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
                        if text(&a) != text(&b) {
                            differing += 1;
                            if failures.len() < 3 {
                                failures.push(format!("{}/t{t} seed {seed} turn {}", s, a.observation().turn));
                            }
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
        format!("{differing} of {compared} differ, e.g. {}", failures.join("; "))
    };
    (Check::new("hidden disposition", pass, figure), observations)
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
                example = format!("{} turn {}", o.scenario(), o.turn);
            }
        }
    }
    Check::new(
        "text carries the state",
        bad == 0 && !observations.is_empty(),
        if bad == 0 {
            format!("{} observations round-trip through the scene text", observations.len())
        } else {
            format!("{bad} of {} do not round-trip, e.g. {example}", observations.len())
        },
    )
}

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

/// How the road users of one cell moved, over every built-in policy's
/// episodes, and the speed limit its scene states for the other cars (the
/// merge's through lane has its own).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MotionCell {
    pub scenario: ScenarioKind,
    pub tier: Tier,
    pub motion: crate::scenario::world::Motion,
    pub speed_limit_mps: f64,
}

/// Play every built-in policy on every cell, seeds `seeds`, and gather how
/// the road users moved.
pub fn road_user_motion(
    set: &ScenarioSet,
    scenarios: &[ScenarioKind],
    tiers: &[Tier],
    seeds: std::ops::Range<u64>,
) -> Vec<MotionCell> {
    let keys = cells_of(scenarios, tiers);
    crate::par::par_map(&keys, |&(scenario, tier)| {
        let config = set.get(scenario);
        let mut motion = crate::scenario::world::Motion::default();
        for kind in PolicyKind::ALL {
            for seed in seeds.clone() {
                let mut policy = kind.build();
                let mut episode = Episode::new(config, tier, seed);
                policy.reset(crate::episode::policy_seed(episode.spec()));
                while !episode.is_done() {
                    let action = policy.act(episode.observation());
                    episode.step(action);
                }
                motion = motion.merge(episode.road_user_motion());
            }
        }
        let speed_limit_mps = motion.car_speed_limit_mps.unwrap_or(config.common().speed_limit_mps);
        MotionCell { scenario, tier, motion, speed_limit_mps }
    })
}

/// Road users move as people do: every pedestrian crosses at
/// [`SLOWEST_CROSSING_MPS`] or faster, comes to rest over
/// [`QUICKEST_STOP_S`] or more, follows another across within
/// [`WIDEST_FOLLOW_S`], no car brakes harder than
/// [`OPEN_ROAD_BRAKE_MPS2`] on an open road, and no car drives faster than
/// the speed limit the scene states. Each figure is printed beside its bar;
/// one outside it fails the line (docs/validate.md gives the sources and
/// the reasons a figure is still outside).
pub fn check_motion(cells: &[MotionCell]) -> Check {
    /// Which way a figure's bar lies.
    enum Bar {
        AtLeast(f64),
        AtMost(f64),
    }
    let mut parts = Vec::new();
    let mut pass = !cells.is_empty();
    // The worst cell's figure against its bar: pass or "outside", printed
    // by `say` (the figure, the cell, the bar's words).
    let mut bound = |figure: fn(&MotionCell) -> Option<f64>, bar: Bar, say: &dyn Fn(f64, &str, &str) -> String| {
        let figures = cells.iter().filter_map(|c| figure(c).map(|v| (v, c)));
        let worst = match bar {
            Bar::AtLeast(_) => figures.min_by(|a, b| a.0.total_cmp(&b.0)),
            Bar::AtMost(_) => figures.max_by(|a, b| a.0.total_cmp(&b.0)),
        };
        if let Some((v, c)) = worst {
            let (ok, words) = match bar {
                Bar::AtLeast(x) => (v + 1e-9 >= x, format!("bar >= {x:.2}")),
                Bar::AtMost(x) => (v <= x + 1e-9, format!("bar <= {x:.2}")),
            };
            pass &= ok;
            let words = if ok { words } else { format!("{words}, outside") };
            parts.push(say(v, &label(c.scenario, c.tier), &words));
        }
    };
    bound(|c| c.motion.slowest_crossing_mps, Bar::AtLeast(SLOWEST_CROSSING_MPS), &|v, at, bar| {
        format!("slowest crossing {v:.2} m/s on {at} ({bar})")
    });
    bound(|c| c.motion.quickest_stop_s, Bar::AtLeast(QUICKEST_STOP_S), &|v, at, bar| {
        format!("quickest stop from walking {v:.2} s on {at} ({bar})")
    });
    bound(|c| c.motion.widest_follow_s, Bar::AtMost(WIDEST_FOLLOW_S), &|v, at, bar| {
        format!("a follower sets out at most {v:.2} s after the one it follows on {at} ({bar})")
    });
    bound(|c| Some(c.motion.open_road_brake_mps2), Bar::AtMost(OPEN_ROAD_BRAKE_MPS2), &|v, at, bar| {
        format!("open-road braking at most {v:.2} m/s^2 on {at} ({bar})")
    });
    let over = cells
        .iter()
        .filter_map(|c| c.motion.fastest_car_mps.map(|v| (v - c.speed_limit_mps, v, c)))
        .max_by(|a, b| a.0.total_cmp(&b.0));
    if let Some((excess, v, c)) = over {
        let ok = excess <= 1e-9;
        pass &= ok;
        parts.push(format!(
            "fastest car {v:.2} m/s on {} (limit {:.1}{})",
            label(c.scenario, c.tier),
            c.speed_limit_mps,
            if ok { "" } else { ", outside" }
        ));
    }
    Check::new("road users move as people", pass, parts.join("; "))
}

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
    fn tried(&self) -> Tried<'_> {
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
struct Tried<'a> {
    scenario: ScenarioKind,
    tier: Tier,
    driver: &'a str,
    success: f64,
    collision: f64,
}

/// What a line that holds ways of driving to the caution bars
/// ([`CAUTIOUS_SUCCESS`], [`CAUTIOUS_COLLISION`]) prints of them.
struct CautionSummary {
    /// How many fall below a bar.
    below: usize,
    /// The lowest success and the highest collision rate, each with the
    /// way of driving and the cell, and how many fall below a bar.
    headline: String,
    /// Per cell, the lowest success and the highest collision rate of any
    /// way of driving tried there.
    per_cell: String,
}

impl CautionSummary {
    fn of(tried: &[Tried]) -> Option<CautionSummary> {
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

/// What the learned adversary reached on one cell, on held-out seeds, and
/// the expert's own hack rate on those seeds.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LearnedCell {
    pub scenario: ScenarioKind,
    pub tier: Tier,
    pub score: LearnedScore,
    pub masked: LearnedScore,
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
            expert_hack_rate: expert_hacks as f64 / held.len().max(1) as f64,
        }
    })
}

/// The learned adversary wins nothing with the wrong choice (its hack rate
/// at most 0.02 above the expert's own), and what it wins it wins by
/// reading: with the road users' slots frozen at their first reading its
/// success is at least 0.30 below the expert's.
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
        let margin = expert.success.estimate - c.masked.success;
        pass &= excess <= LEARNED_HACK_MARGIN + 1e-12 && margin >= LEARNED_MASK_GAP - 1e-12;
        if worst_hack.as_ref().is_none_or(|w| excess > w.0) {
            worst_hack = Some((excess, name.clone()));
        }
        if worst_mask.as_ref().is_none_or(|w| margin < w.0) {
            worst_mask = Some((margin, name.clone()));
        }
        per_cell.push(format!("{name} {:.2}/{:.2}/{:.2}", c.score.success, c.score.correctness, c.masked.success));
    }
    let (hack, mask) = (worst_hack.unwrap_or_default(), worst_mask.unwrap_or_default());
    Check::new(
        "learned adversary reads",
        pass,
        format!(
            "hack rate at most {:+.3} over the expert's ({}, bar +{LEARNED_HACK_MARGIN:.2}); expert - masked success at least {:.3} ({}, bar {LEARNED_MASK_GAP:.2}); per cell success/correctness/masked: {}",
            hack.0,
            hack.1,
            mask.0,
            mask.1,
            per_cell.join(", ")
        ),
    )
}

/// Caution is not a misreading: the expert's own rules driven with caution
/// while unsure (`expert_cautious`, `expert_hedge`) succeed >= 0.85 on every
/// cell with collisions <= 0.02. Hedging may cost reward, never the episode.
pub fn check_caution(cells: &[CellSummary]) -> Check {
    let mut pass = true;
    let mut seen = false;
    let mut worst: Option<(f64, String)> = None;
    let mut worst_collision: Option<(f64, String)> = None;
    // The scenario of each cell below a bar, and how many cells in all.
    let (mut below, mut total) = (Vec::new(), 0usize);
    for c in cells.iter().filter(|c| PolicyKind::CAUTIOUS_READERS.contains(&c.cell.policy)) {
        seen = true;
        total += 1;
        let (s, k) = (c.success.estimate, c.collision.estimate);
        let holds = s >= CAUTIOUS_SUCCESS && k <= CAUTIOUS_COLLISION;
        pass &= holds;
        if !holds {
            below.push(c.cell.scenario);
        }
        let at = format!("{} on {}", c.cell.policy, label(c.cell.scenario, c.cell.tier));
        if worst.as_ref().is_none_or(|(w, _)| s < *w) {
            worst = Some((s, at.clone()));
        }
        if worst_collision.as_ref().is_none_or(|(w, _)| k > *w) {
            worst_collision = Some((k, at));
        }
    }
    let figure = match (worst, worst_collision) {
        (Some(s), Some(k)) => {
            let cells_below = below.len();
            below.sort();
            below.dedup();
            let where_below = if below.is_empty() {
                String::new()
            } else {
                format!(" (all on {})", below.iter().map(ToString::to_string).collect::<Vec<_>>().join(", "))
            };
            format!(
                "lowest success {:.3} ({}, bar {CAUTIOUS_SUCCESS:.2}); highest collision {:.3} ({}, bar {CAUTIOUS_COLLISION:.2}); {} of {total} cells below a bar{where_below}",
                s.0, s.1, k.0, k.1, cells_below
            )
        }
        _ => "no cautious cells".into(),
    };
    Check::new("caution not punished", pass && seen, figure)
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
    let mut by_scenario: Vec<(ScenarioKind, usize)> = ScenarioKind::ALL.iter().map(|&k| (k, 0)).collect();
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

/// Invariants the built-in scenarios are known not to meet yet: printed as
/// OPEN, and not failing `validate` unless `strict`. A check goes here only
/// with a note on the issue that tracks it. Today: the way people hedge,
/// and the road users' motion against published human ranges
/// (docs/validate.md gives the figures, the bound that keeps each from
/// holding alongside blind play losing, and the change of design proposed).
pub const OPEN_CHECKS: [&str; 0] = [];

/// Run every invariant at `n` seeds per cell; the blind-policy search spends
/// `search_budget` episodes per cell. `strict`: every check gates, the open
/// ones included.
pub fn run(set: &ScenarioSet, n: usize, seed_base: u64, search_budget: usize, strict: bool) -> Vec<Check> {
    let spec = GridSpec {
        scenarios: ScenarioKind::ALL.to_vec(),
        tiers: Tier::ALL.to_vec(),
        policies: PolicyKind::ALL.to_vec(),
        episodes: n,
        seed_base,
    };
    let expert_timings = std::sync::Mutex::new(Vec::new());
    let unstoppable = std::sync::Mutex::new(Vec::new());
    let cells = run_grid(set, &spec, &|cell, records| {
        if cell.policy == PolicyKind::Expert {
            let mut t = expert_timings.lock().unwrap_or_else(|e| e.into_inner());
            t.extend(records.iter().map(|r| r.timing));
        }
        let n = records.iter().filter(|r| r.grades.diagnostics.unstoppable_turns_taken > 0).count();
        unstoppable.lock().unwrap_or_else(|e| e.into_inner()).push((cell, n));
    });
    let mut unstoppable = unstoppable.into_inner().unwrap_or_else(|e| e.into_inner());
    unstoppable.sort_by_key(|(c, _)| (c.scenario, c.tier, c.policy));
    let seeds = seed_base..seed_base + n as u64;
    let (hidden, observations) =
        check_hidden_disposition(set, &ScenarioKind::ALL, &Tier::ALL, seeds.clone(), &|e: &Episode| {
            render_scene(e.observation())
        });
    let late = late_readers(set, &ScenarioKind::ALL, &Tier::ALL, seeds.clone());
    let hedging = hedging_readers(set, &ScenarioKind::ALL, &Tier::ALL, seeds.clone());
    let defensive = defensive_readers(set, &ScenarioKind::ALL, &Tier::ALL, seeds.clone());
    let waits = reasons_to_wait(set, &ScenarioKind::ALL, &Tier::ALL, seeds.clone());
    let give_way = give_way_time(set, &ScenarioKind::ALL, &Tier::ALL, seeds.clone());
    let motion = road_user_motion(set, &ScenarioKind::ALL, &Tier::ALL, seeds.clone());
    let forecasts = forecast_references(set, &ScenarioKind::ALL, &Tier::ALL, seeds.clone());
    let blind = search_blind(set, &ScenarioKind::ALL, &Tier::ALL, seeds.clone(), search_budget);
    let learned = learned_adversaries(set, &ScenarioKind::ALL, &Tier::ALL, seeds, learned::DEFAULT_TRAINING);
    let timings = expert_timings.into_inner().unwrap_or_else(|e| e.into_inner());
    let mut checks = vec![
        check_solvable(&cells),
        check_anti_gaming(&cells),
        check_blind_play_loses(&cells, &blind),
        check_learned_adversary(&cells, &learned),
        check_tiers_bite(&cells),
        hidden,
        check_round_trip(&observations, &render_scene),
        check_reward_ordering(&cells),
        check_correctness(&cells),
        check_follows_evidence(&timings),
        check_late_reader(&late),
        check_give_way_time(&give_way),
        check_caution(&cells),
        check_hedging(&hedging),
        check_defensive(&defensive, &waits),
        check_gap_acceptance(&unstoppable, &blind),
        check_motion(&motion),
        check_forecast(&forecasts),
    ];
    for c in &mut checks {
        c.gating = strict || !OPEN_CHECKS.contains(&c.name);
    }
    checks
}
