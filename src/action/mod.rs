//! The ego's action: what a policy (or a language model) answers each turn,
//! and how it maps to the longitudinal controller.

mod json;
mod parse;

pub use parse::{
    ActionParseError, BeliefParseError, ForecastParseError, ParsedAction, StatedForecast, parse_action, parse_belief,
    parse_forecast,
};

use serde::{Deserialize, Serialize};
use std::fmt;

/// The controller mode a turn selects.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Maneuver {
    Proceed,
    Yield,
    Stop,
    NudgeForward,
}

impl Maneuver {
    pub const ALL: [Maneuver; 4] = [Maneuver::Proceed, Maneuver::Yield, Maneuver::Stop, Maneuver::NudgeForward];

    pub fn name(self) -> &'static str {
        match self {
            Maneuver::Proceed => "proceed",
            Maneuver::Yield => "yield",
            Maneuver::Stop => "stop",
            Maneuver::NudgeForward => "nudge_forward",
        }
    }

    /// Go / give-way class used by decision correctness: only `proceed`
    /// asserts the right of way; a creep does not.
    pub fn is_go(self) -> bool {
        matches!(self, Maneuver::Proceed)
    }

    /// Parse a maneuver name, tolerating case, surrounding space, and `-`,
    /// space or nothing in place of `_` ("Nudge-Forward", "NUDGEFORWARD").
    pub fn from_loose(s: &str) -> Option<Maneuver> {
        let norm: String =
            s.trim().chars().filter(|c| !matches!(c, '_' | '-' | ' ' | '\t')).flat_map(char::to_lowercase).collect();
        match norm.as_str() {
            "proceed" => Some(Maneuver::Proceed),
            "yield" => Some(Maneuver::Yield),
            "stop" => Some(Maneuver::Stop),
            "nudgeforward" => Some(Maneuver::NudgeForward),
            _ => None,
        }
    }
}

impl fmt::Display for Maneuver {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// One turn's decision. `acceleration` is a normalised magnitude in
/// [-1, 1]; `steering` is recorded and ignored (the task is longitudinal).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Action {
    pub maneuver: Maneuver,
    pub acceleration: f64,
    pub steering: f64,
}

/// Speed the ego creeps at under `nudge_forward` (m/s).
pub const CREEP_SPEED: f64 = 2.0;

/// `proceed`'s rate at full strength (m/s^2); at strength 0 it holds the
/// current speed, so a driver can always keep its pace without alternating
/// maneuvers.
pub const PROCEED_MAX_ACCEL: f64 = 3.0;

impl Action {
    /// What an unreadable reply turns into: brake firmly to a stop.
    pub const CONSERVATIVE: Action = Action { maneuver: Maneuver::Stop, acceleration: -0.5, steering: 0.0 };

    pub const fn new(maneuver: Maneuver, acceleration: f64) -> Action {
        Action { maneuver, acceleration, steering: 0.0 }
    }

    /// `proceed` at the strength that accelerates at `mps2` (0 holds the
    /// current speed; 3 m/s^2 is full strength).
    pub fn proceed_at(mps2: f64) -> Action {
        Action::new(Maneuver::Proceed, (mps2 / PROCEED_MAX_ACCEL).clamp(0.0, 1.0))
    }

    /// `proceed` at strength 0: keep the current speed (brake only above the
    /// speed limit).
    pub fn hold() -> Action {
        Action::new(Maneuver::Proceed, 0.0)
    }

    /// The controller this action selects. The maneuver picks the mode and
    /// its target speed; `|acceleration|` picks the strength inside the
    /// mode's band:
    ///
    /// | maneuver | target speed | rate (m/s^2) at \|a\| = 0 .. 1 |
    /// |---|---|---|
    /// | proceed | speed limit | accelerate 0.0 .. 3.0 (0: hold the current speed) |
    /// | nudge_forward | 2.0 m/s creep | accelerate 0.5 .. 1.5, brake 2.0 .. 4.0 if faster |
    /// | yield | 0 | brake 0.5 .. 4.0 |
    /// | stop | 0 | brake 4.0 .. 8.0 |
    pub fn control(&self) -> Control {
        let m = self.acceleration.abs().clamp(0.0, 1.0);
        let band = |lo: f64, hi: f64| lo + (hi - lo) * m;
        match self.maneuver {
            Maneuver::Proceed => {
                Control { target: Target::SpeedLimit, accel: band(0.0, PROCEED_MAX_ACCEL), brake: 3.0 }
            }
            Maneuver::NudgeForward => Control { target: Target::Creep, accel: band(0.5, 1.5), brake: band(2.0, 4.0) },
            Maneuver::Yield => Control { target: Target::Halt, accel: 0.0, brake: band(0.5, 4.0) },
            Maneuver::Stop => Control { target: Target::Halt, accel: 0.0, brake: band(4.0, 8.0) },
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Target {
    SpeedLimit,
    Creep,
    Halt,
}

/// A speed-tracking controller: move toward the target speed, accelerating
/// at most `accel` and braking at most `brake`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Control {
    pub target: Target,
    pub accel: f64,
    pub brake: f64,
}

impl Control {
    pub fn acceleration(&self, v: f64, speed_limit: f64, dt: f64) -> f64 {
        let target = match self.target {
            Target::SpeedLimit => speed_limit,
            Target::Creep => CREEP_SPEED,
            Target::Halt => 0.0,
        };
        crate::sim::track_speed(v, target, self.accel, self.brake, dt)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn maneuver_names_are_tolerant() {
        assert_eq!(Maneuver::from_loose(" Nudge-Forward "), Some(Maneuver::NudgeForward));
        assert_eq!(Maneuver::from_loose("NUDGE FORWARD"), Some(Maneuver::NudgeForward));
        assert_eq!(Maneuver::from_loose("PROCEED"), Some(Maneuver::Proceed));
        assert_eq!(Maneuver::from_loose("accelerate"), None);
    }

    #[test]
    fn stronger_magnitude_brakes_harder() {
        let soft = Action::new(Maneuver::Stop, 0.0).control().acceleration(10.0, 12.0, 0.1);
        let hard = Action::new(Maneuver::Stop, -1.0).control().acceleration(10.0, 12.0, 0.1);
        assert_eq!(soft, -4.0);
        assert_eq!(hard, -8.0);
        let go = Action::new(Maneuver::Proceed, 1.0).control().acceleration(5.0, 12.0, 0.1);
        assert_eq!(go, 3.0);
    }

    #[test]
    fn proceed_at_strength_zero_holds_the_current_speed() {
        assert_eq!(Action::hold().control().acceleration(7.3, 12.0, 0.1), 0.0);
        assert_eq!(Action::hold().control().acceleration(0.0, 12.0, 0.1), 0.0);
        // Above the limit it still brakes back to it.
        assert!(Action::hold().control().acceleration(13.0, 12.0, 0.1) < 0.0);
        let gentle = Action::proceed_at(1.0).control().acceleration(5.0, 12.0, 0.1);
        assert!((gentle - 1.0).abs() < 1e-12, "{gentle}");
    }

    #[test]
    fn proceed_holds_the_speed_limit() {
        let a = Action::new(Maneuver::Proceed, 1.0).control().acceleration(12.0, 12.0, 0.1);
        assert_eq!(a, 0.0);
    }
}
