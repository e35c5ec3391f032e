//! The merge's road-user model, for the forecast: a lane car that lets the
//! ego go drops back to a gap behind it and keeps it; one that does not
//! holds the lane, drawing level with a faster ego alongside that keeps
//! pace; one wholly ahead of the ego has nothing left to give or hold and
//! keeps its pace. Positions are from where the ego is at the decision.

use super::{Rules, travel};
use crate::observation::{HISTORY_SPACING_S, Observation, Sample, Track};
use crate::scenario::contested_merge::typical;
use crate::sim::{CAR_LENGTH, track_speed};

/// A lane car letting the ego go slows at most as hard as the scenario
/// file's `lane.open_decel_mps2` and picks up speed at lane traffic's IDM
/// rate, holding back this much slower than the ego (m/s) until it is
/// `lane.open_gap_m` behind the ego's rear, closing on that gap at this
/// rate (1/s); overlapping the ego it drops back this much slower (m/s).
const HOLD_BACK_MPS: f64 = 0.7;
const GAP_GAIN: f64 = 0.8;
const DROP_BACK_MPS: f64 = 4.0;
/// A lane car this much faster than the ego is passing it (m/s).
const PASSING_MPS: f64 = 0.5;
/// An ego braking harder than this (m/s^2) hangs back; a car letting it
/// go then covers it, its centre this far from the ego's (m), braking up
/// to lane traffic's hardest. One holding the lane draws level with a
/// faster ego alongside (the file's `lane.deny_*` figures).
const HANGING_BACK_MPS2: f64 = -1.0;
const COVER_AT_M: f64 = -(CAR_LENGTH - 1.5);
/// Readings a noisy scene's position and speed are averaged over.
const SMOOTH_OVER: usize = 3;
/// The step of the forecast's own little simulation (s).
const STEP_S: f64 = 0.1;

pub(super) const RULES: Rules = Rules { at };

fn at(obs: &Observation, lets_you_go: bool, h: f64) -> Vec<f64> {
    let typical = typical();
    let tracks = obs.scene.tracks();
    let (lane, follower) = (read(obs, &tracks[0]), read(obs, &tracks[1]));
    let (p, v, ego_v) = (lane.position_m, lane.velocity_mps.max(0.0), obs.ego.speed_mps);
    // A car faster than the ego beside it is passing it (it took its turn).
    let passing = v > ego_v + PASSING_MPS && p > -CAR_LENGTH;
    // Wholly ahead of the ego it has nothing left to give way or to hold:
    // it keeps its pace.
    let settled = p >= CAR_LENGTH;
    let keeps_pace = obs.ego.accel_mps2 > HANGING_BACK_MPS2;
    let moved = if settled {
        v * h
    } else if lets_you_go && !passing {
        gives_way(p, v, ego_v, keeps_pace, h)
    } else if !lets_you_go && p.abs() < CAR_LENGTH && ego_v > v && keeps_pace {
        travel(v, typical.deny_accel_mps2, h, ego_v.min(v + typical.deny_extra_mps))
    } else {
        v * h
    };
    // The car behind keeps its pace under either (closing the door on a
    // cut-in, it closes up as much as the lane car drops back: its own
    // speed is the better guess).
    vec![p + moved, follower.position_m + follower.velocity_mps.max(0.0) * h]
}

/// How far a car letting the ego go travels in `h`, the ego holding its
/// speed: behind an ego that keeps pace it keeps a gap behind the ego's
/// rear, visibly slower than the ego until it has one; beside an ego that
/// hangs back it covers it.
fn gives_way(p: f64, v: f64, ego_v: f64, keeps_pace: bool, h: f64) -> f64 {
    let typical = typical();
    let (mut rel, mut v, mut moved) = (p, v, 0.0);
    for _ in 0..(h / STEP_S).round() as usize {
        let gap = -rel - CAR_LENGTH;
        let (target, brake) = if keeps_pace {
            let follow = (ego_v + GAP_GAIN * (gap - typical.open_gap_m)).min(ego_v - HOLD_BACK_MPS);
            (if gap < 0.0 { follow.min(ego_v - DROP_BACK_MPS).min(v) } else { follow }, typical.open_decel_mps2)
        } else {
            (ego_v + (COVER_AT_M - rel), typical.max_brake_mps2)
        };
        let a = track_speed(v, target.max(0.0), typical.pick_up_mps2, brake, STEP_S);
        let next = (v + a * STEP_S).max(0.0);
        moved += 0.5 * (v + next) * STEP_S;
        rel += (0.5 * (v + next) - ego_v) * STEP_S;
        v = next;
    }
    moved
}

/// A lane car's current position and speed: as read, or, where the scene
/// says its readings carry noise, the mean of the last [`SMOOTH_OVER`]
/// readings, each carried forward to now (by the car's read speed less
/// the ego's, whose earlier speed its current acceleration gives).
fn read(obs: &Observation, track: &Track) -> Sample {
    if obs.reading_noise.is_none() {
        return track.now;
    }
    let samples: Vec<(f64, Sample)> = std::iter::once((0.0, track.now))
        .chain(track.past.iter().rev().enumerate().map(|(i, s)| ((i + 1) as f64 * HISTORY_SPACING_S, *s)))
        .take(SMOOTH_OVER)
        .collect();
    let n = samples.len() as f64;
    let velocity = samples.iter().map(|(_, s)| s.velocity_mps).sum::<f64>() / n;
    let (ego_v, ego_a) = (obs.ego.speed_mps, obs.ego.accel_mps2);
    let position =
        samples.iter().map(|&(ago, s)| s.position_m + (velocity - (ego_v - 0.5 * ego_a * ago)) * ago).sum::<f64>() / n;
    Sample { position_m: position, velocity_mps: velocity }
}
