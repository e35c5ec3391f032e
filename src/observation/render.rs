//! The scene text a language model reads each turn. Every number it prints
//! is parsed back by `parse_scene`, so the text alone carries the public
//! observation (to the printed precision).

use super::{Observation, Scene, Track, round_to};
use std::fmt::Write;

/// Format with one decimal, never "-0.0".
pub(super) fn f1(x: f64) -> String {
    format!("{:.1}", round_to(x, 1))
}

fn f2(x: f64) -> String {
    format!("{:.2}", round_to(x, 2))
}

pub(super) const YIELD_SITUATION: &str = "Unsignalled T-intersection. You approach on the stem and must cross the conflict zone; two cars approach one behind the other on the crossing road. There are no signs, no signals and no agreed right of way: read the other driver's intent from its motion. Distances to the conflict zone are from the front bumper to the zone's near edge; negative means already inside or past it (a car has fully crossed below -6.7 m).";
pub(super) const PEDESTRIAN_SITUATION: &str = "Urban street with an unmarked crosswalk ahead. A pedestrian is near the kerb on your side. The pedestrian's position is lateral, from the near kerb: negative = on the sidewalk, 0 = kerb, 0.6 to 2.9 = in your path, 7.0 = far kerb. Positive velocity = moving into the road. Distance to the crosswalk is from your front bumper to the pedestrian's crossing line.";
pub(super) const MERGE_SITUATION: &str = "On-ramp merging into a single through lane; the ramp ends, so you must merge before it runs out. A lane car is alongside and another car follows it. Positions of lane cars are centre to centre along the road relative to you (positive = ahead of you). Your body starts to overlap the lane at the merge point.";

/// `now` formats the current sample, e.g. "21.0 m to the conflict zone, speed 9.4 m/s".
fn track_lines(out: &mut String, label: &str, t: &Track, now: fn(&str, &str) -> String) {
    let _ = writeln!(out, "{label}: {}", now(&f1(t.now.position_m), &f1(t.now.velocity_mps)));
    let past: Vec<String> =
        t.past.iter().map(|s| format!("{} m at {} m/s", f1(s.position_m), f1(s.velocity_mps))).collect();
    let _ = writeln!(out, "{label} over the last 2 s (oldest first): {}", past.join("; "));
}

/// Render an observation as the scene text of one user turn.
pub fn render_scene(obs: &Observation) -> String {
    let mut out = String::with_capacity(900);
    let situation = match obs.scene {
        Scene::YieldStandoff { .. } => YIELD_SITUATION,
        Scene::PedestrianFeint { .. } => PEDESTRIAN_SITUATION,
        Scene::ContestedMerge { .. } => MERGE_SITUATION,
    };
    // The scene is named by its geometry only: a scenario name such as
    // "pedestrian_feint" would tell the model which behaviour to expect.
    let _ = writeln!(out, "Scene: {}", obs.scenario().scene_name());
    let _ = writeln!(out, "Situation: {situation}");
    let _ = writeln!(out, "Time: {} s", f1(obs.time_s));
    let _ = writeln!(
        out,
        "Turn: {} of {} ({} left including this one; each action is held for 0.5 s)",
        obs.turn,
        obs.turn_budget,
        obs.turns_left()
    );
    let e = &obs.ego;
    let place = match obs.scene {
        Scene::YieldStandoff { ego_to_conflict_m, .. } => format!("{} m to the conflict zone", f1(ego_to_conflict_m)),
        Scene::PedestrianFeint { ego_to_crosswalk_m, .. } => format!("{} m to the crosswalk", f1(ego_to_crosswalk_m)),
        Scene::ContestedMerge { ego_to_merge_m, ramp_left_m, .. } => {
            format!("{} m to the merge point, {} m of ramp left", f1(ego_to_merge_m), f1(ramp_left_m))
        }
    };
    let _ = writeln!(
        out,
        "You: speed {} m/s, acceleration {} m/s^2, {place}, {} m to your goal, speed limit {} m/s",
        f1(e.speed_mps),
        f1(e.accel_mps2),
        f1(e.to_goal_m),
        f1(e.speed_limit_mps)
    );
    match &obs.scene {
        Scene::YieldStandoff { other, follower, .. } => {
            let to_zone = |p: &str, v: &str| format!("{p} m to the conflict zone, speed {v} m/s");
            track_lines(&mut out, "Other car", other, to_zone);
            track_lines(&mut out, "Car behind it", follower, to_zone);
        }
        Scene::PedestrianFeint { pedestrian, .. } => {
            track_lines(&mut out, "Pedestrian", pedestrian, |p, v| format!("at {p} m (lateral), velocity {v} m/s"))
        }
        Scene::ContestedMerge { lane_car, follower, .. } => {
            let relative = |p: &str, v: &str| format!("at {p} m (relative to you), speed {v} m/s");
            track_lines(&mut out, "Lane car", lane_car, relative);
            track_lines(&mut out, "Car behind it", follower, relative);
        }
    }
    match obs.last_action {
        Some(a) => {
            let _ =
                writeln!(out, "Your last action: {}, acceleration {}", a.maneuver, f2(a.acceleration.clamp(-1.0, 1.0)));
        }
        None => {
            let _ = writeln!(out, "Your last action: none (first turn)");
        }
    }
    out
}
