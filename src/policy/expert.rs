//! Behaviour-conditioned rule policies. Both read only the public
//! observation, so `negotiator serve` can run them from the scene text.
//!
//! The expert waits for a *committed* signal before going: a car that has
//! actually stopped, a pedestrian who has crossed or walks away, a lane car
//! that has dropped to a crawl behind the ego; otherwise it hedges (keeps a
//! comfortable stop possible) and lets the other go first. The cue follower
//! acts on the instantaneous cue instead: the other is braking, so go.

use super::{Policy, go, hedge};
use crate::action::Action;
use crate::observation::{Observation, Scene, Track};
use crate::scenario::pedestrian_feint::PATH_FAR;
use crate::sim::CAR_LENGTH;

/// Conflict-zone depth: a crossing car has fully cleared below minus this.
const CONFLICT_ZONE_M: f64 = 6.7;
/// Where the expert waits: this far before the conflict zone / crosswalk /
/// merge point.
const WAIT_GAP_M: f64 = 3.0;

pub struct Expert;
pub struct CueFollower;

/// Whether a car track has been at rest for the last half second.
fn at_rest(t: &Track) -> bool {
    t.now.velocity_mps <= 0.1 && t.past[t.past.len() - 1].velocity_mps <= 0.1
}

/// Whether a crossing car has left the conflict zone behind.
fn crossed(t: &Track) -> bool {
    t.now.position_m < -CONFLICT_ZONE_M - 0.5
}

/// Merge: whether the lane has room for the ego now. Cars are placed by
/// their centre relative to the ego (positive ahead). The car ahead needs a
/// headway that grows with the closing speed; a car behind must either be far
/// back or have actually slowed to a crawl (`crawl_ok`), since a car that only
/// eases off may close the gap again.
fn lane_has_room(cars: [&Track; 2], ego_speed: f64, crawl_ok: bool) -> bool {
    cars.iter().all(|t| {
        let (rel, v) = (t.now.position_m, t.now.velocity_mps);
        if rel >= 0.0 {
            let gap = rel - CAR_LENGTH;
            gap >= 2.0 + 0.8 * ego_speed + 1.5 * (ego_speed - v).max(0.0)
        } else {
            let gap = -rel - CAR_LENGTH;
            let far = gap >= 4.0 + 0.6 * v + 2.0 * (v - ego_speed).max(0.0);
            far || (crawl_ok && gap >= 1.0 && v < 4.0)
        }
    })
}

impl Policy for Expert {
    fn act(&mut self, obs: &Observation) -> Action {
        let v = obs.ego.speed_mps;
        match &obs.scene {
            Scene::YieldStandoff { ego_to_conflict_m: d, other } => {
                if *d < 0.5 || crossed(other) || (at_rest(other) && other.now.position_m > 0.0) {
                    go()
                } else {
                    hedge(v, d - WAIT_GAP_M)
                }
            }
            Scene::PedestrianFeint { ego_to_crosswalk_m: d, pedestrian: p } => {
                let crossed = p.now.position_m > PATH_FAR + 0.3 && p.now.velocity_mps >= -0.1;
                let walking_away = p.now.velocity_mps < -0.3;
                if *d < 0.0 || crossed || walking_away { go() } else { hedge(v, d - WAIT_GAP_M) }
            }
            Scene::ContestedMerge { ego_to_merge_m: d, lane_car, follower, .. } => {
                if lane_has_room([lane_car, follower], v, true) {
                    go()
                } else if *d < 0.0 {
                    Action::new(crate::action::Maneuver::Yield, 0.5)
                } else {
                    hedge(v, d - WAIT_GAP_M)
                }
            }
        }
    }
}

impl Policy for CueFollower {
    fn act(&mut self, obs: &Observation) -> Action {
        let v = obs.ego.speed_mps;
        match &obs.scene {
            Scene::YieldStandoff { ego_to_conflict_m: d, other } => {
                let braking = other.recent_accel() < -0.3 || other.now.velocity_mps <= 0.1;
                if *d < 0.5 || crossed(other) || braking { go() } else { hedge(v, d - WAIT_GAP_M) }
            }
            Scene::PedestrianFeint { ego_to_crosswalk_m: d, pedestrian: p } => {
                let lat = p.now.position_m;
                let crossed = lat > PATH_FAR + 0.3;
                let coming = p.now.velocity_mps > 0.2 || (lat > 0.0 && !crossed);
                if *d < 0.0 || crossed || !coming { go() } else { hedge(v, d - WAIT_GAP_M) }
            }
            Scene::ContestedMerge { ego_to_merge_m: d, lane_car, follower, .. } => {
                let giving_way = lane_car.recent_accel() < -0.3;
                if *d < 0.0 || lane_has_room([lane_car, follower], v, true) || giving_way {
                    go()
                } else {
                    hedge(v, d - 1.0)
                }
            }
        }
    }
}
