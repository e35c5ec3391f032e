//! The observation as a fixed-length numeric vector, for policies that do
//! not read text (a classic RL agent, a small network). Every scenario and
//! tier gives the same length and the same slot meanings; a slot a scenario
//! does not use holds 0 and its `present` flag says so. Units are SI (m,
//! m/s, m/s^2, s), unscaled: normalise in the agent. It names no scenario:
//! its layout is the same whatever scenarios the benchmark holds, so that
//! adding one changes no trained agent's input (an agent learns one cell).
//!
//! It is computed from the observation rounded to the scene text's
//! precision, so it carries exactly what the text does, nothing the
//! disposition could leak through below the printed digits.
//!
//! Road-user slots follow the scene's order (`Scene::tracks`): on
//! `yield_standoff` the other car then the car behind it (metres from the
//! ego lane's near edge; the third slot is absent), on `pedestrian_feint`
//! the pedestrian then its two companions (lateral metres from the near
//! kerb), on `contested_merge` the lane car then the car behind it (centre
//! to centre relative to the ego, positive ahead; the third slot is
//! absent). Each slot holds the current
//! sample and the four past ones (t-2.0 .. t-0.5 s, oldest first).

use crate::action::{Action, Maneuver};
use crate::observation::{HISTORY_LEN, Observation};
use crate::scenario::{ScenarioKind, Tier};

/// Road-user slots in the vector: the most a scene may have, so that the
/// layout is the same whatever scenarios the benchmark holds.
const TRACK_SLOTS: usize = crate::scenario::MAX_TRACKS;

/// Collects (name, value) pairs in layout order; the names and the values
/// come from the same code, so the published layout cannot drift.
/// Names are only built when asked for (per step only the values are).
struct Layout {
    names: Option<Vec<String>>,
    values: Vec<f64>,
}

impl Layout {
    fn put(&mut self, name: impl std::fmt::Display, value: f64) {
        if let Some(names) = self.names.as_mut() {
            names.push(name.to_string());
        }
        self.values.push(value);
    }

    fn flag(&mut self, name: impl std::fmt::Display, on: bool) {
        self.put(name, if on { 1.0 } else { 0.0 });
    }
}

fn layout(o: &Observation, tier: Tier, with_names: bool) -> Layout {
    let mut f = Layout { names: with_names.then(|| Vec::with_capacity(64)), values: Vec::with_capacity(64) };
    for t in Tier::ALL {
        f.flag(format_args!("tier.{}", t.number()), t == tier);
    }
    f.put("turn", o.turn as f64);
    f.put("turn_budget", o.turn_budget as f64);
    f.put("turns_left", o.turns_left() as f64);
    f.put("time_s", o.time_s);
    f.put("ego.speed_mps", o.ego.speed_mps);
    f.put("ego.accel_mps2", o.ego.accel_mps2);
    f.put("ego.to_goal_m", o.ego.to_goal_m);
    f.put("ego.speed_limit_mps", o.ego.speed_limit_mps);
    f.flag("ego.speed_limit_ahead.present", o.ego.speed_limit_ahead_mps.is_some());
    f.put("ego.speed_limit_ahead_mps", o.ego.speed_limit_ahead_mps.unwrap_or(0.0));
    let place = o.scene.place();
    f.put("ego.to_conflict_m", place[0]);
    f.put("ego.ramp_left_m", place.get(1).copied().unwrap_or(0.0));
    let tracks = o.scene.tracks();
    for slot in 0..TRACK_SLOTS {
        let track = tracks.get(slot);
        f.flag(format_args!("road_user{slot}.present"), track.is_some());
        let now = track.map(|t| t.now);
        f.put(format_args!("road_user{slot}.position_m"), now.map_or(0.0, |s| s.position_m));
        f.put(format_args!("road_user{slot}.velocity_mps"), now.map_or(0.0, |s| s.velocity_mps));
        for k in 0..HISTORY_LEN {
            let ago = (HISTORY_LEN - k) as f64 * crate::observation::HISTORY_SPACING_S;
            let s = track.map(|t| t.past[k]);
            f.put(format_args!("road_user{slot}.position_m@-{ago:.1}s"), s.map_or(0.0, |s| s.position_m));
            f.put(format_args!("road_user{slot}.velocity_mps@-{ago:.1}s"), s.map_or(0.0, |s| s.velocity_mps));
        }
    }
    let last = o.last_action;
    f.flag("last_action.present", last.is_some());
    for m in Maneuver::ALL {
        f.flag(format_args!("last_action.{}", m.name()), last.is_some_and(|a| a.maneuver == m));
    }
    f.put("last_action.strength", last.map_or(0.0, |a| a.acceleration.abs()));
    let noise = o.reading_noise;
    f.flag("reading_noise.present", noise.is_some());
    f.put("reading_noise.position_sd_m", noise.map_or(0.0, |n| n.position_sd_m));
    f.put("reading_noise.speed_sd_mps", noise.map_or(0.0, |n| n.speed_sd_mps));
    f
}

/// A discrete action set for policies that choose from a list (a
/// Gymnasium `Discrete` space, the learned adversary): (maneuver,
/// strength) pairs spanning what the built-in policies use. Index 0 holds
/// the current speed (`proceed` at strength 0 accelerates at 0 m/s^2).
/// `/metadata` publishes it as `discrete_actions`.
pub const DISCRETE_ACTIONS: [Action; 10] = [
    Action::new(Maneuver::Proceed, 0.0),
    Action::new(Maneuver::Proceed, 0.3),
    Action::new(Maneuver::Proceed, 0.6),
    Action::new(Maneuver::Proceed, 1.0),
    Action::new(Maneuver::Yield, 0.1),
    Action::new(Maneuver::Yield, 0.3),
    Action::new(Maneuver::Yield, 0.6),
    Action::new(Maneuver::Yield, 1.0),
    Action::new(Maneuver::Stop, 0.5),
    Action::new(Maneuver::NudgeForward, 0.5),
];

/// The index in [`DISCRETE_ACTIONS`] of the action nearest `action` for an
/// ego at `speed_mps` under `speed_limit_mps`: of the actions that go when
/// `action` goes (and hold back when it holds back), the one whose
/// controller commands the nearest acceleration now (the first on a tie).
/// env-server's teacher gives it, so that a learner on the discrete set can
/// imitate a built-in policy; the expert played this way keeps at least
/// 97% of its wins on every cell (tested below).
pub fn nearest_discrete_action(action: Action, speed_mps: f64, speed_limit_mps: f64) -> usize {
    let rate = |a: &Action| a.control().acceleration(speed_mps, speed_limit_mps, crate::sim::DT);
    let wanted = rate(&action);
    let mut best = (f64::INFINITY, 0);
    for (i, candidate) in DISCRETE_ACTIONS.iter().enumerate() {
        if candidate.maneuver.is_go() != action.maneuver.is_go() {
            continue;
        }
        let error = (rate(candidate) - wanted).abs();
        if error < best.0 {
            best = (error, i);
        }
    }
    best.1
}

/// [`DISCRETE_ACTIONS`] as the action objects a client sends.
pub(crate) fn discrete_actions_json() -> serde_json::Value {
    DISCRETE_ACTIONS
        .iter()
        .map(|a| serde_json::json!({"maneuver": a.maneuver.name(), "acceleration": a.acceleration}))
        .collect()
}

/// The indices of the slots that describe the other road users (every
/// `road_user*` slot): what the masked view freezes at its first reading.
pub(crate) fn road_user_slots() -> Vec<usize> {
    feature_names().iter().enumerate().filter(|(_, n)| n.starts_with("road_user")).map(|(i, _)| i).collect()
}

/// The feature vector of an observation (pass the rounded observation).
pub fn features(o: &Observation, tier: Tier) -> Vec<f64> {
    layout(o, tier, false).values
}

/// The name of every slot, in order (the same for every scenario).
pub fn feature_names() -> Vec<String> {
    let set = crate::scenario::ScenarioSet::default();
    let episode = crate::episode::Episode::new(set.get(ScenarioKind::YieldStandoff), Tier::T1, 0);
    layout(episode.observation(), Tier::T1, true).names.unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::episode::Episode;
    use crate::scenario::ScenarioSet;

    #[test]
    fn every_scenario_and_tier_gives_the_same_layout() {
        let set = ScenarioSet::default();
        let names = feature_names();
        for kind in ScenarioKind::ALL {
            for tier in Tier::ALL {
                let mut e = Episode::new(set.get(kind), tier, 3);
                e.step(crate::action::Action::new(Maneuver::Yield, 0.3));
                let l = layout(&e.observation().rounded(), tier, true);
                assert_eq!(l.names.as_ref(), Some(&names), "{kind} {tier}");
                assert_eq!(l.values, features(&e.observation().rounded(), tier));
                assert!(l.values.iter().all(|v| v.is_finite()));
                assert_eq!(l.values[names.iter().position(|n| n == "last_action.yield").unwrap()], 1.0);
            }
        }
        let unique: std::collections::HashSet<&String> = names.iter().collect();
        assert_eq!(unique.len(), names.len());
    }

    /// What makes the discrete set a fair space to learn in, and the
    /// teacher's labels worth imitating: the expert, each move replaced by
    /// its nearest discrete action, keeps at least 97% of its wins on every
    /// cell.
    #[test]
    fn the_expert_on_the_discrete_set_keeps_its_wins() {
        use crate::policy::PolicyKind;
        let set = ScenarioSet::default();
        for kind in ScenarioKind::ALL {
            for tier in Tier::ALL {
                let mut won = 0;
                let seeds = 10_000..10_200u64;
                for seed in seeds.clone() {
                    let mut e = Episode::new(set.get(kind), tier, seed);
                    let mut expert = PolicyKind::Expert.build();
                    expert.reset(crate::episode::policy_seed(e.spec()));
                    while !e.is_done() {
                        let o = e.observation().rounded();
                        let a = expert.act(&o);
                        let nearest =
                            DISCRETE_ACTIONS[nearest_discrete_action(a, o.ego.speed_mps, o.ego.speed_limit_mps)];
                        assert_eq!(nearest.maneuver.is_go(), a.maneuver.is_go());
                        e.step(nearest);
                    }
                    won += usize::from(e.outcome() == Some(crate::grading::Outcome::Success));
                }
                let rate = won as f64 / seeds.count() as f64;
                assert!(rate >= 0.97, "{kind} {tier}: {rate}");
            }
        }
    }
}
