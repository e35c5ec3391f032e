//! The expert's and the cue follower's rules on `toy_crossing`, the
//! scenario the unit tests add through the registry alone. They read only
//! the public scene.

use super::Move;
use crate::policy::{go, hedge};
use crate::scenario::toy_crossing::HALF_ZONE;

/// Where the expert waits: this far before the zone (m).
const WAIT_GAP_M: f64 = 2.0;

/// Go once the crossing car has stopped or is through the zone; give way
/// before the zone until then.
pub(super) const RULES: super::Rules = super::Rules {
    expert: |obs| {
        let car = obs.scene.tracks()[0].now;
        let d = obs.scene.ego_to_conflict_m();
        if d < 0.5 || car.velocity_mps < 0.05 || car.position_m < -2.0 * HALF_ZONE - 0.5 {
            Move::go(go())
        } else {
            Move::not_yet(hedge(obs.ego.speed_mps, d - WAIT_GAP_M))
        }
    },
    // The cue: a car slower than it came is stopping.
    cue_follower: |scene, v, _v_max| {
        let car = scene.tracks()[0];
        if car.recent_accel() < -0.5 || car.now.velocity_mps < 0.05 {
            go()
        } else {
            hedge(v, scene.ego_to_conflict_m() - WAIT_GAP_M)
        }
    },
    watch: |_obs, _confirm| false,
};
