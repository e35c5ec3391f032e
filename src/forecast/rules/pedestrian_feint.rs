//! The crosswalk's road-user model, for the forecast: a pedestrian who
//! lets the ego go stops back from the kerb's edge and stays; one who does
//! not walks on across, steps out on its own time, or darts from the edge
//! once the car is about to reach the line; one who has crossed stops on
//! the far sidewalk.

use super::Rules;
use crate::observation::Observation;
use crate::scenario::pedestrian_feint::{AT_EDGE_M, FAR_KERB, FAR_STOP, typical};

/// Below this (m/s) a pedestrian stands.
const STANDING_MPS: f64 = 0.1;

pub(super) const RULES: Rules = Rules { at };

fn at(obs: &Observation, lets_you_go: bool, h: f64) -> Vec<f64> {
    let track = obs.scene.tracks()[0];
    let (lat, v) = (track.now.position_m, track.now.velocity_mps);
    // Where one waiting for cars stands, and how a crosser sets out: the
    // scenario file's typical figures.
    let typical = typical();
    let kerb_stop_m = typical.kerb_stop_m;
    if lat > FAR_KERB {
        // It has crossed (the scene marks the far kerb): it walks on to its
        // stop on the far sidewalk and stays; it never darts back across.
        return vec![(lat + v.max(0.0) * h).min(FAR_STOP.max(lat))];
    }
    if v > STANDING_MPS {
        // Walking toward the kerb, one who lets the car go stops back from
        // its edge; on the road, anyone walks on.
        let walked = lat + v * h;
        return vec![if lets_you_go && lat < kerb_stop_m { walked.min(kerb_stop_m) } else { walked }];
    }
    if lets_you_go {
        return vec![lat];
    }
    let now = obs.time_s;
    let (start, pace) = if lat > AT_EDGE_M {
        let to_line = obs.scene.ego_to_conflict_m();
        let eta = if obs.ego.speed_mps > 0.1 { to_line / obs.ego.speed_mps } else { f64::INFINITY };
        (now + (eta - typical.dart_horizon_s).max(0.0), typical.dart_speed_mps)
    } else {
        (typical.step_out_at_s.max(now), typical.step_out_speed_mps)
    };
    vec![lat + pace * (now + h - start).max(0.0)]
}

#[cfg(test)]
mod tests {
    use crate::action::{Action, Maneuver};
    use crate::episode::Episode;
    use crate::forecast::{Forecaster, rules::RulesForecaster};
    use crate::scenario::{ScenarioKind, ScenarioSet, Tier};

    #[test]
    fn one_who_has_crossed_stays_on_the_far_sidewalk() {
        // A car that waits at the line lets the crosser cross whole and stop
        // past the far kerb; as the car then drives on, the pedestrian there
        // neither walks on nor darts back across in front of it.
        let set = ScenarioSet::default();
        let config = set.get(ScenarioKind::PedestrianFeint);
        let mut episode = Episode::with_disposition(config, Tier::T3, 3, crate::scenario::pedestrian_feint::CROSSER);
        let (mut seen, mut action) = (0, Action::new(Maneuver::NudgeForward, 0.0));
        while episode.step(action).is_none() {
            let obs = episode.observation();
            let now = obs.scene.tracks()[0].now;
            if now.position_m > super::FAR_KERB && now.velocity_mps <= super::STANDING_MPS {
                action = Action::new(Maneuver::Proceed, 1.0);
                let f = RulesForecaster.forecast(obs);
                for at in [&f.lets_you_go[0], &f.does_not[0]] {
                    assert_eq!(*at, [now.position_m; 2], "at {:.2} s, {:.1} m/s", obs.time_s, obs.ego.speed_mps);
                }
                seen += usize::from(obs.ego.speed_mps > 0.1);
            }
        }
        assert!(seen > 0, "the car never drove on with the crosser past the far kerb");
    }
}
