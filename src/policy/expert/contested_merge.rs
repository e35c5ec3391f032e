//! The expert's and the cue follower's rules on `contested_merge`. They read only the
//! public scene (the `Scene` a policy is given) and the scenario's public
//! geometry, never its world: they live on the public side of the firewall.

use super::{GENTLE_YIELD, Move, bolder, gentler};
use crate::action::{Action, Maneuver};
use crate::observation::Track;
use crate::policy::{go, hedge};
use crate::sim::CAR_LENGTH;

/// A car behind the ego is taken to be this much closer than it reads (m).
const BEHIND_MARGIN_M: f64 = 1.5;
/// Where the expert stops at the latest: this far before the merge point.
const WAIT_GAP_M: f64 = 2.0;
/// A lane car this far below its recent mean speed (m/s) is clearly slowing:
/// twice the noisy tier's speed noise (the scenario file's typical figure)
/// on that difference.
fn slowing_mps() -> f64 {
    2.0 * crate::scenario::contested_merge::typical().speed_noise_mps
}
/// A slowing lane car still this much faster than the ego (m/s) is not
/// dropping back but settling to its cruise after closing a gap hard.
const SETTLING_MARGIN_MPS: f64 = 2.0;
/// A lane car gaining speed faster than this (m/s^2, over the last
/// decision) is closing a gap, not letting the ego go, however far back it
/// reads: read only where the readings are exact (two noisy speeds half a
/// second apart make no acceleration).
const REGAINING_MPS2: f64 = 2.0;
/// Until this close to the merge point (m), a lane car that has shown
/// nothing yet is given the chance to make room.
const UNDECIDED_UNTIL_M: f64 = 26.0;
/// Whether the lane has room for the ego now. Cars are placed by their
/// centre relative to the ego (positive ahead). The car ahead needs a
/// bumper gap that covers a short headway and the closing speed; a car
/// behind needs one in which it can brake comfortably to the ego's speed,
/// and must not be gaining speed (a car that re-accelerates may be closing
/// the gap on purpose).
fn lane_has_room(cars: [&Track; 2], ego_speed: f64) -> bool {
    cars.iter().all(|t| {
        let (rel, v) = (t.now.position_m, t.now.velocity_mps);
        if rel >= 0.0 {
            let gap = rel - CAR_LENGTH;
            let closing = (ego_speed - v).max(0.0);
            gap >= 1.0 + 0.3 * ego_speed + closing * closing / 6.0
        } else {
            // Read pessimistically (a reading may be noisy): as close as
            // the track allows and as fast as it has lately been.
            let v = v.max(t.past.iter().map(|p| p.velocity_mps).sum::<f64>() / t.past.len() as f64);
            let gap = -rel - CAR_LENGTH - BEHIND_MARGIN_M;
            let closing = (v - ego_speed).max(0.0);
            gap >= 0.5 + closing * closing / 6.0 && (t.recent_accel() < 0.5 || v < ego_speed - 0.5)
        }
    })
}

/// Whether the lane car is making room: clearly slowing, or holding back
/// behind the ego's rear no faster than the ego. With `exact` readings, a
/// car fallen back behind the ego that is gaining speed hard is not: a
/// reader a decision late sees a closing bluffer where it was, behind.
///
/// Clearly slowing is measured against its own recent speeds
/// ([`slowing_mps`]), which a car dropping back shows within one decision
/// whatever the ego's own speed: a driver who eased off while unsure reads
/// it as soon as one at full pace. A car that is still much faster than the
/// ego is not making room ([`SETTLING_MARGIN_MPS`]): it may be coming back
/// down to its cruise after closing a gap hard (the tier-3 bluff).
fn making_room(lane_car: &Track, ego_speed: f64, exact: bool) -> bool {
    let (rel, v) = (lane_car.now.position_m, lane_car.now.velocity_mps);
    let dropping_back = speed_trend(lane_car) < -slowing_mps() && v < ego_speed + SETTLING_MARGIN_MPS;
    let slowing = rel < CAR_LENGTH && (dropping_back || (v < ego_speed - 2.5 && lane_car.recent_accel() < 2.0));
    // Behind the ego's centre and no faster: it is letting the ego go.
    let fallen_back = rel < -1.5 && v < ego_speed - 0.5 && !(exact && lane_car.recent_accel() > REGAINING_MPS2);
    let holding_back = rel < -CAR_LENGTH
        && v <= ego_speed + 0.3
        && (lane_car.recent_accel() < 0.5 || (v < ego_speed - 1.0 && lane_car.recent_accel() < 2.0));
    slowing || holding_back || fallen_back
}

/// The lane car's speed now against its mean over the observed history
/// (m/s): robust to observation noise, negative for a car easing off.
fn speed_trend(t: &Track) -> f64 {
    let mean = t.past.iter().map(|p| p.velocity_mps).sum::<f64>() / t.past.len() as f64;
    t.now.velocity_mps - mean
}

/// Speed-tracking action toward `target`, braking at most as needed.
fn toward(v: f64, target: f64) -> Action {
    if v < target - 0.2 {
        Action::proceed_at(1.0 + 2.0 * ((target - v) / 1.5 - 0.5).clamp(0.0, 1.0))
    } else if v > target + 0.2 {
        Action::new(Maneuver::Yield, ((v - target) / 2.0 - 0.1).clamp(0.0, 1.0))
    } else {
        Action::proceed_at(1.0)
    }
}

/// In the lane: full speed, but keep a safe gap to a lane car ahead.
fn follow_in_lane(v: f64, v_max: f64, cars: [&Track; 2]) -> Action {
    let ahead =
        cars.iter().filter(|t| t.now.position_m > 0.0).min_by(|a, b| a.now.position_m.total_cmp(&b.now.position_m));
    match ahead {
        Some(t) => {
            let gap = t.now.position_m - CAR_LENGTH;
            let target = (t.now.velocity_mps + 0.8 * (gap - 2.0 - 0.6 * v)).clamp(0.0, v_max);
            toward(v, target)
        }
        None => go(),
    }
}

/// This scenario's rules, read from its scene (whose layout its scenario
/// fixes; any other is given way to).
pub(super) const RULES: super::Rules = super::Rules {
    expert: |obs| match obs.scene.tracks() {
        [lane_car, follower] => {
            let (v, v_max) = (obs.ego.speed_mps, obs.ego.speed_limit_mps);
            let exact = obs.reading_noise.is_none();
            expert(v, v_max, obs.scene.ego_to_conflict_m(), lane_car, follower, exact)
        }
        _ => Move::not_yet(super::hold_back(&obs.scene, obs.ego.speed_mps)),
    },
    cue_follower: |scene, v, v_max| match scene.tracks() {
        [lane_car, follower] => cue_follower(v, v_max, scene.ego_to_conflict_m(), lane_car, follower),
        _ => super::hold_back(scene, v),
    },
    watch: |obs, _confirm| match obs.scene.tracks() {
        [lane_car, follower] => follower_may_close_on_the_ego(obs.ego.speed_mps, lane_car, follower),
        _ => false,
    },
};

/// Whether the lane car's follower (not the tier's question) could close
/// on the ego in the lane: it leaves the room a car behind the ego needs
/// ([`lane_has_room`]) unless it is queued behind the lane car, which any
/// slot the ego takes is ahead of. The rules read it already where it is
/// nearer: this is the habit, stated over every road user.
fn follower_may_close_on_the_ego(ego_speed: f64, lane_car: &Track, follower: &Track) -> bool {
    let behind_lane_car = follower.now.position_m < lane_car.now.position_m - CAR_LENGTH;
    follower.now.position_m < 0.0 && !behind_lane_car && !lane_has_room([follower, follower], ego_speed)
}

/// The expert: keep pace at first (a car making room only opens a gap for
/// an ego that keeps pace); merge ahead once the lane car shows it makes
/// room; otherwise let the lane car and its follower pass, keeping a stop
/// before the merge point possible, and merge behind them.
/// `exact`: the scene's readings carry no noise.
pub(crate) fn expert(v: f64, v_max: f64, d: f64, lane_car: &Track, follower: &Track, exact: bool) -> Move {
    if d < 0.0 {
        return Move::go(follow_in_lane(v, v_max, [lane_car, follower]));
    }
    if lane_has_room([lane_car, follower], v) {
        return Move::go(gentler(v, v_max, go(), follow_in_lane(v, v_max, [lane_car, follower])));
    }
    if making_room(lane_car, v, exact) {
        return Move::go(go());
    }
    // No sign yet of a car holding the lane (speeding up to keep the ego
    // out): keep pace while it may still make room.
    let undecided = speed_trend(lane_car) < 1.0 && lane_car.now.position_m.abs() < CAR_LENGTH + 1.0;
    if undecided && d > UNDECIDED_UNTIL_M {
        return Move::not_yet(go());
    }
    // Let both lane cars go first: arrive at the merge point once the last
    // of them has cleared it, never closer than a comfortable stop.
    let last = if follower.now.position_m > lane_car.now.position_m { lane_car } else { follower };
    let (rel, v_last) = (last.now.position_m, last.now.velocity_mps.max(1.0));
    let clear_in = (d - rel + CAR_LENGTH + 3.0) / v_last;
    let target = (d / clear_in).min(v_last - 1.0).max(0.0);
    // On noisy readings a single reading can flip the rules from going to
    // giving way: slow toward the target no harder than a driver unsure of
    // what it saw (braking at 2 m/s^2 or more gives the lane car its turn
    // plainly, and a car making room takes it), unless the stop before the
    // merge point needs more.
    let slow_down = toward(v, target);
    let slow_down =
        if exact { slow_down } else { bolder(v, v_max, slow_down, Action::new(Maneuver::Yield, GENTLE_YIELD)) };
    Move::not_yet(gentler(v, v_max, slow_down, hedge(v, d - WAIT_GAP_M)))
}

/// The cue follower: merge whenever the lane car has dropped back (behind
/// the ego and slower than it), without checking that it keeps making room
/// (a car closing a gap from behind is still behind and slower for a while).
pub(crate) fn cue_follower(v: f64, v_max: f64, d: f64, lane_car: &Track, follower: &Track) -> Action {
    let (rel, v_lane) = (lane_car.now.position_m, lane_car.now.velocity_mps);
    let top = lane_car.past.iter().map(|p| p.velocity_mps).fold(v_lane, f64::max);
    let eased = v_lane < top - 1.0 || lane_car.past.iter().any(|p| p.velocity_mps < top - 1.0);
    let braking = lane_car.recent_accel() < -1.2;
    let dropping_back = braking || (eased && rel < 0.0);
    if dropping_back || d < 0.0 || lane_has_room([lane_car, follower], v) {
        go()
    } else {
        expert(v, v_max, d, lane_car, follower, false).action
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::observation::Sample;

    fn track(position_m: f64, speeds: [f64; 5]) -> Track {
        let past = std::array::from_fn(|i| Sample { position_m, velocity_mps: speeds[i] });
        Track { now: Sample { position_m, velocity_mps: speeds[4] }, past }
    }

    /// A car dropping back at 3 m/s^2 beside an ego that eased off while
    /// unsure (traced: merge tier 1, seed 0, `expert_cautious`, t = 1 s) is
    /// making room, as it is for an ego at full pace.
    #[test]
    fn a_car_dropping_back_beside_an_ego_that_eased_off_is_making_room() {
        let lane_car = track(-0.98, [10.53, 10.53, 10.53, 8.53, 7.90]);
        for exact in [true, false] {
            assert!(making_room(&lane_car, 9.4, exact));
            assert!(making_room(&lane_car, 13.0, exact));
        }
    }

    /// A bluffer closing the gap from a car length behind the ego, slower
    /// than it but gaining 3.3 m/s^2 (traced: merge tier 3, seed 8, as a
    /// reader a decision late once read it). With exact readings that is no
    /// car making room; with noisy ones the gain is not read.
    #[test]
    fn a_bluffer_regaining_speed_behind_a_late_reader_is_not_making_room() {
        let bluffer = track(-4.79, [10.88, 10.88, 8.88, 6.88, 8.53]);
        assert!(!making_room(&bluffer, 10.4, true));
        assert!(making_room(&bluffer, 10.4, false));
    }

    /// A car coming back down to its cruise after closing the gap hard
    /// (traced: the tier-3 bluffer, seed 22, t = 3 s) is not making room,
    /// though it slows as much: it is still far faster than the ego.
    #[test]
    fn a_car_settling_after_a_hard_close_is_not_making_room() {
        let bluffer = track(0.89, [11.86, 14.11, 13.34, 11.84, 10.74]);
        assert!(speed_trend(&bluffer) < -slowing_mps());
        assert!(!making_room(&bluffer, 7.0, true));
    }
}
