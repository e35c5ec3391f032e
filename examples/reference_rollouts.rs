//! Reference rollouts from the Rust episode loop, one JSON line per
//! episode, for checking other front ends against it (see
//! `scripts/openenv_check.sh`).
//! `cargo run --release --example reference_rollouts -- <policy|schedule> <seeds>`
//! plays seeds 0..seeds of every scenario and tier; a schedule is written
//! `maneuver:strength:turns,...` (the last entry repeats) and acts on the
//! turn alone.
#[path = "shared/schedule.rs"]
mod schedule;

use negotiator::action::Action;
use negotiator::episode::run_episode;
use negotiator::observation::Observation;
use negotiator::policy::{Policy, PolicyKind};
use negotiator::scenario::{ScenarioKind, ScenarioSet, Tier};
use std::io::Write;

struct Schedule(Vec<Action>);

impl Policy for Schedule {
    fn act(&mut self, o: &Observation) -> Action {
        self.0[(o.turn as usize - 1).min(self.0.len() - 1)]
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let usage = "usage: reference_rollouts <policy|schedule> <seeds>";
    let (Some(which), Some(seeds)) = (args.get(1), args.get(2).and_then(|n| n.parse::<u64>().ok())) else {
        eprintln!("{usage}");
        std::process::exit(2);
    };
    let build = || -> Box<dyn Policy> {
        match which.parse::<PolicyKind>() {
            Ok(kind) => kind.build(),
            Err(_) => Box::new(schedule::parse(which).map(Schedule).unwrap_or_else(|| {
                eprintln!("{usage}: '{which}' is neither a policy nor a schedule");
                std::process::exit(2)
            })),
        }
    };
    let set = ScenarioSet::default();
    let mut out = std::io::stdout().lock();
    for kind in ScenarioKind::ALL {
        for tier in Tier::ALL {
            for seed in 0..seeds {
                let mut policy = build();
                let record = run_episode(set.get(kind), tier, seed, policy.as_mut());
                let line = serde_json::json!({
                    "scenario": kind.name(),
                    "tier": tier.number(),
                    "seed": seed,
                    "outcome": record.outcome.name(),
                    "reward": record.grades.reward,
                    "decisions": record.decisions.len(),
                    "disposition": record.disposition.name(),
                });
                // A closed pipe (`| head`) ends the listing quietly.
                if writeln!(out, "{line}").is_err() {
                    return;
                }
            }
        }
    }
}
