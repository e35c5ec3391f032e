//! `yield_standoff`: an unsignalled T-intersection (a game of chicken). The
//! other car is `committed` (drives through) or a `yielder` (brakes to a stop
//! before the conflict zone and waits for the ego).
//!
//! Frame: the ego drives along +y at x = 0, the other car along +x at y = 0;
//! positions are box centres, the crossing centre is the origin.

use super::world::{Contact, EgoApproach, History, PlanPoint, ROW_MARGIN_S, World, car_box, crossing_ttc};
use super::{Common, Disposition, FieldCheck, Range, ScenarioError, Tier};
use crate::action::Action;
use crate::observation::{Sample, Scene, Track};
use crate::policy::{go, hedge};
use crate::rng::EpisodeRng;
use crate::sim::{Body, CAR_LENGTH, CAR_WIDTH, EGO_MAX_ACCEL, stopping_decel, track_speed, travel_time};
use serde::{Deserialize, Serialize};

/// Centre distance from the crossing centre at which boxes start to overlap.
pub const HALF_ZONE: f64 = 0.5 * (CAR_LENGTH + CAR_WIDTH);

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct YieldParams {
    pub episode: Common,
    pub ego: YieldEgo,
    pub other: YieldOther,
    pub tier2: YieldTier2,
    pub tier3: YieldTier3,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct YieldEgo {
    /// Front bumper to the conflict zone at t = 0 (m).
    pub start_distance_m: Range,
    pub start_speed_mps: Range,
    /// Goal: the ego's centre this far past the crossing centre (m).
    pub goal_past_zone_m: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct YieldOther {
    pub cruise_speed_mps: Range,
    /// Arrival of the other car at the zone relative to a full-throttle ego
    /// (s): near zero makes "always proceed" meet a committed car.
    pub arrival_offset_s: Range,
    /// A yielder stops this far before the zone (m).
    pub stop_line_m: f64,
    /// A stopped yielder waits this long for an ego that does not come (s).
    pub patience_s: f64,
    /// Acceleration of a car driving off (m/s^2).
    pub go_accel_mps2: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct YieldTier2 {
    /// Both dispositions cruise identically until this close to the zone (m).
    pub reveal_distance_m: Range,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct YieldTier3 {
    /// Both dispositions brake as if to stop at the stop line; the planned
    /// stop comes this many times later than a full-throttle ego's arrival.
    pub stop_time_factor: Range,
    /// A bluffer never slows below this (m/s): it rolls, it never stops.
    pub floor_speed_mps: f64,
    /// The ego "commits" when it proceeds with less than this to the zone (s).
    pub commit_horizon_s: f64,
    /// A bluffer re-accelerates this hard once the ego commits (m/s^2).
    pub bluff_accel_mps2: f64,
}

impl YieldParams {
    pub(crate) fn validate(&self, c: &FieldCheck) -> Result<(), ScenarioError> {
        self.episode.validate(c)?;
        c.range_within("ego.start_distance_m", self.ego.start_distance_m, 10.0, 200.0)?;
        c.range_within("ego.start_speed_mps", self.ego.start_speed_mps, 0.0, self.episode.speed_limit_mps)?;
        c.within("ego.goal_past_zone_m", self.ego.goal_past_zone_m, HALF_ZONE, 200.0)?;
        c.range_within("other.cruise_speed_mps", self.other.cruise_speed_mps, 1.0, 25.0)?;
        c.range_within("other.arrival_offset_s", self.other.arrival_offset_s, -5.0, 5.0)?;
        c.within("other.stop_line_m", self.other.stop_line_m, 0.5, 10.0)?;
        c.within("other.patience_s", self.other.patience_s, 0.0, 60.0)?;
        c.within("other.go_accel_mps2", self.other.go_accel_mps2, 0.5, 5.0)?;
        c.range_within("tier2.reveal_distance_m", self.tier2.reveal_distance_m, 5.0, 100.0)?;
        c.range_within("tier3.stop_time_factor", self.tier3.stop_time_factor, 1.0, 4.0)?;
        c.within("tier3.floor_speed_mps", self.tier3.floor_speed_mps, 0.5, 10.0)?;
        c.within("tier3.commit_horizon_s", self.tier3.commit_horizon_s, 0.1, 5.0)?;
        c.within("tier3.bluff_accel_mps2", self.tier3.bluff_accel_mps2, 0.5, 6.0)
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    /// Constant speed.
    Cruise,
    /// Braking to stop at the stop line (yielder), or the tier-3 common
    /// profile at a fixed rate (either disposition).
    Braking,
    Stopped {
        since: f64,
    },
    /// Driving off or through at `go_accel` (or the bluff's re-acceleration).
    Going {
        accel: f64,
    },
}

pub struct YieldWorld {
    tier: Tier,
    disposition: Disposition,
    params: YieldParams,
    ego_start: Body,
    other: Body,
    cruise: f64,
    phase: Phase,
    /// Fixed deceleration of the tier-3 common braking profile.
    profile_decel: f64,
    reveal_distance: f64,
    revealed: bool,
    history: History,
}

impl YieldWorld {
    pub fn new(params: &YieldParams, tier: Tier, disposition: Disposition, geometry: &mut EpisodeRng) -> Self {
        let d_ego = params.ego.start_distance_m.sample(geometry);
        let v_ego = params.ego.start_speed_mps.sample(geometry);
        let cruise = params.other.cruise_speed_mps.sample(geometry);
        let offset = params.other.arrival_offset_s.sample(geometry);
        let reveal_distance = params.tier2.reveal_distance_m.sample(geometry);
        let stop_factor = params.tier3.stop_time_factor.sample(geometry);
        let t_ego = travel_time(d_ego, v_ego, params.episode.speed_limit_mps, EGO_MAX_ACCEL);
        let arrival = (t_ego + offset).max(0.5);
        let stop_line = params.other.stop_line_m;
        let (d_other, phase, profile_decel) = match tier {
            Tier::T1 | Tier::T2 => (cruise * arrival, Phase::Cruise, 0.0),
            Tier::T3 => {
                // Uniform braking to the stop line over `stop_factor * arrival` s.
                let braking_distance = 0.5 * cruise * stop_factor * arrival;
                (stop_line + braking_distance, Phase::Braking, stopping_decel(cruise, braking_distance))
            }
        };
        let ego_start = Body::new(-HALF_ZONE - d_ego, v_ego);
        let other = Body::new(-HALF_ZONE - d_other, cruise);
        let history = History::steady(Sample { position_m: d_other, velocity_mps: cruise }, -cruise);
        YieldWorld {
            tier,
            disposition,
            params: params.clone(),
            ego_start,
            other,
            cruise,
            phase,
            profile_decel,
            reveal_distance,
            revealed: tier == Tier::T1,
            history,
        }
    }

    fn other_to_zone(&self) -> f64 {
        -HALF_ZONE - self.other.s
    }

    fn yielder_accel(&mut self, ego: &Body, t: f64, dt: f64) -> f64 {
        let to_line = self.other_to_zone() - self.params.other.stop_line_m;
        match self.phase {
            Phase::Cruise => 0.0,
            Phase::Braking => {
                if self.other.v <= 0.0 {
                    self.phase = Phase::Stopped { since: t };
                    0.0
                } else {
                    -stopping_decel(self.other.v, to_line).min(8.0)
                }
            }
            Phase::Stopped { since } => {
                let ego_cleared = ego.s > HALF_ZONE;
                let ego_to_zone = -HALF_ZONE - ego.s;
                let ego_entering = ego_to_zone < 3.0 && ego.v > 0.3 && !ego_cleared;
                if ego_cleared || (t - since >= self.params.other.patience_s && !ego_entering) {
                    self.phase = Phase::Going { accel: self.params.other.go_accel_mps2 };
                }
                0.0
            }
            Phase::Going { accel } => track_speed(self.other.v, self.cruise, accel, 3.0, dt),
        }
    }
}

impl World for YieldWorld {
    fn ego_start(&self) -> Body {
        self.ego_start
    }

    fn goal_s(&self) -> f64 {
        self.params.ego.goal_past_zone_m
    }

    fn advance(&mut self, ego: &Body, t: f64, dt: f64) {
        let to_zone = self.other_to_zone();
        let accel = match (self.tier, self.disposition) {
            (Tier::T1, Disposition::Committed) => 0.0,
            (Tier::T1, _) => {
                if self.phase == Phase::Cruise {
                    self.phase = Phase::Braking;
                }
                self.yielder_accel(ego, t, dt)
            }
            (Tier::T2, disposition) => {
                if !self.revealed && to_zone <= self.reveal_distance {
                    self.revealed = true;
                    if disposition == Disposition::Yielder {
                        self.phase = Phase::Braking;
                    }
                }
                if disposition == Disposition::Committed { 0.0 } else { self.yielder_accel(ego, t, dt) }
            }
            (Tier::T3, disposition) => {
                // The ego commits when its motion (speed and acceleration)
                // brings it into the zone within the commit horizon.
                let approach = EgoApproach::new(-HALF_ZONE - ego.s, ego);
                let ego_commits = approach.to_conflict > 0.0
                    && ego.v > 1.0
                    && approach.eta(self.params.episode.speed_limit_mps) < self.params.tier3.commit_horizon_s;
                let at_floor = self.other.v <= self.params.tier3.floor_speed_mps;
                if !self.revealed && (ego_commits || at_floor) {
                    self.revealed = true;
                }
                match disposition {
                    Disposition::Committed => match self.phase {
                        Phase::Braking if ego_commits => {
                            self.phase = Phase::Going { accel: self.params.tier3.bluff_accel_mps2 };
                            self.params.tier3.bluff_accel_mps2
                        }
                        Phase::Braking if at_floor => 0.0,
                        Phase::Braking => -self.profile_decel,
                        Phase::Going { accel } => track_speed(self.other.v, self.cruise, accel, 3.0, dt),
                        _ => 0.0,
                    },
                    _ => {
                        if !self.revealed && self.phase == Phase::Braking {
                            -self.profile_decel
                        } else {
                            self.yielder_accel(ego, t, dt)
                        }
                    }
                }
            }
        };
        self.other.advance(accel, dt);
    }

    fn contact(&self, ego: &Body) -> Contact {
        let e = car_box(0.0, ego.s, false);
        let o = car_box(self.other.s, 0.0, true);
        let ttc = crossing_ttc(
            -HALF_ZONE - ego.s,
            HALF_ZONE - ego.s,
            ego.v,
            -HALF_ZONE - self.other.s,
            HALF_ZONE - self.other.s,
            self.other.v,
        );
        Contact { gap_m: e.gap(&o), ttc_s: ttc, collision: e.overlaps(&o) }
    }

    fn observe(&mut self, ego: &Body) -> Scene {
        let now = Sample { position_m: self.other_to_zone(), velocity_mps: self.other.v };
        Scene::YieldStandoff { ego_to_conflict_m: -HALF_ZONE - ego.s, other: self.history.track(now) }
    }

    fn revealed(&self) -> bool {
        self.revealed
    }

    fn ego_to_conflict(&self, ego: &Body) -> f64 {
        -HALF_ZONE - ego.s
    }

    fn other_entered(&self) -> bool {
        self.other.s > -HALF_ZONE
    }

    fn cuts_off(&self, ego: &Body) -> bool {
        let ego_inside = ego.s > -HALF_ZONE && ego.s < HALF_ZONE;
        if !ego_inside {
            return false;
        }
        let o = self.other_to_zone();
        let other_inside = o <= 0.0 && o > -2.0 * HALF_ZONE;
        let other_due = o > 0.0 && self.other.v > 0.1 && o / self.other.v < ROW_MARGIN_S;
        other_inside || other_due
    }

    fn plan(&self, ego: &Body) -> Vec<PlanPoint> {
        vec![PlanPoint { x: 0.0, y: ego.s, v: ego.v }, PlanPoint { x: self.other.s, y: 0.0, v: self.other.v }]
    }
}

// --- Baseline rules for this scenario (read only the public observation) ---

/// Conflict-zone depth: a crossing car has fully cleared below minus this.
const CONFLICT_ZONE_M: f64 = 6.7;
/// Where the expert waits: this far before the conflict zone.
const WAIT_GAP_M: f64 = 3.0;

/// Whether a car track has been at rest for the last half second.
fn at_rest(t: &Track) -> bool {
    t.now.velocity_mps <= 0.1 && t.past[t.past.len() - 1].velocity_mps <= 0.1
}

/// Whether a crossing car has left the conflict zone behind.
fn crossed(t: &Track) -> bool {
    t.now.position_m < -CONFLICT_ZONE_M - 0.5
}

/// The expert: go once the other car has stopped or crossed; until then keep
/// a stop before the zone possible and let it go first.
pub(crate) fn expert(v: f64, _v_max: f64, d: f64, other: &Track) -> Action {
    if d < 0.5 || crossed(other) || (at_rest(other) && other.now.position_m > 0.0) {
        go()
    } else {
        hedge(v, d - WAIT_GAP_M)
    }
}

/// The cue follower: go as soon as the other car brakes.
pub(crate) fn cue_follower(v: f64, _v_max: f64, d: f64, other: &Track) -> Action {
    let braking = other.recent_accel() < -0.3 || other.now.velocity_mps <= 0.1;
    if d < 0.5 || crossed(other) || braking { go() } else { hedge(v, d - WAIT_GAP_M) }
}
