//! A scenario's plan-view layout, as its definition (`def.rs`) gives it:
//! which way the ego and the road users progress, their roles, and a road
//! user's lateral frame. The report's figures and the drill-down read it
//! through [`super::ScenarioKind::plan_axes`].

/// The plan-view reading of a scenario (see [`super::ScenarioKind::plan_axes`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanAxes {
    /// The ego progresses along y (else x).
    pub ego_along_y: bool,
    /// The other road users progress along y (else x).
    pub others_along_y: bool,
    /// What position 0 along the paths is.
    pub zero_label: &'static str,
    /// The road users other than the ego, in the order of the plan-view
    /// points after the ego's (and of the scene text's tracks).
    pub road_users: &'static [RoadUser],
}

impl PlanAxes {
    /// Progress of the ego (`ego`) or another road user along its path.
    pub fn along(&self, p: &super::world::PlanPoint, ego: bool) -> f64 {
        let along_y = if ego { self.ego_along_y } else { self.others_along_y };
        if along_y { p.y } else { p.x }
    }

    /// The role of the `k`-th road user other than the ego ("road user
    /// k+1" beyond the scenario's list, which a well-formed record never
    /// reaches).
    pub fn role(&self, k: usize) -> std::borrow::Cow<'static, str> {
        match self.road_users.get(k) {
            Some(u) => u.role.into(),
            None => format!("road user {}", k + 1).into(),
        }
    }
}

/// A road user other than the ego, as figures and the drill-down name and
/// place it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoadUser {
    /// Its role in the scenario ("lane car", "follower").
    pub role: &'static str,
    /// For a road user that crosses the ego's road: the scene text's
    /// lateral frame of its position. `None`: it travels along a path whose
    /// progress shares the ego's axis.
    pub lateral: Option<LateralFrame>,
}

/// A lateral frame across the ego's road, the one the scene text states
/// (the pedestrian's position "from the near kerb"), so that figures and
/// the drill-down show the numbers the model read.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LateralFrame {
    /// What the value measures, for an axis title ("from the near kerb").
    pub measured: &'static str,
    /// The frame's value is the plan view's y plus this (m).
    pub plan_offset: f64,
    /// Lines of the road in the frame: (value, label).
    pub marks: [(f64, &'static str); 2],
    /// Where the road user is in the ego's path, in the frame: [lo, hi].
    pub in_path: (f64, f64),
}

impl LateralFrame {
    /// A plan-view point's value in this frame.
    pub fn of(&self, p: &super::world::PlanPoint) -> f64 {
        p.y + self.plan_offset
    }
}
