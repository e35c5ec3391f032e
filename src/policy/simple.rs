//! State-ignorant baselines.

use super::Policy;
use crate::action::{Action, Maneuver};
use crate::observation::Observation;
use crate::rng::{EpisodeRng, Stream};

/// Always `proceed` at full strength.
pub struct AlwaysProceed;
impl Policy for AlwaysProceed {
    fn act(&mut self, _: &Observation) -> Action {
        super::go()
    }
}

/// Always `stop`.
pub struct AlwaysStop;
impl Policy for AlwaysStop {
    fn act(&mut self, _: &Observation) -> Action {
        Action::new(Maneuver::Stop, 0.5)
    }
}

/// A constant slow creep (`nudge_forward`).
pub struct Cautious;
impl Policy for Cautious {
    fn act(&mut self, _: &Observation) -> Action {
        Action::new(Maneuver::NudgeForward, 0.5)
    }
}

/// Uniformly random maneuver and magnitude, seeded per episode.
pub struct RandomPolicy {
    rng: EpisodeRng,
    seed: u64,
}

impl Default for RandomPolicy {
    fn default() -> Self {
        RandomPolicy { rng: EpisodeRng::new(&[0], Stream::Policy), seed: 0 }
    }
}

impl Policy for RandomPolicy {
    fn reset(&mut self, policy_seed: u64) {
        self.rng = EpisodeRng::new(&[policy_seed], Stream::Policy);
        self.seed = policy_seed;
    }

    /// Uniform on [0, 1), from (seed, turn) rather than the action stream,
    /// so probing a belief never changes the actions.
    fn belief(&mut self, obs: &Observation, _action: &Action, _ideal: f64) -> f64 {
        EpisodeRng::new(&[self.seed, u64::from(obs.turn)], Stream::Policy).unit()
    }
    fn act(&mut self, _: &Observation) -> Action {
        let maneuver = Maneuver::ALL[self.rng.below(4) as usize];
        let acceleration = 2.0 * self.rng.unit() - 1.0;
        Action::new(maneuver, acceleration)
    }
}
