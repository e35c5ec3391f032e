//! Behaviour-conditioned rule policies. Both read only the public
//! observation, so `negotiator serve` can run them from the scene text.
//!
//! The expert waits for a *committed* signal before going (a car that has
//! actually stopped, a pedestrian who waits or crosses, a lane car that makes
//! room), keeps the pace of a car that means to go while a hard stop stays
//! possible, and lets the other go first otherwise. The cue follower acts on
//! the instantaneous cue instead: the other is braking, so go. The rules of
//! each scenario live with the scenario (scenario knowledge stays in
//! `scenario/`); this file only dispatches.

use super::Policy;
use crate::action::Action;
use crate::observation::{Observation, Scene};
use crate::scenario::{contested_merge, pedestrian_feint, yield_standoff};

pub struct Expert;
pub struct CueFollower;

impl Policy for Expert {
    fn act(&mut self, obs: &Observation) -> Action {
        let v = obs.ego.speed_mps;
        let v_max = obs.ego.speed_limit_mps;
        match &obs.scene {
            Scene::YieldStandoff { ego_to_conflict_m, other, follower } => {
                yield_standoff::expert(v, v_max, *ego_to_conflict_m, other, follower, obs.last_action)
            }
            Scene::PedestrianFeint { ego_to_crosswalk_m, pedestrian } => {
                pedestrian_feint::expert(v, v_max, *ego_to_crosswalk_m, pedestrian)
            }
            Scene::ContestedMerge { ego_to_merge_m, lane_car, follower, .. } => {
                contested_merge::expert(v, v_max, *ego_to_merge_m, lane_car, follower)
            }
        }
    }

    /// The reference belief: the ideal observer's.
    fn belief(&mut self, _obs: &Observation, _action: &Action, ideal: f64) -> f64 {
        ideal
    }
}

impl Policy for CueFollower {
    fn act(&mut self, obs: &Observation) -> Action {
        let v = obs.ego.speed_mps;
        let v_max = obs.ego.speed_limit_mps;
        match &obs.scene {
            Scene::YieldStandoff { ego_to_conflict_m, other, follower } => {
                yield_standoff::cue_follower(v, v_max, *ego_to_conflict_m, other, follower)
            }
            Scene::PedestrianFeint { ego_to_crosswalk_m, pedestrian } => {
                pedestrian_feint::cue_follower(v, v_max, *ego_to_crosswalk_m, pedestrian)
            }
            Scene::ContestedMerge { ego_to_merge_m, lane_car, follower, .. } => {
                contested_merge::cue_follower(v, v_max, *ego_to_merge_m, lane_car, follower)
            }
        }
    }
}
