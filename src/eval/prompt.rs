//! The conversation a model sees: one system prompt, then one user message
//! per decision carrying the scene text, with the model's earlier answers
//! kept in between.
//!
//! The system prompt explains the task, the answer format and the controller
//! mapping of [`crate::action::Action::control`]. It says nothing about the
//! other road user's possible intentions or how they show: inferring them is
//! the task.

use crate::belief::Probe;
use crate::llm::{ChatMessage, Role};
use crate::rundir::HistoryWindow;
use crate::scenario::ScenarioKind;

pub const SYSTEM_PROMPT: &str = "\
You are the driver of an automated car (the ego vehicle) in a short traffic situation. \
Each turn you receive a description of the scene: your own speed, acceleration and distances, \
and the recent positions and speeds of the other road users. You cannot see what the others \
intend; you can only judge from how they move. Your goal is to reach your goal position without \
a collision, and without waiting needlessly: the episode ends when you reach the goal, when you \
collide, or when the turns run out. Running out of turns is a failure (scored only by how far you \
got, always below any success); a collision is the worst outcome. A collision is any overlap of \
your car's body with another road user's body (cars are 4.8 m long and 1.9 m wide, a pedestrian \
0.6 m across), checked every 0.1 s.

Every turn, answer with exactly one JSON object and nothing else:
{\"reasoning\": \"<one or two short sentences>\", \"maneuver\": \"<proceed | yield | stop | nudge_forward>\", \"acceleration\": <number from -1 to 1>, \"steering\": 0.0}

The maneuver selects how your car is controlled; the magnitude |acceleration| (0 to 1) sets \
how strongly, linearly inside that maneuver's band (a = |acceleration|):
- proceed: go on toward the speed limit, accelerating at 3.0 x a m/s^2: 0 holds your current speed, 1 accelerates at 3.0 m/s^2.
- nudge_forward: creep toward 2.0 m/s, accelerating at 0.5 + 1.0 x a m/s^2, or braking at 2.0 + 2.0 x a m/s^2 if faster.
- yield: slow down toward a stop, braking at 0.5 + 3.5 x a m/s^2.
- stop: brake to a stop, at 4.0 + 4.0 x a m/s^2.
The sign of acceleration does not matter, and steering is ignored (you stay on your path). \
Each answer is held for 0.5 s, then you get the next scene. An answer that cannot be read as \
this JSON object is executed as a firm stop.";

/// The system prompt of one episode: [`SYSTEM_PROMPT`], plus the belief
/// question of its scenario when the run probes beliefs.
pub fn system_prompt(probe: Probe, kind: ScenarioKind) -> String {
    match probe {
        Probe::None => SYSTEM_PROMPT.to_string(),
        Probe::Belief => format!("{SYSTEM_PROMPT}{}", crate::belief::prompt_paragraph(kind)),
    }
}

/// The hash of every system prompt a run may send (part of the run's
/// identity): the plain prompt's alone without a probe, so runs made before
/// probes existed keep their hash.
pub fn prompt_hash(probe: Probe) -> String {
    match probe {
        Probe::None => crate::hash::fnv1a64_hex(SYSTEM_PROMPT),
        Probe::Belief => {
            let all: Vec<String> = ScenarioKind::ALL.iter().map(|&k| system_prompt(probe, k)).collect();
            crate::hash::fnv1a64_hex(&all.join("\u{0}"))
        }
    }
}

/// The conversation so far: earlier (scene, answer) pairs.
#[derive(Debug, Default)]
pub struct History {
    turns: Vec<(ChatMessage, ChatMessage)>,
}

impl History {
    pub fn push(&mut self, scene: ChatMessage, answer: ChatMessage) {
        self.turns.push((scene, answer));
    }

    /// The messages of the next request: the system prompt, the earlier
    /// turns the window keeps, then the new scene. Borrowed, so a long
    /// history is never copied per request.
    pub fn messages<'a>(
        &'a self,
        system: &'a ChatMessage,
        window: HistoryWindow,
        scene: &'a ChatMessage,
    ) -> Vec<&'a ChatMessage> {
        let keep = match window {
            HistoryWindow::Full => self.turns.len(),
            HistoryWindow::Last(k) => k.min(self.turns.len()),
        };
        let mut out = Vec::with_capacity(2 + 2 * keep);
        out.push(system);
        for (u, a) in &self.turns[self.turns.len() - keep..] {
            out.push(u);
            out.push(a);
        }
        out.push(scene);
        out
    }
}

/// What goes back into the history for a reply: the answer with any
/// `<think>` block removed (reasoning is never sent back). An empty reply
/// stays in the conversation as a visible placeholder, since several
/// providers reject empty assistant messages.
pub fn history_answer(answer: &str) -> ChatMessage {
    let trimmed = answer.trim();
    ChatMessage::new(Role::Assistant, if trimmed.is_empty() { "(no answer)" } else { trimmed })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn history(n: usize) -> History {
        let mut h = History::default();
        for i in 0..n {
            h.push(
                ChatMessage::new(Role::User, format!("scene {i}")),
                ChatMessage::new(Role::Assistant, format!("answer {i}")),
            );
        }
        h
    }

    fn texts(msgs: &[&ChatMessage]) -> Vec<String> {
        msgs.iter().map(|m| m.content.clone()).collect()
    }

    #[test]
    fn full_history_keeps_every_turn_in_order() {
        let h = history(3);
        let sys = ChatMessage::new(Role::System, "sys");
        let now = ChatMessage::new(Role::User, "scene 3");
        let m = h.messages(&sys, HistoryWindow::Full, &now);
        assert_eq!(texts(&m), ["sys", "scene 0", "answer 0", "scene 1", "answer 1", "scene 2", "answer 2", "scene 3"]);
        assert_eq!(m[2].role, Role::Assistant);
    }

    #[test]
    fn last_k_trims_old_turns() {
        let h = history(5);
        let sys = ChatMessage::new(Role::System, "sys");
        let now = ChatMessage::new(Role::User, "scene 5");
        assert_eq!(
            texts(&h.messages(&sys, HistoryWindow::Last(2), &now)),
            ["sys", "scene 3", "answer 3", "scene 4", "answer 4", "scene 5"]
        );
        assert_eq!(texts(&h.messages(&sys, HistoryWindow::Last(0), &now)), ["sys", "scene 5"]);
        assert_eq!(h.messages(&sys, HistoryWindow::Last(99), &now).len(), 12);
        assert_eq!(texts(&History::default().messages(&sys, HistoryWindow::Last(2), &now)), ["sys", "scene 5"]);
    }

    #[test]
    fn the_prompt_hints_at_no_disposition() {
        assert_eq!(crate::belief::check_neutral(SYSTEM_PROMPT), Ok(()));
        for kind in crate::scenario::ScenarioKind::ALL {
            for probe in [Probe::None, Probe::Belief] {
                assert_eq!(crate::belief::check_neutral(&system_prompt(probe, kind)), Ok(()), "{kind} {probe:?}");
            }
        }
        for m in crate::action::Maneuver::ALL {
            assert!(SYSTEM_PROMPT.contains(m.name()), "{m}");
        }
    }

    #[test]
    fn answers_go_back_without_reasoning_or_emptiness() {
        assert_eq!(history_answer("  {\"a\":1} ").content, "{\"a\":1}");
        assert_eq!(history_answer("").content, "(no answer)");
    }
}
