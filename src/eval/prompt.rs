//! The conversation a model sees: one system prompt, then one user message
//! per decision carrying the scene (its text, its picture, or both), with
//! the model's earlier answers kept in between.
//!
//! The system prompt itself is [`crate::instructions::system_prompt`], the
//! one every front end sends.

use crate::llm::{ChatMessage, ImageUrl, Role};
use crate::observation::{Observation, render_scene};
use crate::probe::Probe;
use crate::rundir::{HistoryWindow, ObservationMode, PictureSettings};
use crate::scenario::ScenarioKind;
use std::sync::Arc;

/// The system prompt of one episode: [`SYSTEM_PROMPT`], plus each probe's
/// paragraph for its scenario and the picture's (the one composition every
/// front end uses).
pub fn system_prompt(probe: Probe, kind: ScenarioKind, observation: ObservationMode) -> String {
    crate::instructions::system_prompt(probe, kind, observation)
}

/// Why a scene could not be put into a message.
#[derive(Debug, thiserror::Error)]
#[error("the scene's picture: {0}")]
pub struct SceneError(#[from] crate::picture::PictureError);

/// One decision's user message, and what stands in for it once the image
/// history has moved past it (the same message without a picture).
#[derive(Debug, Clone)]
pub struct SceneMessage {
    /// The scene text (what a record keeps, whatever the model was shown).
    pub scene: String,
    pub message: ChatMessage,
    pub without_picture: Option<ChatMessage>,
}

impl SceneMessage {
    /// The scene as the run shows it: its text (no picture settings), or
    /// its picture with one line (`image`) or beside the text (`both`).
    pub fn new(obs: &Observation, pictures: Option<PictureSettings>) -> Result<SceneMessage, SceneError> {
        SceneMessage::build(obs, pictures, true)
    }

    /// The same message with an empty picture (nothing drawn), for counting
    /// a request's text and pictures (`eval --dry-run` plays thousands).
    pub fn for_counting(obs: &Observation, pictures: Option<PictureSettings>) -> SceneMessage {
        SceneMessage::build(obs, pictures, false).expect("nothing is drawn")
    }

    fn build(obs: &Observation, pictures: Option<PictureSettings>, draw: bool) -> Result<SceneMessage, SceneError> {
        let scene = render_scene(obs);
        let Some(p) = pictures.filter(|p| p.observation != ObservationMode::Text) else {
            return Ok(SceneMessage {
                message: ChatMessage::new(Role::User, scene.clone()),
                scene,
                without_picture: None,
            });
        };
        let image = Arc::new(match draw {
            true => ImageUrl::png(&crate::picture::png(obs)?, p.detail.name()),
            false => ImageUrl::new("", p.detail.name()),
        });
        let (text, placeholder) = match p.observation {
            ObservationMode::Both => (scene.clone(), scene.clone()),
            _ => (
                crate::picture::user_line(obs),
                format!("Turn {} of {}: (its picture is no longer shown)", obs.turn, obs.turn_budget),
            ),
        };
        Ok(SceneMessage {
            scene,
            message: ChatMessage::new(Role::User, text).with_image(image),
            without_picture: Some(ChatMessage::new(Role::User, placeholder)),
        })
    }
}

/// The conversation so far: earlier (scene, answer) pairs.
#[derive(Debug, Default)]
pub struct History {
    turns: Vec<(SceneMessage, ChatMessage)>,
}

impl History {
    pub fn push(&mut self, scene: SceneMessage, answer: ChatMessage) {
        self.turns.push((scene, answer));
    }

    /// The messages of the next request: the system prompt, the earlier
    /// turns the window keeps, then the new scene. With an image history
    /// of K, only the last K user turns (the new one included) carry their
    /// picture; older ones carry what stands in for it. Borrowed, so a long
    /// history is never copied per request.
    pub fn messages<'a>(
        &'a self,
        system: &'a ChatMessage,
        window: HistoryWindow,
        image_history: Option<u32>,
        scene: &'a ChatMessage,
    ) -> Vec<&'a ChatMessage> {
        let keep = match window {
            HistoryWindow::Full => self.turns.len(),
            HistoryWindow::Last(k) => k.min(self.turns.len()),
        };
        // Earlier turns that keep their picture: K - 1 (the new one is the K-th).
        let pictured = image_history.map_or(usize::MAX, |k| (k as usize).saturating_sub(1));
        let mut out = Vec::with_capacity(2 + 2 * keep);
        out.push(system);
        for (i, (u, a)) in self.turns[self.turns.len() - keep..].iter().enumerate() {
            let from_end = keep - i;
            out.push(match &u.without_picture {
                Some(stand_in) if from_end > pictured => stand_in,
                _ => &u.message,
            });
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
    use crate::instructions::{SYSTEM_PROMPT, prompt_hash};

    fn history(n: usize) -> History {
        let mut h = History::default();
        for i in 0..n {
            h.push(
                SceneMessage {
                    scene: format!("scene {i}"),
                    message: ChatMessage::new(Role::User, format!("scene {i}")),
                    without_picture: None,
                },
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
        let m = h.messages(&sys, HistoryWindow::Full, None, &now);
        assert_eq!(texts(&m), ["sys", "scene 0", "answer 0", "scene 1", "answer 1", "scene 2", "answer 2", "scene 3"]);
        assert_eq!(m[2].role, Role::Assistant);
    }

    #[test]
    fn last_k_trims_old_turns() {
        let h = history(5);
        let sys = ChatMessage::new(Role::System, "sys");
        let now = ChatMessage::new(Role::User, "scene 5");
        assert_eq!(
            texts(&h.messages(&sys, HistoryWindow::Last(2), None, &now)),
            ["sys", "scene 3", "answer 3", "scene 4", "answer 4", "scene 5"]
        );
        assert_eq!(texts(&h.messages(&sys, HistoryWindow::Last(0), None, &now)), ["sys", "scene 5"]);
        assert_eq!(h.messages(&sys, HistoryWindow::Last(99), None, &now).len(), 12);
        assert_eq!(texts(&History::default().messages(&sys, HistoryWindow::Last(2), None, &now)), ["sys", "scene 5"]);
    }

    #[test]
    fn the_prompt_hints_at_no_disposition() {
        assert_eq!(crate::belief::check_neutral(SYSTEM_PROMPT), Ok(()));
        for kind in crate::scenario::ScenarioKind::ALL {
            for probe in ["none", "belief", "forecast", "belief,forecast"].map(|p| p.parse::<Probe>().unwrap()) {
                for seen in [ObservationMode::Text, ObservationMode::Image, ObservationMode::Both] {
                    let prompt = system_prompt(probe, kind, seen);
                    assert_eq!(crate::belief::check_neutral(&prompt), Ok(()), "{kind} {probe:?} {seen}");
                }
            }
        }
        for m in crate::action::Maneuver::ALL {
            assert!(SYSTEM_PROMPT.contains(m.name()), "{m}");
        }
    }

    #[test]
    fn every_observation_has_its_own_prompt_hash() {
        let hashes: std::collections::BTreeSet<String> =
            [ObservationMode::Text, ObservationMode::Image, ObservationMode::Both]
                .into_iter()
                .flat_map(|o| [prompt_hash(Probe::NONE, o), prompt_hash(Probe::BELIEF, o)])
                .collect();
        assert_eq!(hashes.len(), 6);
        assert_eq!(prompt_hash(Probe::NONE, ObservationMode::Text), crate::hash::fnv1a64_hex(SYSTEM_PROMPT));
    }

    /// With `--image-history K`, the last K user turns (the new one
    /// included) carry their picture; older ones carry their stand-in.
    #[test]
    fn the_image_history_keeps_pictures_in_the_last_k_user_turns() {
        let set = crate::scenario::ScenarioSet::default();
        let mut episode = crate::episode::Episode::new(set.get(ScenarioKind::ALL[0]), crate::scenario::Tier::T1, 3);
        let settings = |mode, history| {
            Some(PictureSettings { observation: mode, detail: crate::rundir::ImageDetail::Low, history })
        };
        for (mode, history) in [(ObservationMode::Image, Some(2)), (ObservationMode::Both, Some(1))] {
            let mut h = History::default();
            let mut scenes = Vec::new();
            for i in 0..4 {
                let scene = SceneMessage::new(episode.observation(), settings(mode, history)).unwrap();
                scenes.push(scene.clone());
                if i < 3 {
                    h.push(scene, ChatMessage::new(Role::Assistant, format!("answer {i}")));
                    episode.step(crate::action::Action::new(crate::action::Maneuver::Yield, 0.3));
                }
            }
            let sys = ChatMessage::new(Role::System, "sys");
            let now = &scenes[3].message;
            let sent = h.messages(&sys, HistoryWindow::Full, history, now);
            let users: Vec<&&ChatMessage> = sent.iter().filter(|m| m.role == Role::User).collect();
            let with_picture: Vec<bool> = users.iter().map(|m| m.image.is_some()).collect();
            let k = history.unwrap() as usize;
            assert_eq!(with_picture, (0..4).map(|i| i >= 4 - k).collect::<Vec<_>>(), "{mode}");
            // The stand-in: the text under `both`, a placeholder naming the turn under `image`.
            let old = users[0];
            match mode {
                ObservationMode::Both => assert_eq!(old.content, scenes[0].message.content),
                _ => {
                    assert!(old.content.starts_with("Turn 1 of ") && !old.content.contains("Scene:"), "{}", old.content)
                }
            }
            // Sent as content parts: the picture first, then the text.
            let json = serde_json::to_value(now).unwrap();
            assert_eq!(json["content"][0]["type"], "image_url");
            assert!(
                json["content"][0]["image_url"]["url"].as_str().unwrap().starts_with("data:image/png;base64,iVBOR")
            );
            assert_eq!(json["content"][0]["image_url"]["detail"], "low");
            assert_eq!(json["content"][1]["type"], "text");
            assert!(serde_json::to_value(old).unwrap()["content"].is_string());
        }
    }

    #[test]
    fn answers_go_back_without_reasoning_or_emptiness() {
        assert_eq!(history_answer("  {\"a\":1} ").content, "{\"a\":1}");
        assert_eq!(history_answer("").content, "(no answer)");
    }
}
