//! The built-in adversarial search for a *blind* policy: one that never
//! looks at the other road user, only at the ego's own state and the clock.
//! A valid scenario makes every such policy lose (docs/scenarios.md, and
//! the "blind play loses" line of docs/validate.md), so
//! `validate` spends a fixed, seeded budget looking for one that wins anyway.
//!
//! The search space:
//! - open-loop schedules of (maneuver, magnitude) per turn: every two-phase
//!   schedule over a grid of actions and switch turns, a seeded sample of
//!   three-phase schedules, and a cross-entropy search over whole per-turn
//!   sequences started from the best schedule found;
//! - rules on the ego's own state and the clock: creep to a distance, hold
//!   for a time, then go; arrive at the conflict at a chosen clock time or at
//!   a chosen delay after the ego's own full-throttle arrival; hold a speed
//!   until a turn, then go.
//!
//! Candidates are ranked by successive halving on training seeds (all on a
//! few seeds, the best tenth on more, the best few on many), and the winner
//! is measured on held-out seeds that the search never saw. The signature
//! of a playing plan's `act` is the guarantee that a candidate is blind:
//! it receives an [`EgoState`], which holds nothing about the other road
//! user.

pub mod learned;

use crate::action::{Action, Maneuver};
use crate::episode::{Episode, Outcome};
use crate::observation::Observation;
use crate::rng::{EpisodeRng, Stream};
use crate::scenario::{ScenarioConfig, Tier};
use crate::sim::{EGO_MAX_ACCEL, travel_time};
use std::fmt;

/// What a blind policy may read: the ego's own state and the clock.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EgoState {
    pub turn: u32,
    pub time_s: f64,
    pub speed_mps: f64,
    pub to_conflict_m: f64,
    pub speed_limit_mps: f64,
}

impl EgoState {
    pub fn of(obs: &Observation) -> EgoState {
        EgoState {
            turn: obs.turn,
            time_s: obs.time_s,
            speed_mps: obs.ego.speed_mps,
            to_conflict_m: obs.ego_to_conflict_m(),
            speed_limit_mps: obs.ego.speed_limit_mps,
        }
    }
}

/// The actions a candidate chooses from: four maneuvers at three strengths.
const PALETTE: [Action; 12] = [
    Action::new(Maneuver::Proceed, 0.0),
    Action::new(Maneuver::Proceed, 0.5),
    Action::new(Maneuver::Proceed, 1.0),
    Action::new(Maneuver::NudgeForward, 0.0),
    Action::new(Maneuver::NudgeForward, 0.5),
    Action::new(Maneuver::NudgeForward, 1.0),
    Action::new(Maneuver::Yield, 0.0),
    Action::new(Maneuver::Yield, 0.5),
    Action::new(Maneuver::Yield, 1.0),
    Action::new(Maneuver::Stop, 0.0),
    Action::new(Maneuver::Stop, 0.5),
    Action::new(Maneuver::Stop, 1.0),
];

/// Turns at which a schedule may switch phase.
const SWITCH_TURNS: [u32; 17] = [1, 2, 3, 4, 5, 6, 7, 8, 10, 12, 14, 16, 18, 20, 24, 28, 32];

/// One blind candidate.
#[derive(Debug, Clone, PartialEq)]
pub enum BlindPlan {
    /// Open loop: palette indices per turn; the last one repeats.
    Schedule(Vec<u8>),
    /// Approach with `approach` until within `distance_m` of the conflict,
    /// hold with `hold` for `hold_turns` turns, then `go`.
    CreepHoldGo { approach: u8, distance_m: f64, hold: u8, hold_turns: u32, go: u8 },
    /// Track the speed that reaches the conflict at clock time `arrive_s`
    /// (or, when `relative`, that long after the ego's own full-throttle
    /// arrival computed on the first turn), then go at full strength.
    TimedArrival { arrive_s: f64, relative: bool },
    /// Hold `speed_mps` until turn `until_turn`, then go at full strength.
    SpeedUntil { speed_mps: f64, until_turn: u32 },
}

impl fmt::Display for BlindPlan {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = |i: u8| {
            let a = PALETTE[i as usize];
            format!("{} {:.1}", a.maneuver, a.acceleration)
        };
        match self {
            BlindPlan::Schedule(turns) => {
                // Run-length form: "nudge_forward 0.5 x12, proceed 1.0 x*".
                let mut runs: Vec<(u8, usize)> = Vec::new();
                for &t in turns {
                    match runs.last_mut() {
                        Some((last, n)) if *last == t => *n += 1,
                        _ => runs.push((t, 1)),
                    }
                }
                let parts: Vec<String> = runs
                    .iter()
                    .enumerate()
                    .map(|(i, (a, n))| {
                        if i + 1 == runs.len() { format!("{} then on", name(*a)) } else { format!("{} x{n}", name(*a)) }
                    })
                    .collect();
                write!(f, "schedule: {}", parts.join(", "))
            }
            BlindPlan::CreepHoldGo { approach, distance_m, hold, hold_turns, go } => write!(
                f,
                "rule: {} to {distance_m:.1} m, {} for {hold_turns} turns, then {}",
                name(*approach),
                name(*hold),
                name(*go)
            ),
            BlindPlan::TimedArrival { arrive_s, relative: false } => {
                write!(f, "rule: reach the conflict at t = {arrive_s:.2} s, then proceed 1.0")
            }
            BlindPlan::TimedArrival { arrive_s, relative: true } => {
                write!(f, "rule: reach the conflict {arrive_s:.2} s after a full-throttle arrival, then proceed 1.0")
            }
            BlindPlan::SpeedUntil { speed_mps, until_turn } => {
                write!(f, "rule: hold {speed_mps:.1} m/s until turn {until_turn}, then proceed 1.0")
            }
        }
    }
}

/// A speed-tracking action built from the maneuvers (a blind policy has no
/// "hold speed" maneuver, so it alternates between them).
fn track_speed(target: f64, v: f64) -> Action {
    if target <= 0.05 {
        Action::new(Maneuver::Stop, 0.5)
    } else if v < target - 0.3 {
        Action::new(Maneuver::Proceed, ((target - v) / 3.0).clamp(0.0, 1.0))
    } else if v > target + 0.3 {
        Action::new(Maneuver::Yield, ((v - target) / 3.0).clamp(0.0, 1.0))
    } else if target <= crate::action::CREEP_SPEED + 0.3 {
        Action::new(Maneuver::NudgeForward, 0.5)
    } else if v < target {
        Action::new(Maneuver::Proceed, 0.0)
    } else {
        Action::new(Maneuver::Yield, 0.0)
    }
}

/// A blind plan being played: the plan plus what it remembers.
struct Runner<'a> {
    plan: &'a BlindPlan,
    /// CreepHoldGo: the turn at which the distance was reached.
    reached_at: Option<u32>,
    /// TimedArrival (relative): the absolute arrival time fixed on turn 1.
    arrive_at: Option<f64>,
}

impl BlindPlan {
    fn runner(&self) -> Runner<'_> {
        Runner { plan: self, reached_at: None, arrive_at: None }
    }
}

impl Runner<'_> {
    /// The plan's action: a function of the ego's own state and the clock
    /// only (and of what the plan itself remembered from earlier turns).
    fn act(&mut self, ego: EgoState) -> Action {
        match self.plan {
            BlindPlan::Schedule(turns) => {
                let i = (ego.turn as usize).saturating_sub(1).min(turns.len() - 1);
                PALETTE[turns[i] as usize]
            }
            BlindPlan::CreepHoldGo { approach, distance_m, hold, hold_turns, go } => {
                if self.reached_at.is_none() && ego.to_conflict_m <= *distance_m {
                    self.reached_at = Some(ego.turn);
                }
                match self.reached_at {
                    None => PALETTE[*approach as usize],
                    Some(t) if ego.turn < t + hold_turns => PALETTE[*hold as usize],
                    Some(_) => PALETTE[*go as usize],
                }
            }
            BlindPlan::TimedArrival { arrive_s, relative } => {
                let arrive_at = *self.arrive_at.get_or_insert_with(|| {
                    let base = if *relative {
                        ego.time_s + travel_time(ego.to_conflict_m, ego.speed_mps, ego.speed_limit_mps, EGO_MAX_ACCEL)
                    } else {
                        0.0
                    };
                    base + arrive_s
                });
                let left = arrive_at - ego.time_s;
                if left <= 0.25 || ego.to_conflict_m <= 0.0 {
                    Action::new(Maneuver::Proceed, 1.0)
                } else {
                    track_speed((ego.to_conflict_m / left).min(ego.speed_limit_mps), ego.speed_mps)
                }
            }
            BlindPlan::SpeedUntil { speed_mps, until_turn } => {
                if ego.turn >= *until_turn {
                    Action::new(Maneuver::Proceed, 1.0)
                } else {
                    track_speed(*speed_mps, ego.speed_mps)
                }
            }
        }
    }
}

/// Scores of one candidate over a set of seeds.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct Score {
    pub episodes: usize,
    pub success: f64,
    pub correctness: f64,
    pub reward: f64,
    /// Episodes in which a road user that had waited for the ego started
    /// into its path while the ego could no longer stop comfortably.
    pub unstoppable_turns_taken: usize,
}

/// Play `plan` on one cell for each seed.
pub fn evaluate(config: &ScenarioConfig, tier: Tier, plan: &BlindPlan, seeds: &[u64]) -> Score {
    let (mut success, mut correctness, mut reward, mut unstoppable) = (0usize, 0.0, 0.0, 0usize);
    for &seed in seeds {
        let mut episode = Episode::new(config, tier, seed);
        // The evidence turn is not needed here; skipping the twin world
        // halves the cost of the search.
        episode.skip_evidence();
        let mut runner = plan.runner();
        while !episode.is_done() {
            let action = runner.act(EgoState::of(episode.observation()));
            episode.step(action);
        }
        let record = episode.finish();
        success += (record.outcome == Outcome::Success) as usize;
        correctness += record.grades.decision_correctness;
        reward += record.grades.reward;
        unstoppable += (record.grades.diagnostics.unstoppable_turns_taken > 0) as usize;
    }
    let n = seeds.len().max(1) as f64;
    Score {
        episodes: seeds.len(),
        success: success as f64 / n,
        correctness: correctness / n,
        reward: reward / n,
        unstoppable_turns_taken: unstoppable,
    }
}

/// What to search on one cell.
#[derive(Debug, Clone, Copy)]
pub struct SearchSpec {
    /// Episodes the search may play on this cell (the held-out measurement
    /// is not counted).
    pub budget: usize,
    /// First training seed; training seeds never overlap the held-out ones.
    pub train_seed_base: u64,
    /// Seed of the search's own randomness (three-phase sample, CEM).
    pub search_seed: u64,
}

/// Default episodes per cell: keeps `validate` under 30 s on 2 cores.
pub const DEFAULT_BUDGET: usize = 60_000;
/// Largest budget `--search-budget` accepts (about an hour on 2 cores).
pub const MAX_BUDGET: usize = 50_000_000;
/// Training seeds start here; `validate`'s held-out seeds start at 0.
pub const TRAIN_SEED_BASE: u64 = 1_000_000_000;

/// The search's findings on one cell.
#[derive(Debug, Clone, PartialEq)]
pub struct Finding {
    /// Best candidate by training success, and its training score.
    pub best: BlindPlan,
    pub train: Score,
    /// Best candidate by training decision correctness.
    pub best_correctness: BlindPlan,
    pub train_correctness: Score,
    /// Candidates scored and episodes played.
    pub candidates: usize,
    pub episodes: usize,
}

/// Every candidate of the grid part of the search space (schedules and
/// rules), in a fixed order.
fn grid_candidates(turn_budget: u32, rng: &mut EpisodeRng, three_phase: usize) -> Vec<BlindPlan> {
    let n = turn_budget as usize;
    let mut out = Vec::new();
    let palette = 0..PALETTE.len() as u8;
    // Constant schedules, then two-phase ones.
    for a in palette.clone() {
        out.push(BlindPlan::Schedule(vec![a]));
    }
    for a1 in palette.clone() {
        for &k in SWITCH_TURNS.iter().filter(|&&k| (k as usize) < n) {
            for a2 in palette.clone().filter(|&a2| a2 != a1) {
                let mut turns = vec![a1; k as usize];
                turns.push(a2);
                out.push(BlindPlan::Schedule(turns));
            }
        }
    }
    // A seeded sample of three-phase schedules.
    let switches: Vec<u32> = SWITCH_TURNS.iter().copied().filter(|&k| (k as usize) < n).collect();
    for _ in 0..three_phase {
        let pick = |rng: &mut EpisodeRng| rng.below(PALETTE.len() as u64) as u8;
        let (a1, a2, a3) = (pick(rng), pick(rng), pick(rng));
        let k1 = switches[rng.below(switches.len() as u64) as usize] as usize;
        let k2 = 1 + rng.below(12) as usize;
        let mut turns = vec![a1; k1];
        turns.extend(std::iter::repeat_n(a2, k2));
        turns.push(a3);
        turns.truncate(n);
        out.push(BlindPlan::Schedule(turns));
    }
    // Rules on the ego's own state and the clock.
    let approaches = [1u8, 2, 4, 6, 7];
    let holds = [9u8, 10, 4];
    let goes = [2u8, 1, 5];
    for &approach in &approaches {
        for distance_m in [0.5, 2.0, 4.0, 6.0, 8.0, 12.0, 16.0, 24.0] {
            for &hold in &holds {
                for hold_turns in [0, 1, 2, 3, 4, 6, 8, 10, 12, 16] {
                    for &go in &goes {
                        out.push(BlindPlan::CreepHoldGo { approach, distance_m, hold, hold_turns, go });
                    }
                }
            }
        }
    }
    for i in 0..=64 {
        out.push(BlindPlan::TimedArrival { arrive_s: 1.0 + 0.25 * i as f64, relative: false });
    }
    for i in 0..=40 {
        out.push(BlindPlan::TimedArrival { arrive_s: -0.5 + 0.25 * i as f64, relative: true });
    }
    for speed_mps in [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 10.0, 12.0] {
        for &until_turn in &switches {
            out.push(BlindPlan::SpeedUntil { speed_mps, until_turn });
        }
    }
    out
}

fn seeds(base: u64, from: usize, n: usize) -> Vec<u64> {
    (from..from + n).map(|i| base.wrapping_add(i as u64)).collect()
}

/// Rank by success, then reward (a candidate that wins more, or wins as
/// often but more cleanly, is the stronger adversary), then order.
fn better(a: &Score, b: &Score) -> bool {
    (a.success, a.reward) > (b.success, b.reward)
}

/// The scenario's part of the search's random key: its RNG id less one,
/// the scenario's index when this key was fixed, so that every published
/// search finding reproduces.
fn search_id(kind: crate::scenario::ScenarioKind) -> u64 {
    kind.rng_id() - 1
}

/// Run the search on one cell.
pub fn search(config: &ScenarioConfig, tier: Tier, spec: SearchSpec) -> Finding {
    let turn_budget = config.common().turn_budget.get(tier);
    let mut rng = EpisodeRng::new(&[spec.search_seed, search_id(config.kind()), tier.number() as u64], Stream::Policy);
    let candidates = grid_candidates(turn_budget, &mut rng, 1500);
    let mut played = 0usize;
    // Budget shares: 45% screening, 20% refining, 10% final, 25% CEM.
    let screen_seeds = (spec.budget * 45 / 100 / candidates.len()).clamp(4, 4096);
    let pool = seeds(spec.train_seed_base, 0, 4096);
    let scored = crate::par::par_map(&candidates, |c| evaluate(config, tier, c, &pool[..screen_seeds]));
    played += screen_seeds * candidates.len();
    let mut order: Vec<usize> = (0..candidates.len()).collect();
    let rank = |order: &mut Vec<usize>, scores: &[Score], by_correctness: bool| {
        order.sort_by(|&a, &b| {
            let (sa, sb) = (&scores[a], &scores[b]);
            let key = |s: &Score| if by_correctness { (s.correctness, s.success) } else { (s.success, s.reward) };
            key(sb).partial_cmp(&key(sa)).unwrap_or(std::cmp::Ordering::Equal).then(a.cmp(&b))
        });
    };
    // Keep the best tenth by success and the best few by correctness.
    rank(&mut order, &scored, false);
    let mut keep: Vec<usize> = order.iter().copied().take((candidates.len() / 10).max(8)).collect();
    rank(&mut order, &scored, true);
    keep.extend(order.iter().copied().take(16));
    keep.sort_unstable();
    keep.dedup();
    let refine_seeds = (spec.budget * 20 / 100 / keep.len()).clamp(8, 4096);
    let kept: Vec<BlindPlan> = keep.iter().map(|&i| candidates[i].clone()).collect();
    let refined = crate::par::par_map(&kept, |c| evaluate(config, tier, c, &pool[..refine_seeds]));
    played += refine_seeds * kept.len();

    // Cross-entropy over whole per-turn sequences, started from the best
    // refined schedule (expanded turn by turn).
    let best_refined = (0..kept.len())
        .reduce(|a, b| if better(&refined[b], &refined[a]) { b } else { a })
        .expect("at least one candidate");
    let cem = cross_entropy(config, tier, &kept[best_refined], turn_budget, spec.budget * 25 / 100, &pool, &mut rng);
    played += cem.1;

    // Final: the best few of every stage on many seeds.
    let mut finalists: Vec<BlindPlan> = Vec::new();
    let mut by_success: Vec<usize> = (0..kept.len()).collect();
    rank(&mut by_success, &refined, false);
    finalists.extend(by_success.iter().take(6).map(|&i| kept[i].clone()));
    let mut by_correctness: Vec<usize> = (0..kept.len()).collect();
    rank(&mut by_correctness, &refined, true);
    finalists.extend(by_correctness.iter().take(3).map(|&i| kept[i].clone()));
    finalists.extend(cem.0);
    let final_seeds = (spec.budget * 10 / 100 / finalists.len()).max(16).min(pool.len());
    let finals = crate::par::par_map(&finalists, |c| evaluate(config, tier, c, &pool[..final_seeds]));
    played += final_seeds * finalists.len();
    let pick = |by_correctness: bool| {
        let mut order: Vec<usize> = (0..finalists.len()).collect();
        rank(&mut order, &finals, by_correctness);
        order[0]
    };
    let (s, c) = (pick(false), pick(true));
    Finding {
        best: finalists[s].clone(),
        train: finals[s],
        best_correctness: finalists[c].clone(),
        train_correctness: finals[c],
        candidates: candidates.len() + finalists.len(),
        episodes: played,
    }
}

/// Cross-entropy method over per-turn palette choices. Returns the best
/// sequences seen (by success, and by correctness) and the episodes played.
fn cross_entropy(
    config: &ScenarioConfig,
    tier: Tier,
    start: &BlindPlan,
    turn_budget: u32,
    budget: usize,
    pool: &[u64],
    rng: &mut EpisodeRng,
) -> (Vec<BlindPlan>, usize) {
    const POPULATION: usize = 48;
    const ELITES: usize = 8;
    let n = turn_budget as usize;
    let k = PALETTE.len();
    let seeds_per = 24usize;
    let iterations = (budget / (POPULATION * seeds_per)).max(1);
    // Initial distribution: the start plan's choice per turn (when it is a
    // schedule) mixed with uniform.
    let mut probs = vec![vec![1.0 / k as f64; k]; n];
    if let BlindPlan::Schedule(turns) = start {
        for (t, p) in probs.iter_mut().enumerate() {
            let a = turns[t.min(turns.len() - 1)] as usize;
            for (i, x) in p.iter_mut().enumerate() {
                *x = 0.5 / k as f64 + if i == a { 0.5 } else { 0.0 };
            }
        }
    }
    let mut best: Option<(Score, BlindPlan)> = None;
    let mut best_c: Option<(Score, BlindPlan)> = None;
    let mut played = 0;
    for it in 0..iterations {
        let population: Vec<BlindPlan> = (0..POPULATION)
            .map(|_| {
                BlindPlan::Schedule(
                    probs
                        .iter()
                        .map(|p| {
                            let mut u = rng.unit();
                            let mut choice = k - 1;
                            for (i, x) in p.iter().enumerate() {
                                if u < *x {
                                    choice = i;
                                    break;
                                }
                                u -= x;
                            }
                            choice as u8
                        })
                        .collect(),
                )
            })
            .collect();
        let from = (it * seeds_per) % (pool.len() - seeds_per);
        let scores = crate::par::par_map(&population, |c| evaluate(config, tier, c, &pool[from..from + seeds_per]));
        played += POPULATION * seeds_per;
        let mut order: Vec<usize> = (0..POPULATION).collect();
        order.sort_by(|&a, &b| {
            (scores[b].success, scores[b].reward)
                .partial_cmp(&(scores[a].success, scores[a].reward))
                .unwrap_or(std::cmp::Ordering::Equal)
                .then(a.cmp(&b))
        });
        for &i in &order[..1] {
            if best.as_ref().is_none_or(|(s, _)| better(&scores[i], s)) {
                best = Some((scores[i], population[i].clone()));
            }
        }
        let top_c = (0..POPULATION)
            .reduce(|a, b| if scores[b].correctness > scores[a].correctness { b } else { a })
            .expect("non-empty population");
        if best_c.as_ref().is_none_or(|(s, _)| scores[top_c].correctness > s.correctness) {
            best_c = Some((scores[top_c], population[top_c].clone()));
        }
        // Move the distribution toward the elites, keeping some mass on
        // every choice so the search does not collapse early.
        for (t, p) in probs.iter_mut().enumerate() {
            let mut counts = vec![0.0; k];
            for &i in &order[..ELITES] {
                if let BlindPlan::Schedule(turns) = &population[i] {
                    counts[turns[t] as usize] += 1.0 / ELITES as f64;
                }
            }
            for (x, c) in p.iter_mut().zip(counts) {
                *x = 0.3 * *x + 0.7 * c + 0.01 / k as f64;
            }
            let total: f64 = p.iter().sum();
            p.iter_mut().for_each(|x| *x /= total);
        }
    }
    let plans = best.into_iter().chain(best_c).map(|(_, p)| p).collect();
    (plans, played)
}
