//! The lines that keep hidden state hidden: the scene text and the
//! scene's picture are the same under both dispositions before the
//! evidence, and the text carries the public state whole.

use super::Check;
use crate::episode::Episode;
use crate::observation::{Observation, parse_scene};
use crate::policy::{Expert, Policy};
use crate::scenario::{ScenarioKind, ScenarioSet, Tier};

/// How the hidden-disposition check turns an episode into the text a model
/// would read. The real one renders the public observation; tests pass a
/// leaky one to see the check fail.
pub type SceneText<'a> = &'a (dyn Fn(&Episode) -> String + Sync);

/// For every seed, play the expert under one disposition, replay its
/// actions under the other, and compare the texts of every turn before the
/// reveal (at least the first). Also collects observations for the round
/// trip. The cells are compared in parallel (the real text includes the
/// scene's picture).
pub fn check_hidden_disposition(
    set: &ScenarioSet,
    scenarios: &[ScenarioKind],
    tiers: &[Tier],
    seeds: std::ops::Range<u64>,
    text: SceneText,
) -> (Check, Vec<Observation>) {
    let cells: Vec<(ScenarioKind, Tier)> = scenarios.iter().flat_map(|&s| tiers.iter().map(move |&t| (s, t))).collect();
    let compared_cells = crate::par::par_map(&cells, |&(s, t)| compare_cell(set, s, t, seeds.clone(), text));
    let (mut compared, mut differing) = (0usize, 0usize);
    let mut failures = Vec::new();
    let mut observations = Vec::new();
    for cell in compared_cells {
        compared += cell.compared;
        differing += cell.differing;
        failures.extend(cell.failures);
        observations.extend(cell.observations);
    }
    failures.truncate(3);
    let pass = failures.is_empty() && compared > 0;
    let figure = if pass {
        format!("{compared} pre-reveal observations byte-identical under both dispositions")
    } else {
        format!("{differing} of {compared} differ, e.g. {}", failures.join("; "))
    };
    (Check::new("hidden disposition", pass, figure), observations)
}

/// What one (scenario, tier) cell's comparison found.
struct Compared {
    compared: usize,
    differing: usize,
    failures: Vec<String>,
    observations: Vec<Observation>,
}

fn compare_cell(set: &ScenarioSet, s: ScenarioKind, t: Tier, seeds: std::ops::Range<u64>, text: SceneText) -> Compared {
    let mut c = Compared { compared: 0, differing: 0, failures: Vec::new(), observations: Vec::new() };
    let [d0, d1] = s.dispositions();
    for seed in seeds {
        let config = set.get(s);
        let mut a = Episode::with_disposition(config, t, seed, d0);
        let mut b = Episode::with_disposition(config, t, seed, d1);
        let mut expert = Expert;
        let mut first = true;
        loop {
            let before_reveal = !a.revealed() && !b.revealed();
            if first || before_reveal {
                c.compared += 1;
                if text(&a) != text(&b) {
                    c.differing += 1;
                    if c.failures.len() < 3 {
                        c.failures.push(format!("{}/t{t} seed {seed} turn {}", s, a.observation().turn));
                    }
                }
            }
            c.observations.push(*a.observation());
            first = false;
            if a.is_done() || b.is_done() || !before_reveal {
                break;
            }
            let action = expert.act(a.observation());
            a.step(action);
            b.step(action);
        }
    }
    c
}

/// Parsing the rendered text gives back the observation, to the printed
/// precision.
pub fn check_round_trip(observations: &[Observation], render: &dyn Fn(&Observation) -> String) -> Check {
    let mut bad = 0usize;
    let mut example = String::new();
    for o in observations {
        let ok = match parse_scene(&render(o)) {
            Ok(parsed) => parsed == o.rounded(),
            Err(e) => {
                if example.is_empty() {
                    example = e.to_string();
                }
                false
            }
        };
        if !ok {
            bad += 1;
            if example.is_empty() {
                example = format!("{} turn {}", o.scenario(), o.turn);
            }
        }
    }
    Check::new(
        "text carries the state",
        bad == 0 && !observations.is_empty(),
        if bad == 0 {
            format!("{} observations round-trip through the scene text", observations.len())
        } else {
            format!("{bad} of {} do not round-trip, e.g. {example}", observations.len())
        },
    )
}
