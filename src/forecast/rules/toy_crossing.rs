//! The toy crossing's road-user model, for the forecast (the scenario the
//! unit tests add through the registry alone): a car that lets the ego go
//! stops at its line; one that does not drives on at its speed.

use super::Rules;
use crate::observation::Observation;

/// A yielder's front bumper comes to rest this far before the zone (m).
const STOP_LINE_M: f64 = 1.0;

pub(super) const RULES: Rules = Rules { at };

fn at(obs: &Observation, lets_you_go: bool, h: f64) -> Vec<f64> {
    let car = obs.scene.tracks()[0].now;
    let (p, v) = (car.position_m, car.velocity_mps.max(0.0));
    let moved = if lets_you_go && p > STOP_LINE_M { (v * h).min(p - STOP_LINE_M) } else { v * h };
    vec![p - moved]
}
