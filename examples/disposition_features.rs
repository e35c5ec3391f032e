//! The feature vectors (env-server's `features` view) a fixed schedule sees
//! under both dispositions of each seed, up to the evidence turn, one JSON
//! line per episode: for checking that a client's surface (the Gymnasium
//! environment) shows nothing of the disposition before the evidence does.
//! `cargo run --release --example disposition_features -- <schedule> <seeds>`
//! plays seeds 0..seeds of every scenario and tier; a schedule is written
//! `maneuver:strength:turns,...` as for `reference_rollouts`.
#[path = "shared/schedule.rs"]
mod schedule;

use negotiator::action::Action;
use negotiator::episode::Episode;
use negotiator::features::features;
use negotiator::scenario::{ScenarioKind, ScenarioSet, Tier};
use std::io::Write;

/// The features seen at every turn of `episode` played with `plan`, and
/// the evidence turn.
fn play(mut episode: Episode, tier: Tier, plan: &[Action]) -> (Vec<Vec<f64>>, Option<u32>) {
    let mut seen = Vec::new();
    while !episode.is_done() {
        let o = episode.observation();
        seen.push(features(&o.rounded(), tier));
        episode.step(plan[(o.turn as usize - 1).min(plan.len() - 1)]);
    }
    (seen, episode.finish().timing.evidence_turn)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let usage = "usage: disposition_features <schedule> <seeds>";
    let (Some(plan), Some(seeds)) =
        (args.get(1).and_then(|s| schedule::parse(s)), args.get(2).and_then(|n| n.parse::<u64>().ok()))
    else {
        eprintln!("{usage}");
        std::process::exit(2);
    };
    let set = ScenarioSet::default();
    let mut out = std::io::stdout().lock();
    for kind in ScenarioKind::ALL {
        for tier in Tier::ALL {
            for seed in 0..seeds {
                let config = set.get(kind);
                let [a, b] = kind.dispositions();
                let (seen_a, evidence_a) = play(Episode::with_disposition(config, tier, seed, a), tier, &plan);
                let (seen_b, evidence_b) = play(Episode::with_disposition(config, tier, seed, b), tier, &plan);
                let line = serde_json::json!({
                    "scenario": kind.name(),
                    "tier": tier.number(),
                    "seed": seed,
                    "dispositions": [a.name(), b.name()],
                    "evidence_turns": [evidence_a, evidence_b],
                    "features": [seen_a, seen_b],
                });
                if writeln!(out, "{line}").is_err() {
                    return;
                }
            }
        }
    }
}
