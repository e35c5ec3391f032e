//! The intersection's road-user model, for the forecast: the other car
//! (the first on the crossing road) stops at its line if it lets the ego go
//! first, and drives through if it does not.

use super::{Rules, travel};
use crate::observation::Observation;

/// A car that lets the ego go stops this far before the zone (m) ...
const STOP_LINE_M: f64 = 1.5;
/// ... braking once a stop at its line takes this rate (m/s^2).
const STOP_DECEL_MPS2: f64 = 3.5;
/// A car braking harder than this (m/s^2) is on its way to a stop.
const BRAKING_MPS2: f64 = 0.5;
/// Below this a car is at rest (m/s).
const AT_REST_MPS: f64 = 0.3;
/// A car that does not let the ego go, but eased off as if to stop, eases
/// off no lower than this (m/s) ...
const FLOOR_MPS: f64 = 2.0;
/// ... and a car pulling away from its line goes up to this (m/s), at this
/// rate (m/s^2).
const GO_SPEED_MPS: f64 = 3.0;
const GO_ACCEL_MPS2: f64 = 1.2;

pub(super) const RULES: Rules = Rules { at };

fn at(obs: &Observation, lets_you_go: bool, h: f64) -> Vec<f64> {
    let track = obs.scene.tracks()[0];
    let (p, v, a) = (track.now.position_m, track.now.velocity_mps.max(0.0), track.recent_accel());
    let moved = if p <= 0.0 || (v < AT_REST_MPS && a > BRAKING_MPS2) {
        // In the zone, or pulling away from its line: it drives on.
        travel(v, GO_ACCEL_MPS2, h, GO_SPEED_MPS.max(v))
    } else if lets_you_go {
        stop_at_line(p, v, a, h)
    } else if a < -BRAKING_MPS2 {
        travel(v, a, h, FLOOR_MPS.min(v))
    } else {
        v * h
    };
    vec![p - moved]
}

/// A car stopping at its line: braking now if it is, or once a stop there
/// takes `STOP_DECEL_MPS2`.
fn stop_at_line(p: f64, v: f64, a: f64, h: f64) -> f64 {
    if v < AT_REST_MPS {
        return 0.0;
    }
    let room = (p - STOP_LINE_M).max(0.05);
    let needed = v * v / (2.0 * room);
    if a < -BRAKING_MPS2 || needed >= STOP_DECEL_MPS2 {
        return travel(v, needed, h, 0.0);
    }
    let cruise = room - v * v / (2.0 * STOP_DECEL_MPS2);
    let t_cruise = cruise / v;
    if t_cruise >= h { v * h } else { cruise + travel(v, STOP_DECEL_MPS2, h - t_cruise, 0.0) }
}
