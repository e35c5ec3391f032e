//! What every scenario world provides to the episode loop. A world owns the
//! other road users and the hidden state; the episode owns the ego.

use super::{HISTORY_LEN, HISTORY_SPACING_S, Sample, Scene, Track};
use crate::sim::{Aabb, Body};

/// Privileged per-step facts the graders read.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Contact {
    /// Clearance between the ego's box and the nearest other box (m).
    pub gap_m: f64,
    /// Time until the boxes would overlap at current speeds (s), if ever.
    pub ttc_s: Option<f64>,
    pub collision: bool,
}

/// Plan-view position of one road user, for trajectory plots.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PlanPoint {
    pub x: f64,
    pub y: f64,
    pub v: f64,
}

pub trait World {
    /// Ego start state, in the world's path coordinate.
    fn ego_start(&self) -> Body;
    /// Ego path coordinate at which the episode succeeds.
    fn goal_s(&self) -> f64;
    /// Move the other road users one physics step. They react to the ego's
    /// kinematic state only (position, speed, acceleration over the last
    /// step): the signature carries no action, so no road user can react to
    /// the maneuver label a policy chose.
    fn advance(&mut self, ego: &Body, t: f64, dt: f64);
    /// Collision, clearance and time-to-collision against the ego.
    fn contact(&self, ego: &Body) -> Contact;
    /// The public scene at a decision. Records the observed sample into the
    /// history (so call it exactly once per decision).
    fn observe(&mut self, ego: &Body) -> Scene;
    /// Privileged: whether the disposition has started to show in the other
    /// agent's motion.
    fn revealed(&self) -> bool;
    /// Distance (m) the ego still has to travel before it enters the
    /// conflict (the crossing, the pedestrian's path, the merge point);
    /// zero or negative once it has.
    fn ego_to_conflict(&self, ego: &Body) -> f64;
    /// Privileged: whether the other road user has entered the conflict.
    fn other_entered(&self) -> bool;
    /// Whether the order of entry, rather than the ego's point of no
    /// return, settles the go / give-way choice: true where the other
    /// travels alongside the ego (a merge), so that an ego that can no
    /// longer stop short of the conflict can still fall in behind it.
    fn order_settles_choice(&self) -> bool {
        false
    }
    /// Privileged: whether the ego is entering the conflict zone while the
    /// other has the way (inside it, or due in less than `ROW_MARGIN_S`).
    fn cuts_off(&self, ego: &Body) -> bool;
    /// Plan-view positions: the ego first, then the other road users.
    fn plan(&self, ego: &Body) -> Vec<PlanPoint>;
    /// The readings the last [`World::observe`] drew through observation
    /// noise, in a fixed order (empty for a world observed without noise).
    /// The ideal observer compares them with the other disposition's truth.
    fn noisy_readings(&self) -> &[crate::noise::NoisyReading] {
        &[]
    }
    /// The size of the noise this world's readings carry, as the scene
    /// text states it (public: a property of the tier).
    fn reading_noise(&self) -> Option<super::ReadingNoise> {
        None
    }
    /// Privileged: how many times a road user that had been waiting for the
    /// ego has started to take its turn into the ego's path (a feinter
    /// stepping in, a crosser taking the ego's invitation, a stopped yielder
    /// pulling away, a lane car passing an ego it covered). The episode
    /// checks, at the step the count grows, that the ego could still stop
    /// before the conflict (`EgoApproach::can_stop`).
    fn turns_taken(&self) -> u32 {
        0
    }
    /// Privileged: how the road users have moved so far, for `validate`'s
    /// "road users move as people" line (each figure beside its published
    /// range).
    fn motion(&self) -> Motion {
        Motion::default()
    }
    /// Privileged: where the road users the forecast probe asks about are
    /// (the scene's first `forecast_tracks` of the scenario's definition,
    /// in its order), on the scene's own axis and in its units, as the
    /// scene would show them without observation noise.
    fn true_positions(&self, ego: &Body) -> Vec<f64>;
    /// The speed limit that binds the ego where it is now (m/s), where the
    /// world states one other than the episode's (the merge's through lane,
    /// once the ego is in it). Public: it is on the "You:" line.
    fn ego_speed_limit(&self, _ego: &Body) -> Option<f64> {
        None
    }
    /// The speed limit of the road the ego is to join (m/s), while it is
    /// not on it yet and the world states one other than the episode's
    /// (the merge's through lane): a driver reads the sign before the
    /// merge. Public: it is on the "You:" line.
    fn speed_limit_ahead(&self, _ego: &Body) -> Option<f64> {
        None
    }
}

/// How a world's road users have moved in one episode: the figures that
/// published ranges of human motion bound.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct Motion {
    /// The slowest pace (m/s) a pedestrian set out across the road at.
    pub slowest_crossing_mps: Option<f64>,
    /// The shortest time (s) a walker took to come to rest from its pace,
    /// from its first slowing step: people end a walk over a step or more.
    pub quickest_stop_s: Option<f64>,
    /// The longest (s) a pedestrian that followed another across set out
    /// after it: a group that follows crosses together.
    pub widest_follow_s: Option<f64>,
    /// The hardest a car braked (m/s^2) on an open road: ahead of the ego,
    /// with nothing ahead of it nearer than its own desired gap.
    pub open_road_brake_mps2: f64,
    /// The fastest a car other than the ego drove (m/s), against the speed
    /// limit the scene states.
    pub fastest_car_mps: Option<f64>,
    /// The speed limit the scene states for the road the other cars drive
    /// on, where it is not the episode's (the merge's through lane).
    pub car_speed_limit_mps: Option<f64>,
}

impl Motion {
    /// The figures of two stretches together (the slowest of the slowest,
    /// the quickest stop, the widest follow, the hardest, the fastest).
    pub fn merge(self, other: Motion) -> Motion {
        let pick = |a: Option<f64>, b: Option<f64>, f: fn(f64, f64) -> f64| match (a, b) {
            (Some(x), Some(y)) => Some(f(x, y)),
            (x, y) => x.or(y),
        };
        Motion {
            slowest_crossing_mps: pick(self.slowest_crossing_mps, other.slowest_crossing_mps, f64::min),
            quickest_stop_s: pick(self.quickest_stop_s, other.quickest_stop_s, f64::min),
            widest_follow_s: pick(self.widest_follow_s, other.widest_follow_s, f64::max),
            open_road_brake_mps2: self.open_road_brake_mps2.max(other.open_road_brake_mps2),
            fastest_car_mps: pick(self.fastest_car_mps, other.fastest_car_mps, f64::max),
            car_speed_limit_mps: pick(self.car_speed_limit_mps, other.car_speed_limit_mps, f64::min),
        }
    }
}

/// Time margin for a right-of-way violation.
pub const ROW_MARGIN_S: f64 = 1.5;

/// A rolling record of what the ego has observed of one road user.
#[derive(Debug, Clone, Copy)]
pub struct History {
    past: [Sample; HISTORY_LEN],
}

impl History {
    /// History of a road user that moved at constant velocity before t = 0:
    /// `position_rate` is how fast its observed position changed.
    pub fn steady(now: Sample, position_rate: f64) -> Self {
        let mut past = [now; HISTORY_LEN];
        for (i, s) in past.iter_mut().enumerate() {
            let k = (HISTORY_LEN - i) as f64;
            s.position_m = now.position_m - position_rate * k * HISTORY_SPACING_S;
        }
        History { past }
    }

    /// [`History::steady`], each past sample read through `observe` (oldest
    /// first): on a noisy tier, every sample shown carries its own noise.
    pub fn steady_observed(now: Sample, position_rate: f64, mut observe: impl FnMut(Sample) -> Sample) -> Self {
        let mut history = History::steady(now, position_rate);
        for s in history.past.iter_mut() {
            *s = observe(*s);
        }
        history
    }

    /// History of a road user whose motion before t = 0 is known: `at(t)`
    /// gives its sample at each earlier reading's time (negative, s).
    pub fn from_past(at: impl Fn(f64) -> Sample) -> Self {
        History { past: std::array::from_fn(|i| at(-((HISTORY_LEN - i) as f64) * HISTORY_SPACING_S)) }
    }

    /// History of a road user that has been braking at `decel` (m/s^2,
    /// positive) before t = 0; `position_rate` is the sign of how its
    /// observed position moves with its own travel (+1 or -1).
    pub fn braking(now: Sample, decel: f64, position_rate: f64) -> Self {
        let mut past = [now; HISTORY_LEN];
        for (i, s) in past.iter_mut().enumerate() {
            let tau = (HISTORY_LEN - i) as f64 * HISTORY_SPACING_S;
            let v = now.velocity_mps + decel * tau;
            let travelled = now.velocity_mps * tau + 0.5 * decel * tau * tau;
            *s = Sample { position_m: now.position_m - position_rate * travelled, velocity_mps: v };
        }
        History { past }
    }

    /// Build the track for `now` and remember `now` for later turns.
    pub fn track(&mut self, now: Sample) -> Track {
        let t = Track { now, past: self.past };
        self.past.rotate_left(1);
        self.past[HISTORY_LEN - 1] = now;
        t
    }
}

/// Time until two 1-D occupancy intervals overlap when each body moves at
/// constant speed: body A occupies its zone for s in (a_in, a_out) and body
/// B for (b_in, b_out), measured as distances still to travel.
pub fn crossing_ttc(
    a_dist_in: f64,
    a_dist_out: f64,
    a_v: f64,
    b_dist_in: f64,
    b_dist_out: f64,
    b_v: f64,
) -> Option<f64> {
    let window = |d_in: f64, d_out: f64, v: f64| -> Option<(f64, f64)> {
        if d_out <= 0.0 {
            return None; // already through
        }
        if d_in <= 0.0 {
            return Some((0.0, if v > 1e-6 { d_out / v } else { f64::INFINITY }));
        }
        if v <= 1e-6 {
            return None;
        }
        Some((d_in / v, d_out / v))
    };
    let (a0, a1) = window(a_dist_in, a_dist_out, a_v)?;
    let (b0, b1) = window(b_dist_in, b_dist_out, b_v)?;
    let start = a0.max(b0);
    if start < a1.min(b1) { Some(start) } else { None }
}

pub fn car_box(x: f64, y: f64, along_x: bool) -> Aabb {
    use crate::sim::{CAR_LENGTH, CAR_WIDTH};
    if along_x { Aabb::centered(x, y, CAR_LENGTH, CAR_WIDTH) } else { Aabb::centered(x, y, CAR_WIDTH, CAR_LENGTH) }
}

/// The patience of a road user waiting for the ego to go first: it runs
/// out once the ego has hung back for `patience_s` *in all*. Going again in
/// between does not reset it, so no rhythm of surges and lulls outlasts it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Patience {
    patience_s: f64,
    hung_back_s: f64,
}

impl Patience {
    pub(crate) fn new(patience_s: f64) -> Self {
        Patience { patience_s, hung_back_s: 0.0 }
    }

    /// The ego hung back for `dt` more seconds.
    pub(crate) fn hang_back(&mut self, dt: f64) {
        self.hung_back_s += dt;
    }

    pub(crate) fn run_out(&self) -> bool {
        self.hung_back_s + 1e-9 >= self.patience_s
    }
}

/// The ego as another road user sees it: where it is relative to the
/// conflict and how it moves. Reactions of other road users are functions
/// of this, never of the ego's action.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct EgoApproach {
    /// Distance to the conflict (m); zero or negative once inside.
    pub to_conflict: f64,
    pub v: f64,
    /// Acceleration over the last physics step.
    pub a: f64,
}

impl EgoApproach {
    pub fn new(to_conflict: f64, ego: &Body) -> Self {
        EgoApproach { to_conflict, v: ego.v, a: ego.a }
    }

    /// Seconds until the ego reaches the conflict if it keeps its current
    /// acceleration (capped at `v_max`); infinite if it would stop short.
    pub fn eta(&self, v_max: f64) -> f64 {
        let (d, v, a) = (self.to_conflict, self.v, self.a);
        if d <= 0.0 {
            return 0.0;
        }
        if a > 1e-6 && v < v_max {
            let t1 = (v_max - v) / a;
            let d1 = v * t1 + 0.5 * a * t1 * t1;
            if d1 >= d { (-v + (v * v + 2.0 * a * d).sqrt()) / a } else { t1 + (d - d1) / v_max }
        } else if a < -1e-6 {
            let disc = v * v + 2.0 * a * d;
            if disc < 0.0 { f64::INFINITY } else { (v - disc.sqrt()) / -a }
        } else if v > 1e-6 {
            d / v
        } else {
            f64::INFINITY
        }
    }

    /// Whether the ego could no longer stop short of the conflict even at
    /// full braking.
    pub fn beyond_stopping(&self) -> bool {
        self.v * self.v / (2.0 * crate::sim::EGO_MAX_BRAKE) > self.to_conflict
    }

    /// Whether the ego could still stop short of the conflict as a driver
    /// does when someone steps out: after a reaction time, braking firmly
    /// but not in an emergency ([`REACTION_S`], [`FIRM_BRAKE`]), or it has
    /// already stopped there.
    pub fn can_stop_comfortably(&self) -> bool {
        // A car at rest at the very edge of the conflict has stopped.
        let at_rest = self.v < 0.05 && self.to_conflict > -0.05;
        at_rest
            || (self.to_conflict > 0.0 && self.v * REACTION_S + self.v * self.v / (2.0 * FIRM_BRAKE) < self.to_conflict)
    }

    /// Whether the ego could still stop short of the conflict: it can stop
    /// comfortably ([`Self::can_stop_comfortably`]), or it is already
    /// braking and stops short at its current deceleration (a car visibly
    /// stopping has no reaction time left to spend). A road user that waits
    /// for the ego and starts into its path while this is false is what
    /// `validate`'s "road users accept gaps" line counts.
    pub fn can_stop(&self) -> bool {
        let stopping = self.a < -0.5 && self.to_conflict > 0.0 && self.v * self.v / (-2.0 * self.a) < self.to_conflict;
        self.can_stop_comfortably() || stopping
    }
}

/// A driver's reaction time to a road user stepping out (s).
pub const REACTION_S: f64 = 0.5;
/// Firm, non-emergency braking (m/s^2): what a road user that waits for the
/// ego expects it to be able to stop with.
pub const FIRM_BRAKE: f64 = 4.0;
