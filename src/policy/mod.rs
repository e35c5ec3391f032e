//! Non-LLM policies. A policy sees only the public [`Observation`] (and an
//! opaque seed for its own randomness): the type of `act` is the firewall.

mod expert;
pub(crate) mod reply;
mod simple;

pub use expert::watching;
pub use expert::{
    CueFollower, Expert, ExpertCautious, ExpertHedge, ExpertLate, HEDGE_BRAKE_MPS2, HEDGE_SECONDS, Hedging,
    HedgingReader, MODERATE_FRACTION,
};
pub use simple::{AlwaysProceed, AlwaysStop, Cautious, RandomPolicy};

use crate::action::{Action, Maneuver};
use crate::observation::Observation;
use std::fmt;
use std::str::FromStr;

pub trait Policy: Send {
    /// Called at the start of every episode with a seed for the policy's own
    /// randomness (derived from, but not revealing, the episode key).
    fn reset(&mut self, _policy_seed: u64) {}
    fn act(&mut self, obs: &Observation) -> Action;
    /// Whether the policy's action depends on earlier observations of the
    /// episode (a front end that sees one turn at a time, like `serve`,
    /// then shows it the episode's earlier scenes first).
    fn remembers(&self) -> bool {
        false
    }
    /// The belief the policy states for the probe: the probability that
    /// the other road user lets the ego pass first, after choosing
    /// `action` for `obs`. By default a policy believes what it does (1
    /// when it proceeds, else 0): the cue follower's belief is thus its
    /// instantaneous cue's. `ideal` is the ideal observer's belief
    /// (privileged): only the expert states it, as the reference a
    /// perfect reader of the scene would give; no action ever reads it.
    fn belief(&mut self, _obs: &Observation, action: &Action, _ideal: f64) -> f64 {
        if action.maneuver.is_go() { 1.0 } else { 0.0 }
    }
}

/// The built-in policies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PolicyKind {
    Expert,
    AlwaysProceed,
    AlwaysStop,
    Cautious,
    Random,
    CueFollower,
    ExpertLate,
    ExpertCautious,
    ExpertHedge,
    HedgingReader,
    HedgingReaderLate,
    HedgingReaderSoft,
    DefensiveReader,
    DefensiveReaderLate,
    DefensiveReaderSoft,
}

impl PolicyKind {
    pub const ALL: [PolicyKind; 15] = [
        PolicyKind::Expert,
        PolicyKind::AlwaysProceed,
        PolicyKind::AlwaysStop,
        PolicyKind::Cautious,
        PolicyKind::Random,
        PolicyKind::CueFollower,
        PolicyKind::ExpertLate,
        PolicyKind::ExpertCautious,
        PolicyKind::ExpertHedge,
        PolicyKind::HedgingReader,
        PolicyKind::HedgingReaderLate,
        PolicyKind::HedgingReaderSoft,
        PolicyKind::DefensiveReader,
        PolicyKind::DefensiveReaderLate,
        PolicyKind::DefensiveReaderSoft,
    ];
    /// The expert's rules driven with caution while unsure (`validate`'s
    /// "caution is not punished" line).
    pub const CAUTIOUS_READERS: [PolicyKind; 2] = [PolicyKind::ExpertCautious, PolicyKind::ExpertHedge];
    /// Policies that ignore the state entirely (the anti-gaming invariant).
    pub const STATE_IGNORANT: [PolicyKind; 4] =
        [PolicyKind::AlwaysProceed, PolicyKind::AlwaysStop, PolicyKind::Cautious, PolicyKind::Random];
    /// Policies that always answer the same action.
    pub const CONSTANT: [PolicyKind; 3] = [PolicyKind::AlwaysProceed, PolicyKind::AlwaysStop, PolicyKind::Cautious];

    pub fn name(self) -> &'static str {
        match self {
            PolicyKind::Expert => "expert",
            PolicyKind::AlwaysProceed => "always_proceed",
            PolicyKind::AlwaysStop => "always_stop",
            PolicyKind::Cautious => "cautious",
            PolicyKind::Random => "random",
            PolicyKind::CueFollower => "cue_follower",
            PolicyKind::ExpertLate => "expert_late",
            PolicyKind::ExpertCautious => "expert_cautious",
            PolicyKind::ExpertHedge => "expert_hedge",
            PolicyKind::HedgingReader => "hedging_reader",
            PolicyKind::HedgingReaderLate => "hedging_reader_late",
            PolicyKind::HedgingReaderSoft => "hedging_reader_soft",
            PolicyKind::DefensiveReader => "defensive_reader",
            PolicyKind::DefensiveReaderLate => "defensive_reader_late",
            PolicyKind::DefensiveReaderSoft => "defensive_reader_soft",
        }
    }

    pub fn build(self) -> Box<dyn Policy> {
        match self {
            PolicyKind::Expert => Box::new(Expert),
            PolicyKind::AlwaysProceed => Box::new(AlwaysProceed),
            PolicyKind::AlwaysStop => Box::new(AlwaysStop),
            PolicyKind::Cautious => Box::new(Cautious),
            PolicyKind::Random => Box::new(RandomPolicy::default()),
            PolicyKind::CueFollower => Box::new(CueFollower),
            PolicyKind::ExpertLate => Box::new(ExpertLate::new(1)),
            PolicyKind::ExpertCautious => Box::new(ExpertCautious),
            PolicyKind::ExpertHedge => Box::new(ExpertHedge),
            PolicyKind::HedgingReader => Box::new(Hedging::on_time(HEDGE_BRAKE_MPS2, HEDGE_SECONDS).build()),
            PolicyKind::HedgingReaderLate => Box::new(Hedging::late(HEDGE_BRAKE_MPS2, HEDGE_SECONDS).build()),
            PolicyKind::HedgingReaderSoft => Box::new(Hedging::late_soft(HEDGE_BRAKE_MPS2, HEDGE_SECONDS).build()),
            PolicyKind::DefensiveReader => Box::new(Hedging::DEFENSIVE[0].build()),
            PolicyKind::DefensiveReaderLate => Box::new(Hedging::DEFENSIVE[1].build()),
            PolicyKind::DefensiveReaderSoft => Box::new(Hedging::DEFENSIVE[2].build()),
        }
    }
}

impl fmt::Display for PolicyKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

#[derive(Debug, thiserror::Error)]
#[error(
    "unknown policy '{0}' (expected expert, always_proceed, always_stop, cautious, random, cue_follower, expert_late, expert_cautious, expert_hedge, hedging_reader, hedging_reader_late, hedging_reader_soft, defensive_reader, defensive_reader_late or defensive_reader_soft)"
)]
pub struct UnknownPolicy(String);

impl FromStr for PolicyKind {
    type Err = UnknownPolicy;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        PolicyKind::ALL.into_iter().find(|k| k.name() == s).ok_or_else(|| UnknownPolicy(s.to_string()))
    }
}

/// Approach a point the ego may have to stop at, never asserting the right
/// of way: coast while a comfortable stop (2.5 m/s^2 after a 0.5 s
/// reaction) remains possible, brake just enough when it no longer is, and
/// creep when slow and still short of the point.
pub fn hedge(speed: f64, distance: f64) -> Action {
    const COMFORT: f64 = 2.5;
    const REACTION: f64 = 0.5;
    if distance <= 0.2 {
        return Action::new(Maneuver::Stop, if speed > 0.5 { 1.0 } else { 0.0 });
    }
    let ra = REACTION * COMFORT;
    let v_ok = -ra + (ra * ra + 2.0 * COMFORT * distance).sqrt();
    if speed > v_ok + 0.2 {
        let needed = speed * speed / (2.0 * distance.max(0.1));
        if needed <= 4.0 {
            Action::new(Maneuver::Yield, ((needed - 0.5) / 3.5).clamp(0.0, 1.0))
        } else {
            Action::new(Maneuver::Stop, ((needed - 4.0) / 4.0).clamp(0.0, 1.0))
        }
    } else if speed < crate::action::CREEP_SPEED && distance > 1.0 {
        Action::new(Maneuver::NudgeForward, 0.5)
    } else {
        Action::new(Maneuver::Yield, 0.0)
    }
}

/// Full-throttle go.
pub fn go() -> Action {
    Action::new(Maneuver::Proceed, 1.0)
}
