//! The person at the terminal as an OpenAI-compatible chat endpoint, in
//! process: `eval` sends it the conversation exactly as it sends a model's
//! endpoint, the last user message (the scene) goes to the screen, and the
//! person's answer comes back as the reply. So a person plays through the
//! very code a model plays through: the same `Episode`, prompt, parser,
//! records, resume and summary.

use axum::Json;
use axum::extract::State;
use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};
use serde_json::{Value, json};
use std::sync::Arc;
use std::sync::mpsc::Sender;
use std::time::Duration;
use tokio::sync::oneshot;

/// The reply when a timed turn runs out before any answer: the firm stop
/// an unreadable answer drives as.
pub(crate) const FIRM_STOP: &str = r#"{"maneuver": "stop", "acceleration": 0.5}"#;

/// One turn waiting for the person.
#[derive(Debug)]
pub(crate) struct Prompt {
    /// The scene text, exactly the user message the model receives.
    pub scene: String,
    /// Told when the scene is on the screen: a timed turn's clock starts
    /// then, not while an "episode over" notice is still up.
    pub shown: Option<oneshot::Sender<()>>,
    pub answer: oneshot::Sender<String>,
}

/// What the screen is told.
#[derive(Debug)]
pub(crate) enum ToScreen {
    Prompt(Prompt),
    /// The clock ran out: the last answer (or a firm stop) was sent.
    TimedOut {
        held: String,
    },
    /// How many episodes the run selects, and how many were already played.
    Planned {
        selected: usize,
        finished: usize,
    },
    EpisodeOver {
        key: crate::rundir::record::EpisodeKey,
        outcome: crate::episode::Outcome,
        reward: f64,
    },
    /// The run is over (finished, or stopped and saved).
    RunOver,
}

pub(crate) struct EndpointState {
    pub screen: Sender<ToScreen>,
    pub turn_seconds: Option<f64>,
    /// `--view picture`: where each turn's picture is written (the screen
    /// names the file; an image viewer that reloads shows it).
    pub picture_file: Option<std::path::PathBuf>,
}

pub(crate) fn router(state: Arc<EndpointState>) -> axum::Router {
    axum::Router::new()
        .route("/v1/chat/completions", axum::routing::post(chat))
        .layer(axum::extract::DefaultBodyLimit::max(64 << 20))
        .with_state(state)
}

/// The text of the last message of `role`: a string, or its text parts.
fn content_of(messages: &[Value], role: &str) -> Option<String> {
    let content = &messages.iter().rev().find(|m| m["role"] == role)?["content"];
    match content {
        Value::String(s) => Some(s.clone()),
        Value::Array(parts) => Some(parts.iter().filter_map(|p| p["text"].as_str()).collect::<Vec<_>>().join("\n")),
        _ => None,
    }
}

/// The picture of the last user message (its PNG), if it has one.
fn picture_of(messages: &[Value]) -> Option<Vec<u8>> {
    use base64::Engine;
    let content = &messages.iter().rev().find(|m| m["role"] == "user")?["content"];
    let url = content.as_array()?.iter().find_map(|p| p["image_url"]["url"].as_str())?;
    base64::engine::general_purpose::STANDARD.decode(url.strip_prefix("data:image/png;base64,")?).ok()
}

async fn chat(State(state): State<Arc<EndpointState>>, Json(body): Json<Value>) -> Response {
    let messages = body["messages"].as_array().map(Vec::as_slice).unwrap_or_default();
    let Some(mut scene) = content_of(messages, "user") else {
        return (StatusCode::BAD_REQUEST, Json(json!({"error": {"message": "no user message"}}))).into_response();
    };
    // The picture goes to its file, whole or not at all, before the line
    // naming it is shown.
    if let (Some(path), Some(png)) = (&state.picture_file, picture_of(messages)) {
        match crate::atomic::write(path, &png) {
            Ok(()) => {
                scene.push_str(&format!("\nPicture: {} (this turn's; it is rewritten every turn)", path.display()))
            }
            Err(e) => scene.push_str(&format!("\nPicture: could not be written to {} ({e})", path.display())),
        }
    }
    // The answer held when a timed turn runs out: the last one given.
    let held = content_of(messages, "assistant").unwrap_or_else(|| FIRM_STOP.to_string());
    let (tx, rx) = oneshot::channel();
    let (shown_tx, shown_rx) = oneshot::channel();
    let prompt = Prompt { scene, shown: Some(shown_tx), answer: tx };
    if state.screen.send(ToScreen::Prompt(prompt)).is_err() {
        return StatusCode::SERVICE_UNAVAILABLE.into_response();
    }
    let reply = match state.turn_seconds {
        None => rx.await.ok(),
        Some(_) if shown_rx.await.is_err() => None,
        Some(s) => match tokio::time::timeout(Duration::from_secs_f64(s), rx).await {
            Ok(answer) => answer.ok(),
            Err(_) => {
                let _ = state.screen.send(ToScreen::TimedOut { held: held.clone() });
                Some(held)
            }
        },
    };
    // No answer: the person quit, and the run is being stopped.
    let Some(reply) = reply else { return StatusCode::SERVICE_UNAVAILABLE.into_response() };
    Json(json!({
        "id": "human",
        "object": "chat.completion",
        "model": body["model"],
        "choices": [{"index": 0, "message": {"role": "assistant", "content": reply}, "finish_reason": "stop"}],
        "usage": {"prompt_tokens": 0, "completion_tokens": 0, "total_tokens": 0},
    }))
    .into_response()
}
