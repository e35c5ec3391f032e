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

    /// Each typical figure the rules (and the expert) read, against the
    /// same figure read back by its path from the scenario in force as a
    /// run records it (its JSON, a range's middle): should the rules read a
    /// figure of their own, or the wrong field, this fails.
    #[test]
    fn the_rules_figures_are_the_scenario_files() {
        use crate::scenario::{ScenarioConfig, contested_merge, pedestrian_feint, yield_standoff};
        let file = |kind: ScenarioKind, path: &str| -> f64 {
            let json = serde_json::to_value(ScenarioConfig::builtin(kind)).unwrap();
            let v = path.split('.').fold(&json, |v, key| &v[key]);
            match v.as_array() {
                Some(range) => 0.5 * (range[0].as_f64().unwrap() + range[1].as_f64().unwrap()),
                None => v.as_f64().unwrap_or_else(|| panic!("{kind}: no figure at {path}")),
            }
        };
        let y = yield_standoff::typical();
        let kind = ScenarioKind::YieldStandoff;
        assert_eq!(
            [y.stop_line_m, y.stop_decel_mps2, y.floor_speed_mps, y.go_speed_mps, y.go_accel_mps2],
            [
                "other.stop_line_m",
                "other.stop_decel_mps2",
                "tier3.floor_speed_mps",
                "other.go_speed_mps",
                "other.go_accel_mps2"
            ]
            .map(|p| file(kind, p))
        );
        let c = pedestrian_feint::typical();
        let kind = ScenarioKind::PedestrianFeint;
        assert_eq!(
            [c.kerb_stop_m, c.step_out_at_s, c.step_out_speed_mps, c.dart_speed_mps, c.dart_horizon_s],
            [
                "pedestrian.kerb_stop_m",
                "tier2.step_at_s",
                "tier2.step_out_speed_mps",
                "tier3.dart_speed_mps",
                "tier3.dart_horizon_s"
            ]
            .map(|p| file(kind, p))
        );
        let m = contested_merge::typical();
        let kind = ScenarioKind::ContestedMerge;
        assert_eq!(
            [
                m.open_decel_mps2,
                m.open_gap_m,
                m.pick_up_mps2,
                m.max_brake_mps2,
                m.deny_accel_mps2,
                m.deny_extra_mps,
                m.speed_noise_mps
            ],
            [
                "lane.open_decel_mps2",
                "lane.open_gap_m",
                "idm.accel",
                "idm.max_brake",
                "lane.deny_accel_mps2",
                "lane.deny_extra_mps",
                "tier2.speed_noise_mps"
            ]
            .map(|p| file(kind, p))
        );
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
