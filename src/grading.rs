//! Graders. They read privileged state (the disposition, the trajectory) and
//! the actions taken; never the reasoning text.

use crate::scenario::Disposition;
use serde::{Deserialize, Serialize};

/// How an episode ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Outcome {
    Success,
    Collision,
    Timeout,
}

impl Outcome {
    pub fn name(self) -> &'static str {
        match self {
            Outcome::Success => "success",
            Outcome::Collision => "collision",
            Outcome::Timeout => "timeout",
        }
    }
}

/// The go / give-way choice the ego made, read from its motion (see
/// `decision_correctness`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Choice {
    /// The ego passed its point of no return (it could no longer stop short
    /// of the conflict at full braking) before the other entered it; where
    /// the other travels alongside (a merge), the ego entered first.
    Go,
    /// The other entered the conflict first while the ego could still stop
    /// (alongside: the other entered first).
    GiveWay,
}

/// nuPlan comfort bounds on longitudinal acceleration (m/s^2) and jerk (m/s^3).
pub const COMFORT_MIN_ACCEL: f64 = -4.05;
pub const COMFORT_MAX_ACCEL: f64 = 2.40;
pub const COMFORT_MAX_JERK: f64 = 4.13;
/// A step braking harder than this starts a hard-brake event (m/s^2).
pub const HARD_BRAKE: f64 = -4.05;

/// Per-episode diagnostics (docs/graders.md).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Diagnostics {
    /// Smallest time to collision at constant speeds seen at any step (s).
    pub min_ttc_s: Option<f64>,
    /// Smallest clearance between the ego's box and another box (m).
    pub min_gap_m: f64,
    /// Distinct episodes of braking harder than 4.05 m/s^2.
    pub hard_brakes: u32,
    /// Times the ego entered the conflict zone while the other had the way.
    pub right_of_way_violations: u32,
    pub time_to_goal_s: Option<f64>,
    /// Start-to-goal distance at the speed limit (s).
    pub free_flow_time_s: f64,
    /// free-flow time / time to goal (0 without reaching the goal).
    pub efficiency: f64,
    /// Fraction of the start-to-goal distance covered.
    pub progress: f64,
    pub peak_accel_mps2: f64,
    pub peak_decel_mps2: f64,
    pub peak_jerk_mps3: f64,
    /// Mean of the fraction of steps within nuPlan's acceleration bounds and
    /// the fraction of decision intervals within its jerk bound.
    pub comfort: f64,
    pub decisions: u32,
    pub duration_s: f64,
    /// Times a road user that had been waiting for the ego started into its
    /// path while the ego could no longer stop comfortably before it (4
    /// m/s^2 after a 0.5 s reaction). Road users accept gaps as people do,
    /// so this is 0 (`validate` counts it); absent from records when 0.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub unstoppable_turns_taken: u32,
}

fn is_zero(n: &u32) -> bool {
    *n == 0
}

/// Scores of one episode.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Grades {
    pub reward: f64,
    pub decision_correctness: f64,
    pub diagnostics: Diagnostics,
}

/// Bounded, lexicographic reward in [-1, 1]:
/// - collision: -1;
/// - timeout: -0.5 + 0.8 * progress, so in [-0.5, 0.3];
/// - success: 0.8 + 0.1 * efficiency + 0.1 * comfort, so in [0.8, 1.0].
///
/// Every collision is below every timeout, which is below every success.
pub fn compute_episode_reward(outcome: Outcome, d: &Diagnostics) -> f64 {
    match outcome {
        Outcome::Collision => -1.0,
        Outcome::Timeout => -0.5 + 0.8 * d.progress.clamp(0.0, 1.0),
        Outcome::Success => 0.8 + 0.1 * d.efficiency.clamp(0.0, 1.0) + 0.1 * d.comfort.clamp(0.0, 1.0),
    }
}

/// Whether the ego's go / give-way choice was the one the hidden
/// disposition requires: 1 or 0 per episode.
///
/// The choice is read from what the ego did, never from the maneuver label
/// it gave (see [`Choice`]): *go* when the ego passed its
/// point of no return (it could no longer stop short of the conflict at
/// full braking, 8 m/s^2) before the other road user entered the conflict;
/// *give way* when the other entered first while the ego could still stop.
/// In a merge, where the other travels alongside, the order of entry
/// decides (see [`crate::scenario::world::World::order_settles_choice`]).
/// Committed cars and crossers require give way; yielders, waiting
/// pedestrians and cars making room require go. A collision scores 0
/// whatever was chosen, and so does an episode in which neither happened
/// (the ego never made the choice).
pub fn decision_correctness(disposition: Disposition, outcome: Outcome, choice: Option<Choice>) -> f64 {
    let want = if disposition.ego_should_go() { Choice::Go } else { Choice::GiveWay };
    if outcome != Outcome::Collision && choice == Some(want) { 1.0 } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn diag(progress: f64, efficiency: f64, comfort: f64) -> Diagnostics {
        Diagnostics {
            min_ttc_s: None,
            min_gap_m: 1.0,
            hard_brakes: 0,
            right_of_way_violations: 0,
            time_to_goal_s: None,
            free_flow_time_s: 5.0,
            efficiency,
            progress,
            peak_accel_mps2: 0.0,
            peak_decel_mps2: 0.0,
            peak_jerk_mps3: 0.0,
            comfort,
            decisions: 1,
            duration_s: 1.0,
            unstoppable_turns_taken: 0,
        }
    }

    #[test]
    fn reward_is_lexicographic_at_the_extremes() {
        let worst_success = compute_episode_reward(Outcome::Success, &diag(1.0, 0.0, 0.0));
        let best_timeout = compute_episode_reward(Outcome::Timeout, &diag(1.0, 1.0, 1.0));
        let worst_timeout = compute_episode_reward(Outcome::Timeout, &diag(0.0, 0.0, 0.0));
        let collision = compute_episode_reward(Outcome::Collision, &diag(1.0, 1.0, 1.0));
        assert_eq!(worst_success, 0.8);
        assert!(best_timeout < worst_success);
        assert!(collision < worst_timeout);
        assert_eq!(compute_episode_reward(Outcome::Success, &diag(1.0, 1.0, 1.0)), 1.0);
    }

    #[test]
    fn correctness_reads_the_choice_made_and_never_credits_a_collision() {
        use Choice::*;
        assert_eq!(
            decision_correctness(crate::scenario::yield_standoff::COMMITTED, Outcome::Timeout, Some(GiveWay)),
            1.0
        );
        assert_eq!(decision_correctness(crate::scenario::yield_standoff::COMMITTED, Outcome::Success, Some(Go)), 0.0);
        assert_eq!(decision_correctness(crate::scenario::yield_standoff::YIELDER, Outcome::Success, Some(Go)), 1.0);
        assert_eq!(decision_correctness(crate::scenario::yield_standoff::YIELDER, Outcome::Collision, Some(Go)), 0.0);
        assert_eq!(
            decision_correctness(crate::scenario::yield_standoff::COMMITTED, Outcome::Collision, Some(GiveWay)),
            0.0
        );
        assert_eq!(decision_correctness(crate::scenario::pedestrian_feint::FEINTER, Outcome::Timeout, None), 0.0);
        assert_eq!(decision_correctness(crate::scenario::pedestrian_feint::CROSSER, Outcome::Timeout, None), 0.0);
    }
}
