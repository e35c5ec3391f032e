//! The expert's and the cue follower's rules on `pedestrian_feint`. They read only the
//! public scene (the `Scene` a policy is given) and the scenario's public
//! geometry, never its world: they live on the public side of the firewall.

use super::Move;
use crate::action::{Action, Maneuver};
use crate::observation::{Observation, Track};
use crate::policy::{go, hedge};
use crate::scenario::pedestrian_feint::{AT_EDGE_M, FAR_KERB, PATH_NEAR, X_HALF};
use crate::sim::{EGO_MAX_ACCEL, travel_time};

/// A pedestrian this far from the near kerb (m) is off the road: the car
/// gives way until every centre on the crossing is past the far kerb (the
/// scene's rule), read with room for the scene's rounding.
const CLEAR_M: f64 = FAR_KERB + 0.1;

/// Where the expert waits: this far before the crossing line.
const WAIT_GAP_M: f64 = 2.0;
/// Giving way to a pedestrian on the road, the expert rolls toward a point
/// this far before the line (m), and picks up pace from there once full
/// throttle would reach the line only after it has crossed: a driver does
/// not creep up to a crossing someone is still walking over.
const LAUNCH_M: f64 = 4.0;
/// The expert's pace while it reads the pedestrian (m/s).
const PACE_MPS: f64 = 10.5;
/// A pedestrian standing at the kerb while the ego is due within this (s)
/// is waiting for the ego: any crosser (late step-out, dart) would already
/// be moving.
const COMMIT_ETA_S: f64 = 1.2;

/// A pedestrian who steps out late (the delayed step-out) is moving by
/// this time (s): the world's latest step-out, plus a decision.
const NO_STEP_OUT_BY_S: f64 = 2.5;

/// Whether the ego could still stop short of the line if it kept its speed
/// for one more decision (0.5 s) and then braked hard.
fn can_wait_a_turn(v: f64, d: f64) -> bool {
    d - 0.5 * v - 0.1 >= v * v / (2.0 * 8.0)
}

/// Give way to a pedestrian in or stepping into the road, timing the arrival
/// at the line for just after it has left the road: pick up pace once even
/// full throttle would reach the line only after it has.
fn give_way(v: f64, v_max: f64, d: f64, lat: f64, vel: f64) -> Action {
    if vel > 0.3 && lat > PATH_NEAR - 1.0 && d > 0.3 {
        let t_clear = (CLEAR_M + 0.1 - lat) / vel + 0.4;
        if travel_time(d, v, v_max, EGO_MAX_ACCEL) > t_clear {
            return go();
        }
        // The steady speed that reaches the launch point as it clears:
        // going from there at full throttle arrives just after it has.
        let v_t = (d - LAUNCH_M).max(0.0) / t_clear;
        return if v > v_t + 0.3 {
            let need = (v - v_t) / 0.5;
            if need > 4.0 {
                Action::new(Maneuver::Stop, ((need - 4.0) / 4.0).clamp(0.0, 1.0))
            } else {
                Action::new(Maneuver::Yield, ((need - 0.5) / 3.5).clamp(0.0, 1.0))
            }
        } else if v < v_t - 0.3 {
            Action::proceed_at(1.0)
        } else {
            Action::new(Maneuver::Yield, 0.0)
        };
    }
    hedge(v, d - WAIT_GAP_M)
}

/// This scenario's rules, read from its scene (whose layout its scenario
/// fixes; any other is given way to).
pub(super) const RULES: super::Rules = super::Rules {
    expert: |obs| match obs.scene.tracks() {
        [pedestrian, companions @ ..] => {
            let (v, v_max, d) = (obs.ego.speed_mps, obs.ego.speed_limit_mps, obs.scene.ego_to_conflict_m());
            let read = expert(v, v_max, obs.time_s, d, pedestrian);
            match companion_in_the_way(companions) {
                Some(c) if d >= 0.0 => {
                    Move { go: read.go, ..Move::not_yet(give_way(v, v_max, d, c.position_m, c.velocity_mps)) }
                }
                _ => read,
            }
        }
        _ => Move::not_yet(super::hold_back(&obs.scene, obs.ego.speed_mps)),
    },
    cue_follower: |scene, v, v_max| match scene.tracks() {
        [pedestrian, companions @ ..] => {
            let d = scene.ego_to_conflict_m();
            match companion_in_the_way(companions) {
                Some(c) if d >= 0.0 => give_way(v, v_max, d, c.position_m, c.velocity_mps),
                _ => cue_follower(v, v_max, d, pedestrian),
            }
        }
        _ => super::hold_back(scene, v),
    },
    watch: |obs, confirm| match obs.scene.tracks() {
        [_, companions @ ..] => companions.iter().any(|c| walker_may_reach_the_road(obs, c, confirm)),
        _ => false,
    },
};

/// Whether a walker that is not the tier's question may be on the road by
/// the time the ego has driven over the crossing, going now at full
/// throttle: it is on the road, or walking toward it and due there by then
/// (with a second to spare), unless its readings show it slowing to a stop
/// short of the kerb. With `confirm`, a walker counts as stopped only once
/// two readings in a row show it at rest, and one that moved at the last
/// reading is taken to walk on at that pace.
fn walker_may_reach_the_road(obs: &Observation, walker: &Track, confirm: bool) -> bool {
    let (lat, vel) = (walker.now.position_m, walker.now.velocity_mps);
    if lat >= CLEAR_M {
        return false;
    }
    if lat > 0.0 {
        return true;
    }
    let before = walker.past[walker.past.len() - 1].velocity_mps;
    let pace = if confirm { vel.max(before) } else { vel };
    if pace <= 0.1 {
        return false;
    }
    // Slowing since the last reading (m/s^2), and where that stops it.
    let slowing = (before - vel) / crate::observation::HISTORY_SPACING_S;
    if !confirm && slowing > 0.3 && lat + vel * vel / (2.0 * slowing) < 0.0 {
        return false;
    }
    let (v, v_max, d) = (obs.ego.speed_mps, obs.ego.speed_limit_mps, obs.scene.ego_to_conflict_m());
    let car_over = travel_time(d.max(0.0) + 2.0 * X_HALF, v, v_max, EGO_MAX_ACCEL);
    -lat / pace < car_over + 1.0
}

/// Companions walking up stop at the kerb back from its edge (-0.6 m);
/// one moving past here has stepped off.
const COMPANION_STOP_M: f64 = -0.5;

/// The companion the ego gives way to, if any is stepping in or on the
/// road: the one furthest from leaving it. Companions only ever follow a
/// pedestrian who took its turn, so one standing at the kerb is no cue.
fn companion_in_the_way(companions: &[Track]) -> Option<crate::observation::Sample> {
    companions
        .iter()
        .map(|c| c.now)
        .filter(|c| {
            c.position_m < CLEAR_M + 0.1
                && (c.position_m > 0.0 || (c.velocity_mps > 0.3 && c.position_m > COMPANION_STOP_M))
        })
        .min_by(|a, b| a.position_m.total_cmp(&b.position_m))
}

/// The expert: give way to a pedestrian moving into or through the road,
/// or standing at the kerb's edge (about to step in); keep a going pace
/// toward one who walks to or waits back from the edge while a stop stays
/// possible, and go once it stopped there to wait, or stands there when a
/// crosser would already have moved (by `NO_STEP_OUT_BY_S`, or with the
/// ego due within `COMMIT_ETA_S`): a standing pedestrian then waits for
/// the ego.
pub(crate) fn expert(v: f64, v_max: f64, time_s: f64, d: f64, p: &Track) -> Move {
    let lat = p.now.position_m;
    let vel = p.now.velocity_mps;
    if d < 0.0 || (lat > CLEAR_M + 0.1 && vel >= -0.1) {
        return Move::go(go());
    }
    let kerb = lat <= -0.1;
    let standing = vel.abs() < 0.15;
    let at_edge = lat > AT_EDGE_M && vel >= -0.1;
    // Picking up pace from the kerb is stepping off (slowing there is stopping).
    let setting_off = vel > 0.3 && p.recent_accel() > 0.3;
    // Crossing: the car waits it out whole, and then goes.
    if !kerb && vel > 0.3 {
        return Move::go(give_way(v, v_max, d, lat, vel));
    }
    if !kerb || at_edge || setting_off {
        return Move::not_yet(give_way(v, v_max, d, lat, vel));
    }
    let eta = if v > 0.5 { d / v } else { f64::INFINITY };
    // It walked up and stopped back from the edge: it waits for the ego.
    let stopped_to_wait = standing && p.past.iter().any(|s| s.velocity_mps > 0.3);
    // Still standing back from the edge once any late crosser would be
    // moving: it waits for the ego.
    let no_step_out = standing && time_s >= NO_STEP_OUT_BY_S;
    if stopped_to_wait || no_step_out || (standing && eta <= COMMIT_ETA_S) {
        return Move::go(go());
    }
    if !can_wait_a_turn(v, d) {
        return Move::not_yet(hedge(v, d - WAIT_GAP_M));
    }
    // Keep a going pace.
    Move::not_yet(if v < PACE_MPS { Action::proceed_at(1.0) } else { Action::new(Maneuver::Yield, 0.0) })
}

/// The cue follower: go as soon as the pedestrian is not moving into the road.
pub(crate) fn cue_follower(v: f64, v_max: f64, d: f64, p: &Track) -> Action {
    let lat = p.now.position_m;
    let crossed = lat > CLEAR_M + 0.3;
    let coming = p.now.velocity_mps > 0.2 || (lat > 0.0 && !crossed);
    if d < 0.0 || crossed || !coming { go() } else { give_way(v, v_max, d, lat, p.now.velocity_mps) }
}
