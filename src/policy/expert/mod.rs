//! Behaviour-conditioned rule policies. Both read only the public
//! observation, so `negotiator serve` can run them from the scene text.
//!
//! The expert waits for a *committed* signal before going (a car that has
//! actually stopped, a pedestrian who waits or crosses, a lane car that makes
//! room), keeps the pace of a car that means to go while a hard stop stays
//! possible, and lets the other go first otherwise. The cue follower acts on
//! the instantaneous cue instead: the other is braking, so go. The late
//! expert is the expert reading the scene one decision late. The rules of
//! each scenario are in this module's files, one per scenario: they read
//! only the public `Scene`, never a world.

mod hedging;

/// The expert's part of the scenario registry: a file of rules per
/// scenario, in the registry's order.
macro_rules! expert_rules {
    ($($name:ident),+) => {
        $(mod $name;)+

        /// Every scenario's rules, in the order of `ScenarioKind::ALL`.
        const RULES: [&Rules; ScenarioKind::ALL.len()] = [$(&$name::RULES),+];
    };
}
crate::scenario::registry!(expert_rules);

use super::Policy;
use crate::action::{Action, Maneuver};
use crate::observation::{Observation, Scene};
use crate::scenario::ScenarioKind;
pub use hedging::{HEDGE_BRAKE_MPS2, HEDGE_SECONDS, Hedging, HedgingReader};

/// Whether a road user that is not the tier's question gives a careful
/// driver reason not to pass the conflict on `obs` (its scenario's
/// rules' `watch`; `confirm`: a walker is stopped only once two readings
/// show it still). `validate` reads it at the evidence turn.
pub fn watching(obs: &Observation, confirm: bool) -> bool {
    rules(&obs.scene).is_some_and(|r| (r.watch)(obs, confirm))
}

/// One scenario's rules, each reading only its public scene and the ego's
/// speed (and, for the expert, its last action). Each scenario's file
/// defines its own.
pub(crate) struct Rules {
    expert: fn(&Observation) -> Move,
    cue_follower: fn(&Scene, f64, f64) -> Action,
    /// The habit a driving instructor teaches, over every road user that is
    /// not the tier's question: whether one is moving toward the ego's path
    /// and could reach it by the time the car does, so that a careful
    /// driver does not pass the conflict yet. With `confirm` (the
    /// defensive readers), a walker counts as stopped only once a second
    /// reading shows it still.
    watch: fn(&Observation, bool) -> bool,
}

/// What the expert's rules decide on one scene: the action, and whether it
/// is the go they wait for (`go`), or anything short of it: keeping a pace
/// or a stop possible while the intent is unknown, or giving way. The
/// cautious baselines change only the moves short of a go.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Move {
    pub action: Action,
    pub go: bool,
}

impl Move {
    /// The go the rules wait for.
    pub(crate) fn go(action: Action) -> Move {
        Move { action, go: true }
    }

    /// Anything short of it.
    pub(crate) fn not_yet(action: Action) -> Move {
        Move { action, go: false }
    }
}

/// The rules of the scene's scenario. A scenario outside the benchmark (a
/// test's) has none: it is played by giving way short of the conflict.
fn rules(scene: &Scene) -> Option<&'static Rules> {
    scene.kind().index().map(|i| RULES[i])
}

/// Give way short of the conflict: the move of a policy with no rule for
/// the scene.
fn hold_back(scene: &Scene, v: f64) -> Action {
    super::hedge(v, scene.ego_to_conflict_m())
}

/// The expert's move on `obs`: its scene's scenario's rule, watching every
/// road user (the skill ceiling does not rely on knowing which of them are
/// scenery).
fn expert_move(obs: &Observation) -> Move {
    watched_move(obs, false)
}

/// The rules' move, held back short of the conflict while a road user that
/// is not the tier's question could still reach the ego's path (as
/// [`Rules::watch`] reads it, `confirm`ing stops or not), and the ego can
/// still stop comfortably before the conflict (past that, going on is the
/// safe play).
fn watched_move(obs: &Observation, confirm: bool) -> Move {
    let (v, d) = (obs.ego.speed_mps, obs.ego_to_conflict_m());
    let Some(r) = rules(&obs.scene) else { return Move::not_yet(hold_back(&obs.scene, v)) };
    let m = (r.expert)(obs);
    let can_stop = d > 0.0 && v * v / (2.0 * crate::scenario::world::FIRM_BRAKE) < d;
    if m.go && can_stop && (r.watch)(obs, confirm) { Move::not_yet(hold_back(&obs.scene, v)) } else { m }
}

/// Of two actions, the one that brakes harder (accelerates less) at speed
/// `v`, by the acceleration each commands.
pub(crate) fn gentler(v: f64, v_max: f64, a: Action, b: Action) -> Action {
    let acc = |x: &Action| x.control().acceleration(v, v_max, crate::sim::DT);
    if acc(&a) <= acc(&b) { a } else { b }
}

/// Of two actions, the one that brakes less (or speeds up more) at speed
/// `v`: [`gentler`]'s other choice.
pub(crate) fn bolder(v: f64, v_max: f64, a: Action, b: Action) -> Action {
    if gentler(v, v_max, a, b) == a { b } else { a }
}

/// The cue follower's action on `scene`: its scenario's instantaneous-cue rule.
fn cue_action(scene: &Scene, v: f64, v_max: f64) -> Action {
    rules(scene).map_or_else(|| hold_back(scene, v), |r| (r.cue_follower)(scene, v, v_max))
}

pub struct Expert;
pub struct CueFollower;

/// `yield` at this strength brakes at 0.5 + 3.5 x 0.25 = 1.375 m/s^2: the
/// gentle braking of a driver who slows while unsure.
const GENTLE_YIELD: f64 = 0.25;

/// The expert's own rules, braking gently whenever they would not yet go:
/// a driver who slows while unsure, and otherwise drives as the expert
/// does (where the rules brake harder, it brakes as hard). Hedging costs
/// reward, never the episode: `validate` holds it to the expert's bar.
pub struct ExpertCautious;

/// The paper's hedge for a delayed reveal: "approach slowly and be ready to
/// stop until intent resolves". The expert's own rules, but until they go,
/// at most a moderate speed ([`MODERATE_FRACTION`] of the limit) and never
/// closer than a comfortable stop allows (the [`super::hedge`] approach).
pub struct ExpertHedge;

/// The hedge's moderate speed, as a fraction of the speed limit.
pub const MODERATE_FRACTION: f64 = 0.6;

/// The expert reading the other road users `lag` decisions late: its own
/// rules, acting on the scene of `lag` decisions ago with its own state
/// (speed, distance, last action) current. Nothing else differs, so its
/// score against the expert's is what that much reaction time costs. Before
/// it has seen `lag` earlier scenes it reads the oldest it has (the first
/// scene is the same under both dispositions).
pub struct ExpertLate {
    lag: usize,
    /// The scenes seen so far this episode and when, oldest first.
    seen: Vec<(Scene, f64)>,
}

impl ExpertLate {
    pub fn new(lag: usize) -> ExpertLate {
        ExpertLate { lag, seen: Vec::with_capacity(48) }
    }

    /// The observation it acts on: `obs` with the road users as they were
    /// `lag` decisions ago, and the clock then (what it has taken in is
    /// that old: "still standing at 2.5 s" is read at 2.5 s).
    fn late_view(&mut self, obs: &Observation) -> Observation {
        // A new episode (a policy reused without `reset`) starts afresh.
        if obs.turn <= 1 {
            self.seen.clear();
        }
        self.seen.push((obs.scene, obs.time_s));
        let (older, then) = self.seen[self.seen.len().saturating_sub(1 + self.lag)];
        Observation { scene: obs.scene.with_road_users_of(&older), time_s: then, ..*obs }
    }
}

impl Policy for Expert {
    fn act(&mut self, obs: &Observation) -> Action {
        expert_move(obs).action
    }

    /// The reference belief: the ideal observer's.
    fn belief(&mut self, _obs: &Observation, _action: &Action, ideal: f64) -> f64 {
        ideal
    }
}

impl Policy for ExpertCautious {
    fn act(&mut self, obs: &Observation) -> Action {
        let (v, v_max) = (obs.ego.speed_mps, obs.ego.speed_limit_mps);
        let m = expert_move(obs);
        if m.go { m.action } else { gentler(v, v_max, m.action, Action::new(Maneuver::Yield, GENTLE_YIELD)) }
    }
}

impl Policy for ExpertHedge {
    fn act(&mut self, obs: &Observation) -> Action {
        let (v, v_max) = (obs.ego.speed_mps, obs.ego.speed_limit_mps);
        let m = expert_move(obs);
        if m.go {
            return m.action;
        }
        let moderate = MODERATE_FRACTION * v_max;
        // Down to the moderate speed gently, then hold it.
        let cap = if v > moderate + 0.2 { Action::new(Maneuver::Yield, GENTLE_YIELD) } else { Action::hold() };
        let ready = super::hedge(v, obs.ego_to_conflict_m() - HEDGE_WAIT_M);
        gentler(v, v_max, m.action, gentler(v, v_max, cap, ready))
    }
}

/// Where the hedge is ready to stop: this far before the conflict (m).
const HEDGE_WAIT_M: f64 = 2.0;

impl Policy for ExpertLate {
    fn reset(&mut self, _policy_seed: u64) {
        self.seen.clear();
    }

    fn remembers(&self) -> bool {
        true
    }

    fn act(&mut self, obs: &Observation) -> Action {
        let view = self.late_view(obs);
        Expert.act(&view)
    }
}

impl Policy for CueFollower {
    fn act(&mut self, obs: &Observation) -> Action {
        cue_action(&obs.scene, obs.ego.speed_mps, obs.ego.speed_limit_mps)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::episode::run_episode;
    use crate::scenario::{ScenarioKind, ScenarioSet, Tier};

    /// The cautious readers change only the moves short of a go: where the
    /// rules go, they go as the expert does; elsewhere they brake at least
    /// gently (the cautious reader) or hold at most a moderate speed (the
    /// hedge), never accelerating harder than the expert would.
    #[test]
    fn the_cautious_readers_change_only_the_moves_short_of_a_go() {
        let set = ScenarioSet::default();
        let accel = |a: Action, v: f64, v_max: f64| a.control().acceleration(v, v_max, crate::sim::DT);
        for kind in ScenarioKind::ALL {
            for tier in Tier::ALL {
                for seed in 0..20 {
                    for which in 0..2 {
                        let mut episode = crate::episode::Episode::new(set.get(kind), tier, seed);
                        let mut policy: Box<dyn Policy> =
                            if which == 0 { Box::new(ExpertCautious) } else { Box::new(ExpertHedge) };
                        while !episode.is_done() {
                            let obs = *episode.observation();
                            let (v, v_max) = (obs.ego.speed_mps, obs.ego.speed_limit_mps);
                            let m = expert_move(&obs);
                            let action = policy.act(&obs);
                            if m.go {
                                assert_eq!(action, m.action, "{kind}/t{tier} seed {seed}");
                            } else {
                                assert!(accel(action, v, v_max) <= accel(m.action, v, v_max) + 1e-12);
                                if which == 0 && v > 0.5 {
                                    let gentle = Action::new(Maneuver::Yield, GENTLE_YIELD);
                                    assert!(accel(action, v, v_max) <= accel(gentle, v, v_max) + 1e-12);
                                }
                                if which == 1 && v > MODERATE_FRACTION * v_max + 0.2 {
                                    assert!(accel(action, v, v_max) < 0.0, "{kind}/t{tier} seed {seed} v {v}");
                                }
                            }
                            episode.step(action);
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn reading_zero_decisions_late_is_the_expert() {
        let set = ScenarioSet::default();
        for kind in ScenarioKind::ALL {
            for tier in Tier::ALL {
                for seed in 0..20 {
                    let late = run_episode(set.get(kind), tier, seed, &mut ExpertLate::new(0));
                    let expert = run_episode(set.get(kind), tier, seed, &mut Expert);
                    assert_eq!(late.decisions, expert.decisions, "{kind}/t{tier} seed {seed}");
                }
            }
        }
    }

    #[test]
    fn a_late_expert_reused_across_episodes_plays_each_afresh() {
        let set = ScenarioSet::default();
        let config = set.get(ScenarioKind::YieldStandoff);
        let mut reused = ExpertLate::new(1);
        for seed in 0..10 {
            let again = run_episode(config, Tier::T2, seed, &mut reused);
            let fresh = run_episode(config, Tier::T2, seed, &mut ExpertLate::new(1));
            assert_eq!(again.decisions, fresh.decisions, "seed {seed}");
        }
    }

    #[test]
    fn the_late_view_keeps_the_ego_current_and_the_road_users_old() {
        let set = ScenarioSet::default();
        for kind in ScenarioKind::ALL {
            let mut episode = crate::episode::Episode::new(set.get(kind), Tier::T1, 3);
            let mut late = ExpertLate::new(1);
            let mut previous: Option<Observation> = None;
            while !episode.is_done() {
                let obs = *episode.observation();
                let view = late.late_view(&obs);
                assert_eq!(view.ego, obs.ego);
                assert_eq!(view.ego_to_conflict_m(), obs.ego_to_conflict_m());
                let older = previous.unwrap_or(obs);
                // Speeds are as the older scene showed them.
                for (seen, then) in view.scene.tracks().iter().zip(older.scene.tracks()) {
                    assert_eq!(seen.now.velocity_mps, then.now.velocity_mps, "{kind}");
                }
                previous = Some(obs);
                episode.step(Expert.act(&obs));
            }
        }
    }
}
