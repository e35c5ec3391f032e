//! The intersection's road-user model, for the forecast: the other car
//! (the first on the crossing road) stops at its line if it lets the ego go
//! first, and drives through if it does not.

use super::{Rules, travel};
use crate::observation::Observation;
use crate::scenario::yield_standoff::typical;

/// A car braking harder than this (m/s^2) is on its way to a stop.
const BRAKING_MPS2: f64 = 0.5;
/// Below this a car is at rest (m/s).
const AT_REST_MPS: f64 = 0.3;

pub(super) const RULES: Rules = Rules { at };

fn at(obs: &Observation, lets_you_go: bool, h: f64) -> Vec<f64> {
    // How a yielder stops, a bluffer eases off and a car pulls away: the
    // scenario file's typical figures.
    let typical = typical();
    let track = obs.scene.tracks()[0];
    let (p, v, a) = (track.now.position_m, track.now.velocity_mps.max(0.0), track.recent_accel());
    let moved = if p <= 0.0 || (v < AT_REST_MPS && a > BRAKING_MPS2) {
        // In the zone, or pulling away from its line: it drives on.
        travel(v, typical.go_accel_mps2, h, typical.go_speed_mps.max(v))
    } else if lets_you_go {
        stop_at_line(p, v, a, h)
    } else if a < -BRAKING_MPS2 {
        travel(v, a, h, typical.floor_speed_mps.min(v))
    } else {
        v * h
    };
    vec![p - moved]
}

/// A car stopping at its line: braking now if it is, or once a stop there
/// takes the file's `other.stop_decel_mps2`.
fn stop_at_line(p: f64, v: f64, a: f64, h: f64) -> f64 {
    let typical = typical();
    if v < AT_REST_MPS {
        return 0.0;
    }
    let room = (p - typical.stop_line_m).max(0.05);
    let needed = v * v / (2.0 * room);
    if a < -BRAKING_MPS2 || needed >= typical.stop_decel_mps2 {
        return travel(v, needed, h, 0.0);
    }
    let cruise = room - v * v / (2.0 * typical.stop_decel_mps2);
    let t_cruise = cruise / v;
    if t_cruise >= h { v * h } else { cruise + travel(v, typical.stop_decel_mps2, h - t_cruise, 0.0) }
}
