//! The conversation a model sees: one system prompt, then one user message
//! per decision carrying the scene text, with the model's earlier answers
//! kept in between.
//!
//! The system prompt itself is [`crate::instructions::SYSTEM_PROMPT`], the
//! one every front end sends.

use crate::instructions::SYSTEM_PROMPT;
use crate::llm::{ChatMessage, Role};
use crate::probe::Probe;
use crate::rundir::HistoryWindow;
use crate::scenario::ScenarioKind;

/// The system prompt of one episode: [`SYSTEM_PROMPT`], plus each probe's
/// paragraph for its scenario (the one composition every front end uses).
pub fn system_prompt(probe: Probe, kind: ScenarioKind) -> String {
    crate::probe::system_prompt(probe, kind)
}

/// The hash of every system prompt a run may send (part of the run's
/// identity): the plain prompt's alone without a probe, so runs made before
/// probes existed keep their hash.
pub fn prompt_hash(probe: Probe) -> String {
    if probe.is_none() {
        return crate::hash::fnv1a64_hex(SYSTEM_PROMPT);
    }
    let all: Vec<String> = ScenarioKind::ALL.iter().map(|&k| system_prompt(probe, k)).collect();
    crate::hash::fnv1a64_hex(&all.join("\u{0}"))
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
            for probe in ["none", "belief", "forecast", "belief,forecast"].map(|p| p.parse::<Probe>().unwrap()) {
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
