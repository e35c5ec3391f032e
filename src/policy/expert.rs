//! Behaviour-conditioned rule policies. Both read only the public
//! observation, so `negotiator serve` can run them from the scene text.
//!
//! The expert waits for a *committed* signal before going (a car that has
//! actually stopped, a pedestrian who waits or crosses, a lane car that makes
//! room), keeps the pace of a car that means to go while a hard stop stays
//! possible, and lets the other go first otherwise. The cue follower acts on
//! the instantaneous cue instead: the other is braking, so go. The rules of
//! each scenario live with the scenario (`scenario/`, reached through
//! [`crate::scenario::Scene`]).

use super::Policy;
use crate::action::Action;
use crate::observation::Observation;

pub struct Expert;
pub struct CueFollower;

impl Policy for Expert {
    fn act(&mut self, obs: &Observation) -> Action {
        obs.scene.expert(obs.ego.speed_mps, obs.ego.speed_limit_mps, obs.last_action)
    }

    /// The reference belief: the ideal observer's.
    fn belief(&mut self, _obs: &Observation, _action: &Action, ideal: f64) -> f64 {
        ideal
    }
}

impl Policy for CueFollower {
    fn act(&mut self, obs: &Observation) -> Action {
        obs.scene.cue_follower(obs.ego.speed_mps, obs.ego.speed_limit_mps)
    }
}
