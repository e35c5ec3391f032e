//! The crosswalk's road-user model, for the forecast: a pedestrian who
//! lets the ego go stops back from the kerb's edge and stays; one who does
//! not walks on across, steps out on its own time, or darts from the edge
//! once the car is about to reach the line; one who has crossed stops on
//! the far sidewalk.

use super::Rules;
use crate::observation::Observation;
use crate::scenario::pedestrian_feint::{FAR_KERB, FAR_STOP};

/// Where a pedestrian waiting for cars stops (lateral from the near kerb, m).
const KERB_STOP_M: f64 = -0.6;
/// Nearer the road than this, at rest, it stands at the kerb's edge.
const EDGE_M: f64 = -0.35;
/// Below this (m/s) a pedestrian stands.
const STANDING_MPS: f64 = 0.1;
/// A crosser at the kerb steps out by this time (s), at this pace (m/s).
const STEP_OUT_AT_S: f64 = 2.15;
const WALK_MPS: f64 = 1.3;
/// One at the edge darts, at this pace (m/s), once the car at its current
/// speed is due at the line within this (s).
const DART_MPS: f64 = 2.5;
const DART_HORIZON_S: f64 = 0.65;

pub(super) const RULES: Rules = Rules { at };

fn at(obs: &Observation, lets_you_go: bool, h: f64) -> Vec<f64> {
    let track = obs.scene.tracks()[0];
    let (lat, v) = (track.now.position_m, track.now.velocity_mps);
    if lat > FAR_KERB {
        // It has crossed (the scene marks the far kerb): it walks on to its
        // stop on the far sidewalk and stays; it never darts back across.
        return vec![(lat + v.max(0.0) * h).min(FAR_STOP.max(lat))];
    }
    if v > STANDING_MPS {
        // Walking toward the kerb, one who lets the car go stops back from
        // its edge; on the road, anyone walks on.
        let walked = lat + v * h;
        return vec![if lets_you_go && lat < KERB_STOP_M { walked.min(KERB_STOP_M) } else { walked }];
    }
    if lets_you_go {
        return vec![lat];
    }
    let now = obs.time_s;
    let (start, pace) = if lat > EDGE_M {
        let to_line = obs.scene.ego_to_conflict_m();
        let eta = if obs.ego.speed_mps > 0.1 { to_line / obs.ego.speed_mps } else { f64::INFINITY };
        (now + (eta - DART_HORIZON_S).max(0.0), DART_MPS)
    } else {
        (STEP_OUT_AT_S.max(now), WALK_MPS)
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
