//! The rules forecaster: each scenario's road-user model under each
//! intent, read from the public scene only (so `serve --policy` can answer
//! with it from the scene text), with the model's typical figures (the
//! middle of each range in `scenarios/*.toml`) in place of the seed's
//! hidden draws. Its error is the floor a reader who knows how road users
//! behave, but not this one's draws, can reach. One file per scenario.

/// The rules forecaster's part of the scenario registry: a file of rules
/// per scenario, in the registry's order.
macro_rules! forecast_rules {
    ($($name:ident),+) => {
        $(mod $name;)+

        /// Every scenario's rules, in the order of `ScenarioKind::ALL`.
        const RULES: [&Rules; ScenarioKind::ALL.len()] = [$(&$name::RULES),+];
    };
}
crate::scenario::registry!(forecast_rules);

use super::{AtHorizons, Forecast, Forecaster, HORIZONS_S};
use crate::observation::Observation;
use crate::scenario::ScenarioKind;

/// One scenario's forecasting rules: where the probe's road users will be
/// at `horizon_s` if the other road user lets the ego go first or not.
pub(super) struct Rules {
    at: fn(&Observation, bool, f64) -> Vec<f64>,
}

/// The reference forecaster; a scene of a scenario outside the benchmark (a
/// test's) is forecast at constant velocity.
pub struct RulesForecaster;

impl Forecaster for RulesForecaster {
    fn forecast(&mut self, obs: &Observation) -> Forecast {
        let Some(rules) = obs.scene.kind().index().map(|i| RULES[i]) else {
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
    fn travel_ramps_then_holds() {
        assert_eq!(travel(10.0, 0.0, 2.0, 0.0), 20.0);
        // 10 m/s braking at 5 m/s^2 to rest: 10 m in 2 s, then stays.
        assert!((travel(10.0, 5.0, 3.0, 0.0) - 10.0).abs() < 1e-12);
        // 2 m/s up to 4 at 2 m/s^2: 3 m in the first second, then 4 m/s.
        assert!((travel(2.0, 2.0, 2.0, 4.0) - 7.0).abs() < 1e-12);
    }
}
