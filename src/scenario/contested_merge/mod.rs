//! `contested_merge`: an on-ramp merge (a coordination game). The lane car
//! alongside the ego `makes_room` (drops back to open a gap ahead of itself)
//! or is `committed` (holds the lane; in tier 3 it first opens the gap like a
//! car making room and closes it when the ego's motion shows it takes the
//! bait). A second car follows the lane car (a platoon) and closes the door
//! on a cut-in between them, so merging behind is right only once both have
//! passed, which is right only when the lane car goes first.
//!
//! Mechanisms (every reaction is a function of the ego's kinematic state):
//! - a car holding the lane keeps an ego that is alongside on the ramp boxed
//!   in: while the ego drives faster than its cruise it closes to level with
//!   it (up to `deny_extra_mps` faster), so a racing ego arrives alongside it
//!   at the merge point, and only an ego that drops below its cruise gets
//!   behind it;
//! - the follower closes the door: while an ego on the ramp is beside the
//!   gap between the lane car and itself, it draws up to `door_gap_m`
//!   behind the lane car (plus a short headway, shorter than a car at every
//!   speed), matching the lane car's acceleration, so that the only places
//!   to merge are ahead of the lane car and behind the follower;
//! - a car making room measures the ego's pace against a *shadow*: where a
//!   committed car would be, given the same ego. The ego keeps pace while it
//!   does not brake and is due at the merge point before the shadow would
//!   have cleared it. Then the car drops back to `open_gap_m` behind the
//!   ego's rear, visibly slower than the ego. An ego due later than that (it
//!   could merge behind a committed car) hangs back: the car covers it (its
//!   front overlapping the ego's rear) and, once the ego has hung back for
//!   its patience in all (drawn per seed; keeping pace in between does not
//!   reset it) or braked hard close to the merge point, takes its turn, at
//!   a moment the ego hangs back (never while it keeps pace again) and
//!   could still stop firmly short of the merge point: it
//!   passes only a little faster than the ego (braking with an ego that
//!   brakes, and, once wholly ahead of it, holding its pace however the
//!   ego accelerates) until its follower, too, has cleared the merge
//!   point, and pulls away gently, the follower closing the door behind
//!   it;
//! - tier 3 (merge bluff): both dispositions first ease off (more gently
//!   than on tier 1) to `floor_fraction` of the cruise; only a car making
//!   room slows further. Once its easing off is on show, the bluffer closes
//!   the gap hard as soon as an ego ahead of it, not braking, is due at the
//!   merge point within `commit_horizon_s`; an ego that waits for a car
//!   slower than the floor (or falls in behind) is safe. The bait is short
//!   (`BAIT_EASE_MPS`), so the close begins early enough for a reader who
//!   sees it a decision late to drop back behind both lane cars;
//! - who goes first is settled by the order of entry, not by the ego's
//!   point of no return (`order_settles_choice`): side by side, an ego that
//!   can no longer stop short of the merge point can still fall in behind;
//! - the turn budget is one number; lane traffic brakes at most
//!   `idm.max_brake` for a car cutting in.
//!
//! Why each blind play loses:
//! - racing: a committed car is level with the ego at the merge point under
//!   every geometry drawn (tier 3: the bluffer, which stayed within reach
//!   while it eased off, closes back to level, from its floor too);
//! - slipping in behind the lane car (a little slower than it): the
//!   follower has closed the door, so under either disposition only the
//!   gaps ahead of the lane car and behind the follower are open;
//! - arriving late (after a committed car would have cleared): to a car
//!   making room that is hanging back, so it covers the ego and then passes
//!   it slowly with its follower close behind: the ego meets it alongside;
//! - braking late: an ego braking harder than `late_brake_mps2` within
//!   `late_brake_within_m` of the merge point hangs back at once;
//! - outwaiting: a car making room that covered a slow ego passes it only a
//!   little faster than it goes and pulls away gently, so waiting for both
//!   lane cars costs more than the turn budget leaves; dragging it up to
//!   speed first (beside it, so that it keeps level) and then braking hard
//!   does not help, since it brakes with the ego until its follower has
//!   cleared the merge point too, and neither does
//!   stopping and then accelerating behind it to pull it through (PPO's
//!   plays, see docs/rl.md), since ahead of the ego it holds its pace;
//! - surging and lulling (keeping pace in bursts to arrive just behind a
//!   committed car while holding a car making room): the patience is
//!   cumulative, so the lulls add up and the car takes its turn.
//!
//! How long a car that makes room waits, and why: it holds its gap open
//! while the ego keeps pace, and takes its turn only once the ego has hung
//! back 0.6-1.5 s in all (`lane.patience_s`, cumulative), longer than one
//! decision: a driver who sees the gap open a decision late, or hesitates a
//! turn before taking it, still finds it open. Shorter (down to 0.3 s, as
//! before) cost a reader one decision late a twentieth of the noisy tier's
//! episodes where the car had made room. It counts that hang-back only from
//! 1.0-1.5 s after its easing off was on show (`lane.look_s`, a driver's
//! perception-reaction time): it judges what the ego does once it could
//! have seen the gap and answered, so a driver who eased off while nothing
//! was known, read the gap a decision late and went softly at first still
//! finds it open (counted from the start, that hedge used the patience up:
//! 0.58 of tier 1). An ego braking harder than that driver
//! (`GIVES_WAY_BRAKE_MPS2`) gives way plainly and counts at once. An ego
//! due at the merge point up to `lane.pace_tolerance_s` (0.4 s) after a
//! committed car would have cleared it still keeps pace (it would meet that
//! car's follower), so a reader who slowed while unsure and then goes is
//! opened for rather than covered.
//!
//! The best blind plans found succeed under one disposition only: about
//! half the episodes, at the default search budget and at 2,000,000
//! episodes alike (see docs/validate.md).
//!
//! The cue follower goes while the lane car brakes, or has eased off and is
//! behind the ego's centre: on tier 3 the bluffer's easing off is that cue.
//!
//! Frame: the through lane runs along +x at y = 0; the ramp is parallel at
//! y = -LANE_OFFSET and tapers into the lane over `road.taper_length_m`
//! starting at x = 0. The ego's lateral position is derived from its
//! progress, as a merge assist would steer it.

use super::world::{Contact, EgoApproach, History, Motion, Patience, PlanPoint, ROW_MARGIN_S, World, car_box};
use super::{Common, Disposition, FieldCheck, Range, ScenarioError, Tier};
use super::{PlanAxes, RoadUser, ScenarioDef, TrackLabel};
use super::{Sample, ScenarioKind, Scene};
use crate::noise::NoisyReading;
use crate::rng::EpisodeRng;
use crate::sim::{Body, CAR_LENGTH, CAR_WIDTH, Idm, track_speed};

mod params;
pub use params::*;

/// The hidden dispositions of this scenario (its definition lists them).
pub const COMMITTED: Disposition = Disposition::new("committed", false);
pub const MAKES_ROOM: Disposition = Disposition::new("makes_room", true);

/// What the rest of the program knows of this scenario.
pub(crate) const DEF: ScenarioDef = ScenarioDef {
    name: "contested_merge",
    scene_name: "on-ramp",
    rng_id: 3,
    dispositions: [COMMITTED, MAKES_ROOM],
    plan_axes: PlanAxes {
        ego_along_y: false,
        others_along_y: false,
        zero_label: "taper start",
        road_users: &[RoadUser { role: "lane car", lateral: None }, RoadUser { role: "follower", lateral: None }],
    },
    scene_doc: "`ego_to_merge_m`: the ego's centre to the point where its body starts\nto overlap the main lane; `ramp_left_m` to the end of the ramp.\n`lane_car.position_m` / `follower.position_m`: their centre relative\nto the ego's centre along the road (positive ahead of the ego).",
    place_fields: &["ego_to_merge_m", "ramp_left_m"],
    place_text: |n| format!("{} m to the merge point, {} m of ramp left", n[0], n[1]),
    tracks_relative_to_ego: true,
    position_per_velocity: 1.0,
    forecast_tracks: 2,
    situation: "On-ramp merging into a single through lane; the ramp ends, so you must merge before it runs out. A lane car is alongside and another car follows it. Cars (yours too) are 4.8 m long. Positions of lane cars are centre to centre along the road relative to you (positive = ahead of you; beyond +/-4.8 m a car is wholly ahead or behind). Your body starts to overlap the lane at the merge point. The through lane has its own speed limit: your line shows it until you are in the lane, where it becomes yours.",
    track_labels: &[
        TrackLabel { now: "Lane car", history: "Lane car over the last 2 s (oldest first)", field: "lane_car" },
        TrackLabel {
            now: "Car behind it",
            history: "Car behind it over the last 2 s (oldest first)",
            field: "follower",
        },
    ],
    track_now: |position, velocity| format!("at {position} m (relative to you), speed {velocity} m/s"),
    belief_question: "the lane car will let you merge into the lane ahead of it",
    forecast_subject: "the lane car and the car behind it will be, each as its position in metres along the road from where you are now (positive = ahead of you),",
    leaderboard_dc: None,
    builtin_file: ("scenarios/contested_merge.toml", include_str!("../../../scenarios/contested_merge.toml")),
    load: super::load::<MergeParams>,
    tier_mechanics: ["observation noise", "merge bluff"],
};

const LANE_OFFSET: f64 = 3.5;
/// A car covering an ego that hangs back overlaps its rear by this (m).
const COVER_OVERLAP_M: f64 = 1.5;
/// An ego braking harder than this (m/s^2) does not keep pace.
const PACE_MIN_ACCEL: f64 = -1.0;
/// A car covering an ego that hangs back brakes up to this (m/s^2).
const COVER_DECEL: f64 = 4.0;
/// A car making room drops back at least this much slower than the ego (m/s).
const DROP_BACK_MPS: f64 = 4.0;
/// ... and, once behind it, keeps at least this much slower (m/s).
const HOLD_BACK_MPS: f64 = 0.7;
/// A car holding the lane eases back to its cruise this gently (m/s^2).
const EASE_BACK_MPS2: f64 = 1.0;
/// A car holding the lane closes on level with an ego alongside at this
/// rate (1/s): it keeps the ego boxed in while the ego drives faster.
const DENY_LEVEL_GAIN: f64 = 0.5;
/// A car above its desired speed with nothing to brake for slows this
/// gently (m/s^2): lifting off the accelerator.
const LIFT_OFF_MPS2: f64 = 0.5;
/// A follower closing the door on an ego keeps this time headway (s) ...
const DOOR_HEADWAY_S: f64 = 0.1;
/// ... tracking its gap and the lane car's speed with these gains (1/s^2,
/// 1/s: critically damped).
const DOOR_GAP_GAIN: f64 = 1.0;
const DOOR_SPEED_GAIN: f64 = 2.0;
/// A tier-3 bluffer has shown its bait once it has eased off this much
/// below its cruise (m/s): a third of a second of easing off, so that its
/// close (the evidence) starts early in the approach. With a bait of
/// 1.5 m/s the close came half a second later, and a reader one decision
/// late could no longer drop back behind the platoon in time (0.84).
const BAIT_EASE_MPS: f64 = 1.0;
/// A car physically in the lane ahead of the lane car caps its
/// acceleration once it would hold it below this share of its comfortable
/// acceleration (the IDM's `accel`).
const LEADER_RESPECT_SHARE: f64 = 0.5;
/// A car making room covers an ego that hangs back while it is at most
/// this much faster than the ego (m/s): level with it, at its speed.
const COVERING_MARGIN_MPS: f64 = 1.5;
/// An ego braking this hard or harder (m/s^2) gives way plainly, harder than
/// the 1.0-1.6 m/s^2 of a driver who slows while nothing is known: a car
/// making room counts it as hanging back at once, before its look is over.
/// Without that, a blind plan that stops hard for a second (the committed
/// pair passes) and then races past the car that made room for it won 0.83
/// of tier 1 (2,000,000 episodes, search seed 0).
const GIVES_WAY_BRAKE_MPS2: f64 = 2.0;
/// A tier-3 car making room shows itself by slowing this far below the
/// bluffer's floor (m/s).
const SHOWN_BELOW_FLOOR_MPS: f64 = 0.5;
/// The ego counts as ahead of the lane car (taking a bluffer's bait)
/// while the lane car's centre is less than this far ahead of the ego's (m).
const EGO_AHEAD_M: f64 = 1.0;
/// A bluffer closing the gap brakes at most this hard (m/s^2).
const CLOSE_BRAKE_MPS2: f64 = 3.0;

#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    /// Holding the lane at cruise speed, keeping an ego alongside out
    /// (committed, tiers 1-2; a tier-3 bluffer once it closed the gap).
    Hold,
    /// Making room: dropping back behind an ego that keeps pace, covering
    /// one that hangs back (a car making room; a tier-3 bluffer until the
    /// ego takes the bait).
    Open { floor_since: Option<f64> },
    /// Closing the gap after a bluff.
    Close,
    /// Taking its turn: drawing level with the ego and passing it slowly,
    /// then back to cruise.
    TakeTurn,
}

pub struct MergeWorld {
    tier: Tier,
    disposition: Disposition,
    params: MergeParams,
    merge_point: f64,
    ego_start: Body,
    lane_car: Body,
    follower: Body,
    cruise: f64,
    phase: Phase,
    /// Where a committed car (one holding the lane) would be, given the
    /// same ego: a car making room measures the ego's pace against it.
    shadow: Body,
    patience: Patience,
    /// How long after its easing off is on show a car making room starts
    /// counting the ego's hang-back (s), and when it was first on show.
    look_s: f64,
    shown_at: Option<f64>,
    /// Times a car making room took its turn in front of the ego.
    turns_taken: u32,
    revealed: bool,
    noise: Option<EpisodeRng>,
    /// The noisy readings of the last observation (tier 2 only).
    readings: Vec<NoisyReading>,
    lane_history: History,
    follower_history: History,
    motion: Motion,
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
        let patience = params.lane.patience_s.sample(geometry);
        let look_s = params.lane.look_s.sample(geometry);
        let ego_start = Body::new(merge_point - d_ego, v_ego);
        let x_lane = ego_start.s + offset;
        let phase = match (tier, disposition) {
            (Tier::T1 | Tier::T2, COMMITTED) => Phase::Hold,
            _ => Phase::Open { floor_since: None },
        };
        // The steady history before t = 0 is observed through the same noise
        // as every later turn (tier 2 only).
        let rel_rate = cruise - v_ego;
        let mut noise = (tier == Tier::T2).then_some(noise);
        let lane_now = Sample { position_m: x_lane - ego_start.s, velocity_mps: cruise };
        let follower_now = Sample { position_m: x_lane - follower_gap - ego_start.s, velocity_mps: cruise };
        // Every sample of it carries its own reading noise: a noisy tier is
        // noisy from its first reading, under both dispositions alike.
        let lane_history =
            History::steady_observed(lane_now, rel_rate, |s| observe_noisy(&mut noise, &params.tier2, s));
        let follower_history =
            History::steady_observed(follower_now, rel_rate, |s| observe_noisy(&mut noise, &params.tier2, s));
        MergeWorld {
            tier,
            disposition,
            params: params.clone(),
            merge_point,
            ego_start,
            lane_car: Body::new(x_lane, cruise),
            follower: Body::new(x_lane - follower_gap, cruise),
            cruise,
            phase,
            shadow: Body::new(x_lane, cruise),
            patience: Patience::new(patience),
            look_s,
            shown_at: None,
            turns_taken: 0,
            revealed: tier != Tier::T3,
            noise,
            readings: Vec::new(),
            lane_history,
            follower_history,
            motion: Motion::default(),
        }
    }

    fn ego_y(&self, x: f64) -> f64 {
        let taper = self.params.road.taper_length_m;
        let f = (x / taper).clamp(0.0, 1.0);
        -LANE_OFFSET * (1.0 - f)
    }

    /// The fastest a lane car drives: up to `deny_extra_mps` above its
    /// cruise to keep an ego out, never above the lane's limit.
    fn top_speed(&self) -> f64 {
        (self.cruise + self.params.lane.deny_extra_mps).min(self.params.lane.speed_limit_mps)
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

    /// Whether the ego keeps the pace of one that takes the gap: not
    /// braking, and due at the merge point before a committed car (the
    /// shadow) would have cleared it, plus the tolerance. An ego due later
    /// than that is hanging back, however fast it goes: it could merge
    /// behind a committed car.
    fn ego_keeps_pace(&self, ego: &Body, t: f64) -> bool {
        if self.ego_in_lane(ego) {
            return true;
        }
        let approach = EgoApproach::new(self.merge_point - ego.s, ego);
        let v_max = self.params.episode.speed_limit_mps;
        let clear_at = self.merge_point + CAR_LENGTH;
        let shadow_clear = t + (clear_at - self.shadow.s).max(0.0) / self.shadow.v.max(0.1);
        ego.a > PACE_MIN_ACCEL && t + approach.eta(v_max) <= shadow_clear + self.params.lane.pace_tolerance_s
    }

    /// The follower: a platoon member at a short headway, which
    /// closes the door while an ego on the ramp is beside the gap between
    /// them (it could cut in): it then keeps `door_gap_m` (plus a short
    /// headway) behind the lane car, matching its acceleration as well as
    /// its speed, so that the gap stays shorter than a car however the lane
    /// car moves (a car taking its turn may pull away from a slow ego hard).
    /// Never closer than a standstill gap to whatever is ahead.
    fn follower_accel(&self, a_lane: f64, ego: &Body) -> f64 {
        let p = &self.params.lane;
        let (lane, follower) = (self.lane_car, self.follower);
        let leader = self.leader(&follower, Some(&lane), ego);
        let door_open = !self.ego_in_lane(ego) && ego.s > follower.s - CAR_LENGTH && ego.s < lane.s + CAR_LENGTH;
        if !door_open {
            let idm = Idm {
                accel: p.deny_accel_mps2,
                headway: p.follower_headway_s,
                min_gap: p.follower_min_gap_m,
                ..self.params.idm
            };
            // Closing on nothing (the car ahead no slower, and not nearer
            // than its minimum gap), a driver above its cruise or nearer
            // than its headway lifts off the accelerator rather than brakes
            // (IDM alone would brake it at up to `max_brake`).
            let a = idm.accel(follower.v, self.cruise, leader);
            let closing_on_nothing = leader.is_none_or(|(gap, closing)| closing <= 0.0 && gap > idm.min_gap);
            return if closing_on_nothing { a.max(-LIFT_OFF_MPS2) } else { a };
        }
        let gap = lane.s - follower.s - CAR_LENGTH;
        let want = a_lane
            + DOOR_GAP_GAIN * (gap - p.door_gap_m - DOOR_HEADWAY_S * follower.v)
            + DOOR_SPEED_GAIN * (lane.v - follower.v);
        let safe = Idm { accel: p.door_accel_mps2, min_gap: 1.0, headway: 0.0, ..self.params.idm }.accel(
            follower.v,
            f64::INFINITY,
            leader,
        );
        want.min(safe).clamp(-self.params.idm.max_brake, p.door_accel_mps2)
    }

    /// Record how the lane cars move this step: their speed, and any
    /// braking of the follower on an open road (it has passed the ego, and
    /// it is closing on nothing: the lane car ahead is no slower, or
    /// farther than the lane's desired gap, as IDM states it). The lane
    /// car's own braking is its disposition's (making room, covering an
    /// ego, the bluff): it brakes for the ego.
    fn track_motion(&mut self, ego: &Body, a_follow: f64) {
        let idm = self.params.idm;
        for car in [self.lane_car, self.follower] {
            let fastest = self.motion.fastest_car_mps.map_or(car.v, |f| f.max(car.v));
            self.motion.fastest_car_mps = Some(fastest);
        }
        let follower = self.follower;
        let passed_ego = follower.s - CAR_LENGTH > ego.s;
        let open = self
            .leader(&follower, Some(&self.lane_car), ego)
            .is_none_or(|(gap, closing)| closing <= 0.0 || gap > idm.min_gap + follower.v * idm.headway);
        if passed_ego && open {
            self.motion.open_road_brake_mps2 = self.motion.open_road_brake_mps2.max(-a_follow);
        }
    }

    /// Whether the ego brakes hard close to the merge point: to a car that
    /// was making room, hanging back at once.
    fn ego_brakes_late(&self, ego: &Body) -> bool {
        let lane = &self.params.lane;
        let d = self.merge_point - ego.s;
        d > 0.0 && d < lane.late_brake_within_m && ego.a < -lane.late_brake_mps2
    }

    /// A car holding the lane: cruise, but keep ahead of an ego that is
    /// alongside on the ramp (match it plus a margin) so that it cannot cut
    /// in ahead.
    fn hold_accel(&self, lane: Body, ego: &Body, dt: f64) -> f64 {
        let p = &self.params.lane;
        let rel = lane.s - ego.s;
        let alongside = !self.ego_in_lane(ego) && rel < CAR_LENGTH && rel > -(CAR_LENGTH + 2.0);
        let target =
            if alongside { (ego.v - DENY_LEVEL_GAIN * rel).clamp(self.cruise, self.top_speed()) } else { self.cruise };
        track_speed(lane.v, target, p.deny_accel_mps2, EASE_BACK_MPS2, dt)
    }

    /// A car taking its turn: draw level with an ego on the ramp and pass
    /// it only a little faster than it goes (so the ego can cut in neither
    /// ahead of it nor, until it and its follower have passed, behind it);
    /// once past, pull back up to cruise gently.
    fn take_turn_accel(&self, ego: &Body, dt: f64) -> f64 {
        let lane = self.lane_car;
        let p = &self.params.lane;
        let rel = lane.s - ego.s;
        // Until its follower has cleared the merge point it stays within
        // reach of an ego on the ramp: an ego that braked hard is passed
        // slowly, by both, however fast it had pulled them along before.
        let clearing = self.follower.s < self.merge_point + CAR_LENGTH;
        if !self.ego_in_lane(ego) && (rel < CAR_LENGTH + 1.0 || clearing) {
            // Near the ego on the ramp: keep just ahead of it (catching up
            // if behind), however it moves, so that it cannot cut in ahead.
            let behind = (-rel).max(0.0);
            let beside = rel < CAR_LENGTH + 1.0;
            let pace = (ego.v + p.pass_margin_mps + 0.5 * behind).max(p.pass_speed_mps).min(self.top_speed());
            // Drawing level with an ego beside it is brisk. Wholly ahead of
            // the ego it holds its pace until it has cleared the merge
            // point (slowing with an ego that slows), however the ego behind
            // it accelerates: an ego cannot pull it through the merge point.
            let target = if beside { pace } else { pace.min(lane.v.max(p.pass_speed_mps)) };
            let up = if behind > 0.0 || (beside && ego.v + p.pass_margin_mps > lane.v) {
                p.deny_accel_mps2
            } else {
                p.resume_accel_mps2
            };
            track_speed(lane.v, target, up, COVER_DECEL, dt)
        } else {
            track_speed(lane.v, self.cruise, p.resume_accel_mps2, 3.0, dt)
        }
    }

    /// A car making room. For an ego that keeps pace: drop back until
    /// `open_gap_m` behind it, then follow it as if it were already the
    /// leader. For an ego that hangs back: cover it (front overlapping the
    /// ego's rear by `COVER_OVERLAP_M`), so that it cannot cut in ahead
    /// unless it goes in time. Never slower than `floor`.
    fn open_accel(&self, ego: &Body, pace: bool, floor: f64, dt: f64) -> f64 {
        let p = &self.params.lane;
        let lane = self.lane_car;
        // Tier 3: both dispositions open the gap more gently (the bluffer
        // stays within reach of an ego that takes the bait).
        let decel = if self.tier == Tier::T3 { self.params.tier3.open_decel_mps2 } else { p.open_decel_mps2 };
        let gap = ego.s - lane.s - CAR_LENGTH;
        if !pace {
            let rel_target = -(CAR_LENGTH - COVER_OVERLAP_M);
            let off = rel_target - (lane.s - ego.s);
            let target = (ego.v + 1.0 * off).max(floor).max(0.0);
            return track_speed(lane.v, target, p.deny_accel_mps2, COVER_DECEL, dt);
        }
        // Drop back to `open_gap_m` behind the ego's rear, then keep that
        // gap (no farther back: the ego is to slip in just ahead).
        // Visibly holding back: never as fast as the ego until it is in.
        let follow = (ego.v + 0.8 * (gap - p.open_gap_m)).min(ego.v - HOLD_BACK_MPS);
        let target = if gap < 0.0 { follow.min(ego.v - DROP_BACK_MPS).min(lane.v) } else { follow };
        let target = target.clamp(floor, self.top_speed());
        track_speed(lane.v, target, self.params.idm.accel, decel, dt)
    }

    /// A bluffer closing the gap: back to level with the ego, hard. Once
    /// level (or the ego is in the lane) it switches the phase to holding
    /// the lane, hence `&mut self`.
    fn close_until_level(&mut self, ego: &Body, dt: f64) -> f64 {
        let lane = self.lane_car;
        let rel = lane.s - ego.s;
        if rel > -1.0 || self.ego_in_lane(ego) {
            self.phase = Phase::Hold;
        }
        let target = (ego.v - DENY_LEVEL_GAIN * rel).max(self.cruise).min(self.top_speed());
        track_speed(lane.v, target, self.params.tier3.close_accel_mps2, CLOSE_BRAKE_MPS2, dt)
    }

    fn lane_car_accel(&mut self, ego: &Body, t: f64, dt: f64) -> f64 {
        let idm = self.params.idm;
        let lane = self.lane_car;
        let in_lane_leader = self.leader(&lane, None, ego);
        // A car physically in the lane ahead is always respected.
        let cap = idm.accel(lane.v, f64::INFINITY, in_lane_leader);
        let respect = |a: f64| if cap < LEADER_RESPECT_SHARE * idm.accel { a.min(cap) } else { a };
        let makes_room = self.disposition == MAKES_ROOM;
        let floor = self.params.tier3.floor_fraction * self.cruise;
        let pace = self.ego_keeps_pace(ego, t);
        if makes_room && matches!(self.phase, Phase::Open { .. }) {
            // Tier 3: the car making room shows itself by slowing below the
            // bluffer's floor; until then it does not give up either.
            let shown = self.tier != Tier::T3 || lane.v < floor - SHOWN_BELOW_FLOOR_MPS;
            if shown {
                self.revealed = true;
            }
            // Its easing off is on show once it is visibly below its cruise
            // (tier 3: below the bluffer's floor). A driver who hedged while
            // nothing was known, or who sees it a decision late, then has
            // `look_s` to answer before its hanging back counts.
            if self.shown_at.is_none() && shown && lane.v <= self.cruise - BAIT_EASE_MPS {
                self.shown_at = Some(t);
            }
            let looked = self.shown_at.is_some_and(|since| t - since + 1e-9 >= self.look_s);
            let gives_way = ego.a <= -GIVES_WAY_BRAKE_MPS2;
            // Patience runs while the car covers an ego that hangs back
            // (level with it at its speed): a car that could not stop as
            // hard as the ego waits first, then pulls away from there.
            let covering = lane.v <= ego.v + COVERING_MARGIN_MPS;
            // At t = 0 the ego's state is where it started, not a choice.
            if !pace && t > 0.0 && (looked || gives_way) {
                self.patience.hang_back(dt);
            }
            // It takes its turn on what the ego does now: an ego that hung
            // back earlier and keeps pace now is not giving way, and one
            // that could no longer stop firmly short of the merge point is
            // not offering it (the car keeps covering it until it could).
            let out = (self.patience.run_out() && !pace) || self.ego_brakes_late(ego);
            let stoppable = EgoApproach::new(self.merge_point - ego.s, ego).can_stop_comfortably();
            if shown && out && covering && stoppable {
                self.turns_taken += 1;
                self.phase = Phase::TakeTurn;
            }
        }
        match self.phase {
            Phase::Hold => respect(self.hold_accel(self.lane_car, ego, dt)),
            Phase::TakeTurn => respect(self.take_turn_accel(ego, dt)),
            Phase::Close => respect(self.close_until_level(ego, dt)),
            Phase::Open { floor_since } => {
                if makes_room {
                    let floor = if self.tier == Tier::T3 && !self.revealed { floor } else { 0.0 };
                    return respect(self.open_accel(ego, pace, floor, dt));
                }
                // Tier-3 bluff: open like a car making room, down to the
                // floor; close the gap once the ego's motion shows it takes
                // the bait, or take the turn after holding the floor.
                let approach = EgoApproach::new(self.merge_point - ego.s, ego);
                let v_max = self.params.episode.speed_limit_mps;
                // The bait is taken by an ego about to merge ahead of it: not
                // braking, ahead of the car, and due at the merge point soon.
                // It closes only once the bait is on show (it has visibly
                // eased off), so that its easing off is what the ego saw.
                let bait_shown = lane.v <= self.cruise - BAIT_EASE_MPS;
                let ego_commits = approach.to_conflict > 0.0
                    && bait_shown
                    && ego.a > PACE_MIN_ACCEL
                    && lane.s < ego.s + EGO_AHEAD_M
                    && approach.eta(v_max) < self.params.tier3.commit_horizon_s;
                if ego_commits {
                    self.revealed = true;
                    self.phase = Phase::Close;
                    return respect(self.close_until_level(ego, dt));
                }
                if lane.v <= floor + 1e-9 {
                    let since = floor_since.unwrap_or(t);
                    self.phase = Phase::Open { floor_since: Some(since) };
                    if t - since >= self.params.tier3.hold_s {
                        self.revealed = true;
                        self.phase = Phase::TakeTurn;
                    }
                }
                respect(self.open_accel(ego, pace, floor, dt))
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
        let a_shadow = self.hold_accel(self.shadow, ego, dt);
        self.shadow.advance(a_shadow, dt);
        // No lane car drives above the lane's limit: closing the door, the
        // follower matches the lane car only up to it.
        let a_follow = self.follower_accel(a_lane, ego).min((self.params.lane.speed_limit_mps - self.follower.v) / dt);
        self.track_motion(ego, a_follow);
        self.lane_car.advance(a_lane, dt);
        self.follower.advance(a_follow, dt);
    }

    fn motion(&self) -> Motion {
        Motion { car_speed_limit_mps: Some(self.params.lane.speed_limit_mps), ..self.motion }
    }

    fn ego_speed_limit(&self, ego: &Body) -> Option<f64> {
        self.ego_in_lane(ego).then_some(self.params.lane.speed_limit_mps)
    }

    fn speed_limit_ahead(&self, ego: &Body) -> Option<f64> {
        (!self.ego_in_lane(ego)).then_some(self.params.lane.speed_limit_mps)
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
        let place = [self.merge_point - ego.s, self.params.road.taper_length_m - ego.s];
        let tracks = [self.lane_history.track(lane), self.follower_history.track(follower)];
        Scene::new(ScenarioKind::ContestedMerge, &place, &tracks).expect("the on-ramp's layout")
    }

    fn revealed(&self) -> bool {
        self.revealed
    }

    fn true_positions(&self, ego: &Body) -> Vec<f64> {
        vec![self.lane_car.s - ego.s, self.follower.s - ego.s]
    }

    fn turns_taken(&self) -> u32 {
        self.turns_taken
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

    fn order_settles_choice(&self) -> bool {
        true
    }

    fn reading_noise(&self) -> Option<super::ReadingNoise> {
        let sd = &self.params.tier2;
        self.noise
            .is_some()
            .then_some(super::ReadingNoise { position_sd_m: sd.position_noise_m, speed_sd_mps: sd.speed_noise_mps })
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Stream;
    use crate::sim::DT;

    /// A car making room takes its turn on what the ego does at that
    /// moment: never while the ego keeps pace (and does not brake late),
    /// whatever it did earlier, and never while the ego could no longer
    /// stop firmly short of the merge point. Random egos that surge and
    /// lull reach the moment the car's patience has run out while it is not
    /// yet covering them and then keep pace, or brake late and hard; the
    /// car must go on waiting.
    #[test]
    fn a_car_making_room_takes_its_turn_only_while_the_ego_gives_way_now() {
        let body = include_str!("../../../scenarios/contested_merge.toml").replace("scenario = \"contested_merge\"", "");
        let params: MergeParams = toml::from_str(&body).unwrap();
        let (mut turns, mut surges_after_patience) = (0, 0);
        for seed in 0..400u64 {
            let tier = Tier::ALL[(seed % 3) as usize];
            let mut geometry = EpisodeRng::new(&[seed], Stream::Geometry);
            let noise = EpisodeRng::new(&[seed], Stream::ObservationNoise);
            let mut world = MergeWorld::new(&params, tier, MAKES_ROOM, &mut geometry, noise);
            let mut actions = EpisodeRng::new(&[seed], Stream::Policy);
            let mut ego = world.ego_start;
            let mut accel = 0.0;
            for step in 0..200 {
                let t = step as f64 * DT;
                if step % 5 == 0 {
                    accel = -4.0 + 6.5 * actions.unit();
                }
                let pace = world.ego_keeps_pace(&ego, t);
                let late = world.ego_brakes_late(&ego);
                let stoppable = EgoApproach::new(world.merge_point - ego.s, &ego).can_stop_comfortably();
                let before = world.turns_taken;
                surges_after_patience += (world.patience.run_out() && pace && before == 0) as u32;
                world.advance(&ego, t, DT);
                if world.turns_taken > before {
                    turns += 1;
                    assert!(
                        !pace || late || t == 0.0,
                        "seed {seed} t{tier}: a turn at t = {t:.1} s while the ego kept pace"
                    );
                    assert!(
                        stoppable,
                        "seed {seed} t{tier}: a turn at t = {t:.1} s in front of an ego that could not stop"
                    );
                }
                ego.advance(accel, DT);
            }
        }
        assert!(turns > 50 && surges_after_patience > 50, "{turns} turns, {surges_after_patience} surges");
    }
}
