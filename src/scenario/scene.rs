//! The public scene of each scenario: what the observation holds beyond the
//! ego's own state. How the scene text phrases it is each scenario's
//! definition (`ScenarioDef`, in its own file); the observation module
//! renders and parses any scene through these methods and that definition
//! without knowing which scenarios exist; the scripted policies' rules read
//! it from the public side (`policy::expert`).

use super::ScenarioKind;
use super::Track;
use serde::{Deserialize, Serialize};

/// Scenario-specific geometry, all distances in metres.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(tag = "scenario", rename_all = "snake_case")]
pub enum Scene {
    /// `ego_to_conflict_m`: the ego's front bumper to the crossing lane's
    /// near edge. `other.position_m`: the other car's front bumper to the
    /// ego lane's near edge (negative once it has entered; it has cleared
    /// the conflict zone below -`CONFLICT_ZONE_M`). `follower`: the car
    /// behind it on the crossing road, measured the same way.
    YieldStandoff { ego_to_conflict_m: f64, other: Track, follower: Track },
    /// `ego_to_crosswalk_m`: the ego's front bumper to the pedestrian's
    /// crossing line. `pedestrian.position_m`: lateral position from the
    /// near kerb (negative on the sidewalk, 0 at the kerb, 3.5 at the far
    /// edge of the ego lane); `velocity_mps` positive when moving into the
    /// road.
    PedestrianFeint { ego_to_crosswalk_m: f64, pedestrian: Track },
    /// `ego_to_merge_m`: the ego's centre to the point where its body starts
    /// to overlap the main lane; `ramp_left_m` to the end of the ramp.
    /// `lane_car.position_m` / `follower.position_m`: their centre relative
    /// to the ego's centre along the road (positive ahead of the ego).
    ContestedMerge { ego_to_merge_m: f64, ramp_left_m: f64, lane_car: Track, follower: Track },
}

impl Scene {
    /// The scenario, as the scene's layout says.
    pub fn kind(&self) -> ScenarioKind {
        match self {
            Scene::YieldStandoff { .. } => ScenarioKind::YieldStandoff,
            Scene::PedestrianFeint { .. } => ScenarioKind::PedestrianFeint,
            Scene::ContestedMerge { .. } => ScenarioKind::ContestedMerge,
        }
    }

    /// The ego's own distance to the conflict: the conflict zone, the
    /// crossing line or the merge point.
    pub fn ego_to_conflict_m(&self) -> f64 {
        match *self {
            Scene::YieldStandoff { ego_to_conflict_m, .. } => ego_to_conflict_m,
            Scene::PedestrianFeint { ego_to_crosswalk_m, .. } => ego_to_crosswalk_m,
            Scene::ContestedMerge { ego_to_merge_m, .. } => ego_to_merge_m,
        }
    }

    /// The numbers of the ego's place on the "You:" line
    /// ([`ScenarioKind::place_numbers`] of them).
    pub(crate) fn place(&self) -> Vec<f64> {
        match *self {
            Scene::ContestedMerge { ego_to_merge_m, ramp_left_m, .. } => vec![ego_to_merge_m, ramp_left_m],
            _ => vec![self.ego_to_conflict_m()],
        }
    }

    /// The ego's place as the "You:" line phrases it, from formatted numbers.
    pub(crate) fn place_text(&self, format: impl Fn(f64) -> String) -> String {
        match *self {
            Scene::YieldStandoff { ego_to_conflict_m, .. } => {
                format!("{} m to the conflict zone", format(ego_to_conflict_m))
            }
            Scene::PedestrianFeint { ego_to_crosswalk_m, .. } => {
                format!("{} m to the crosswalk", format(ego_to_crosswalk_m))
            }
            Scene::ContestedMerge { ego_to_merge_m, ramp_left_m, .. } => {
                format!("{} m to the merge point, {} m of ramp left", format(ego_to_merge_m), format(ramp_left_m))
            }
        }
    }

    /// The road users' tracks, in the order of `ScenarioKind::track_labels`.
    pub fn tracks(&self) -> Vec<Track> {
        match *self {
            Scene::YieldStandoff { other, follower, .. } => vec![other, follower],
            Scene::PedestrianFeint { pedestrian, .. } => vec![pedestrian],
            Scene::ContestedMerge { lane_car, follower, .. } => vec![lane_car, follower],
        }
    }

    /// Rebuild a scene from its place numbers and tracks (the inverse of
    /// [`Scene::place`] and [`Scene::tracks`]); `None` if the counts do not
    /// match the scenario's layout.
    pub(crate) fn from_parts(kind: ScenarioKind, place: &[f64], tracks: &[Track]) -> Option<Scene> {
        Some(match (kind, place, tracks) {
            (ScenarioKind::YieldStandoff, &[d], &[other, follower]) => {
                Scene::YieldStandoff { ego_to_conflict_m: d, other, follower }
            }
            (ScenarioKind::PedestrianFeint, &[d], &[pedestrian]) => {
                Scene::PedestrianFeint { ego_to_crosswalk_m: d, pedestrian }
            }
            (ScenarioKind::ContestedMerge, &[d, ramp], &[lane_car, follower]) => {
                Scene::ContestedMerge { ego_to_merge_m: d, ramp_left_m: ramp, lane_car, follower }
            }
            _ => return None,
        })
    }

    /// The same scene with every number passed through `number` and every
    /// track through `track` (used to round to the printed precision).
    pub(crate) fn map(&self, number: impl Fn(f64) -> f64, track: impl Fn(Track) -> Track) -> Scene {
        let place: Vec<f64> = self.place().into_iter().map(&number).collect();
        let tracks: Vec<Track> = self.tracks().into_iter().map(track).collect();
        Scene::from_parts(self.kind(), &place, &tracks).expect("a scene's own parts rebuild it")
    }

    /// What a reader whose view of the other road users lags sees: this
    /// scene's own place (the ego's state is current) with the road users
    /// as `older` showed them. Where a road user's position is relative to
    /// the ego (the merge), it is moved by the ego's own travel since, so
    /// the older reading stays where that road user then was.
    pub(crate) fn with_road_users_of(&self, older: &Scene) -> Scene {
        if older.kind() != self.kind() {
            return *self;
        }
        let tracks = match (*self, *older) {
            (Scene::ContestedMerge { ego_to_merge_m: now, .. }, Scene::ContestedMerge { ego_to_merge_m: then, .. }) => {
                let travelled = then - now;
                let shift = |s: super::Sample| super::Sample {
                    position_m: s.position_m - travelled,
                    velocity_mps: s.velocity_mps,
                };
                older.tracks().into_iter().map(|t| Track { now: shift(t.now), past: t.past.map(shift) }).collect()
            }
            _ => older.tracks(),
        };
        Scene::from_parts(self.kind(), &self.place(), &tracks).expect("a scene's own parts rebuild it")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::Sample;

    fn track(position_m: f64, velocity_mps: f64) -> Track {
        let s = Sample { position_m, velocity_mps };
        Track { now: s, past: [s; crate::scenario::HISTORY_LEN] }
    }

    #[test]
    fn an_older_merge_reading_stays_where_the_car_then_was() {
        // Half a second ago the lane car was 2 m ahead of the ego; the ego
        // has since driven 6 m: that car, as then seen, is now 4 m behind.
        let then = Scene::ContestedMerge {
            ego_to_merge_m: 30.0,
            ramp_left_m: 60.0,
            lane_car: track(2.0, 11.0),
            follower: track(-12.0, 11.0),
        };
        let now = Scene::ContestedMerge {
            ego_to_merge_m: 24.0,
            ramp_left_m: 54.0,
            lane_car: track(1.0, 12.0),
            follower: track(-13.0, 12.0),
        };
        let late = now.with_road_users_of(&then);
        assert_eq!(late.place(), now.place());
        let tracks = late.tracks();
        assert!((tracks[0].now.position_m - -4.0).abs() < 1e-12);
        assert!((tracks[1].now.position_m - -18.0).abs() < 1e-12);
        assert_eq!(tracks[0].now.velocity_mps, 11.0);
    }

    #[test]
    fn an_older_crossing_reading_is_taken_as_it_was() {
        let then =
            Scene::YieldStandoff { ego_to_conflict_m: 30.0, other: track(12.0, 5.0), follower: track(20.0, 5.0) };
        let now = Scene::YieldStandoff { ego_to_conflict_m: 25.0, other: track(9.5, 4.0), follower: track(17.5, 5.0) };
        let late = now.with_road_users_of(&then);
        assert_eq!(late.ego_to_conflict_m(), 25.0);
        assert_eq!(late.tracks(), then.tracks());
    }
}
