//! The lines read off the baseline grid: the expert solves every cell,
//! beats every state-ignorant policy, the tiers bite, the reward orders
//! the outcomes, correctness is honest, and caution is not punished.

use super::{
    ANTI_GAMING_MARGIN, BITE_MARGIN, CAUTIOUS_COLLISION, CAUTIOUS_SUCCESS, CONSTANT_CORRECTNESS, Check,
    EXPERT_CORRECTNESS, SOLVABLE_ANY, SOLVABLE_TIER1, TIER1_CUE_FOLLOWER_WITHIN, cell_keys, find, label,
};
use crate::baselines::CellSummary;
use crate::episode::Outcome;
use crate::policy::PolicyKind;
use crate::scenario::Tier;

/// Expert success >= 0.95 on tier 1 and >= 0.85 on every tier.
pub fn check_solvable(cells: &[CellSummary]) -> Check {
    let mut worst: Option<(f64, String)> = None;
    let mut pass = true;
    for (s, t) in cell_keys(cells) {
        let Some(e) = find(cells, s, t, PolicyKind::Expert) else { continue };
        let bar = if t == Tier::T1 { SOLVABLE_TIER1 } else { SOLVABLE_ANY };
        let slack = e.success.estimate - bar;
        pass &= slack >= 0.0;
        if worst.as_ref().is_none_or(|(w, _)| slack < *w) {
            worst =
                Some((slack, format!("expert success {:.3} on {} (bar {bar:.2})", e.success.estimate, label(s, t))));
        }
    }
    Check::new(
        "solvable",
        pass && worst.is_some(),
        worst.map_or("no expert cells".into(), |w| format!("lowest: {}", w.1)),
    )
}

/// On every cell the expert beats every state-ignorant policy by >= 0.30.
pub fn check_anti_gaming(cells: &[CellSummary]) -> Check {
    let mut worst: Option<(f64, String)> = None;
    for (s, t) in cell_keys(cells) {
        let Some(e) = find(cells, s, t, PolicyKind::Expert) else { continue };
        for p in PolicyKind::STATE_IGNORANT {
            let Some(c) = find(cells, s, t, p) else { continue };
            let margin = e.success.estimate - c.success.estimate;
            if worst.as_ref().is_none_or(|(w, _)| margin < *w) {
                worst = Some((margin, format!("expert - {p} = {margin:.3} on {}", label(s, t))));
            }
        }
    }
    let pass = worst.as_ref().is_some_and(|(m, _)| *m >= ANTI_GAMING_MARGIN);
    Check::new(
        "anti-gaming",
        pass,
        worst.map_or("no cells".into(), |w| format!("smallest margin: {} (bar {ANTI_GAMING_MARGIN:.2})", w.1)),
    )
}

/// On tier 3 (bluff / pause-then-dart / merge bluff) the cue follower is
/// >= 0.30 below the expert; on tier 1 it is within 0.20.
pub fn check_tiers_bite(cells: &[CellSummary]) -> Check {
    let mut pass = true;
    let mut parts = Vec::new();
    let mut seen = false;
    for (s, t) in cell_keys(cells) {
        if t == Tier::T2 {
            continue;
        }
        let (Some(e), Some(c)) = (find(cells, s, t, PolicyKind::Expert), find(cells, s, t, PolicyKind::CueFollower))
        else {
            continue;
        };
        seen = true;
        let gap = e.success.estimate - c.success.estimate;
        let ok = if t == Tier::T3 { gap >= BITE_MARGIN } else { gap <= TIER1_CUE_FOLLOWER_WITHIN };
        pass &= ok;
        parts.push(format!("{} {gap:+.2}", label(s, t)));
    }
    Check::new(
        "tiers bite",
        pass && seen,
        format!(
            "expert - cue_follower: {} (tier 3 >= {BITE_MARGIN:.2}, tier 1 <= {TIER1_CUE_FOLLOWER_WITHIN:.2})",
            parts.join(", ")
        ),
    )
}

/// Every collision < every timeout < every success, over all episodes.
pub fn check_reward_ordering(cells: &[CellSummary]) -> Check {
    let agg = |o: Outcome| {
        cells
            .iter()
            .map(|c| c.span(o))
            .filter(|s| s.count > 0)
            .fold((f64::INFINITY, f64::NEG_INFINITY, 0usize), |acc, s| {
                (acc.0.min(s.min), acc.1.max(s.max), acc.2 + s.count)
            })
    };
    let (_, c_max, c_n) = agg(Outcome::Collision);
    let (t_min, t_max, t_n) = agg(Outcome::Timeout);
    let (s_min, _, s_n) = agg(Outcome::Success);
    // Compare only outcomes that occurred.
    let collision_below = c_n == 0 || (t_n > 0 && c_max < t_min) || (t_n == 0 && (s_n == 0 || c_max < s_min));
    let timeout_below = t_n == 0 || s_n == 0 || t_max < s_min;
    Check::new(
        "reward ordering",
        collision_below && timeout_below && c_n + t_n + s_n > 0,
        format!(
            "collision max {c_max:.3} < timeout [{t_min:.3}, {t_max:.3}] < success min {s_min:.3} over {} episodes",
            c_n + t_n + s_n
        ),
    )
}

/// Expert decision correctness >= 0.90 and every constant policy <= 0.60,
/// on every cell (the searched blind policies are held to the same bar by
/// [`super::check_blind_play_loses`]).
pub fn check_correctness(cells: &[CellSummary]) -> Check {
    let mut expert_min = f64::INFINITY;
    let mut constant_max = f64::NEG_INFINITY;
    let mut where_e = String::new();
    let mut where_c = String::new();
    for c in cells {
        let dc = c.decision_correctness.estimate;
        if c.cell.policy == PolicyKind::Expert && dc < expert_min {
            expert_min = dc;
            where_e = label(c.cell.scenario, c.cell.tier);
        }
        if PolicyKind::CONSTANT.contains(&c.cell.policy) && dc > constant_max {
            constant_max = dc;
            where_c = format!("{} on {}", c.cell.policy, label(c.cell.scenario, c.cell.tier));
        }
    }
    Check::new(
        "correctness honest",
        expert_min >= EXPERT_CORRECTNESS && constant_max <= CONSTANT_CORRECTNESS,
        format!(
            "expert min {expert_min:.3} ({where_e}, bar {EXPERT_CORRECTNESS:.2}); constant max {constant_max:.3} ({where_c}, bar {CONSTANT_CORRECTNESS:.2})"
        ),
    )
}

/// Caution is not a misreading: the expert's own rules driven with caution
/// while unsure (`expert_cautious`, `expert_hedge`) succeed >= 0.85 on every
/// cell with collisions <= 0.02. Hedging may cost reward, never the episode.
pub fn check_caution(cells: &[CellSummary]) -> Check {
    let mut pass = true;
    let mut seen = false;
    let mut worst: Option<(f64, String)> = None;
    let mut worst_collision: Option<(f64, String)> = None;
    // The scenario of each cell below a bar, and how many cells in all.
    let (mut below, mut total) = (Vec::new(), 0usize);
    for c in cells.iter().filter(|c| PolicyKind::CAUTIOUS_READERS.contains(&c.cell.policy)) {
        seen = true;
        total += 1;
        let (s, k) = (c.success.estimate, c.collision.estimate);
        let holds = s >= CAUTIOUS_SUCCESS && k <= CAUTIOUS_COLLISION;
        pass &= holds;
        if !holds {
            below.push(c.cell.scenario);
        }
        let at = format!("{} on {}", c.cell.policy, label(c.cell.scenario, c.cell.tier));
        if worst.as_ref().is_none_or(|(w, _)| s < *w) {
            worst = Some((s, at.clone()));
        }
        if worst_collision.as_ref().is_none_or(|(w, _)| k > *w) {
            worst_collision = Some((k, at));
        }
    }
    let figure = match (worst, worst_collision) {
        (Some(s), Some(k)) => {
            let cells_below = below.len();
            below.sort();
            below.dedup();
            let where_below = if below.is_empty() {
                String::new()
            } else {
                format!(" (all on {})", below.iter().map(ToString::to_string).collect::<Vec<_>>().join(", "))
            };
            format!(
                "lowest success {:.3} ({}, bar {CAUTIOUS_SUCCESS:.2}); highest collision {:.3} ({}, bar {CAUTIOUS_COLLISION:.2}); {} of {total} cells below a bar{where_below}",
                s.0, s.1, k.0, k.1, cells_below
            )
        }
        _ => "no cautious cells".into(),
    };
    Check::new("caution not punished", pass && seen, figure)
}
