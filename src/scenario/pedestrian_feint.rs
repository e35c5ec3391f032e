//! `pedestrian_feint`: an unmarked crosswalk (a signalling game). The
//! pedestrian is a `crosser` (steps in and crosses: the ego must give way) or
//! a `feinter` (stops at the kerb to let the car pass: the ego should go). A
//! feinter waits only for a car whose motion says it is going; once the car
//! hangs back for the feinter's patience (drawn per seed), it takes its turn
//! and crosses at walking pace: a car that slows and stops is, to a
//! pedestrian, an invitation.
//!
//! Until the reveal both dispositions move identically: same start, same
//! walking speed (tiers 1 and 3), the same wait at the kerb (tier 2). Every
//! reaction is a function of the ego's kinematic state only (`EgoApproach`).
//!
//! Tiers (all timings drawn per seed and tied to the ego's own full-throttle
//! arrival at the crossing line, `t_race`):
//! - tier 1: the pedestrian walks toward the kerb and reaches it
//!   `tier1.kerb_lead_s` before `t_race`; the crosser walks on, the feinter
//!   decelerates and stops at the kerb (the cue).
//! - tier 2: both wait at the kerb; the crosser steps out late and briskly,
//!   `tier2.step_lead_s` before `t_race` (less reaction time).
//! - tier 3 (pause-then-dart): both walk toward the kerb and both stop. The
//!   feinter stops back from the edge, as on tier 1 (the tell, early); the
//!   crosser walks on to the kerb's edge (`tier3.crosser_stop_m`) and
//!   pauses there: at rest, it looks like a pedestrian waiting. It darts
//!   (2.5 m/s) the moment the ego's motion shows it will reach the line
//!   within `tier3.dart_horizon_s` at its current speed, which is inside
//!   any stopping distance: a car that took the pause for a wait is hit.
//!   A car that gives way to it (not going, by the measure below, for
//!   `tier3.invite_s`) invites it across, and its long linger ends the
//!   pause otherwise. The bite is the misleading pause, not a reaction
//!   time: the tell (where it stopped) comes 2.6-3.2 s before a
//!   full-throttle arrival, so a reader two decisions late still gives way
//!   in time.
//!
//! Why each blind play loses (one that never looks at the pedestrian):
//! - racing: the crosser is in the ego's path when a full-throttle ego
//!   arrives under every geometry drawn (tiers 1-2: its timing is tied to
//!   `t_race`; tier 3: its dart is triggered by the approach itself and
//!   occupies the path when a fast car arrives).
//! - keeping a "going" pace but arriving late: the feinter counts as going
//!   only a car that is not braking and either keeps 85% of the speed limit
//!   or is due within `waits_while_eta_s`; from such a pace the ego cannot
//!   lose enough time to let a crosser clear, and every second of anything
//!   else (braking, a slow approach) counts against the feinter's patience.
//! - hanging back to let a possible crosser pass (late hard stop, slow
//!   approach, stop-and-go, triggering the dart and then braking): the
//!   feinter's patience is short (cumulative from t = 0), so it steps in
//!   (after standing `look_s` at the kerb) and is in the ego's path by the
//!   time the crosser would have cleared it or the dart would have passed;
//!   on tier 3 hanging back also invites a crosser at the edge across
//!   first, and the feinter follows it before the car can go.
//! - outwaiting both: the feinter's own passage (stepping in only after
//!   `look_s`, then walking slowly in front of a stopped car), and in tier 3
//!   the crosser's long linger before an untriggered dart, end later than
//!   the turn budget allows; the expert, who reads the cue and times its
//!   arrival behind a crosser, finishes within it with slack.
//!
//! How long a feinter waits, and why: it stands at the kerb for at least
//! `look_s` (1.0-1.5 s, a human perception-reaction time) after it has
//! stopped there before it steps in, however the car moves, so a driver who
//! sees it stop has two decisions or more to go. The turn budget (20 on
//! tiers 1-2) leaves a driver who gives way to a crosser one decision late
//! time to finish; a feinter who gave up crosses hesitantly (0.7-0.9 m/s),
//! so that outwaiting it still does not fit. The tier-2 crosser steps out
//! early enough (1.7-1.9 s before a full-throttle arrival) for a reader two
//! decisions late to give way. Tier 3 keeps 18 decisions (a longer budget
//! lets one blind schedule in five outwait it): a crosser at the edge that
//! a car gives way to crosses within a second of being invited (0.3-0.6 s
//! of the car visibly giving way), so a reader two decisions late still
//! finishes. The tier-3 dart (triggered 1.2-1.3 s before the car would
//! arrive) is a reaction-time trap only for a car that ignored the tell.
//!
//! Frame: the ego drives along +x centred on y = 0 (lane from -1.75 to
//! 1.75); the pedestrian crosses along +y at x = 0. Its public position is
//! lateral from the near kerb: `lat = y + 1.75`.

use super::world::{Contact, EgoApproach, History, Patience, PlanPoint, World, car_box, crossing_ttc};
use super::{Common, Disposition, FieldCheck, Range, ScenarioError, Tier};
use super::{PlanAxes, RoadUser, ScenarioDef, TrackLabel};
use super::{Sample, ScenarioKind, Scene};
use crate::rng::EpisodeRng;
use crate::sim::{Aabb, Body, CAR_LENGTH, CAR_WIDTH, EGO_MAX_ACCEL, PEDESTRIAN_SIZE, travel_time};
use serde::{Deserialize, Serialize};

/// What the rest of the program knows of this scenario.
pub(crate) const DEF: ScenarioDef = ScenarioDef {
    name: "pedestrian_feint",
    scene_name: "crosswalk",
    rng_id: 2,
    dispositions: [Disposition::Crosser, Disposition::Feinter],
    plan_axes: PlanAxes {
        ego_along_y: false,
        others_along_y: true,
        zero_label: "crosswalk",
        road_users: &[RoadUser { role: "pedestrian", lateral: Some(KERB_FRAME) }],
    },
    scene_doc: "`ego_to_crosswalk_m`: the ego's front bumper to the pedestrian's\ncrossing line. `pedestrian.position_m`: lateral position from the\nnear kerb (negative on the sidewalk, 0 at the kerb, 3.5 at the far\nedge of the ego lane); `velocity_mps` positive when moving into the\nroad.",
    place_fields: &["ego_to_crosswalk_m"],
    place_text: |n| format!("{} m to the crosswalk", n[0]),
    tracks_relative_to_ego: false,
    situation: "Urban street with an unmarked crosswalk ahead. A pedestrian is near the kerb on your side. The pedestrian (0.6 m across) is placed by its centre, laterally from the near kerb (your car: 1.9 m wide, 4.8 m long): negative = on the sidewalk, 0 = kerb, 7.0 = far kerb; with its centre between 0.5 and 3.0 its body overlaps your car's path. Positive velocity = moving into the road. Distance to the crosswalk is from your front bumper to the pedestrian's crossing line; you have passed it below -5.4 m.",
    track_labels: &[TrackLabel {
        now: "Pedestrian",
        history: "Pedestrian over the last 2 s (oldest first)",
        field: "pedestrian",
    }],
    track_now: |position, velocity| format!("at {position} m (lateral), velocity {velocity} m/s"),
    belief_question: "the pedestrian will let you drive past the crosswalk before stepping into your path",
    leaderboard_dc: None,
    builtin_file: ("scenarios/pedestrian_feint.toml", include_str!("../../scenarios/pedestrian_feint.toml")),
    load: super::load::<PedestrianParams>,
    tier_mechanics: ["delayed step-out", "pause-then-dart"],
};

/// Lane half-width; the near kerb is at y = -KERB.
const KERB: f64 = 1.75;
/// Ego centre distance from the crossing line at which boxes can overlap.
pub const X_HALF: f64 = 0.5 * (CAR_LENGTH + PEDESTRIAN_SIZE);
/// Lateral band (from the near kerb) in which the pedestrian is in the ego's path.
pub const PATH_NEAR: f64 = KERB - 0.5 * (CAR_WIDTH + PEDESTRIAN_SIZE);
pub const PATH_FAR: f64 = KERB + 0.5 * (CAR_WIDTH + PEDESTRIAN_SIZE);
/// Far kerb of the two-lane road.
pub const FAR_KERB: f64 = 4.0 * KERB;
/// The pedestrian's public frame (lateral from the near kerb, as the scene
/// text states it), for figures and the drill-down.
pub(crate) const KERB_FRAME: super::LateralFrame = super::LateralFrame {
    measured: "from the near kerb",
    plan_offset: KERB,
    marks: [(0.0, "near kerb"), (FAR_KERB, "far kerb")],
    in_path: (PATH_NEAR, PATH_FAR),
};
/// Pedestrians stop and step out this briskly (m/s^2).
const PED_ACCEL: f64 = 6.0;
/// A car keeping at least this fraction of the speed limit (and not
/// braking) is going, to a waiting pedestrian.
const GOING_PACE: f64 = 0.85;
/// A car slower than this (m/s) is not "going" to a waiting pedestrian.
const GOING_MIN_SPEED: f64 = 3.0;
/// A car braking harder than this (m/s^2) is hanging back.
const GOING_MIN_ACCEL: f64 = -0.6;
/// A darting crosser reacts to a car at most this slow (m/s) too.
const DART_MIN_SPEED: f64 = 1.0;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PedestrianParams {
    pub episode: Common,
    pub ego: PedEgo,
    pub pedestrian: PedBehaviour,
    pub tier1: PedTier1,
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
    /// Walking speed of both dispositions until the reveal (m/s).
    pub walk_speed_mps: Range,
    /// Where the pedestrian stands when it waits at the kerb (lateral, m).
    pub kerb_stop_m: f64,
    /// A waiting pedestrian keeps waiting while the car, not braking and
    /// faster than a crawl, is due at the crossing line within this (s).
    pub waits_while_eta_s: f64,
    /// A feinter stands at the kerb at least this long (s), from the moment
    /// it decides (tier 2: when a crosser would step out), before it steps in.
    pub look_s: Range,
    /// A feinter who gave up walks across at this pace (m/s) ...
    pub give_up_speed_mps: Range,
    /// ... pulling away from rest this gently (m/s^2).
    pub give_up_accel_mps2: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PedTier1 {
    /// The pedestrian reaches the kerb this long (s) before a full-throttle
    /// ego would reach the crossing line.
    pub kerb_lead_s: Range,
    /// Hang-back (s) a waiting feinter tolerates before it crosses.
    pub patience_s: Range,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PedTier2 {
    /// Both wait at the kerb; the crosser steps out this long (s) before a
    /// full-throttle ego would reach the crossing line.
    pub step_lead_s: Range,
    pub step_out_speed_mps: Range,
    pub patience_s: Range,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PedTier3 {
    /// Both reach the feinter's stop this long (s) before a full-throttle
    /// arrival; the feinter stops there, the crosser walks on to ...
    pub kerb_lead_s: Range,
    /// ... the kerb's edge, where it stops too (lateral, m): a step nearer
    /// the road than a pedestrian who waits for cars.
    pub crosser_stop_m: f64,
    /// The crosser darts after lingering this long (s) at the kerb ...
    pub linger_s: Range,
    /// ... or as soon as a moving, not-stopping ego is due at the crossing
    /// line within this (s), after a reaction time.
    pub dart_horizon_s: Range,
    pub dart_reaction_s: f64,
    pub dart_speed_mps: f64,
    /// A crosser at the edge takes its turn once the car, still short of
    /// the line, has been giving way (not going, as a waiting pedestrian
    /// judges it) for this long (s): a car that slows for it invites it.
    pub invite_s: Range,
    pub patience_s: Range,
}

impl super::ScenarioParams for PedestrianParams {
    fn common(&self) -> &Common {
        &self.episode
    }

    fn build_world(
        &self,
        tier: Tier,
        disposition: Disposition,
        geometry: &mut EpisodeRng,
        _noise: EpisodeRng,
    ) -> Box<dyn World + Send> {
        Box::new(PedestrianWorld::new(self, tier, disposition, geometry))
    }

    fn validate(&self, c: &FieldCheck) -> Result<(), ScenarioError> {
        self.episode.validate(c)?;
        c.range_within("ego.start_distance_m", self.ego.start_distance_m, 10.0, 200.0)?;
        c.range_within("ego.start_speed_mps", self.ego.start_speed_mps, 0.5, self.episode.speed_limit_mps)?;
        c.within("ego.goal_past_crosswalk_m", self.ego.goal_past_crosswalk_m, X_HALF, 200.0)?;
        let b = &self.pedestrian;
        c.range_within("pedestrian.walk_speed_mps", b.walk_speed_mps, 0.3, 3.0)?;
        c.within("pedestrian.kerb_stop_m", b.kerb_stop_m, -2.0, 0.0)?;
        c.within("pedestrian.waits_while_eta_s", b.waits_while_eta_s, 0.5, 10.0)?;
        c.range_within("pedestrian.look_s", b.look_s, 0.0, 10.0)?;
        c.range_within("pedestrian.give_up_speed_mps", b.give_up_speed_mps, 0.3, 3.0)?;
        c.within("pedestrian.give_up_accel_mps2", b.give_up_accel_mps2, 0.1, PED_ACCEL)?;
        c.range_within("tier1.kerb_lead_s", self.tier1.kerb_lead_s, 0.0, 10.0)?;
        c.range_within("tier1.patience_s", self.tier1.patience_s, 0.0, 20.0)?;
        c.range_within("tier2.step_lead_s", self.tier2.step_lead_s, 0.0, 10.0)?;
        c.range_within("tier2.step_out_speed_mps", self.tier2.step_out_speed_mps, 0.3, 4.0)?;
        c.range_within("tier2.patience_s", self.tier2.patience_s, 0.0, 20.0)?;
        c.range_within("tier3.kerb_lead_s", self.tier3.kerb_lead_s, 0.0, 10.0)?;
        c.within("tier3.crosser_stop_m", self.tier3.crosser_stop_m, b.kerb_stop_m, 0.0)?;
        c.range_within("tier3.invite_s", self.tier3.invite_s, 0.0, 5.0)?;
        c.range_within("tier3.linger_s", self.tier3.linger_s, 0.0, 30.0)?;
        c.range_within("tier3.dart_horizon_s", self.tier3.dart_horizon_s, 0.0, 5.0)?;
        c.within("tier3.dart_reaction_s", self.tier3.dart_reaction_s, 0.0, 2.0)?;
        c.within("tier3.dart_speed_mps", self.tier3.dart_speed_mps, 0.5, 5.0)?;
        c.range_within("tier3.patience_s", self.tier3.patience_s, 0.0, 20.0)
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    /// Walking toward the kerb (tiers 1 and 3). A tier-1 crosser walks on.
    ToKerb,
    /// Standing at the kerb since `since`.
    AtKerb { since: f64 },
    /// Crossing the road at `speed`, changing speed at most `accel`.
    Cross { speed: f64, accel: f64 },
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
    walk: f64,
    /// Tier 1: the crosser keeps walking; tier 2: the crosser steps out and
    /// the feinter starts watching at `decide_at` (s).
    decide_at: f64,
    step_speed: f64,
    /// The feinter's patience with a car that hangs back.
    patience: Patience,
    give_up_speed: f64,
    look: f64,
    linger: f64,
    dart_horizon: f64,
    dart_at: Option<f64>,
    /// Tier 3: how long the car has been giving way to a crosser at the
    /// edge (s, continuous), and how long that takes to invite it.
    invited_for: f64,
    invite: f64,
    /// Times the pedestrian, having waited for the ego, took its turn (a
    /// feinter giving up, a crosser at the edge taking an invitation).
    turns_taken: u32,
    revealed: bool,
    history: History,
}

impl PedestrianWorld {
    pub fn new(params: &PedestrianParams, tier: Tier, disposition: Disposition, geometry: &mut EpisodeRng) -> Self {
        let b = &params.pedestrian;
        // Every draw is made under both dispositions, in the same order.
        let d_ego = params.ego.start_distance_m.sample(geometry);
        let v_ego = params.ego.start_speed_mps.sample(geometry);
        let walk = b.walk_speed_mps.sample(geometry);
        let give_up_speed = b.give_up_speed_mps.sample(geometry);
        let look = b.look_s.sample(geometry);
        let (lead, patience, step_speed, linger, dart_horizon, invite) = match tier {
            Tier::T1 => (
                params.tier1.kerb_lead_s.sample(geometry),
                params.tier1.patience_s.sample(geometry),
                walk,
                0.0,
                0.0,
                0.0,
            ),
            Tier::T2 => (
                params.tier2.step_lead_s.sample(geometry),
                params.tier2.patience_s.sample(geometry),
                params.tier2.step_out_speed_mps.sample(geometry),
                0.0,
                0.0,
                0.0,
            ),
            Tier::T3 => (
                params.tier3.kerb_lead_s.sample(geometry),
                params.tier3.patience_s.sample(geometry),
                params.tier3.dart_speed_mps,
                params.tier3.linger_s.sample(geometry),
                params.tier3.dart_horizon_s.sample(geometry),
                params.tier3.invite_s.sample(geometry),
            ),
        };
        let t_race = travel_time(d_ego, v_ego, params.episode.speed_limit_mps, EGO_MAX_ACCEL);
        let decide_at = (t_race - lead).max(0.5);
        let (lat, vel, phase) = match tier {
            // Already walking: at the kerb stop at `decide_at`.
            Tier::T1 | Tier::T3 => (b.kerb_stop_m - walk * decide_at, walk, Phase::ToKerb),
            Tier::T2 => (b.kerb_stop_m, 0.0, Phase::AtKerb { since: 0.0 }),
        };
        PedestrianWorld {
            tier,
            disposition,
            params: params.clone(),
            ego_start: Body::new(-X_HALF - d_ego, v_ego),
            lat,
            vel,
            phase,
            walk,
            decide_at,
            step_speed,
            patience: Patience::new(patience),
            give_up_speed,
            look,
            linger,
            dart_horizon,
            dart_at: None,
            invited_for: 0.0,
            invite,
            turns_taken: 0,
            revealed: false,
            history: History::steady(Sample { position_m: lat, velocity_mps: vel }, vel),
        }
    }

    fn ped_box(&self) -> Aabb {
        Aabb::centered(0.0, self.lat - KERB, PEDESTRIAN_SIZE, PEDESTRIAN_SIZE)
    }

    /// Move toward `target_vel`, changing speed at most `accel`.
    fn walk_toward(&mut self, target_vel: f64, accel: f64, dt: f64) {
        let dv = (target_vel - self.vel).clamp(-accel * dt, accel * dt);
        let v_next = self.vel + dv;
        self.lat += 0.5 * (self.vel + v_next) * dt;
        self.vel = v_next;
    }

    /// Whether the ego's motion tells a waiting pedestrian that it is going
    /// first: not braking, and either keeping a through pace or, faster than
    /// a crawl, due soon.
    fn ego_going(&self, ego: &Body) -> bool {
        let v_max = self.params.episode.speed_limit_mps;
        let app = EgoApproach::new(-X_HALF - ego.s, ego);
        app.to_conflict > 0.0
            && ego.a > GOING_MIN_ACCEL
            && (ego.v >= GOING_PACE * v_max
                || (ego.v >= GOING_MIN_SPEED && app.eta(v_max) <= self.params.pedestrian.waits_while_eta_s))
    }

    /// Whether the ego's motion shows it will reach the line within the
    /// dart horizon at its current speed (moving and not braking).
    fn ego_due(&self, ego: &Body) -> bool {
        let d = -X_HALF - ego.s;
        d > 0.0 && ego.v >= DART_MIN_SPEED && ego.a > GOING_MIN_ACCEL && d <= self.dart_horizon * ego.v
    }
}

impl World for PedestrianWorld {
    fn ego_start(&self) -> Body {
        self.ego_start
    }

    fn goal_s(&self) -> f64 {
        self.params.ego.goal_past_crosswalk_m
    }

    fn advance(&mut self, ego: &Body, t: f64, dt: f64) {
        let crosser = self.disposition == Disposition::Crosser;
        // Tier 3: the crosser stops a step further on, at the kerb's edge.
        let kerb_stop = if self.tier == Tier::T3 && crosser {
            self.params.tier3.crosser_stop_m
        } else {
            self.params.pedestrian.kerb_stop_m
        };
        let feinter_stop = self.params.pedestrian.kerb_stop_m;
        let mut accel = PED_ACCEL;
        // The pedestrian watches the car from the start: hang-back counts
        // whenever the car's motion does not say it is going first.
        let hanging_back = ego.s < -X_HALF && !self.ego_going(ego);
        if hanging_back {
            self.patience.hang_back(dt);
        }
        let target = match self.phase {
            Phase::ToKerb => {
                let left = kerb_stop - self.lat;
                // Where a pedestrian who stops at the kerb starts to slow.
                let feinter_left = feinter_stop - self.lat;
                if feinter_left <= self.walk * self.walk / (2.0 * PED_ACCEL) + 0.02 && self.tier != Tier::T2 {
                    self.revealed = true;
                }
                if self.tier == Tier::T1 && crosser {
                    self.phase = Phase::Cross { speed: self.walk, accel: PED_ACCEL };
                    if left > 0.0 {
                        self.phase = Phase::ToKerb;
                    }
                    self.walk
                } else if left <= 0.005 && self.vel <= 0.05 {
                    self.phase = Phase::AtKerb { since: t };
                    0.0
                } else {
                    self.walk.min((2.0 * PED_ACCEL * left.max(0.0)).sqrt())
                }
            }
            Phase::AtKerb { since } => {
                if crosser {
                    match self.tier {
                        Tier::T1 => {}
                        Tier::T2 => {
                            if t + 1e-9 >= self.decide_at {
                                self.revealed = true;
                                self.phase = Phase::Cross { speed: self.step_speed, accel: PED_ACCEL };
                            }
                        }
                        Tier::T3 => {
                            if self.dart_at.is_none() && self.ego_due(ego) {
                                self.dart_at = Some(t + self.params.tier3.dart_reaction_s);
                            }
                            // A car hanging back gives way to it: an invitation.
                            self.invited_for = if hanging_back { self.invited_for + dt } else { 0.0 };
                            let triggered = self.dart_at.is_some_and(|d| t + 1e-9 >= d);
                            let invited = self.invited_for + 1e-9 >= self.invite;
                            let dart = triggered || invited || t - since + 1e-9 >= self.linger;
                            if dart {
                                // Taking the ego's invitation is taking a turn;
                                // the dart and the linger are the crosser's own.
                                self.turns_taken += (invited && !triggered) as u32;
                                self.revealed = true;
                                self.phase = Phase::Cross { speed: self.step_speed, accel: PED_ACCEL };
                            }
                        }
                    }
                } else {
                    // It decides no earlier than a crosser would step out.
                    let decided = match self.tier {
                        Tier::T2 => self.decide_at,
                        _ => since,
                    };
                    let deciding = t + 1e-9 >= decided + self.look;
                    if deciding && self.patience.run_out() {
                        self.turns_taken += 1;
                        self.revealed = true;
                        self.phase = Phase::Cross {
                            speed: self.give_up_speed,
                            accel: self.params.pedestrian.give_up_accel_mps2,
                        };
                    }
                }
                0.0
            }
            Phase::Cross { speed, accel: a } => {
                accel = a;
                if self.lat >= FAR_KERB + 1.0 { 0.0 } else { speed }
            }
        };
        self.walk_toward(target, accel, dt);
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
        Scene::new(ScenarioKind::PedestrianFeint, &[-X_HALF - ego.s], &[self.history.track(now)])
            .expect("the crosswalk's layout")
    }

    fn revealed(&self) -> bool {
        self.revealed
    }

    fn turns_taken(&self) -> u32 {
        self.turns_taken
    }

    fn ego_to_conflict(&self, ego: &Body) -> f64 {
        -X_HALF - ego.s
    }

    fn other_entered(&self) -> bool {
        self.lat > PATH_NEAR
    }

    fn cuts_off(&self, ego: &Body) -> bool {
        // Driving over the crossing line while the pedestrian is on the road.
        ego.s.abs() < X_HALF && self.lat > 0.0 && self.lat < FAR_KERB
    }

    fn plan(&self, ego: &Body) -> Vec<PlanPoint> {
        vec![PlanPoint { x: ego.s, y: 0.0, v: ego.v }, PlanPoint { x: 0.0, y: self.lat - KERB, v: self.vel }]
    }
}
