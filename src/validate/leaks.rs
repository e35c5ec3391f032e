//! The lines that keep hidden state hidden: the scene text is the same
//! under both dispositions before the evidence, and carries the public
//! state whole.

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
/// reveal (at least the first). Also collects observations for the round trip.
pub fn check_hidden_disposition(
    set: &ScenarioSet,
    scenarios: &[ScenarioKind],
    tiers: &[Tier],
    seeds: std::ops::Range<u64>,
    text: SceneText,
) -> (Check, Vec<Observation>) {
    let mut compared = 0usize;
    let mut differing = 0usize;
    let mut failures = Vec::new();
    let mut observations = Vec::new();
    for &s in scenarios {
        let [d0, d1] = s.dispositions();
        for &t in tiers {
            for seed in seeds.clone() {
                let config = set.get(s);
                let mut a = Episode::with_disposition(config, t, seed, d0);
                let mut b = Episode::with_disposition(config, t, seed, d1);
                let mut expert = Expert;
                let mut first = true;
                loop {
                    let before_reveal = !a.revealed() && !b.revealed();
                    if first || before_reveal {
                        compared += 1;
                        if text(&a) != text(&b) {
                            differing += 1;
                            if failures.len() < 3 {
                                failures.push(format!("{}/t{t} seed {seed} turn {}", s, a.observation().turn));
                            }
                        }
                    }
                    observations.push(*a.observation());
                    first = false;
                    if a.is_done() || b.is_done() || !before_reveal {
                        break;
                    }
                    let action = expert.act(a.observation());
                    a.step(action);
                    b.step(action);
                }
            }
        }
    }
    let pass = failures.is_empty() && compared > 0;
    let figure = if pass {
        format!("{compared} pre-reveal observations byte-identical under both dispositions")
    } else {
        format!("{differing} of {compared} differ, e.g. {}", failures.join("; "))
    };
    (Check::new("hidden disposition", pass, figure), observations)
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
