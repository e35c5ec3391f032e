//! The merge's road-user model, for the forecast: a lane car that lets the
//! ego go drops back to a gap behind it and keeps it; one that does not
//! holds the lane, drawing level with a faster ego alongside that keeps
//! pace; one wholly ahead of the ego has nothing left to give or hold and
//! keeps its pace. Positions are from where the ego is at the decision.

use super::{Rules, travel};
use crate::observation::{HISTORY_SPACING_S, Observation, Sample, Track};
use crate::sim::{CAR_LENGTH, track_speed};

/// A lane car letting the go ego slows at most this hard (m/s^2) and
/// picks up speed this gently (m/s^2, lane traffic's IDM rate) ...
const OPEN_DECEL_MPS2: f64 = 3.0;
const PICK_UP_MPS2: f64 = 1.5;
/// ... holding back this much slower than the ego (m/s) until it is this
/// far behind the ego's rear (m), closing on that gap at this rate (1/s);
/// overlapping the ego it drops back this much slower (m/s).
const HOLD_BACK_MPS: f64 = 0.7;
const OPEN_GAP_M: f64 = 1.0;
const GAP_GAIN: f64 = 0.8;
const DROP_BACK_MPS: f64 = 4.0;
/// A lane car this much faster than the ego is passing it (m/s).
const PASSING_MPS: f64 = 0.5;
/// An ego braking harder than this (m/s^2) hangs back; a car letting it
/// go then covers it, its centre this far from the ego's (m), braking up
/// to this hard (m/s^2).
const HANGING_BACK_MPS2: f64 = -1.0;
const COVER_AT_M: f64 = -(CAR_LENGTH - 1.5);
const COVER_DECEL_MPS2: f64 = 4.0;
/// One holding the lane draws level with a faster ego alongside at this
/// rate (m/s^2), at most this much above its speed (m/s).
const HOLD_ACCEL_MPS2: f64 = 3.0;
const HOLD_EXTRA_MPS: f64 = 4.0;
/// Readings a noisy scene's position and speed are averaged over.
const SMOOTH_OVER: usize = 3;
/// The step of the forecast's own little simulation (s).
const STEP_S: f64 = 0.1;

pub(super) const RULES: Rules = Rules { at };

fn at(obs: &Observation, lets_you_go: bool, h: f64) -> Vec<f64> {
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
        travel(v, HOLD_ACCEL_MPS2, h, ego_v.min(v + HOLD_EXTRA_MPS))
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
    let (mut rel, mut v, mut moved) = (p, v, 0.0);
    for _ in 0..(h / STEP_S).round() as usize {
        let gap = -rel - CAR_LENGTH;
        let (target, brake) = if keeps_pace {
            let follow = (ego_v + GAP_GAIN * (gap - OPEN_GAP_M)).min(ego_v - HOLD_BACK_MPS);
            (if gap < 0.0 { follow.min(ego_v - DROP_BACK_MPS).min(v) } else { follow }, OPEN_DECEL_MPS2)
        } else {
            (ego_v + (COVER_AT_M - rel), COVER_DECEL_MPS2)
        };
        let a = track_speed(v, target.max(0.0), PICK_UP_MPS2, brake, STEP_S);
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
