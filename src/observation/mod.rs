//! The public observation: everything a policy, the prompt and the text
//! renderer may see. It is built by the simulator from public state only;
//! nothing in it is derived from the hidden disposition except through the
//! other agent's visible motion.

mod parse;
mod render;

pub use parse::{SceneParseError, parse_scene};
pub use render::render_scene;
pub(crate) use render::{fixed_point, last_action_line, you_line};

use crate::action::Action;
use crate::scenario::ScenarioKind;
use serde::{Deserialize, Serialize};

// The readings of the other road users are the worlds' output: defined with
// them (`scenario::track`), so that `scenario` never imports this module.
pub use crate::scenario::{HISTORY_LEN, HISTORY_SPACING_S, ReadingNoise, Sample, Scene, Track};

/// The ego's own state.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct EgoView {
    pub speed_mps: f64,
    pub accel_mps2: f64,
    pub to_goal_m: f64,
    pub speed_limit_mps: f64,
    /// The speed limit of the road the ego is to join, while it is not on
    /// it yet and it differs from the episode's (the merge's through lane).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub speed_limit_ahead_mps: Option<f64>,
}

/// What a policy sees at one decision.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Observation {
    pub time_s: f64,
    /// 1-based index of this decision.
    pub turn: u32,
    pub turn_budget: u32,
    pub ego: EgoView,
    pub scene: Scene,
    /// The action held over the last half second (None on the first turn).
    pub last_action: Option<Action>,
    /// The noise on the other road users' readings, on a tier that adds it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reading_noise: Option<ReadingNoise>,
}

impl Observation {
    /// The scenario, as the scene's layout says.
    pub fn scenario(&self) -> ScenarioKind {
        self.scene.kind()
    }

    /// The ego's own distance to the conflict: the conflict zone, the
    /// crossing line or the merge point. Part of the ego's own state (what
    /// a policy that ignores the other road user may still read).
    pub fn ego_to_conflict_m(&self) -> f64 {
        self.scene.ego_to_conflict_m()
    }

    pub fn turns_left(&self) -> u32 {
        self.turn_budget.saturating_sub(self.turn) + 1
    }

    /// Every number in the observation rounded to the precision the text
    /// renderer prints, so that `parse(render(o)) == o.rounded()`.
    pub fn rounded(&self) -> Observation {
        let r1 = |x: f64| round_to(x, 1);
        let track = |t: Track| Track {
            now: Sample { position_m: r1(t.now.position_m), velocity_mps: r1(t.now.velocity_mps) },
            past: t.past.map(|s| Sample { position_m: r1(s.position_m), velocity_mps: r1(s.velocity_mps) }),
        };
        let scene = self.scene.map(r1, track);
        Observation {
            time_s: r1(self.time_s),
            turn: self.turn,
            turn_budget: self.turn_budget,
            ego: EgoView {
                speed_mps: r1(self.ego.speed_mps),
                accel_mps2: r1(self.ego.accel_mps2),
                to_goal_m: r1(self.ego.to_goal_m),
                speed_limit_mps: r1(self.ego.speed_limit_mps),
                speed_limit_ahead_mps: self.ego.speed_limit_ahead_mps.map(r1),
            },
            scene,
            last_action: self.last_action.map(|a| Action {
                maneuver: a.maneuver,
                acceleration: round_to(a.acceleration.clamp(-1.0, 1.0), 2),
                steering: 0.0,
            }),
            reading_noise: self
                .reading_noise
                .map(|n| ReadingNoise { position_sd_m: r1(n.position_sd_m), speed_sd_mps: r1(n.speed_sd_mps) }),
        }
    }
}

/// Round half away from zero to `digits` decimals, and never return -0.0
/// (so the text never shows "-0.0").
pub fn round_to(x: f64, digits: i32) -> f64 {
    let scale = 10f64.powi(digits);
    let r = (x * scale).round() / scale;
    if r == 0.0 { 0.0 } else { r }
}
