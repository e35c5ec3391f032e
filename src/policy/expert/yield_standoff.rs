//! The expert's and the cue follower's rules on `yield_standoff`. They read only the
//! public scene (the `Scene` a policy is given) and the scenario's public
//! geometry, never its world: they live on the public side of the firewall.

use super::Move;
use crate::action::{Action, Maneuver};
use crate::observation::Track;
use crate::policy::{go, hedge};
use crate::scenario::yield_standoff::HALF_ZONE;
use crate::sim::{EGO_MAX_ACCEL, travel_time};

/// Conflict-zone depth: a crossing car has fully cleared below minus this.
const CONFLICT_ZONE_M: f64 = 2.0 * HALF_ZONE;
/// Where the expert waits: this far before the conflict zone.
const WAIT_GAP_M: f64 = 3.0;

/// Whether a car track is at rest now after slowing down: a stop, the one
/// signal a bluff never gives.
fn stopped(t: &Track) -> bool {
    t.now.velocity_mps <= 0.05 && t.now.position_m > 0.0
}

/// Whether a crossing car has left the conflict zone behind.
fn crossed(t: &Track) -> bool {
    t.now.position_m < -CONFLICT_ZONE_M - 0.5
}

/// Whether the car started braking while the ego watched: steady speed at
/// the start of the window, braking at its end. A car that began to slow
/// only once the ego was there is yielding to it; one that was slowing all
/// along may be bluffing.
fn began_braking(t: &Track) -> bool {
    let steady = (t.past[1].velocity_mps - t.past[0].velocity_mps).abs() < 0.05;
    steady && t.recent_accel() < -0.4 && t.now.position_m > 0.0
}

/// Whether a car short of its line is stopping: at rest, or crawling
/// slower than a walking pace and still braking (a bluff rolls on faster).
fn stopping(t: &Track) -> bool {
    stopped(t) || (t.now.position_m > 0.0 && t.now.velocity_mps < 1.5 && t.recent_accel() < -0.3)
}

/// Whether a car is slowing for the ego or waiting at its line.
fn yielding(t: &Track) -> bool {
    t.now.position_m > 0.0 && (t.recent_accel() < -0.2 || t.now.velocity_mps <= 0.05)
}

/// Whether the ego, going now at full throttle, clears the zone at least a
/// second before `car` can reach it at its current speed.
fn passes_before(v: f64, v_max: f64, d: f64, car: &Track) -> bool {
    if crossed(car) {
        return true;
    }
    let (p, vc) = (car.now.position_m, car.now.velocity_mps);
    if p <= 0.0 {
        return false;
    }
    let ego_clear = travel_time(d.max(0.0) + CONFLICT_ZONE_M, v, v_max, EGO_MAX_ACCEL);
    let car_due = if vc > 0.3 { p / vc } else { f64::INFINITY };
    car_due > ego_clear + 1.0
}

/// Whether the ego, going now at full throttle, reaches the zone at least
/// 0.3 s after `car` has left it at its current speed.
fn arrives_after(v: f64, v_max: f64, d: f64, car: &Track) -> bool {
    let (p, vc) = (car.now.position_m, car.now.velocity_mps);
    if crossed(car) {
        return true;
    }
    if vc < 1.0 {
        return false;
    }
    travel_time(d.max(0.0), v, v_max, EGO_MAX_ACCEL) > (p + CONFLICT_ZONE_M) / vc + 0.3
}

/// This scenario's rules, read from its scene (whose layout its scenario
/// fixes; any other is given way to).
pub(super) const RULES: super::Rules = super::Rules {
    expert: |obs| match obs.scene.tracks() {
        [other, follower] => {
            let (v, v_max) = (obs.ego.speed_mps, obs.ego.speed_limit_mps);
            expert(v, v_max, obs.scene.ego_to_conflict_m(), other, follower, obs.last_action)
        }
        _ => Move::not_yet(super::hold_back(&obs.scene, obs.ego.speed_mps)),
    },
    cue_follower: |scene, v, v_max| match scene.tracks() {
        [other, follower] => cue_follower(v, v_max, scene.ego_to_conflict_m(), other, follower),
        _ => super::hold_back(scene, v),
    },
    watch: |obs, _confirm| match obs.scene.tracks() {
        [other, follower] => {
            let (v, v_max) = (obs.ego.speed_mps, obs.ego.speed_limit_mps);
            follower_may_meet_the_ego(v, v_max, obs.scene.ego_to_conflict_m(), other, follower)
        }
        _ => false,
    },
};

/// Whether the car behind (not the tier's question) may be in the zone
/// with the ego, going now at full throttle: it has not entered yet, moves
/// toward it, and neither passes well after the ego nor clears before it;
/// unless it is queued behind the first car, which is ahead of it on its
/// road and stopping or yielding (it cannot pass through it), or its own
/// readings show it braking to a stop short of the zone.
fn follower_may_meet_the_ego(v: f64, v_max: f64, d: f64, other: &Track, follower: &Track) -> bool {
    let (p, vf) = (follower.now.position_m, follower.now.velocity_mps);
    if p <= 0.0 || vf <= 0.3 || passes_before(v, v_max, d, follower) || arrives_after(v, v_max, d, follower) {
        return false;
    }
    let queued = other.now.position_m < p && (stopping(other) || yielding(other));
    let braking = -follower.recent_accel();
    let stops_short = braking > 0.3 && vf * vf / (2.0 * braking) < p;
    !queued && !stops_short
}

/// The expert: go once the first car has stopped at its line or began to
/// brake for the ego (and keep going while it stays slow), or once both
/// cars are through or far enough; until then keep a stop before the zone
/// possible and let them pass.
pub(crate) fn expert(v: f64, v_max: f64, d: f64, other: &Track, follower: &Track, last: Option<Action>) -> Move {
    let going = last.is_some_and(|a| a.maneuver == Maneuver::Proceed && a.acceleration >= 1.0);
    let clear = passes_before(v, v_max, d, other) && passes_before(v, v_max, d, follower);
    let behind = arrives_after(v, v_max, d, other) && arrives_after(v, v_max, d, follower);
    if d < 0.5 || clear || behind || stopping(other) || began_braking(other) || (going && yielding(other)) {
        Move::go(go())
    } else {
        Move::not_yet(hedge(v, d - WAIT_GAP_M))
    }
}

/// The cue follower: go as soon as the first car brakes.
pub(crate) fn cue_follower(v: f64, v_max: f64, d: f64, other: &Track, follower: &Track) -> Action {
    let clear = passes_before(v, v_max, d, other) && passes_before(v, v_max, d, follower);
    if d < 0.5 || clear || yielding(other) { go() } else { hedge(v, d - WAIT_GAP_M) }
}
