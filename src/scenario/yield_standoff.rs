//! `yield_standoff`: an unsignalled T-intersection (a game of chicken). Two
//! cars approach on the crossing road, one behind the other. The first is
//! `committed` (drives through) or a `yielder` (stops at its line and waits
//! for the ego, but only while the ego comes: once the ego has hung back for
//! the yielder's patience, it takes its turn). The car behind it follows it
//! (Newell's car-following model: the leader's trajectory, shifted by a lag
//! and a jam spacing), so it queues behind a yielder and drives through a
//! second or so behind a committed car.
//!
//! Why each blind play loses (the ego only chooses *when* it reaches the
//! zone, from its own state and the clock):
//! - racing: a committed car reaches the zone when a full-throttle ego
//!   does, under every geometry drawn, and the car behind it follows too
//!   closely for the ego to slip between them;
//! - arriving after the committed pair: the ego has to hang back for that.
//!   Crossing cars approach carefully (3-4 m/s), so a committed pair takes
//!   about four seconds to clear the zone after the first car reaches it,
//!   while a yielder is at rest at its line within half a second of that
//!   moment; once the ego has hung back for the yielder's patience it pulls
//!   away, and an ego counts as coming only when due within 2 s, which is
//!   before the committed pair would have cleared: a late ego either meets
//!   the yielder in the zone or, had it come in time to hold it, the
//!   committed pair;
//! - waiting for both: a yielder that took its turn pulls away from rest
//!   with its follower queued behind it, so the pair clears the zone seconds
//!   after a committed pair does; the turn budget ends in between (the
//!   expert giving way to a committed pair finishes before it, an ego that
//!   outwaits a yielding pair after it);
//! - tier 3 (both cars brake from the start as if to stop): racing makes the
//!   committed car re-accelerate into the zone (the ego's motion shows it
//!   will enter within the commit horizon); hanging back makes it roll
//!   through at its floor speed and then drive on, gently (1.2 m/s^2); a
//!   yielder stops and waits as on tier 1. Both count the ego as coming on
//!   a shorter horizon there (not braking and due within 1 s, speeding up
//!   and due within 1.8 s): with tier 1's 2 s a late blind ego held the
//!   yielder and still passed behind the bluffer (docs/validate.md).
//!
//! How long a stopped yielder waits, and why: it takes its turn only once
//! the ego has hung back for 1.0-1.5 s in all after it came to rest (drawn
//! per seed; tier 2, whose yielder stops sooner after its braking shows,
//! 1.5-2.0 s; tier 3 1.0-1.5 s). A human driver's perception-reaction time
//! is about 1-1.5 s: a driver who sees the stop at the next decision and
//! answers a decision later is coming (not braking and due within
//! `coming_eta_s`, or speeding up and due within `speeding_up_eta_s`)
//! before the patience runs out, so "wait for the car to stop, then go"
//! works one decision late (`tests/it/core.rs`), and so does a driver who
//! braked gently from the first decision until after the evidence, then
//! reads it a decision late and first only holds speed (`validate`'s
//! hedging line). A patience under one decision (the 0.2-0.5 s this
//! scenario once had) is not a person, and the late-reader line of
//! `validate` catches it.
//!
//! Frame: the ego drives along +y at x = 0, the crossing cars along +x at
//! y = 0; positions are box centres, the crossing centre is the origin.

use super::world::{Contact, EgoApproach, History, Patience, PlanPoint, ROW_MARGIN_S, World, car_box, crossing_ttc};
use super::{Common, Disposition, FieldCheck, Range, ScenarioError, Tier};
use super::{PlanAxes, RoadUser, ScenarioDef, TrackLabel};
use super::{Sample, ScenarioKind, Scene};
use crate::rng::EpisodeRng;
use crate::sim::{Body, CAR_LENGTH, CAR_WIDTH, DT, EGO_MAX_ACCEL, stopping_decel, track_speed, travel_time};
use serde::{Deserialize, Serialize};

/// The hidden dispositions of this scenario (its definition lists them).
pub const COMMITTED: Disposition = Disposition::new("committed", false);
pub const YIELDER: Disposition = Disposition::new("yielder", true);

/// What the rest of the program knows of this scenario.
pub(crate) const DEF: ScenarioDef = ScenarioDef {
    name: "yield_standoff",
    scene_name: "intersection",
    rng_id: 1,
    dispositions: [COMMITTED, YIELDER],
    plan_axes: PlanAxes {
        ego_along_y: true,
        others_along_y: false,
        zero_label: "crossing centre",
        road_users: &[RoadUser { role: "other car", lateral: None }, RoadUser { role: "follower", lateral: None }],
    },
    scene_doc: "`ego_to_conflict_m`: the ego's front bumper to the crossing lane's\nnear edge. `other.position_m`: the other car's front bumper to the\nego lane's near edge (negative once it has entered; it has cleared\nthe conflict zone below -`CONFLICT_ZONE_M`). `follower`: the car\nbehind it on the crossing road, measured the same way.",
    place_fields: &["ego_to_conflict_m"],
    place_text: |n| format!("{} m to the conflict zone", n[0]),
    tracks_relative_to_ego: false,
    position_per_velocity: -1.0,
    forecast_tracks: 1,
    situation: "Unsignalled T-intersection. You approach on the stem and must cross the conflict zone; two cars approach one behind the other on the crossing road. There are no signs, no signals and no agreed right of way: read the other driver's intent from its motion. Cars (yours too) are 4.8 m long, 1.9 m wide. Distances to the conflict zone are from the front bumper to the zone's near edge; negative means already inside or past it (any car has fully crossed below -6.7 m).",
    track_labels: &[
        TrackLabel { now: "Other car", history: "Other car over the last 2 s (oldest first)", field: "other" },
        TrackLabel {
            now: "Car behind it",
            history: "Car behind it over the last 2 s (oldest first)",
            field: "follower",
        },
    ],
    track_now: |position, velocity| format!("{position} m to the conflict zone, speed {velocity} m/s"),
    belief_question: "the other car will let you pass through the conflict zone before it",
    forecast_subject: "the other car (the first on the crossing road) will be, as its distance in metres to the conflict zone as the scene measures it,",
    leaderboard_dc: Some("yield"),
    builtin_file: ("scenarios/yield_standoff.toml", include_str!("../../scenarios/yield_standoff.toml")),
    load: super::load::<YieldParams>,
    tier_mechanics: ["delayed reveal", "bluff"],
};

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
    /// Both crossing cars approach at this speed (m/s).
    pub approach_speed_mps: Range,
    /// When the first car would reach the zone at that speed, relative to a
    /// full-throttle ego (s): a committed car is in the zone when a racing
    /// ego gets there.
    pub arrival_offset_s: Range,
    /// The car behind follows the first one's trajectory this much later
    /// (s) ...
    pub follower_lag_s: Range,
    /// ... and this far behind it, centre to centre (m): its spacing when
    /// both are at rest.
    pub jam_spacing_m: f64,
    /// A yielder stops this far before the zone (m).
    pub stop_line_m: f64,
    /// A yielder drives on until a stop at its line takes this braking rate
    /// (m/s^2): the moment its disposition shows.
    pub stop_decel_mps2: f64,
    /// A yielder counts the ego as coming while it is not braking, drives at
    /// least 1.5 m/s and is due at the zone within this long (s), or can no
    /// longer stop short of it (tiers 1 and 2; tier 3 has its own) ...
    pub coming_eta_s: f64,
    /// ... or is speeding up toward the zone (at least 0.5 m/s^2, at least
    /// 1.5 m/s) and due within this long (s): what a driver waiting at its
    /// line sees as a car coming through.
    pub speeding_up_eta_s: f64,
    /// ... and, once stopped, takes its turn after the ego has hung back for
    /// this long in all (s), drawn per episode.
    pub patience_s: Range,
    /// Acceleration of a car pulling away from its line (m/s^2) ...
    pub go_accel_mps2: f64,
    /// ... up to this speed (m/s).
    pub go_speed_mps: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct YieldTier2 {
    /// Delayed reveal: a yielder brakes later and harder (m/s^2).
    pub stop_decel_mps2: f64,
    /// A tier-2 yielder's patience once stopped (s), drawn per episode: it
    /// stops sooner after its braking shows than a tier-1 yielder, so it
    /// waits as much longer, and it decides as long after its evidence.
    pub patience_s: Range,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct YieldTier3 {
    /// Both crossing cars approach at this speed on tier 3 (m/s): a
    /// bluff needs a car fast enough that rolling on at its floor, then
    /// re-accelerating, still reaches the zone first.
    pub approach_speed_mps: Range,
    /// Both dispositions were already braking when the ego arrived, on a
    /// profile that would stop at the line this many times later than a
    /// full-throttle ego's arrival.
    pub stop_time_factor: Range,
    /// A bluffer never slows below this (m/s): it rolls, it never stops.
    pub floor_speed_mps: f64,
    /// The ego "commits" when its motion brings it into the zone within
    /// this long (s) ...
    pub commit_horizon_s: f64,
    /// ... and a bluffer then re-accelerates this hard (m/s^2).
    pub bluff_accel_mps2: f64,
    /// A bluffer at its floor speed drives on once the ego has not come for
    /// this long (s), drawn per episode ...
    pub hold_s: Range,
    /// ... at this acceleration (m/s^2).
    pub drive_on_accel_mps2: f64,
    /// A tier-3 yielder's patience once stopped (s), drawn per episode:
    /// its stop is the first sign, so the ego needs longer to answer it.
    pub patience_s: Range,
    /// On tier 3 both cars count the ego as coming when it is not braking
    /// and due within this long (s) ...
    pub coming_eta_s: f64,
    /// ... or speeding up toward the zone and due within this long (s).
    pub speeding_up_eta_s: f64,
}

impl super::ScenarioParams for YieldParams {
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
        Box::new(YieldWorld::new(self, tier, disposition, geometry))
    }

    fn validate(&self, c: &FieldCheck) -> Result<(), ScenarioError> {
        self.episode.validate(c)?;
        c.range_within("ego.start_distance_m", self.ego.start_distance_m, 10.0, 200.0)?;
        c.range_within("ego.start_speed_mps", self.ego.start_speed_mps, 0.0, self.episode.speed_limit_mps)?;
        c.within("ego.goal_past_zone_m", self.ego.goal_past_zone_m, HALF_ZONE, 200.0)?;
        let o = &self.other;
        c.range_within("other.approach_speed_mps", o.approach_speed_mps, 1.0, 20.0)?;
        c.range_within("other.arrival_offset_s", o.arrival_offset_s, -5.0, 5.0)?;
        c.range_within("other.follower_lag_s", o.follower_lag_s, 0.0, 5.0)?;
        c.within("other.jam_spacing_m", o.jam_spacing_m, CAR_LENGTH + 0.5, 30.0)?;
        c.within("other.stop_line_m", o.stop_line_m, 0.5, 10.0)?;
        c.within("other.stop_decel_mps2", o.stop_decel_mps2, 0.5, 8.0)?;
        c.within("other.coming_eta_s", o.coming_eta_s, 0.1, 10.0)?;
        c.within("other.speeding_up_eta_s", o.speeding_up_eta_s, 0.0, 10.0)?;
        c.range_within("other.patience_s", o.patience_s, 0.0, 30.0)?;
        c.within("other.go_accel_mps2", o.go_accel_mps2, 0.5, 5.0)?;
        c.within("other.go_speed_mps", o.go_speed_mps, 1.0, 20.0)?;
        c.within("tier2.stop_decel_mps2", self.tier2.stop_decel_mps2, 0.5, 8.0)?;
        c.range_within("tier2.patience_s", self.tier2.patience_s, 0.0, 30.0)?;
        let t3 = &self.tier3;
        c.range_within("tier3.approach_speed_mps", t3.approach_speed_mps, 1.0, 20.0)?;
        c.range_within("tier3.stop_time_factor", t3.stop_time_factor, 0.5, 4.0)?;
        c.within("tier3.floor_speed_mps", t3.floor_speed_mps, 0.5, 10.0)?;
        c.within("tier3.commit_horizon_s", t3.commit_horizon_s, 0.1, 5.0)?;
        c.within("tier3.bluff_accel_mps2", t3.bluff_accel_mps2, 0.5, 6.0)?;
        c.range_within("tier3.hold_s", t3.hold_s, 0.0, 30.0)?;
        c.within("tier3.drive_on_accel_mps2", t3.drive_on_accel_mps2, 0.5, 6.0)?;
        c.range_within("tier3.patience_s", t3.patience_s, 0.0, 30.0)?;
        c.within("tier3.coming_eta_s", t3.coming_eta_s, 0.1, 10.0)?;
        c.within("tier3.speeding_up_eta_s", t3.speeding_up_eta_s, 0.0, 10.0)
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    /// Constant speed.
    Cruise,
    /// A yielder braking to stop at its line, or the tier-3 common profile
    /// (either disposition, until it shows).
    Braking,
    /// A yielder at its line, waiting for the ego.
    Stopped,
    /// A tier-3 bluffer rolling at its floor speed since `since`.
    Floor { since: f64 },
    /// Driving off or through at `accel`.
    Going { accel: f64 },
}

/// The first car's past, sampled every physics step: the follower replays
/// it (Newell's model). Before t = 0 the car moved at `v0` under constant
/// acceleration `a0`.
#[derive(Debug, Clone)]
struct Trajectory {
    s0: f64,
    v0: f64,
    a0: f64,
    /// (s, v) after each step.
    steps: Vec<(f64, f64)>,
}

impl Trajectory {
    /// Position and speed at time `t` (s), linear between steps.
    fn at(&self, t: f64) -> (f64, f64) {
        if t <= 0.0 {
            let v = (self.v0 + self.a0 * t).max(0.0);
            return (self.s0 + self.v0 * t + 0.5 * self.a0 * t * t, v);
        }
        let k = t / DT;
        let i = k.floor() as usize;
        let frac = k - i as f64;
        let point = |j: usize| if j == 0 { (self.s0, self.v0) } else { self.steps[(j - 1).min(self.steps.len() - 1)] };
        let (a, b) = (point(i), point(i + 1));
        (a.0 + frac * (b.0 - a.0), a.1 + frac * (b.1 - a.1))
    }
}

/// The typical figures of the intersection's other car, as the public
/// rules read them (the scenario file in the binary, middles of ranges).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Typical {
    /// A yielder stops this far before the zone (m) ...
    pub stop_line_m: f64,
    /// ... braking once a stop at its line takes this rate (m/s^2).
    pub stop_decel_mps2: f64,
    /// A tier-3 bluffer eases off no lower than this (m/s).
    pub floor_speed_mps: f64,
    /// A car pulling away from its line goes up to this (m/s), at this
    /// rate (m/s^2).
    pub go_speed_mps: f64,
    pub go_accel_mps2: f64,
}

impl Typical {
    pub fn of(p: &YieldParams) -> Typical {
        Typical {
            stop_line_m: p.other.stop_line_m,
            stop_decel_mps2: p.other.stop_decel_mps2,
            floor_speed_mps: p.tier3.floor_speed_mps,
            go_speed_mps: p.other.go_speed_mps,
            go_accel_mps2: p.other.go_accel_mps2,
        }
    }
}

/// The built-in file's [`Typical`] figures.
pub fn typical() -> &'static Typical {
    static TYPICAL: std::sync::LazyLock<Typical> =
        std::sync::LazyLock::new(|| Typical::of(&super::def::builtin_params::<YieldParams>(&DEF)));
    &TYPICAL
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
    revealed: bool,
    /// Hang-back the yielder tolerates once stopped.
    patience: Patience,
    /// Times a stopped yielder took its turn in front of the ego.
    turns_taken: u32,
    /// How long a tier-3 bluffer rolls at its floor for an ego that hangs back.
    hold: f64,
    /// Newell follower: lag (s) and jam spacing (m) behind the first car.
    lag: f64,
    spacing: f64,
    path: Trajectory,
    follower: Body,
    history: History,
    follower_history: History,
    /// Time of the last physics step (s).
    now: f64,
}

impl YieldWorld {
    pub fn new(params: &YieldParams, tier: Tier, disposition: Disposition, geometry: &mut EpisodeRng) -> Self {
        let d_ego = params.ego.start_distance_m.sample(geometry);
        let v_ego = params.ego.start_speed_mps.sample(geometry);
        let approach = params.other.approach_speed_mps.sample(geometry);
        // Drawn on every tier, so that tier 3's speed does not shift the
        // draws after it.
        let approach_t3 = params.tier3.approach_speed_mps.sample(geometry);
        let approach = if tier == Tier::T3 { approach_t3 } else { approach };
        let offset = params.other.arrival_offset_s.sample(geometry);
        let lag = params.other.follower_lag_s.sample(geometry);
        let patience = match tier {
            Tier::T1 => params.other.patience_s.sample(geometry),
            Tier::T2 => params.tier2.patience_s.sample(geometry),
            Tier::T3 => params.tier3.patience_s.sample(geometry),
        };
        let stop_factor = params.tier3.stop_time_factor.sample(geometry);
        let hold = params.tier3.hold_s.sample(geometry);
        let t_ego = travel_time(d_ego, v_ego, params.episode.speed_limit_mps, EGO_MAX_ACCEL);
        let arrival = (t_ego + offset).max(0.5);
        let stop_line = params.other.stop_line_m;
        let (d_other, phase, profile_decel) = match tier {
            Tier::T1 | Tier::T2 => (approach * arrival, Phase::Cruise, 0.0),
            Tier::T3 => {
                // Uniform braking to the stop line over `stop_factor * arrival` s.
                let braking_distance = 0.5 * approach * stop_factor * arrival;
                (stop_line + braking_distance, Phase::Braking, stopping_decel(approach, braking_distance))
            }
        };
        let ego_start = Body::new(-HALF_ZONE - d_ego, v_ego);
        let other = Body::new(-HALF_ZONE - d_other, approach);
        let path = Trajectory { s0: other.s, v0: approach, a0: -profile_decel, steps: Vec::with_capacity(512) };
        let spacing = params.other.jam_spacing_m;
        let (f_s, f_v) = path.at(-lag);
        let follower = Body::new(f_s - spacing, f_v);
        // Both cars moved as they move now before t = 0: steady on tiers 1
        // and 2, braking on tier 3 (for the junction, not for the ego).
        let observed = |b: &Body| Sample { position_m: -HALF_ZONE - b.s, velocity_mps: b.v };
        let past = |b: &Body| match tier {
            Tier::T3 => History::braking(observed(b), profile_decel, -1.0),
            _ => History::steady(observed(b), -b.v),
        };
        YieldWorld {
            tier,
            disposition,
            params: params.clone(),
            ego_start,
            history: past(&other),
            follower_history: past(&follower),
            other,
            cruise: approach,
            phase,
            profile_decel,
            revealed: false,
            patience: Patience::new(patience),
            turns_taken: 0,
            hold,
            lag,
            spacing,
            path,
            follower,
            now: 0.0,
        }
    }

    fn other_to_zone(&self) -> f64 {
        -HALF_ZONE - self.other.s
    }

    fn approach(&self, ego: &Body) -> EgoApproach {
        EgoApproach::new(-HALF_ZONE - ego.s, ego)
    }

    /// Whether the ego's motion says it is coming through first: it can no
    /// longer stop short of the zone, or it drives at least 1.5 m/s and is
    /// either not braking and due within `coming_eta_s`, or speeding up and
    /// due within `speeding_up_eta_s`.
    fn ego_coming(&self, ego: &Body) -> bool {
        let a = self.approach(ego);
        if a.to_conflict <= 0.0 {
            return true;
        }
        let eta = a.eta(self.params.episode.speed_limit_mps);
        let (coming_eta, speeding_up_eta) = match self.tier {
            Tier::T3 => (self.params.tier3.coming_eta_s, self.params.tier3.speeding_up_eta_s),
            _ => (self.params.other.coming_eta_s, self.params.other.speeding_up_eta_s),
        };
        a.beyond_stopping()
            || (ego.a > -0.5 && ego.v >= 1.5 && eta <= coming_eta)
            || (ego.a >= 0.5 && ego.v >= 1.5 && eta <= speeding_up_eta)
    }

    /// A yielder: drive on until a stop at the line takes its braking rate,
    /// brake to the line and wait there for an ego that comes. Once the ego
    /// has hung back for its patience in all, it takes its turn at the first
    /// moment the ego is hanging back *now*; it also drives on once the ego
    /// has passed.
    fn yielder_accel(&mut self, ego: &Body, dt: f64) -> f64 {
        let to_line = self.other_to_zone() - self.params.other.stop_line_m;
        let rate = match self.tier {
            Tier::T2 => self.params.tier2.stop_decel_mps2,
            _ => self.params.other.stop_decel_mps2,
        };
        if self.phase == Phase::Cruise && stopping_decel(self.other.v, to_line) >= rate {
            self.phase = Phase::Braking;
            self.revealed = true;
        }
        if self.phase == Phase::Braking && self.other.v <= 0.0 {
            self.phase = Phase::Stopped;
        }
        if self.phase == Phase::Stopped {
            if !self.ego_coming(ego) {
                self.patience.hang_back(dt);
            }
            let passed = ego.s > HALF_ZONE;
            // It acts on what the ego does now: an ego that hung back
            // earlier and is coming on now is no invitation (and one that
            // could no longer stop at all is coming). So is one still
            // moving that brakes but will not stop short of the zone (nor
            // could comfortably): no one at a stop line starts in front of
            // it. Waiting for every ego that could no longer stop *firmly*,
            // braking or not, lets a blind plan that comes on fast and then
            // rolls through win tier 3 (docs/validate.md).
            let braking_through = ego.a <= -0.5 && ego.v >= 1.5 && !self.approach(ego).can_stop();
            let gap_now = !self.ego_coming(ego) && !braking_through;
            let turn = self.patience.run_out() && gap_now;
            self.turns_taken += (turn && !passed) as u32;
            if passed || turn {
                self.phase = Phase::Going { accel: self.params.other.go_accel_mps2 };
            }
        }
        match self.phase {
            Phase::Cruise | Phase::Stopped | Phase::Floor { .. } => 0.0,
            Phase::Braking if self.tier == Tier::T3 && self.other.v > self.params.tier3.floor_speed_mps => {
                -self.profile_decel
            }
            Phase::Braking => -stopping_decel(self.other.v, to_line.max(0.01)).min(8.0),
            Phase::Going { accel } => track_speed(self.other.v, self.params.other.go_speed_mps, accel, 3.0, dt),
        }
    }

    /// The tier-3 bluffer: the common braking profile down to its floor,
    /// then rolling on; it re-accelerates hard once the ego's motion shows
    /// it will enter within the commit horizon, and drives on once it has
    /// rolled at its floor for `hold` without the ego coming.
    fn bluffer_accel(&mut self, ego: &Body, t: f64, dt: f64) -> f64 {
        let t3 = &self.params.tier3;
        let a = self.approach(ego);
        let commits =
            a.to_conflict > 0.0 && ego.v > 1.0 && a.eta(self.params.episode.speed_limit_mps) < t3.commit_horizon_s;
        match self.phase {
            Phase::Braking | Phase::Floor { .. } if commits => {
                self.phase = Phase::Going { accel: t3.bluff_accel_mps2 };
            }
            Phase::Braking if self.other.v <= t3.floor_speed_mps => self.phase = Phase::Floor { since: t },
            Phase::Floor { since } if t - since >= self.hold && !self.ego_coming(ego) => {
                self.phase = Phase::Going { accel: t3.drive_on_accel_mps2 };
            }
            _ => {}
        }
        match self.phase {
            Phase::Braking => -self.profile_decel,
            Phase::Going { accel } => track_speed(self.other.v, self.cruise, accel, 3.0, dt),
            _ => 0.0,
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
        let accel = match (self.tier, self.disposition) {
            (Tier::T1 | Tier::T2, COMMITTED) => 0.0,
            (Tier::T1 | Tier::T2, _) => self.yielder_accel(ego, dt),
            (Tier::T3, COMMITTED) => {
                let a = self.bluffer_accel(ego, t, dt);
                // The bluff shows once the car stops slowing above the floor
                // a yielder brakes through, or re-accelerates.
                self.revealed |= !matches!(self.phase, Phase::Braking);
                a
            }
            (Tier::T3, _) => {
                self.revealed |= self.other.v < self.params.tier3.floor_speed_mps;
                self.yielder_accel(ego, dt)
            }
        };
        self.other.advance(accel, dt);
        self.path.steps.push((self.other.s, self.other.v));
        self.now = t + dt;
        let (s, v) = self.path.at(self.now - self.lag);
        let previous = self.follower.v;
        self.follower = Body { s: s - self.spacing, v, a: (v - previous) / dt };
    }

    fn contact(&self, ego: &Body) -> Contact {
        let e = car_box(0.0, ego.s, false);
        let mut contact = Contact { gap_m: f64::INFINITY, ttc_s: None, collision: false };
        for car in [&self.other, &self.follower] {
            let o = car_box(car.s, 0.0, true);
            let ttc = crossing_ttc(
                -HALF_ZONE - ego.s,
                HALF_ZONE - ego.s,
                ego.v,
                -HALF_ZONE - car.s,
                HALF_ZONE - car.s,
                car.v,
            );
            contact.gap_m = contact.gap_m.min(e.gap(&o));
            contact.ttc_s = match (contact.ttc_s, ttc) {
                (Some(a), Some(b)) => Some(a.min(b)),
                (a, b) => a.or(b),
            };
            contact.collision |= e.overlaps(&o);
        }
        contact
    }

    fn observe(&mut self, ego: &Body) -> Scene {
        let observed = |b: &Body| Sample { position_m: -HALF_ZONE - b.s, velocity_mps: b.v };
        let (now, follower_now) = (observed(&self.other), observed(&self.follower));
        let tracks = [self.history.track(now), self.follower_history.track(follower_now)];
        Scene::new(ScenarioKind::YieldStandoff, &[-HALF_ZONE - ego.s], &tracks).expect("the intersection's layout")
    }

    fn revealed(&self) -> bool {
        self.revealed
    }

    fn true_positions(&self, _ego: &Body) -> Vec<f64> {
        vec![-HALF_ZONE - self.other.s]
    }

    fn turns_taken(&self) -> u32 {
        self.turns_taken
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
        [&self.other, &self.follower].iter().any(|car| {
            let o = -HALF_ZONE - car.s;
            let inside = o <= 0.0 && o > -2.0 * HALF_ZONE;
            let due = o > 0.0 && car.v > 0.1 && o / car.v < ROW_MARGIN_S;
            inside || due
        })
    }

    fn plan(&self, ego: &Body) -> Vec<PlanPoint> {
        vec![
            PlanPoint { x: 0.0, y: ego.s, v: ego.v },
            PlanPoint { x: self.other.s, y: 0.0, v: self.other.v },
            PlanPoint { x: self.follower.s, y: 0.0, v: self.follower.v },
        ]
    }
}
