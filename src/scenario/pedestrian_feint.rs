//! `pedestrian_feint`: an unmarked crosswalk (a signalling game). The
//! pedestrian is a `crosser` (steps in and crosses) or a `feinter` (lurches
//! toward the road, stops short at the kerb, then steps back and walks away).
//!
//! Frame: the ego drives along +x centred on y = 0 (lane from -1.75 to
//! 1.75); the pedestrian crosses along +y at x = 0. Its public position is
//! lateral from the near kerb: `lat = y + 1.75`.

use super::world::{Contact, History, PlanPoint, World, car_box, crossing_ttc};
use super::{Common, Disposition, FieldCheck, Range, ScenarioError, Tier};
use crate::action::{Action, Maneuver};
use crate::observation::{Sample, Scene};
use crate::rng::EpisodeRng;
use crate::sim::{Aabb, Body, CAR_LENGTH, CAR_WIDTH, EGO_MAX_ACCEL, PEDESTRIAN_SIZE, travel_time};
use serde::{Deserialize, Serialize};

/// Lane half-width; the near kerb is at y = -KERB.
const KERB: f64 = 1.75;
/// Ego centre distance from the crossing line at which boxes can overlap.
pub const X_HALF: f64 = 0.5 * (CAR_LENGTH + PEDESTRIAN_SIZE);
/// Lateral band (from the near kerb) in which the pedestrian is in the ego's path.
pub const PATH_NEAR: f64 = KERB - 0.5 * (CAR_WIDTH + PEDESTRIAN_SIZE);
pub const PATH_FAR: f64 = KERB + 0.5 * (CAR_WIDTH + PEDESTRIAN_SIZE);
/// Far kerb of the two-lane road.
pub const FAR_KERB: f64 = 4.0 * KERB;
/// Pedestrians change speed at most this fast (m/s^2).
const PED_ACCEL: f64 = 6.0;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PedestrianParams {
    pub episode: Common,
    pub ego: PedEgo,
    pub pedestrian: PedBehaviour,
    pub tier2: PedTier2,
    pub tier3: PedTier3,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PedEgo {
    /// Front bumper to the crossing line at t = 0 (m).
    pub start_distance_m: Range,
    pub start_speed_mps: Range,
    /// Goal: the ego's centre this far past the crossing line (m).
    pub goal_past_crosswalk_m: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PedBehaviour {
    /// Lateral start position (negative: on the sidewalk).
    pub start_position_m: Range,
    pub walk_speed_mps: Range,
    /// Speed of a feinter's lurch toward the kerb.
    pub lurch_speed_mps: f64,
    /// Where a feinter (and a pausing crosser) stops short.
    pub kerb_stop_m: f64,
    /// How long a feinter stands at the kerb before stepping back (s).
    pub hold_s: Range,
    pub step_back_speed_mps: f64,
    /// Where a crosser is (lateral) when a full-throttle ego reaches the
    /// crossing line: inside the ego's path band makes "always proceed" hit it.
    pub position_at_ego_arrival_m: Range,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PedTier2 {
    /// The pedestrian waits closer to the kerb and the crosser steps out late
    /// and fast: less reaction time.
    pub start_position_m: Range,
    pub step_out_speed_mps: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PedTier3 {
    /// Where both start, walking to the kerb at once.
    pub start_position_m: Range,
    /// Both walk to the kerb and stop; they linger this long (s) before the
    /// feinter steps back or the crosser darts.
    pub linger_s: Range,
    pub dart_speed_mps: f64,
    /// The crosser darts at once when a moving ego is due at the crossing
    /// line within this many seconds.
    pub dart_horizon_s: f64,
}

impl PedestrianParams {
    pub(crate) fn validate(&self, c: &FieldCheck) -> Result<(), ScenarioError> {
        self.episode.validate(c)?;
        c.range_within("ego.start_distance_m", self.ego.start_distance_m, 10.0, 200.0)?;
        c.range_within("ego.start_speed_mps", self.ego.start_speed_mps, 0.0, self.episode.speed_limit_mps)?;
        c.within("ego.goal_past_crosswalk_m", self.ego.goal_past_crosswalk_m, X_HALF, 200.0)?;
        let b = &self.pedestrian;
        c.range_within("pedestrian.start_position_m", b.start_position_m, -10.0, -0.5)?;
        c.range_within("pedestrian.walk_speed_mps", b.walk_speed_mps, 0.3, 3.0)?;
        c.within("pedestrian.lurch_speed_mps", b.lurch_speed_mps, 0.3, 4.0)?;
        c.within("pedestrian.kerb_stop_m", b.kerb_stop_m, -2.0, 0.0)?;
        c.range_within("pedestrian.hold_s", b.hold_s, 0.0, 20.0)?;
        c.within("pedestrian.step_back_speed_mps", b.step_back_speed_mps, 0.3, 3.0)?;
        c.range_within("pedestrian.position_at_ego_arrival_m", b.position_at_ego_arrival_m, PATH_NEAR, PATH_FAR)?;
        c.range_within("tier2.start_position_m", self.tier2.start_position_m, -10.0, b.kerb_stop_m)?;
        c.within("tier2.step_out_speed_mps", self.tier2.step_out_speed_mps, 0.3, 4.0)?;
        c.range_within("tier3.start_position_m", self.tier3.start_position_m, -10.0, b.kerb_stop_m)?;
        c.range_within("tier3.linger_s", self.tier3.linger_s, 0.0, 20.0)?;
        c.within("tier3.dart_speed_mps", self.tier3.dart_speed_mps, 0.5, 5.0)?;
        c.within("tier3.dart_horizon_s", self.tier3.dart_horizon_s, 0.0, 5.0)
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    /// Standing at the start until `until`.
    Wait {
        until: f64,
    },
    /// Crossing the road at `speed`.
    Cross {
        speed: f64,
    },
    /// Moving toward the kerb stop at `speed`, then lingering.
    ToKerb {
        speed: f64,
    },
    Linger {
        since: f64,
    },
    /// Walking away from the road.
    StepBack,
}

pub struct PedestrianWorld {
    tier: Tier,
    disposition: Disposition,
    params: PedestrianParams,
    ego_start: Body,
    /// Lateral position from the near kerb and signed velocity (+ into the road).
    lat: f64,
    vel: f64,
    phase: Phase,
    /// Speed at which a crosser steps out in tiers 1 and 2.
    cross_speed: f64,
    linger: f64,
    revealed: bool,
    history: History,
}

impl PedestrianWorld {
    pub fn new(params: &PedestrianParams, tier: Tier, disposition: Disposition, geometry: &mut EpisodeRng) -> Self {
        let b = &params.pedestrian;
        let d_ego = params.ego.start_distance_m.sample(geometry);
        let v_ego = params.ego.start_speed_mps.sample(geometry);
        let start_t1 = b.start_position_m.sample(geometry);
        let start_t2 = params.tier2.start_position_m.sample(geometry);
        let walk = b.walk_speed_mps.sample(geometry);
        let at_arrival = b.position_at_ego_arrival_m.sample(geometry);
        let hold = b.hold_s.sample(geometry);
        let linger3 = params.tier3.linger_s.sample(geometry);
        let start_t3 = params.tier3.start_position_m.sample(geometry);
        let t3_start = 0.3 + 0.5 * geometry.unit();
        let t_ego = travel_time(d_ego, v_ego, params.episode.speed_limit_mps, EGO_MAX_ACCEL);
        let (lat, cross_speed) = match tier {
            Tier::T1 => (start_t1, walk),
            Tier::T2 => (start_t2, params.tier2.step_out_speed_mps),
            Tier::T3 => (start_t3, walk),
        };
        let (phase, linger) = match tier {
            Tier::T1 | Tier::T2 => {
                // A crosser stepping out at `until` is at `at_arrival` when a
                // full-throttle ego reaches the line.
                let until = (t_ego - (at_arrival - lat) / cross_speed).max(0.5);
                (Phase::Wait { until }, hold)
            }
            Tier::T3 => (Phase::Wait { until: t3_start }, linger3),
        };
        PedestrianWorld {
            tier,
            disposition,
            params: params.clone(),
            ego_start: Body::new(-X_HALF - d_ego, v_ego),
            lat,
            vel: 0.0,
            phase,
            cross_speed,
            linger,
            revealed: false,
            history: History::steady(Sample { position_m: lat, velocity_mps: 0.0 }, 0.0),
        }
    }

    fn ped_box(&self) -> Aabb {
        Aabb::centered(0.0, self.lat - KERB, PEDESTRIAN_SIZE, PEDESTRIAN_SIZE)
    }

    /// Move toward `target_vel`, changing speed at most PED_ACCEL.
    fn walk(&mut self, target_vel: f64, dt: f64) {
        let dv = (target_vel - self.vel).clamp(-PED_ACCEL * dt, PED_ACCEL * dt);
        let v_next = self.vel + dv;
        self.lat += 0.5 * (self.vel + v_next) * dt;
        self.vel = v_next;
    }
}

impl World for PedestrianWorld {
    fn ego_start(&self) -> Body {
        self.ego_start
    }

    fn goal_s(&self) -> f64 {
        self.params.ego.goal_past_crosswalk_m
    }

    fn advance(&mut self, ego: &Body, ego_action: &Action, t: f64, dt: f64) {
        let b = &self.params.pedestrian;
        let crosser = self.disposition == Disposition::Crosser;
        let kerb_stop = b.kerb_stop_m;
        let (lurch, step_back) = (b.lurch_speed_mps, b.step_back_speed_mps);
        let target = match self.phase {
            Phase::Wait { until } => {
                if t + 1e-9 >= until {
                    self.phase = match (self.tier, crosser) {
                        (Tier::T3, _) => Phase::ToKerb { speed: self.cross_speed },
                        (_, true) => Phase::Cross { speed: self.cross_speed },
                        (_, false) => Phase::ToKerb { speed: lurch },
                    };
                    if self.tier != Tier::T3 {
                        self.revealed = true;
                    }
                }
                0.0
            }
            Phase::Cross { speed } => {
                if self.lat >= FAR_KERB + 1.0 {
                    0.0
                } else {
                    speed
                }
            }
            Phase::ToKerb { speed } => {
                // Stop short exactly at the kerb stop.
                let left = kerb_stop - self.lat;
                let v_stop = (2.0 * PED_ACCEL * left.max(0.0)).sqrt();
                if left <= 0.005 && self.vel <= 0.05 {
                    self.phase = Phase::Linger { since: t };
                    0.0
                } else {
                    speed.min(v_stop)
                }
            }
            Phase::Linger { since } => {
                let waited = t - since >= self.linger;
                let ego_to_line = -X_HALF - ego.s;
                let ego_due = ego.v > 3.0
                    && ego_to_line > 0.0
                    && ego_to_line < self.params.tier3.dart_horizon_s * ego.v
                    && ego_action.maneuver != Maneuver::Stop;
                if self.tier == Tier::T3 && crosser && (waited || ego_due) {
                    self.revealed = true;
                    self.phase = Phase::Cross { speed: self.params.tier3.dart_speed_mps };
                } else if waited {
                    self.revealed = true;
                    self.phase = Phase::StepBack;
                }
                0.0
            }
            Phase::StepBack => -step_back,
        };
        self.walk(target, dt);
    }

    fn contact(&self, ego: &Body) -> Contact {
        let e = car_box(ego.s, 0.0, true);
        let p = self.ped_box();
        let ttc = crossing_ttc(
            -X_HALF - ego.s,
            X_HALF - ego.s,
            ego.v,
            PATH_NEAR - self.lat,
            PATH_FAR - self.lat,
            self.vel.max(0.0),
        );
        Contact { gap_m: e.gap(&p), ttc_s: ttc, collision: e.overlaps(&p) }
    }

    fn observe(&mut self, ego: &Body) -> Scene {
        let now = Sample { position_m: self.lat, velocity_mps: self.vel };
        Scene::PedestrianFeint { ego_to_crosswalk_m: -X_HALF - ego.s, pedestrian: self.history.track(now) }
    }

    fn disposition(&self) -> Disposition {
        self.disposition
    }

    fn revealed(&self) -> bool {
        self.revealed
    }

    fn resolved(&self, ego: &Body) -> bool {
        ego.s > -X_HALF || self.lat > PATH_NEAR
    }

    fn cuts_off(&self, ego: &Body) -> bool {
        // Driving over the crossing line while the pedestrian is on the road.
        ego.s.abs() < X_HALF && self.lat > 0.0 && self.lat < FAR_KERB
    }

    fn plan(&self, ego: &Body) -> Vec<PlanPoint> {
        vec![PlanPoint { x: ego.s, y: 0.0, v: ego.v }, PlanPoint { x: 0.0, y: self.lat - KERB, v: self.vel }]
    }
}
