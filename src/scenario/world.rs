//! What every scenario world provides to the episode loop. A world owns the
//! other road users and the hidden state; the episode owns the ego.

use crate::action::Action;
use crate::observation::{HISTORY_LEN, Sample, Scene, Track};
use crate::scenario::Disposition;
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
    /// Move the other road users one physics step; they may react to the
    /// ego's state and to the action it currently holds.
    fn advance(&mut self, ego: &Body, ego_action: &Action, t: f64, dt: f64);
    /// Collision, clearance and time-to-collision against the ego.
    fn contact(&self, ego: &Body) -> Contact;
    /// The public scene at a decision. Records the observed sample into the
    /// history (so call it exactly once per decision).
    fn observe(&mut self, ego: &Body) -> Scene;
    /// Privileged: the hidden disposition.
    fn disposition(&self) -> Disposition;
    /// Privileged: whether the disposition has started to show in the other
    /// agent's motion.
    fn revealed(&self) -> bool;
    /// Privileged: whether the go / give-way question is settled (one of the
    /// two has entered the conflict zone).
    fn resolved(&self, ego: &Body) -> bool;
    /// Privileged: whether the ego is entering the conflict zone while the
    /// other has the way (inside it, or due in less than `ROW_MARGIN_S`).
    fn cuts_off(&self, ego: &Body) -> bool;
    /// Plan-view positions: the ego first, then the other road users.
    fn plan(&self, ego: &Body) -> Vec<PlanPoint>;
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
            s.position_m = now.position_m - position_rate * k * crate::observation::HISTORY_SPACING_S;
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
