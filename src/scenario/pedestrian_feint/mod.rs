//! `pedestrian_feint`: an unmarked crosswalk (a signalling game). The
//! pedestrian is a `crosser` (steps in and crosses: the ego must give way) or
//! a `feinter` (stops at the kerb to let the car pass: the ego should go). A
//! feinter waits for a car that comes on, and takes its turn when the car
//! leaves it a gap; it then crosses at a group's walking pace with the two
//! companions who stand beside it at the kerb, and a car that hangs back
//! waits for the whole of that: the crossing is clear once every centre is
//! off the road.
//!
//! Every walker moves as people do: it slows to a stop over 0.6 s or more
//! (`pedestrian.stop_decel_mps2`), so a reading shows it slowing; a
//! companion sets out within a second of the pedestrian it follows and
//! walks beside it; and the companions, who are the same in both worlds,
//! stand at the kerb before any evidence can come (a careful driver has no
//! reason to wait for them once the pedestrian's intent shows).
//!
//! Until the reveal both dispositions move identically: same start, same
//! walking speed (tiers 1 and 3), the same wait at the kerb (tier 2). Every
//! reaction is a function of the ego's kinematic state only (`EgoApproach`).
//!
//! How a waiting pedestrian judges the car (every tier, `Judge`): as
//! people at a kerb do, by the gap in front of it now. The car leaves a
//! gap when it could still stop short of the line (comfortably, or because
//! it is already braking to stop there: `EgoApproach::can_stop`) and it is
//! crawling, braking to stop short, or due later than the pedestrian's
//! critical gap at its current motion. A feinter that has stood at the kerb
//! `look_s` takes a gap that has stayed open `patience_s` without a break;
//! hang-back earlier never counts once the car comes on, and it never steps
//! in front of a car that could no longer stop. The critical gaps (tier 1:
//! 1.8-2.2 s, tier 2: 2.3-2.6 s, tier 3: 2.5-3.0 s, drawn per seed) are
//! shorter than the accepted gaps published for crossing in front of
//! traffic that does not yield (3 s at the least in a single stream,
//! DiPietro and King, 1970; 85th percentiles of 5.3-9.4 s across a road,
//! Brewer et al., 2006): this pedestrian means to let the car pass and
//! takes a car well below the flow's pace for one giving way. With longer
//! ones a blind driver that slows early and then keeps coming wins tiers 1
//! and 2 (docs/validate.md).
//!
//! Tiers (all timings drawn per seed; on tiers 1 and 3 tied to the ego's
//! own full-throttle arrival at the crossing line, `t_race`):
//! - tier 1: the pedestrian walks toward the kerb at 1.2-1.4 m/s and reaches
//!   it `tier1.kerb_lead_s` before `t_race`; the crosser walks on, the
//!   feinter slows and stops back from the edge (the tell).
//! - tier 2 (delayed step-out): both wait at the kerb; the crosser, not
//!   watching the car, steps out late on its own time (`tier2.step_at_s`,
//!   2.0-2.3 s after the start, whatever the car does) and walks across at
//!   1.2-1.4 m/s. Nothing tells the two apart before then: the tell is that
//!   nobody stepped out (the expert reads it at 2.5 s). The feinter decides
//!   no earlier than a crosser would step out, and looks `tier2.look_s`
//!   (0.5-0.7 s) more before it takes a gap, so that a driver who slowed
//!   while unsure and picks up pace at the tell leaves it none.
//! - tier 3 (pause-then-dart): both walk toward the kerb and both stop. The
//!   feinter stops back from the edge, as on tier 1 (the tell, early); the
//!   crosser walks on to the kerb's edge (`tier3.crosser_stop_m`) and
//!   pauses there: at rest, it looks like a pedestrian waiting. It darts
//!   (2.5 m/s) the moment the ego's motion shows it will reach the line
//!   within `tier3.dart_horizon_s` (0.6-0.7 s, shorter than a car at the
//!   limit needs to stop even with no reaction time): a car that took the
//!   pause for a wait is hit. A car that leaves it a gap for
//!   `tier3.invite_s` invites it, and it walks across
//!   (`tier3.invited_speed_mps`); its long linger ends the pause otherwise.
//!   The bite is the misleading pause, not a reaction time: the tell comes
//!   2.2-2.6 s before a full-throttle arrival.
//!
//! Why each blind play loses (one that never looks at the pedestrian):
//! - racing: the crosser is in the ego's path when a full-throttle ego
//!   arrives under every geometry drawn (tier 1: its timing is tied to
//!   `t_race`; tier 2: it steps out 1.5-2.0 s before a full-throttle
//!   arrival and walks slowly; tier 3: its dart is triggered by the
//!   approach itself).
//! - slowing early and coming on late enough to let a crosser clear: a
//!   crosser (tiers 1 and 2) walks slowly enough that a car due within the
//!   feinter's critical gap once it has looked arrives while a crosser is
//!   still in its path, and a car due later leaves the feinter a gap.
//! - hanging back (a slow approach, a stop, braking to creep through): the
//!   car leaves a gap, so the feinter steps in and crosses with its group
//!   (0.9-1.1 m/s), and the car waits for all of it or hits it; on tier 3
//!   it also invites a crosser at the edge first.
//! - outwaiting both: the group's passage, after the feinter has looked,
//!   ends later than the turn budget allows; the expert, who reads the tell
//!   and times its arrival behind a crosser walking at its own pace,
//!   finishes within it with slack.
//!
//! The turn budgets (27, 27, 29) leave a driver who gives way to a crosser
//! two decisions to spare, and one a decision late, or who eased off while
//! unsure (`expert_cautious`, `expert_hedge`), time to finish; a longer one
//! lets outwaiting fit. A reader can go at the tell at once: the feinter
//! stands at the kerb at least `look_s` (2.0-2.5 s on every tier, on tier 2
//! from a crosser's step-out time) before it takes a gap, and a car that
//! picks up pace toward it leaves none.
//!
//! Frame: the ego drives along +x centred on y = 0 (lane from -1.75 to
//! 1.75); the pedestrian crosses along +y at x = 0. Its public position is
//! lateral from the near kerb: `lat = y + 1.75`.

use super::world::{Contact, EgoApproach, History, Motion, PlanPoint, World, car_box, crossing_ttc};
use super::{Common, Disposition, FieldCheck, Range, ScenarioError, Tier};
use super::{PlanAxes, RoadUser, ScenarioDef, TrackLabel};
use super::{Sample, ScenarioKind, Scene};
use crate::rng::EpisodeRng;
use crate::sim::{Aabb, Body, CAR_LENGTH, CAR_WIDTH, EGO_MAX_ACCEL, PEDESTRIAN_SIZE, travel_time};

mod params;
pub use params::*;

/// The hidden dispositions of this scenario (its definition lists them).
pub const CROSSER: Disposition = Disposition::new("crosser", false);
pub const FEINTER: Disposition = Disposition::new("feinter", true);

/// What the rest of the program knows of this scenario.
pub(crate) const DEF: ScenarioDef = ScenarioDef {
    name: "pedestrian_feint",
    scene_name: "crosswalk",
    rng_id: 2,
    dispositions: [CROSSER, FEINTER],
    plan_axes: PlanAxes {
        ego_along_y: false,
        others_along_y: true,
        zero_label: "crosswalk",
        road_users: &[
            RoadUser { role: "pedestrian", lateral: Some(KERB_FRAME) },
            RoadUser { role: "companion", lateral: Some(KERB_FRAME) },
            RoadUser { role: "companion", lateral: Some(KERB_FRAME) },
        ],
    },
    scene_doc: "`ego_to_crosswalk_m`: the ego's front bumper to the pedestrian's\ncrossing line. `pedestrian.position_m`: lateral position from the\nnear kerb (negative on the sidewalk, 0 at the kerb, 3.5 at the far\nedge of the ego lane, 7.0 at the far kerb); `velocity_mps` positive\nwhen moving into the road. `companion1` and `companion2`: the two\npedestrians walking up the sidewalk behind it, in the same frame.",
    place_fields: &["ego_to_crosswalk_m"],
    place_text: |n| format!("{} m to the crosswalk", n[0]),
    tracks_relative_to_ego: false,
    position_per_velocity: 1.0,
    forecast_tracks: 1,
    situation: "Unmarked crosswalk ahead. A pedestrian and two companions are near your kerb. Each (0.6 m across) is placed by its centre, laterally from the near kerb (your car: 1.9 m wide, 4.8 m long): negative = sidewalk, 0 = kerb, 7.0 = far kerb; a centre between 0.5 and 3.0 overlaps your path. Positive velocity = into the road. Distance to the crosswalk is from your front bumper (on it: 0 to -5.4 m). Being on it while any centre is between 0 and 7.0 is a collision.",
    track_labels: &[
        TrackLabel { now: "Pedestrian", history: "Pedestrian over the last 2 s (oldest first)", field: "pedestrian" },
        TrackLabel {
            now: "First companion",
            history: "First companion over the last 2 s (oldest first)",
            field: "companion1",
        },
        TrackLabel {
            now: "Second companion",
            history: "Second companion over the last 2 s (oldest first)",
            field: "companion2",
        },
    ],
    track_now: |position, velocity| format!("at {position} m (lateral), velocity {velocity} m/s"),
    belief_question: "the pedestrian will let you drive past the crosswalk before stepping into your path",
    forecast_subject: "the pedestrian will be, as its lateral position in metres from the near kerb as the scene measures it,",
    leaderboard_dc: None,
    builtin_file: ("scenarios/pedestrian_feint.toml", include_str!("../../../scenarios/pedestrian_feint.toml")),
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
/// A pedestrian standing this near the road (lateral from the near kerb,
/// m), its toes at the kerb's edge, is about to step in; one who waits for
/// cars stands back from the edge (`pedestrian.kerb_stop_m`). How the
/// public rules (the expert's, the forecaster's) read the scene.
pub const AT_EDGE_M: f64 = -0.35;
/// Where a pedestrian who has crossed stops, on the far sidewalk.
pub const FAR_STOP: f64 = FAR_KERB + 1.0;
/// The pedestrian's public frame (lateral from the near kerb, as the scene
/// text states it), for figures and the drill-down.
pub(crate) const KERB_FRAME: super::LateralFrame = super::LateralFrame {
    measured: "from the near kerb",
    plan_offset: KERB,
    marks: [(0.0, "near kerb"), (FAR_KERB, "far kerb")],
    in_path: (PATH_NEAR, PATH_FAR),
};
/// Pedestrians step out (and a darting crosser speeds up) this briskly
/// (m/s^2); they stop at `pedestrian.stop_decel_mps2`.
const PED_ACCEL: f64 = 6.0;
/// A car slower than this (m/s) is crawling: to a waiting pedestrian, a gap.
const CRAWL_MPS: f64 = 3.0;
/// A darting crosser reacts to a car at most this slow (m/s) too.
const DART_MIN_SPEED: f64 = 1.0;

#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    /// Walking toward the kerb (tiers 1 and 3). A tier-1 crosser walks on.
    ToKerb,
    /// Standing at the kerb since `since`.
    AtKerb { since: f64 },
    /// Crossing the road at `speed`, changing speed at most `accel`.
    Cross { speed: f64, accel: f64 },
}

/// How a waiting pedestrian judges the ego's motion: as people at a kerb
/// do, by the gap in front of it now. It takes a gap that has stayed open
/// for `confirm` without a break (`PedestrianWorld::gap_open`), and never
/// one the ego could not stop for.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Judge {
    critical_gap: f64,
    confirm: f64,
    open_for: f64,
}

impl Judge {
    fn new(critical_gap: f64, confirm: f64) -> Judge {
        Judge { critical_gap, confirm, open_for: 0.0 }
    }

    /// One step of `dt` in which the gap was (or was not) open: it counts
    /// only while it stays open.
    fn watch(&mut self, open: bool, dt: f64) {
        self.open_for = if open { self.open_for + dt } else { 0.0 };
    }

    /// Whether a feinter that has looked takes its turn now.
    fn takes_turn(&self) -> bool {
        self.open_for + 1e-9 >= self.confirm
    }
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
    /// How a waiting pedestrian judges the ego's motion.
    judge: Judge,
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
    motion: Motion,
    companions: [Companion; COMPANIONS],
    /// When the pedestrian took a turn its companions follow (one that
    /// waited back from the edge, as people waiting for cars do), if it
    /// has, and the pace it set out at: they walk beside it at that pace.
    followed_from: Option<(f64, f64)>,
    /// Whether its first turn was one they do not follow.
    not_followed: bool,
    /// When the pedestrian began to slow to its present stop, if it is
    /// slowing (for the quickest-stop figure).
    slowing_since: Option<f64>,
}

/// How many companions walk up to the kerb.
const COMPANIONS: usize = 2;

/// One step of a walker toward `target_vel`, changing speed at most
/// `accel` (trapezoidal position update).
fn step_toward(lat: &mut f64, vel: &mut f64, target_vel: f64, accel: f64, dt: f64) {
    let dv = (target_vel - *vel).clamp(-accel * dt, accel * dt);
    let v_next = *vel + dv;
    *lat += 0.5 * (*vel + v_next) * dt;
    *vel = v_next;
}

/// What one step of [`walk_to`] did.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Stride {
    /// Walked on (or picked up pace), or stood.
    Walked,
    /// Slowed toward its stop.
    Slowed,
    /// Came to rest at its stop this far (s) into the step.
    Halted(f64),
}

/// One step of a walker heading for a stop at `mark` at `pace`: it keeps
/// its pace (changing speed at most `accel`) until slowing at `decel` would
/// only just stop it at the mark, then slows at the one deceleration that
/// stops it exactly there. That deceleration is constant over the stop (so
/// the trapezoidal update is exact), never sharper than `decel`, and the
/// walker neither overshoots its mark nor stops short of it.
fn walk_to(lat: &mut f64, vel: &mut f64, mark: f64, pace: f64, accel: f64, decel: f64, dt: f64) -> Stride {
    let (left, v) = (mark - *lat, *vel);
    if v <= 1e-9 && left <= 1e-9 {
        *vel = 0.0;
        return Stride::Walked;
    }
    if v > 1e-9 && left - v * dt <= v * v / (2.0 * decel) {
        let a = if left > 1e-9 { v * v / (2.0 * left) } else { f64::INFINITY };
        let v_next = v - a * dt;
        if v_next <= 1e-9 {
            *lat = mark;
            *vel = 0.0;
            return Stride::Halted(if a.is_finite() { v / a } else { 0.0 });
        }
        *lat += 0.5 * (v + v_next) * dt;
        *vel = v_next;
        return Stride::Slowed;
    }
    step_toward(lat, vel, pace, accel, dt);
    Stride::Walked
}

/// Where a walker heading for the far sidewalk at `pace` slows to its
/// stop: no more sharply than `decel`, and only once past the far kerb.
fn far_side_decel(pace: f64, decel: f64) -> f64 {
    decel.max(pace * pace / (2.0 * (FAR_STOP - FAR_KERB)))
}

/// Record the end of a walker's stop in `motion`: it began to slow at
/// `since` and came to rest at `at` (s).
fn record_stop(motion: &mut Motion, since: Option<f64>, at: f64) {
    let took = at - since.unwrap_or(at);
    motion.quickest_stop_s = Some(motion.quickest_stop_s.map_or(took, |q| q.min(took)));
}

/// A companion: it walks up to the kerb and stops there, and crosses only
/// with the pedestrian it saw take its turn, beside it.
#[derive(Debug, Clone, Copy)]
struct Companion {
    lat: f64,
    vel: f64,
    walk: f64,
    /// When it comes to rest at the kerb (s), and how sharply it slows.
    arrive: f64,
    decel: f64,
    delay: f64,
    stepped_at: Option<f64>,
    at_kerb_since: Option<f64>,
    /// Whether, due to set out, it let a car that could not stop pass.
    left_behind: bool,
    slowing_since: Option<f64>,
    history: History,
}

impl Companion {
    /// Its walk up the sidewalk, in closed form: at its pace until it
    /// slows at `decel` to rest at the kerb stop `kerb` at `arrive`; the
    /// same in both worlds, before the start too (its first history).
    fn approach_at(&self, kerb: f64, t: f64) -> Sample {
        let (w, a) = (self.walk, self.decel);
        let to_rest = self.arrive - t;
        if to_rest <= 0.0 {
            Sample { position_m: kerb, velocity_mps: 0.0 }
        } else if to_rest <= w / a {
            Sample { position_m: kerb - 0.5 * a * to_rest * to_rest, velocity_mps: a * to_rest }
        } else {
            Sample { position_m: kerb - w * w / (2.0 * a) - w * (to_rest - w / a), velocity_mps: w }
        }
    }
}

impl PedestrianWorld {
    pub fn new(params: &PedestrianParams, tier: Tier, disposition: Disposition, geometry: &mut EpisodeRng) -> Self {
        let b = &params.pedestrian;
        // Every draw is made under both dispositions, in the same order.
        let d_ego = params.ego.start_distance_m.sample(geometry);
        let v_ego = params.ego.start_speed_mps.sample(geometry);
        let walk = b.walk_speed_mps.sample(geometry);
        let (give_up_speed, look) = match tier {
            Tier::T1 => (params.tier1.give_up_speed_mps, params.tier1.look_s),
            Tier::T2 => (params.tier2.give_up_speed_mps, params.tier2.look_s),
            Tier::T3 => (params.tier3.give_up_speed_mps, params.tier3.look_s),
        };
        let (give_up_speed, look) = (give_up_speed.sample(geometry), look.sample(geometry));
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
                params.tier2.step_at_s.sample(geometry),
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
        // Drawn last, and only where a waiting pedestrian judges gaps.
        let critical_gap = match tier {
            Tier::T1 => params.tier1.critical_gap_s,
            Tier::T2 => params.tier2.critical_gap_s,
            Tier::T3 => params.tier3.critical_gap_s,
        };
        let judge = Judge::new(critical_gap.sample(geometry), patience);
        let k = &params.companions;
        let mut arrive = k.arrive_s.sample(geometry);
        let companions = [(); COMPANIONS].map(|()| {
            let (walk, delay) = (k.walk_speed_mps.sample(geometry), k.follow_delay_s.sample(geometry));
            let mut c = Companion {
                lat: 0.0,
                vel: 0.0,
                walk,
                arrive,
                decel: b.stop_decel_mps2,
                delay,
                stepped_at: None,
                at_kerb_since: None,
                left_behind: false,
                slowing_since: None,
                history: History::steady(Sample { position_m: 0.0, velocity_mps: 0.0 }, 0.0),
            };
            arrive += k.spacing_s.sample(geometry);
            let now = c.approach_at(b.kerb_stop_m, 0.0);
            (c.lat, c.vel) = (now.position_m, now.velocity_mps);
            c.history = History::from_past(|t| c.approach_at(b.kerb_stop_m, t));
            c
        });
        let t_race = travel_time(d_ego, v_ego, params.episode.speed_limit_mps, EGO_MAX_ACCEL);
        // Tier 2's crosser keeps its own time; elsewhere the pedestrian
        // reaches the kerb `lead` before the ego's full-throttle arrival.
        let decide_at = if tier == Tier::T2 { lead } else { (t_race - lead).max(0.5) };
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
            judge,
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
            motion: Motion::default(),
            companions,
            followed_from: None,
            not_followed: false,
            slowing_since: None,
        }
    }

    fn ped_box(&self) -> Aabb {
        Aabb::centered(0.0, self.lat - KERB, PEDESTRIAN_SIZE, PEDESTRIAN_SIZE)
    }

    /// Whether the ego leaves a waiting pedestrian a gap it would take now:
    /// it could still stop short of the line (`EgoApproach::can_stop`), and
    /// it is crawling, braking to stop short (never arriving at its current
    /// motion), or due later than the pedestrian's critical gap.
    fn gap_open(ego: &Body, v_max: f64, critical_gap: f64) -> bool {
        let app = EgoApproach::new(-X_HALF - ego.s, ego);
        app.can_stop() && (ego.v < CRAWL_MPS || app.eta(v_max) > critical_gap)
    }

    /// The companions' step: each walks up to the kerb and stops; it sets
    /// out `delay` after the pedestrian took its turn and walks beside it at
    /// its pace, if it was at the kerb when the pedestrian did (or within
    /// `joined_within_s`), and only while the car can still stop. Once
    /// across it stops on the far sidewalk.
    fn advance_companions(&mut self, ego: &Body, t: f64, dt: f64) {
        let kerb = self.params.pedestrian.kerb_stop_m;
        if self.followed_from.is_none() && self.turns_taken > 0 && !self.not_followed {
            // Followed only if it stood back from the edge, waiting for cars
            // as they were: a crosser at the edge is on its own time. (Where
            // each stands, nearer one stop than the other.)
            let back_from_edge = 0.5 * (kerb + self.params.tier3.crosser_stop_m);
            match self.phase {
                Phase::Cross { speed, .. } if self.lat < back_from_edge => self.followed_from = Some((t, speed)),
                _ => self.not_followed = true,
            }
        }
        let can_stop = EgoApproach::new(-X_HALF - ego.s, ego).can_stop();
        let joined_within = self.params.companions.joined_within_s;
        let set_out_accel = self.params.pedestrian.give_up_accel_mps2;
        let followed_from = self.followed_from;
        for c in self.companions.iter_mut() {
            if let Some((_, pace)) = followed_from.filter(|_| c.stepped_at.is_some()) {
                let decel = far_side_decel(pace, c.decel);
                match walk_to(&mut c.lat, &mut c.vel, FAR_STOP, pace, set_out_accel, decel, dt) {
                    Stride::Slowed => c.slowing_since = c.slowing_since.or(Some(t)),
                    Stride::Halted(into) => record_stop(&mut self.motion, c.slowing_since.take(), t + into),
                    Stride::Walked => {}
                }
                continue;
            }
            let at_kerb = t + 1e-9 >= c.arrive;
            if at_kerb && c.at_kerb_since.is_none() {
                c.at_kerb_since = Some(t);
                // It slowed from its walk to rest over `walk / decel`.
                record_stop(&mut self.motion, Some(c.arrive - c.walk / c.decel), c.arrive);
            }
            let (saw, due) = match (c.at_kerb_since, followed_from) {
                (Some(a), Some((f, _))) => (a <= f + joined_within, t + 1e-9 >= f + c.delay),
                _ => (false, false),
            };
            if at_kerb && saw && due && !c.left_behind && !can_stop {
                // The car it would step in front of can no longer stop: it
                // lets it pass, and the group crosses without it.
                c.left_behind = true;
            }
            if let (true, Some((f, pace))) = (at_kerb && saw && due && !c.left_behind, followed_from) {
                let lag = t - f;
                self.motion.widest_follow_s = Some(self.motion.widest_follow_s.map_or(lag, |w| w.max(lag)));
                let slowest = self.motion.slowest_crossing_mps.map_or(pace, |v| v.min(pace));
                self.motion.slowest_crossing_mps = Some(slowest);
                c.stepped_at = Some(t);
                step_toward(&mut c.lat, &mut c.vel, pace, set_out_accel, dt);
            } else {
                let next = c.approach_at(kerb, t + dt);
                (c.lat, c.vel) = (next.position_m, next.velocity_mps);
            }
        }
    }

    /// Whether the ego's motion shows it will reach the line within the
    /// dart horizon at its current speed and acceleration.
    fn ego_due(&self, ego: &Body) -> bool {
        let app = EgoApproach::new(-X_HALF - ego.s, ego);
        app.to_conflict > 0.0
            && ego.v >= DART_MIN_SPEED
            && app.eta(self.params.episode.speed_limit_mps) <= self.dart_horizon
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
        let crosser = self.disposition == CROSSER;
        // Tier 3: the crosser stops a step further on, at the kerb's edge.
        let kerb_stop = if self.tier == Tier::T3 && crosser {
            self.params.tier3.crosser_stop_m
        } else {
            self.params.pedestrian.kerb_stop_m
        };
        let feinter_stop = self.params.pedestrian.kerb_stop_m;
        let stop_decel = self.params.pedestrian.stop_decel_mps2;
        // The pedestrian watches the car from the start: whether it leaves a
        // gap now.
        let hanging_back = Self::gap_open(ego, self.params.episode.speed_limit_mps, self.judge.critical_gap);
        self.judge.watch(hanging_back, dt);
        // It moves this step as its phase at the start of the step says (one
        // that decides to cross sets out on the next).
        let moving = self.phase;
        match self.phase {
            Phase::ToKerb => {
                // A pedestrian who stops at the kerb starts to slow here: the
                // step after which stopping at `stop_decel` would overrun it.
                let feinter_left = feinter_stop - self.lat;
                if feinter_left - self.walk * dt <= self.walk * self.walk / (2.0 * stop_decel) && self.tier != Tier::T2
                {
                    self.revealed = true;
                }
                if self.tier == Tier::T1 && crosser && self.lat > kerb_stop {
                    self.phase = Phase::Cross { speed: self.walk, accel: PED_ACCEL };
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
                                // Invited, it walks across; darting, it runs.
                                let speed = if triggered || !invited {
                                    self.step_speed
                                } else {
                                    self.params.tier3.invited_speed_mps
                                };
                                self.phase = Phase::Cross { speed, accel: PED_ACCEL };
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
                    if deciding && self.judge.takes_turn() {
                        self.turns_taken += 1;
                        self.revealed = true;
                        self.phase = Phase::Cross {
                            speed: self.give_up_speed,
                            accel: self.params.pedestrian.give_up_accel_mps2,
                        };
                    }
                }
            }
            Phase::Cross { .. } => {}
        }
        if let Phase::Cross { speed, .. } = self.phase {
            let slowest = self.motion.slowest_crossing_mps.map_or(speed, |s| s.min(speed));
            self.motion.slowest_crossing_mps = Some(slowest);
        }
        let (lat, vel) = (&mut self.lat, &mut self.vel);
        let stride = match moving {
            // A tier-1 crosser walks on across.
            Phase::ToKerb if self.tier == Tier::T1 && crosser => {
                walk_to(lat, vel, FAR_STOP, self.walk, PED_ACCEL, far_side_decel(self.walk, stop_decel), dt)
            }
            Phase::ToKerb => walk_to(lat, vel, kerb_stop, self.walk, PED_ACCEL, stop_decel, dt),
            Phase::AtKerb { .. } => Stride::Walked,
            Phase::Cross { speed, accel } => {
                walk_to(lat, vel, FAR_STOP, speed, accel, far_side_decel(speed, stop_decel), dt)
            }
        };
        match stride {
            Stride::Slowed => self.slowing_since = self.slowing_since.or(Some(t)),
            Stride::Halted(into) => {
                record_stop(&mut self.motion, self.slowing_since.take(), t + into);
                if self.phase == Phase::ToKerb {
                    self.phase = Phase::AtKerb { since: t + into };
                }
            }
            Stride::Walked => {}
        }
        self.advance_companions(ego, t, dt);
    }

    fn motion(&self) -> Motion {
        self.motion
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
        let mut contact = Contact { gap_m: e.gap(&p), ttc_s: ttc, collision: e.overlaps(&p) };
        for c in &self.companions {
            let b = Aabb::centered(0.0, c.lat - KERB, PEDESTRIAN_SIZE, PEDESTRIAN_SIZE);
            contact.gap_m = contact.gap_m.min(e.gap(&b));
            contact.collision |= e.overlaps(&b);
        }
        // The car gives way until everyone on the crossing is off the road:
        // driving over it with anyone between the kerbs is a collision.
        contact.collision |= self.cuts_off(ego);
        contact
    }

    fn observe(&mut self, ego: &Body) -> Scene {
        let now = Sample { position_m: self.lat, velocity_mps: self.vel };
        let [a, b] =
            self.companions.each_mut().map(|c| c.history.track(Sample { position_m: c.lat, velocity_mps: c.vel }));
        Scene::new(ScenarioKind::PedestrianFeint, &[-X_HALF - ego.s], &[self.history.track(now), a, b])
            .expect("the crosswalk's layout")
    }

    fn revealed(&self) -> bool {
        self.revealed
    }

    fn true_positions(&self, _ego: &Body) -> Vec<f64> {
        vec![self.lat]
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
        // Driving over the crossing line while anyone is on the road.
        let on_road = |lat: f64| lat > 0.0 && lat < FAR_KERB;
        ego.s.abs() < X_HALF && (on_road(self.lat) || self.companions.iter().any(|c| on_road(c.lat)))
    }

    fn plan(&self, ego: &Body) -> Vec<PlanPoint> {
        let mut plan =
            vec![PlanPoint { x: ego.s, y: 0.0, v: ego.v }, PlanPoint { x: 0.0, y: self.lat - KERB, v: self.vel }];
        plan.extend(self.companions.iter().map(|c| PlanPoint { x: 0.0, y: c.lat - KERB, v: c.vel }));
        plan
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Stream;

    fn world(tier: Tier) -> PedestrianWorld {
        let text = DEF.builtin_file.1;
        let params: PedestrianParams = toml::from_str(&text[text.find("[episode]").unwrap_or(0)..]).unwrap();
        PedestrianWorld::new(&params, tier, FEINTER, &mut EpisodeRng::new(&[0], Stream::Geometry))
    }

    /// The scene's rule for when the crosswalk is clear is the collision
    /// test's, to the centimetre: a car whose front is between 0 and -5.4 m
    /// past the line is on the crossing, and being on it while any centre
    /// (the pedestrian's or a companion's) is between 0 and 7.0 m is a
    /// collision; a centre just off the road on either side is not.
    #[test]
    fn the_scene_states_the_collision_tests_rule_for_a_clear_crossing() {
        assert!(DEF.situation.contains("(on it: 0 to -5.4 m)"), "{}", DEF.situation);
        assert!(DEF.situation.contains("while any centre is between 0 and 7.0 is a collision"));
        assert!((FAR_KERB - 7.0).abs() < 1e-12 && (2.0 * X_HALF - 5.4).abs() < 1e-9);
        let on = |d: f64| Body::new(-X_HALF - d, 0.0);
        for who in 0..3 {
            for (lat, collides) in [(-0.01, false), (0.01, true), (3.5, true), (6.99, true), (7.01, false)] {
                let mut w = world(Tier::T1);
                // Everyone else well off the road, the car stopped on the crossing.
                w.lat = -2.0;
                for c in w.companions.iter_mut() {
                    c.lat = -2.0;
                }
                if who == 0 {
                    w.lat = lat
                } else {
                    w.companions[who - 1].lat = lat
                }
                for d in [-0.01, -2.7, -5.39] {
                    assert_eq!(w.cuts_off(&on(d)), collides, "road user {who} at {lat}, car at {d}");
                }
                for d in [0.01, -5.41] {
                    assert!(!w.cuts_off(&on(d)), "road user {who} at {lat}, car at {d}: off the crossing");
                }
            }
        }
    }
}
