//! Physics shared by every scenario: fixed-step 1-D kinematics along a path,
//! axis-aligned boxes in the plane, and overlap tests.
//!
//! Only IEEE-exact operations (`+ - * /`, `sqrt`) are used on the simulation
//! path so that an episode reproduces bit for bit on any machine.

/// Physics step in seconds.
pub const DT: f64 = 0.1;
/// Physics steps between two policy decisions (0.5 s).
pub const DECISION_INTERVAL: u32 = 5;
/// Upper bound on the turn budget of any scenario.
pub const MAX_TURNS: u32 = 40;
/// Ego acceleration limit (m/s^2).
pub const EGO_MAX_ACCEL: f64 = 3.0;
/// Ego emergency braking limit (m/s^2, a positive magnitude).
pub const EGO_MAX_BRAKE: f64 = 8.0;
/// Car body length and width (m).
pub const CAR_LENGTH: f64 = 4.8;
pub const CAR_WIDTH: f64 = 1.9;
/// Pedestrian footprint side (m).
pub const PEDESTRIAN_SIZE: f64 = 0.6;

/// A point mass moving along its own path: position `s` (m), speed `v`
/// (m/s, never negative) and the acceleration applied over the last step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Body {
    pub s: f64,
    pub v: f64,
    pub a: f64,
}

impl Body {
    pub fn new(s: f64, v: f64) -> Self {
        Body { s, v, a: 0.0 }
    }

    /// Advance one physics step under a commanded acceleration. A body that
    /// would reverse stops exactly where its speed reaches zero, and the
    /// recorded acceleration is the one actually realised.
    pub fn advance(&mut self, accel: f64, dt: f64) {
        let v_next = self.v + accel * dt;
        if v_next >= 0.0 {
            self.s += 0.5 * (self.v + v_next) * dt;
            self.a = accel;
            self.v = v_next;
        } else {
            // Stops inside the step: travel v^2 / (2|a|), realised mean accel.
            if accel < 0.0 {
                self.s += self.v * self.v / (-2.0 * accel);
            }
            self.a = -self.v / dt;
            self.v = 0.0;
        }
    }
}

/// Axis-aligned rectangle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    pub min_x: f64,
    pub max_x: f64,
    pub min_y: f64,
    pub max_y: f64,
}

impl Aabb {
    pub fn centered(x: f64, y: f64, len_x: f64, len_y: f64) -> Self {
        Aabb { min_x: x - 0.5 * len_x, max_x: x + 0.5 * len_x, min_y: y - 0.5 * len_y, max_y: y + 0.5 * len_y }
    }

    /// Strict overlap: touching edges are not a collision.
    pub fn overlaps(&self, other: &Aabb) -> bool {
        self.min_x < other.max_x && other.min_x < self.max_x && self.min_y < other.max_y && other.min_y < self.max_y
    }

    /// Euclidean clearance between two boxes (0 when they overlap).
    pub fn gap(&self, other: &Aabb) -> f64 {
        let dx = (other.min_x - self.max_x).max(self.min_x - other.max_x).max(0.0);
        let dy = (other.min_y - self.max_y).max(self.min_y - other.max_y).max(0.0);
        (dx * dx + dy * dy).sqrt()
    }
}

/// Acceleration that moves speed `v` toward `target` at up to `accel_up`
/// (when slower) or `brake` (when faster), without overshooting in one step.
pub fn track_speed(v: f64, target: f64, accel_up: f64, brake: f64, dt: f64) -> f64 {
    let needed = (target - v) / dt;
    if needed >= 0.0 { needed.min(accel_up) } else { needed.max(-brake) }
}

/// Constant deceleration that brings speed `v` to rest over `distance`.
pub fn stopping_decel(v: f64, distance: f64) -> f64 {
    if distance <= 0.01 { f64::INFINITY } else { v * v / (2.0 * distance) }
}

/// Intelligent Driver Model acceleration (Treiber et al.), with the
/// exponent fixed at 4 and written as products for bit-exact results.
#[derive(Debug, Clone, Copy, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct Idm {
    /// Comfortable acceleration (m/s^2).
    pub accel: f64,
    /// Comfortable braking (m/s^2).
    pub brake: f64,
    /// Desired time headway (s).
    pub headway: f64,
    /// Minimum bumper-to-bumper gap (m).
    pub min_gap: f64,
    /// Hardest braking the model may apply (m/s^2).
    pub max_brake: f64,
}

impl Idm {
    /// `gap` is bumper to bumper to the leader (None: free road), `dv` is
    /// own speed minus the leader's.
    pub fn accel(&self, v: f64, v0: f64, leader: Option<(f64, f64)>) -> f64 {
        let r = if v0 > 0.0 { v / v0 } else { 1.0 };
        let free = 1.0 - r * r * r * r;
        let interaction = match leader {
            Some((gap, dv)) => {
                let s_star =
                    self.min_gap + (v * self.headway + v * dv / (2.0 * (self.accel * self.brake).sqrt())).max(0.0);
                let q = s_star / gap.max(0.1);
                q * q
            }
            None => 0.0,
        };
        (self.accel * (free - interaction)).max(-self.max_brake)
    }
}

/// Time to cover `distance` starting at `v0`, accelerating at `accel` up to
/// `v_max` and cruising after. Used to synchronise conflicts at episode start.
pub fn travel_time(distance: f64, v0: f64, v_max: f64, accel: f64) -> f64 {
    if distance <= 0.0 {
        return 0.0;
    }
    if accel <= 0.0 || v0 >= v_max {
        return distance / v0.max(0.1);
    }
    let t_acc = (v_max - v0) / accel;
    let d_acc = v0 * t_acc + 0.5 * accel * t_acc * t_acc;
    if d_acc >= distance {
        // Solve v0 t + a t^2 / 2 = d.
        (-v0 + (v0 * v0 + 2.0 * accel * distance).sqrt()) / accel
    } else {
        t_acc + (distance - d_acc) / v_max
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn braking_body_stops_exactly_and_never_reverses() {
        // 0.5 m/s at -8 m/s^2 stops after 0.0625 s and 0.25 / 16 m.
        let mut b = Body::new(0.0, 0.5);
        b.advance(-8.0, DT);
        assert_eq!(b.v, 0.0);
        assert!((b.s - 0.25 / 16.0).abs() < 1e-12);
        assert!((b.a - (-5.0)).abs() < 1e-12, "realised mean deceleration {}", b.a);
        b.advance(-8.0, DT);
        assert_eq!(b.v, 0.0);
        assert!((b.s - 0.25 / 16.0).abs() < 1e-12);
    }

    #[test]
    fn constant_accel_matches_closed_form() {
        let mut b = Body::new(0.0, 2.0);
        for _ in 0..10 {
            b.advance(1.0, DT);
        }
        assert!((b.v - 3.0).abs() < 1e-12);
        assert!((b.s - 2.5).abs() < 1e-12);
    }

    #[test]
    fn boxes_touching_do_not_overlap() {
        let a = Aabb::centered(0.0, 0.0, 2.0, 2.0);
        let b = Aabb::centered(2.0, 0.0, 2.0, 2.0);
        assert!(!a.overlaps(&b));
        assert_eq!(a.gap(&b), 0.0);
        let c = Aabb::centered(1.9, 0.5, 2.0, 2.0);
        assert!(a.overlaps(&c));
        let d = Aabb::centered(5.0, 4.0, 2.0, 2.0);
        assert!((a.gap(&d) - (9.0f64 + 4.0).sqrt()).abs() < 1e-12);
    }

    #[test]
    fn travel_time_accelerating_then_cruising() {
        // 0 -> 10 m/s at 2 m/s^2 takes 5 s and 25 m; 75 m more at 10 m/s.
        assert!((travel_time(100.0, 0.0, 10.0, 2.0) - 12.5).abs() < 1e-9);
        assert!((travel_time(9.0, 0.0, 10.0, 2.0) - 3.0).abs() < 1e-9);
    }

    #[test]
    fn idm_brakes_for_a_close_slow_leader_and_accelerates_on_free_road() {
        let idm = Idm { accel: 1.5, brake: 3.0, headway: 1.5, min_gap: 2.0, max_brake: 8.0 };
        assert!(idm.accel(5.0, 12.0, None) > 1.4);
        assert!(idm.accel(12.0, 12.0, Some((5.0, 12.0))) <= -7.99);
        assert!(idm.accel(12.0, 12.0, None).abs() < 1e-12);
    }
}
