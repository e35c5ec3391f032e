//! The rules forecaster: each scenario's road-user model under each
//! intent, read from the public scene only (so `serve --policy` can answer
//! with it from the scene text), with the model's typical figures (the
//! middle of each range in `scenarios/*.toml`) in place of the seed's
//! hidden draws. Its error is the floor a reader who knows how road users
//! behave, but not this one's draws, can reach. One file per scenario.

mod contested_merge;
mod pedestrian_feint;
mod yield_standoff;

use super::{AtHorizons, Forecast, Forecaster, HORIZONS_S};
use crate::observation::Observation;
use crate::scenario::ScenarioKind;

/// One scenario's forecasting rules: where the probe's road users will be
/// at `horizon_s` if the other road user lets the ego go first or not.
pub(super) struct Rules {
    scenario: ScenarioKind,
    at: fn(&Observation, bool, f64) -> Vec<f64>,
}

const RULES: [&Rules; 3] = [&yield_standoff::RULES, &pedestrian_feint::RULES, &contested_merge::RULES];

/// The reference forecaster; a scene without rules here is forecast at
/// constant velocity (a test holds every scenario to having rules).
pub struct RulesForecaster;

impl Forecaster for RulesForecaster {
    fn forecast(&mut self, obs: &Observation) -> Forecast {
        let Some(rules) = RULES.into_iter().find(|r| r.scenario == obs.scene.kind()) else {
            return Forecast::same(super::constant_velocity(obs));
        };
        let under = |lets_you_go: bool| -> Vec<AtHorizons> {
            let [a, b] = HORIZONS_S.map(|h| (rules.at)(obs, lets_you_go, h));
            a.into_iter().zip(b).map(|(x, y)| [x, y]).collect()
        };
        Forecast { lets_you_go: under(true), does_not: under(false) }
    }
}

/// Distance travelled in `h` seconds from speed `v`, changing speed at
/// `rate` (m/s^2, its sign ignored) toward `target`, then holding it.
pub(super) fn travel(v: f64, rate: f64, h: f64, target: f64) -> f64 {
    let rate = rate.abs();
    if rate < 1e-9 || (target - v).abs() < 1e-9 {
        return v * h;
    }
    let dir = (target - v).signum();
    let t_reach = ((target - v).abs() / rate).min(h);
    let ramp = v * t_reach + 0.5 * dir * rate * t_reach * t_reach;
    ramp + target * (h - t_reach).max(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_scenario_has_forecasting_rules() {
        for kind in ScenarioKind::ALL {
            assert!(RULES.iter().any(|r| r.scenario == kind), "{kind}");
        }
    }

    #[test]
    fn travel_ramps_then_holds() {
        assert_eq!(travel(10.0, 0.0, 2.0, 0.0), 20.0);
        // 10 m/s braking at 5 m/s^2 to rest: 10 m in 2 s, then stays.
        assert!((travel(10.0, 5.0, 3.0, 0.0) - 10.0).abs() < 1e-12);
        // 2 m/s up to 4 at 2 m/s^2: 3 m in the first second, then 4 m/s.
        assert!((travel(2.0, 2.0, 2.0, 4.0) - 7.0).abs() < 1e-12);
    }
}
