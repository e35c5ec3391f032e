//! The readings of a road user that a world produces for the public
//! observation: its position and velocity now and over the last two
//! seconds, and the size of the noise a tier puts on them. Public types,
//! defined beside the worlds that fill them (the `observation` module
//! re-exports them) so that `scenario` never imports `observation`.

use serde::{Deserialize, Serialize};

/// Past samples of the other agent kept in an observation: t-2.0, t-1.5,
/// t-1.0 and t-0.5 s, oldest first.
pub const HISTORY_LEN: usize = 4;
/// Seconds between two history samples (one decision).
pub const HISTORY_SPACING_S: f64 = 0.5;

/// Position and velocity of the other agent at one instant, in the
/// scenario's frame (see [`super::Scene`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Sample {
    pub position_m: f64,
    pub velocity_mps: f64,
}

/// The other agent now and over the last two seconds.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Track {
    pub now: Sample,
    pub past: [Sample; HISTORY_LEN],
}

impl Track {
    /// A track at rest at 0 (a scene's unused slots).
    pub const ZERO: Track = Track {
        now: Sample { position_m: 0.0, velocity_mps: 0.0 },
        past: [Sample { position_m: 0.0, velocity_mps: 0.0 }; HISTORY_LEN],
    };

    /// Mean acceleration over the last half second.
    pub fn recent_accel(&self) -> f64 {
        (self.now.velocity_mps - self.past[HISTORY_LEN - 1].velocity_mps) / HISTORY_SPACING_S
    }
}

/// The size of the random noise on the other road users' readings, where a
/// tier adds it (one standard deviation, drawn afresh each turn). Public: it
/// is a property of the tier, the same under both dispositions, and a
/// driver told nothing would misread a jumping position as motion.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct ReadingNoise {
    pub position_sd_m: f64,
    pub speed_sd_mps: f64,
}
