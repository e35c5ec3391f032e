//! "Road users move as people do": each figure of their motion beside
//! its published range.

use super::{Check, OPEN_ROAD_BRAKE_MPS2, QUICKEST_STOP_S, SLOWEST_CROSSING_MPS, WIDEST_FOLLOW_S, cells_of, label};
use crate::episode::Episode;
use crate::policy::PolicyKind;
use crate::scenario::{ScenarioKind, ScenarioSet, Tier};
use serde::Serialize;

/// How the road users of one cell moved, over every built-in policy's
/// episodes, and the speed limit its scene states for the other cars (the
/// merge's through lane has its own).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MotionCell {
    pub scenario: ScenarioKind,
    pub tier: Tier,
    pub motion: crate::scenario::world::Motion,
    pub speed_limit_mps: f64,
}

/// Play every built-in policy on every cell, seeds `seeds`, and gather how
/// the road users moved.
pub fn road_user_motion(
    set: &ScenarioSet,
    scenarios: &[ScenarioKind],
    tiers: &[Tier],
    seeds: std::ops::Range<u64>,
) -> Vec<MotionCell> {
    let keys = cells_of(scenarios, tiers);
    crate::par::par_map(&keys, |&(scenario, tier)| {
        let config = set.get(scenario);
        let mut motion = crate::scenario::world::Motion::default();
        for kind in PolicyKind::ALL {
            for seed in seeds.clone() {
                let mut policy = kind.build();
                let mut episode = Episode::new(config, tier, seed);
                policy.reset(crate::episode::policy_seed(episode.spec()));
                while !episode.is_done() {
                    let action = policy.act(episode.observation());
                    episode.step(action);
                }
                motion = motion.merge(episode.road_user_motion());
            }
        }
        let speed_limit_mps = motion.car_speed_limit_mps.unwrap_or(config.common().speed_limit_mps);
        MotionCell { scenario, tier, motion, speed_limit_mps }
    })
}

/// Road users move as people do: every pedestrian crosses at
/// [`SLOWEST_CROSSING_MPS`] or faster, comes to rest over
/// [`QUICKEST_STOP_S`] or more, follows another across within
/// [`WIDEST_FOLLOW_S`], no car brakes harder than
/// [`OPEN_ROAD_BRAKE_MPS2`] on an open road, and no car drives faster than
/// the speed limit the scene states. Each figure is printed beside its bar;
/// one outside it fails the line (docs/validate.md gives the sources and
/// the reasons a figure is still outside).
pub fn check_motion(cells: &[MotionCell]) -> Check {
    /// Which way a figure's bar lies.
    enum Bar {
        AtLeast(f64),
        AtMost(f64),
    }
    let mut parts = Vec::new();
    let mut pass = !cells.is_empty();
    // The worst cell's figure against its bar: pass or "outside", printed
    // by `say` (the figure, the cell, the bar's words).
    let mut bound = |figure: fn(&MotionCell) -> Option<f64>, bar: Bar, say: &dyn Fn(f64, &str, &str) -> String| {
        let figures = cells.iter().filter_map(|c| figure(c).map(|v| (v, c)));
        let worst = match bar {
            Bar::AtLeast(_) => figures.min_by(|a, b| a.0.total_cmp(&b.0)),
            Bar::AtMost(_) => figures.max_by(|a, b| a.0.total_cmp(&b.0)),
        };
        if let Some((v, c)) = worst {
            let (ok, words) = match bar {
                Bar::AtLeast(x) => (v + 1e-9 >= x, format!("bar >= {x:.2}")),
                Bar::AtMost(x) => (v <= x + 1e-9, format!("bar <= {x:.2}")),
            };
            pass &= ok;
            let words = if ok { words } else { format!("{words}, outside") };
            parts.push(say(v, &label(c.scenario, c.tier), &words));
        }
    };
    bound(|c| c.motion.slowest_crossing_mps, Bar::AtLeast(SLOWEST_CROSSING_MPS), &|v, at, bar| {
        format!("slowest crossing {v:.2} m/s on {at} ({bar})")
    });
    bound(|c| c.motion.quickest_stop_s, Bar::AtLeast(QUICKEST_STOP_S), &|v, at, bar| {
        format!("quickest stop from walking {v:.2} s on {at} ({bar})")
    });
    bound(|c| c.motion.widest_follow_s, Bar::AtMost(WIDEST_FOLLOW_S), &|v, at, bar| {
        format!("a follower sets out at most {v:.2} s after the one it follows on {at} ({bar})")
    });
    bound(|c| Some(c.motion.open_road_brake_mps2), Bar::AtMost(OPEN_ROAD_BRAKE_MPS2), &|v, at, bar| {
        format!("open-road braking at most {v:.2} m/s^2 on {at} ({bar})")
    });
    let over = cells
        .iter()
        .filter_map(|c| c.motion.fastest_car_mps.map(|v| (v - c.speed_limit_mps, v, c)))
        .max_by(|a, b| a.0.total_cmp(&b.0));
    if let Some((excess, v, c)) = over {
        let ok = excess <= 1e-9;
        pass &= ok;
        parts.push(format!(
            "fastest car {v:.2} m/s on {} (limit {:.1}{})",
            label(c.scenario, c.tier),
            c.speed_limit_mps,
            if ok { "" } else { ", outside" }
        ));
    }
    Check::new("road users move as people", pass, parts.join("; "))
}
