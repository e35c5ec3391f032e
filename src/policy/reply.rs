//! A scripted policy's reply to a scene text, as a model would give it:
//! the scene text parsed back into an observation, the policy's action,
//! and the JSON answer a client executes. `serve` answers with it, and
//! `eval`'s dry-run plan shows it as the example answer; it lives below
//! both, so that neither front end reaches into the other.

use super::PolicyKind;
use crate::action::Action;
use crate::hash::{fnv1a64, splitmix64};
use crate::observation::parse_scene;
use serde_json::{Value, json};

/// The scripted model's answer to a scene text.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Answer {
    pub(crate) action: Action,
    /// The `reasoning` field of the reply.
    pub(crate) reasoning: String,
    /// Whether the scene text could be read (else the action is the
    /// conservative stop); counted in `serve`'s count of unreadable scenes.
    pub(crate) scene: SceneRead,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum SceneRead {
    Readable,
    Unreadable,
}

pub(crate) fn answer(policy: PolicyKind, seed: u64, scene_text: &str) -> Answer {
    answer_with_belief(policy, seed, &[], scene_text, None).0
}

/// The answer and, when probing, the stated belief (`ideal`: the ideal
/// observer's belief for this conversation, None when its episode is not
/// known; the expert then states 0.5). `earlier` are the conversation's
/// earlier scenes: a policy with memory (the late expert) is shown them
/// first, in order, so it answers as it would have in one episode.
pub(crate) fn answer_with_belief(
    policy: PolicyKind,
    seed: u64,
    earlier: &[&str],
    scene_text: &str,
    ideal: Option<f64>,
) -> (Answer, f64) {
    match parse_scene(scene_text) {
        Ok(obs) => {
            let mut p = policy.build();
            p.reset(splitmix64(seed ^ fnv1a64(scene_text)));
            let memory = if p.remembers() { earlier } else { &[] };
            for earlier in memory.iter().filter_map(|text| parse_scene(text).ok()) {
                if earlier.scenario() == obs.scenario() && earlier.turn < obs.turn {
                    p.act(&earlier);
                }
            }
            let action = p.act(&obs);
            let belief = p.belief(&obs, &action, ideal.unwrap_or(0.5));
            let answer = Answer {
                action,
                reasoning: format!("{policy} policy at turn {} of {}", obs.turn, obs.turn_budget),
                scene: SceneRead::Readable,
            };
            (answer, belief)
        }
        Err(e) => {
            let answer = Answer {
                action: Action::CONSERVATIVE,
                reasoning: format!("no readable scene ({e}); stopping"),
                scene: SceneRead::Unreadable,
            };
            (answer, 0.5)
        }
    }
}

/// The JSON reply content for an action. Numbers are printed in full
/// (shortest round-trip form), so the client executes exactly this action.
pub(crate) fn action_content(action: &Action, reasoning: &str) -> String {
    action_json(action, reasoning).to_string()
}

pub(crate) fn action_json(action: &Action, reasoning: &str) -> Value {
    json!({
        "reasoning": reasoning,
        "acceleration": action.acceleration,
        "steering": action.steering,
        "maneuver": action.maneuver.name(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unreadable_scene_gets_the_conservative_stop() {
        let a = answer(PolicyKind::Expert, 0, "hello");
        assert_eq!((a.action, a.scene), (Action::CONSERVATIVE, SceneRead::Unreadable));
        assert!(a.reasoning.starts_with("no readable scene"), "{}", a.reasoning);
    }

    #[test]
    fn the_answer_round_trips_through_the_action_parser() {
        use crate::episode::Episode;
        use crate::scenario::{ScenarioConfig, ScenarioKind, Tier};
        for kind in ScenarioKind::ALL {
            let ep = Episode::new(&ScenarioConfig::builtin(kind), Tier::T1, 3);
            let text = crate::observation::render_scene(ep.observation());
            for policy in PolicyKind::ALL {
                let a = answer(policy, 5, &text);
                assert_eq!(a.scene, SceneRead::Readable);
                let parsed = crate::action::parse_action(&action_content(&a.action, &a.reasoning));
                assert!(parsed.is_clean(), "{policy}: {:?}", parsed.errors);
                assert_eq!(parsed.action, a.action);
                // Same scene, same answer (random included).
                assert_eq!(answer(policy, 5, &text), a);
            }
        }
    }
}
