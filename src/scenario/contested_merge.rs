//! `contested_merge`: an on-ramp merge (a coordination game). The lane car
//! alongside the ego `makes_room` (drops back to open a gap ahead of itself)
//! or is `committed` (holds its speed; in tier 3 it first opens the gap and
//! closes it when the ego commits). A second car follows the lane car, so
//! merging behind is right only when the lane car goes first.
//!
//! Frame: the through lane runs along +x at y = 0; the ramp is parallel at
//! y = -LANE_OFFSET and tapers into the lane over `road.taper_length_m`
//! starting at x = 0. The ego's lateral position is derived from its
//! progress, as a merge assist would steer it.

use super::world::{Contact, History, PlanPoint, ROW_MARGIN_S, World, car_box};
use super::{Common, Disposition, FieldCheck, Range, ScenarioError, Tier};
use crate::action::Action;
use crate::belief::NoisyReading;
use crate::observation::{Sample, Scene, Track};
use crate::policy::{go, hedge};
use crate::rng::EpisodeRng;
use crate::sim::{Body, CAR_LENGTH, CAR_WIDTH, Idm, track_speed};
use serde::{Deserialize, Serialize};

const LANE_OFFSET: f64 = 3.5;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MergeParams {
    pub episode: Common,
    pub ego: MergeEgo,
    pub road: MergeRoad,
    pub lane: MergeLane,
    pub idm: Idm,
    pub tier2: MergeTier2,
    pub tier3: MergeTier3,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MergeEgo {
    /// Ego centre to the merge point at t = 0 (m).
    pub start_distance_m: Range,
    pub start_speed_mps: Range,
    /// Goal: this far past the end of the ramp (m).
    pub goal_past_ramp_end_m: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MergeRoad {
    /// Length over which the ramp tapers into the lane (m).
    pub taper_length_m: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MergeLane {
    pub cruise_speed_mps: Range,
    /// Lane car's centre relative to the ego's at t = 0 (m): it starts alongside.
    pub alongside_offset_m: Range,
    /// How much faster than its cruise a committed car drives to deny the
    /// gap ahead of itself to an ego that speeds up (m/s).
    pub deny_extra_mps: f64,
    /// Bumper gap a car making room opens ahead of itself (m).
    pub open_gap_m: f64,
    /// Follower's centre behind the lane car's centre at t = 0 (m).
    pub follower_gap_m: Range,
    /// Deceleration with which a car opens a gap for the ego (m/s^2).
    pub open_decel_mps2: f64,
    /// A yielding lane car that has crawled this long gives up and drives on (s).
    pub patience_s: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MergeTier2 {
    /// Standard deviation of the noise on observed lane-car positions (m).
    pub position_noise_m: f64,
    /// Standard deviation of the noise on observed lane-car speeds (m/s).
    pub speed_noise_mps: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MergeTier3 {
    /// A bluffing car opens the gap only down to this fraction of its cruise speed.
    pub floor_fraction: f64,
    /// ... holds that speed this long, then drives on if the ego has not committed (s).
    pub hold_s: f64,
    /// The ego commits when it proceeds while due at the merge point within this (s).
    pub commit_horizon_s: f64,
    /// The bluffer closes the gap this hard (m/s^2).
    pub close_accel_mps2: f64,
}

impl MergeParams {
    pub(crate) fn validate(&self, c: &FieldCheck) -> Result<(), ScenarioError> {
        self.episode.validate(c)?;
        c.range_within("ego.start_distance_m", self.ego.start_distance_m, 10.0, 200.0)?;
        c.range_within("ego.start_speed_mps", self.ego.start_speed_mps, 0.0, self.episode.speed_limit_mps)?;
        c.within("ego.goal_past_ramp_end_m", self.ego.goal_past_ramp_end_m, 0.0, 200.0)?;
        c.within("road.taper_length_m", self.road.taper_length_m, 5.0, 100.0)?;
        c.range_within("lane.cruise_speed_mps", self.lane.cruise_speed_mps, 1.0, 25.0)?;
        c.range_within("lane.alongside_offset_m", self.lane.alongside_offset_m, -20.0, 20.0)?;
        c.range_within("lane.follower_gap_m", self.lane.follower_gap_m, CAR_LENGTH + 1.0, 200.0)?;
        c.within("lane.open_decel_mps2", self.lane.open_decel_mps2, 0.3, 6.0)?;
        c.within("lane.deny_extra_mps", self.lane.deny_extra_mps, 0.0, 10.0)?;
        c.within("lane.open_gap_m", self.lane.open_gap_m, 0.0, 50.0)?;
        c.within("lane.patience_s", self.lane.patience_s, 0.0, 60.0)?;
        c.within("idm.accel", self.idm.accel, 0.3, 5.0)?;
        c.within("idm.brake", self.idm.brake, 0.5, 8.0)?;
        c.within("idm.headway", self.idm.headway, 0.1, 5.0)?;
        c.within("idm.min_gap", self.idm.min_gap, 0.0, 20.0)?;
        c.within("idm.max_brake", self.idm.max_brake, self.idm.brake, 12.0)?;
        c.within("tier2.position_noise_m", self.tier2.position_noise_m, 0.0, 10.0)?;
        c.within("tier2.speed_noise_mps", self.tier2.speed_noise_mps, 0.0, 5.0)?;
        c.within("tier3.floor_fraction", self.tier3.floor_fraction, 0.0, 1.0)?;
        c.within("tier3.hold_s", self.tier3.hold_s, 0.0, 60.0)?;
        c.within("tier3.commit_horizon_s", self.tier3.commit_horizon_s, 0.1, 5.0)?;
        c.within("tier3.close_accel_mps2", self.tier3.close_accel_mps2, 0.5, 6.0)
    }

    /// Ego centre x at which its body starts to overlap the lane.
    pub fn merge_point(&self) -> f64 {
        self.road.taper_length_m * (1.0 - CAR_WIDTH / LANE_OFFSET)
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    /// Holding the lane at cruise speed (committed, tiers 1-2).
    Hold,
    /// Dropping back behind the ego.
    Open { crawling_since: Option<f64>, floor_since: Option<f64> },
    /// Closing the gap after a bluff.
    Close,
    /// Driving on, reacting only to a car physically ahead in the lane.
    Drive,
}

pub struct MergeWorld {
    disposition: Disposition,
    params: MergeParams,
    merge_point: f64,
    ego_start: Body,
    lane_car: Body,
    follower: Body,
    cruise: f64,
    phase: Phase,
    revealed: bool,
    noise: Option<EpisodeRng>,
    /// The noisy readings of the last observation (tier 2 only).
    readings: Vec<NoisyReading>,
    lane_history: History,
    follower_history: History,
}

impl MergeWorld {
    pub fn new(
        params: &MergeParams,
        tier: Tier,
        disposition: Disposition,
        geometry: &mut EpisodeRng,
        noise: EpisodeRng,
    ) -> Self {
        let merge_point = params.merge_point();
        let d_ego = params.ego.start_distance_m.sample(geometry);
        let v_ego = params.ego.start_speed_mps.sample(geometry);
        let cruise = params.lane.cruise_speed_mps.sample(geometry);
        let offset = params.lane.alongside_offset_m.sample(geometry);
        let follower_gap = params.lane.follower_gap_m.sample(geometry);
        let ego_start = Body::new(merge_point - d_ego, v_ego);
        let x_lane = ego_start.s + offset;
        let phase = match (tier, disposition) {
            (Tier::T1 | Tier::T2, Disposition::Committed) => Phase::Hold,
            _ => Phase::Open { crawling_since: None, floor_since: None },
        };
        // The steady history before t = 0 is observed through the same noise
        // as every later turn (tier 2 only).
        let rel_rate = cruise - v_ego;
        let mut noise = (tier == Tier::T2).then_some(noise);
        let lane_now = Sample { position_m: x_lane - ego_start.s, velocity_mps: cruise };
        let follower_now = Sample { position_m: x_lane - follower_gap - ego_start.s, velocity_mps: cruise };
        let lane_history = History::steady(observe_noisy(&mut noise, &params.tier2, lane_now), rel_rate);
        let follower_history = History::steady(observe_noisy(&mut noise, &params.tier2, follower_now), rel_rate);
        MergeWorld {
            disposition,
            params: params.clone(),
            merge_point,
            ego_start,
            lane_car: Body::new(x_lane, cruise),
            follower: Body::new(x_lane - follower_gap, cruise),
            cruise,
            phase,
            revealed: tier != Tier::T3,
            noise,
            readings: Vec::new(),
            lane_history,
            follower_history,
        }
    }

    fn ego_y(&self, x: f64) -> f64 {
        let taper = self.params.road.taper_length_m;
        let f = (x / taper).clamp(0.0, 1.0);
        -LANE_OFFSET * (1.0 - f)
    }

    /// Whether the ego's body overlaps the through lane.
    fn ego_in_lane(&self, ego: &Body) -> bool {
        ego.s > self.merge_point
    }

    /// IDM leader (bumper gap, speed difference) for a lane car at `car`:
    /// the nearest of `ahead` and the ego when the ego is in the lane ahead.
    fn leader(&self, car: &Body, ahead: Option<&Body>, ego: &Body) -> Option<(f64, f64)> {
        let mut best: Option<(f64, f64)> = None;
        let mut consider = |other: &Body| {
            let gap = other.s - car.s - CAR_LENGTH;
            if other.s > car.s && best.is_none_or(|(g, _)| gap < g) {
                best = Some((gap, car.v - other.v));
            }
        };
        if let Some(a) = ahead {
            consider(a);
        }
        if self.ego_in_lane(ego) {
            consider(ego);
        }
        best
    }

    fn lane_car_accel(&mut self, ego: &Body, t: f64, dt: f64) -> f64 {
        let idm = self.params.idm;
        let lane = self.lane_car;
        let rel = lane.s - ego.s;
        let in_lane_leader = self.leader(&lane, None, ego);
        // A car physically in the lane ahead is always respected.
        let respect = |a: f64| a.min(idm.accel(lane.v, f64::INFINITY, in_lane_leader));
        match self.phase {
            Phase::Drive => idm.accel(lane.v, self.cruise, in_lane_leader),
            Phase::Hold => {
                // Committed: deny the gap ahead by matching a faster ego while
                // alongside; otherwise keep cruising.
                let alongside = rel < CAR_LENGTH && rel > -2.0 * CAR_LENGTH;
                let target = if alongside {
                    (ego.v + 0.5).clamp(self.cruise, self.cruise + self.params.lane.deny_extra_mps)
                } else {
                    self.cruise
                };
                respect(track_speed(lane.v, target, 2.5, 3.0, dt))
            }
            Phase::Close => {
                track_speed(lane.v, (ego.v + 2.0).max(self.cruise), self.params.tier3.close_accel_mps2, 3.0, dt)
            }
            Phase::Open { crawling_since, floor_since } => {
                let bluffing = self.disposition == Disposition::Committed;
                let floor = self.params.tier3.floor_fraction * self.cruise;
                let ego_to_merge = self.merge_point - ego.s;
                let ego_commits = ego.a > -0.5
                    && ego.v > 1.0
                    && ego_to_merge > 0.0
                    && ego_to_merge < self.params.tier3.commit_horizon_s * ego.v.max(0.1);
                if !self.revealed && (ego_commits || lane.v <= floor) {
                    self.revealed = true;
                }
                if bluffing {
                    if ego_commits {
                        self.phase = Phase::Close;
                        return self.params.tier3.close_accel_mps2;
                    }
                    if lane.v <= floor {
                        let since = floor_since.unwrap_or(t);
                        self.phase = Phase::Open { crawling_since, floor_since: Some(since) };
                        if t - since >= self.params.tier3.hold_s {
                            self.phase = Phase::Drive;
                        }
                        return 0.0;
                    }
                }
                // Drop back until `open_gap_m` behind the ego, then follow it
                // as if it were already the leader.
                let gap = ego.s - lane.s - CAR_LENGTH;
                let a = if gap < self.params.lane.open_gap_m {
                    // Fall back relative to the ego, however slowly it goes.
                    track_speed(lane.v, (ego.v - 2.0).max(0.0), idm.accel, self.params.lane.open_decel_mps2, dt)
                } else {
                    idm.accel(
                        lane.v,
                        self.cruise,
                        Some((gap - self.params.lane.open_gap_m + idm.min_gap, lane.v - ego.v)),
                    )
                };
                let crawling = lane.v < 1.0;
                let since = if crawling { Some(crawling_since.unwrap_or(t)) } else { None };
                self.phase = Phase::Open { crawling_since: since, floor_since };
                if since.is_some_and(|s| t - s >= self.params.lane.patience_s) {
                    self.phase = Phase::Drive;
                }
                a
            }
        }
    }
}

/// What the ego observes of a lane car: the truth, plus seeded noise on the
/// observation-noise tier.
fn observe_noisy(noise: &mut Option<EpisodeRng>, sd: &MergeTier2, s: Sample) -> Sample {
    match noise.as_mut() {
        Some(rng) => Sample {
            position_m: s.position_m + sd.position_noise_m * rng.standard_noise(),
            velocity_mps: (s.velocity_mps + sd.speed_noise_mps * rng.standard_noise()).max(0.0),
        },
        None => s,
    }
}

impl World for MergeWorld {
    fn ego_start(&self) -> Body {
        self.ego_start
    }

    fn goal_s(&self) -> f64 {
        self.params.road.taper_length_m + self.params.ego.goal_past_ramp_end_m
    }

    fn advance(&mut self, ego: &Body, t: f64, dt: f64) {
        let a_lane = self.lane_car_accel(ego, t, dt);
        let leader = self.leader(&self.follower, Some(&self.lane_car), ego);
        let a_follow = self.params.idm.accel(self.follower.v, self.cruise, leader);
        self.lane_car.advance(a_lane, dt);
        self.follower.advance(a_follow, dt);
    }

    fn contact(&self, ego: &Body) -> Contact {
        let e = car_box(ego.s, self.ego_y(ego.s), true);
        let mut contact = Contact { gap_m: f64::INFINITY, ttc_s: None, collision: false };
        for car in [&self.lane_car, &self.follower] {
            let c = car_box(car.s, 0.0, true);
            contact.gap_m = contact.gap_m.min(e.gap(&c));
            contact.collision |= e.overlaps(&c);
            if self.ego_in_lane(ego) {
                // Same-lane closing time, whichever car is behind.
                let (rear, front) = if car.s < ego.s { (car, ego) } else { (ego, car) };
                let gap = front.s - rear.s - CAR_LENGTH;
                let closing = rear.v - front.v;
                if closing > 0.0 && gap > 0.0 {
                    let ttc = gap / closing;
                    contact.ttc_s = Some(contact.ttc_s.map_or(ttc, |t: f64| t.min(ttc)));
                }
            }
        }
        contact
    }

    fn observe(&mut self, ego: &Body) -> Scene {
        let lane = Sample { position_m: self.lane_car.s - ego.s, velocity_mps: self.lane_car.v };
        let follower = Sample { position_m: self.follower.s - ego.s, velocity_mps: self.follower.v };
        let (lane_true, follower_true) = (lane, follower);
        let lane = observe_noisy(&mut self.noise, &self.params.tier2, lane);
        let follower = observe_noisy(&mut self.noise, &self.params.tier2, follower);
        self.readings.clear();
        if self.noise.is_some() {
            let sd = &self.params.tier2;
            for (truth, shown) in [(lane_true, lane), (follower_true, follower)] {
                let position = NoisyReading {
                    shown: shown.position_m,
                    truth: truth.position_m,
                    sd: sd.position_noise_m,
                    floor: None,
                };
                let speed = NoisyReading {
                    shown: shown.velocity_mps,
                    truth: truth.velocity_mps,
                    sd: sd.speed_noise_mps,
                    floor: Some(0.0),
                };
                self.readings.extend([position, speed]);
            }
        }
        Scene::ContestedMerge {
            ego_to_merge_m: self.merge_point - ego.s,
            ramp_left_m: self.params.road.taper_length_m - ego.s,
            lane_car: self.lane_history.track(lane),
            follower: self.follower_history.track(follower),
        }
    }

    fn revealed(&self) -> bool {
        self.revealed
    }

    fn noisy_readings(&self) -> &[NoisyReading] {
        &self.readings
    }

    fn ego_to_conflict(&self, ego: &Body) -> f64 {
        self.merge_point - ego.s
    }

    fn other_entered(&self) -> bool {
        self.lane_car.s >= self.merge_point
    }

    fn cuts_off(&self, ego: &Body) -> bool {
        if !self.ego_in_lane(ego) {
            return false;
        }
        [&self.lane_car, &self.follower].iter().any(|car| {
            let alongside = (car.s - ego.s).abs() < CAR_LENGTH;
            let gap = ego.s - car.s - CAR_LENGTH;
            let tailgated = car.s < ego.s && car.v > ego.v && gap < (car.v - ego.v) * ROW_MARGIN_S;
            alongside || tailgated
        })
    }

    fn plan(&self, ego: &Body) -> Vec<PlanPoint> {
        vec![
            PlanPoint { x: ego.s, y: self.ego_y(ego.s), v: ego.v },
            PlanPoint { x: self.lane_car.s, y: 0.0, v: self.lane_car.v },
            PlanPoint { x: self.follower.s, y: 0.0, v: self.follower.v },
        ]
    }
}

// --- Baseline rules for this scenario (read only the public observation) ---

/// Where the expert waits: this far before the merge point.
const WAIT_GAP_M: f64 = 3.0;

/// Whether the lane has room for the ego now. Cars are placed by their
/// centre relative to the ego (positive ahead). The car ahead needs a
/// headway that grows with the closing speed; a car behind must either be
/// far back or have actually slowed to a crawl (`crawl_ok`), since a car that
/// only eases off may close the gap again.
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

/// The expert: merge once the lane has room; until then keep a stop before
/// the merge point possible.
pub(crate) fn expert(v: f64, _v_max: f64, d: f64, lane_car: &Track, follower: &Track) -> Action {
    if lane_has_room([lane_car, follower], v, true) {
        go()
    } else if d < 0.0 {
        Action::new(crate::action::Maneuver::Yield, 0.5)
    } else {
        hedge(v, d - WAIT_GAP_M)
    }
}

/// The cue follower: merge as soon as the lane car eases off.
pub(crate) fn cue_follower(v: f64, _v_max: f64, d: f64, lane_car: &Track, follower: &Track) -> Action {
    let giving_way = lane_car.recent_accel() < -0.3;
    if d < 0.0 || lane_has_room([lane_car, follower], v, true) || giving_way { go() } else { hedge(v, d - 1.0) }
}
