//! The HTTP endpoints: `POST /reset`, `POST /step` and `GET /state` (an
//! episode held under its `episode_id`, so that a client without
//! WebSockets can play a whole one), the bearer-token check, and reading a
//! body under the read deadline and the size limit. Requests are checked by
//! [`super::request`], as the WebSocket's messages are; an error is
//! FastAPI's 422 with each field located in the body.

use super::request::{FieldError, Names, clip, located};
use super::session::{ResetRequest, Session, SessionError};
use super::{AtCapacity, EnvServerState, HttpEpisode};
use axum::body::Bytes;
use axum::extract::{Query, State};
use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};
use serde_json::{Map, Value, json};
use std::sync::Arc;
use std::sync::atomic::Ordering::Relaxed;
use std::time::Instant;

/// With `--token-var`, every request but `/health` (a probe's) carries
/// `Authorization: Bearer TOKEN`; others get 401 with OpenEnv's JSON error.
pub(super) async fn require_token(
    State(state): State<Arc<EnvServerState>>,
    request: axum::extract::Request,
    next: axum::middleware::Next,
) -> Response {
    let Some(token) = state.config.token.as_deref() else { return next.run(request).await };
    if request.uri().path() == "/health" {
        return next.run(request).await;
    }
    let presented = request
        .headers()
        .get(axum::http::header::AUTHORIZATION)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.strip_prefix("Bearer "))
        .unwrap_or("");
    if same_secret(presented.as_bytes(), token.as_bytes()) {
        return next.run(request).await;
    }
    let mut response = detail(StatusCode::UNAUTHORIZED, json!("missing or wrong bearer token"));
    response.headers_mut().insert(axum::http::header::WWW_AUTHENTICATE, axum::http::HeaderValue::from_static("Bearer"));
    response
}

/// Compare two secrets in time that depends on their lengths only.
fn same_secret(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

/// A request's body, read within the read deadline and the size limit; past
/// either, OpenEnv's JSON error (413, 408) instead of a plain-text one.
pub(super) async fn read_body(state: &EnvServerState, body: axum::body::Body) -> Result<Bytes, Response> {
    let limit = state.config.max_message_bytes;
    match tokio::time::timeout(state.config.read_timeout, axum::body::to_bytes(body, limit)).await {
        Ok(Ok(bytes)) => Ok(bytes),
        Ok(Err(e)) => {
            let too_large = e.into_inner().is::<http_body_util::LengthLimitError>();
            Err(if too_large {
                detail(StatusCode::PAYLOAD_TOO_LARGE, json!(format!("request body larger than {limit} bytes")))
            } else {
                detail(StatusCode::BAD_REQUEST, json!("the request body could not be read"))
            })
        }
        Err(_) => Err(detail(
            StatusCode::REQUEST_TIMEOUT,
            json!(format!("request body not received within {} s", state.config.read_timeout.as_secs_f64())),
        )),
    }
}

pub(super) fn json_bytes(body: Bytes) -> Response {
    ([(axum::http::header::CONTENT_TYPE, "application/json")], body).into_response()
}

fn detail(status: StatusCode, detail: Value) -> Response {
    (status, axum::Json(json!({ "detail": detail }))).into_response()
}

/// The fields of a step's body: the action, and the episode it plays.
/// `timeout_s` and `request_id` (OpenEnv's clients send them) are read and
/// ignored.
const STEP: Names = Names { required: &["action", "episode_id"], optional: &["timeout_s", "request_id"] };

/// A refused request: counted, and answered as FastAPI answers a body that
/// fails validation (422, `detail` the list of located field errors).
fn unprocessable(state: &EnvServerState, errors: Vec<FieldError>) -> Response {
    state.stats.errors.fetch_add(1, Relaxed);
    detail(StatusCode::UNPROCESSABLE_ENTITY, serde_json::to_value(errors).expect("field errors serialise"))
}

/// A request body as a JSON object (an empty body is `{}`), or the errors
/// located in the body.
fn body_object(body: &[u8]) -> Result<Map<String, Value>, Vec<FieldError>> {
    if body.iter().all(u8::is_ascii_whitespace) {
        return Ok(Map::new());
    }
    let value = serde_json::from_slice::<Value>(body)
        .map_err(|e| vec![FieldError::whole("json_invalid", format!("JSON decode error: {e}"))])?;
    super::request::into_object(value, "a JSON object").map_err(|e| vec![e])
}

/// A session's refusal of what the body at `at` asked.
fn session_error(state: &EnvServerState, e: SessionError, at: &[&str]) -> Response {
    match e {
        SessionError::Invalid(errors) => unprocessable(state, located(errors, at)),
        SessionError::NotReset | SessionError::EpisodeOver(_) => {
            state.stats.errors.fetch_add(1, Relaxed);
            detail(StatusCode::CONFLICT, json!(e.to_string()))
        }
    }
}

pub(super) async fn http_reset(State(state): State<Arc<EnvServerState>>, body: axum::body::Body) -> Response {
    let body = match read_body(&state, body).await {
        Ok(b) => b,
        Err(r) => return r,
    };
    let request = match body_object(&body) {
        Ok(fields) => ResetRequest::from_fields(&fields),
        Err(errors) => Err(SessionError::Invalid(errors)),
    };
    let request = match request {
        Ok(r) => r,
        Err(e) => return session_error(&state, e, &["body"]),
    };
    let id = request.episode_id.clone().unwrap_or_else(|| state.new_episode_id());
    let request = ResetRequest { episode_id: Some(id.clone()), ..request };
    state.reap();
    let mut episodes = state.http_episodes();
    // An id is its episode's capability: naming a live one is refused, never
    // a way to take the episode over.
    if episodes.contains_key(&id) {
        state.stats.errors.fetch_add(1, Relaxed);
        return detail(
            StatusCode::CONFLICT,
            json!(format!("episode_id '{}' is in use: reset without an episode_id to get a fresh one", clip(&id))),
        );
    }
    let slot = match state.acquire() {
        Ok(slot) => slot,
        Err(AtCapacity { active, max }) => {
            return detail(
                StatusCode::SERVICE_UNAVAILABLE,
                json!(format!("server at capacity: {active} of {max} sessions in use; retry later")),
            );
        }
    };
    let mut session = Session::default();
    let reply = session.reset(&state.scenarios, request, || state.draw_seed(), || unreachable!("the id is set"));
    episodes.insert(id, HttpEpisode { session, last_used: Instant::now(), _slot: slot });
    axum::Json(reply).into_response()
}

/// A step's body, checked: its action and the id of its episode.
fn step_request(body: &[u8]) -> Result<(Value, String), Vec<FieldError>> {
    let mut fields = body_object(body)?;
    STEP.check(&fields)?;
    let action = fields.remove("action").expect("checked present");
    match fields.remove("episode_id") {
        Some(Value::String(id)) => Ok((action, id)),
        _ => Err(vec![FieldError::new("string_type", "episode_id", "expected the episode_id /reset returned")]),
    }
}

pub(super) async fn http_step(State(state): State<Arc<EnvServerState>>, body: axum::body::Body) -> Response {
    let body = match read_body(&state, body).await {
        Ok(b) => b,
        Err(r) => return r,
    };
    let (action, id) = match step_request(&body) {
        Ok(request) => request,
        Err(errors) => return unprocessable(&state, located(errors, &["body"])),
    };
    let mut episodes = state.http_episodes();
    let Some(entry) = episodes.get_mut(&id) else {
        state.stats.errors.fetch_add(1, Relaxed);
        return detail(
            StatusCode::NOT_FOUND,
            json!(format!(
                "unknown episode_id '{}': reset first (an HTTP episode is forgotten when it ends or after {} s idle)",
                clip(&id),
                state.config.session_timeout.as_secs()
            )),
        );
    };
    entry.last_used = Instant::now();
    match entry.session.step(&action) {
        Ok(reply) => {
            state.stats.steps.fetch_add(1, Relaxed);
            if reply.done {
                state.stats.episodes_done.fetch_add(1, Relaxed);
                episodes.remove(&id);
            }
            axum::Json(reply).into_response()
        }
        Err(e) => session_error(&state, e, &["body", "action"]),
    }
}

#[derive(serde::Deserialize)]
pub(super) struct StateQuery {
    episode_id: Option<String>,
}

pub(super) async fn http_state(State(state): State<Arc<EnvServerState>>, Query(q): Query<StateQuery>) -> Response {
    let Some(id) = q.episode_id else {
        return axum::Json(Session::default().state()).into_response();
    };
    match state.http_episodes().get(&id) {
        Some(e) => axum::Json(e.session.state()).into_response(),
        None => detail(StatusCode::NOT_FOUND, json!(format!("unknown episode_id '{}'", clip(&id)))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn secrets_compare_by_content_and_length() {
        assert!(same_secret(b"s3cret", b"s3cret"));
        assert!(!same_secret(b"s3cret", b"s3creT"));
        assert!(!same_secret(b"s3cret", b"s3cret!"));
        assert!(!same_secret(b"", b"x"));
    }

    /// Every problem with a step's body is found by the one checker and
    /// located in the body: what is missing, what is extra, what is not an
    /// object or not JSON.
    #[test]
    fn a_steps_body_is_checked_field_by_field() {
        let loc = |body: &str| -> Vec<Vec<String>> {
            let errors = step_request(body.as_bytes()).unwrap_err();
            located(errors, &["body"]).into_iter().map(|e| e.loc).collect()
        };
        assert_eq!(loc(r#"{"action": {}}"#), [["body", "episode_id"]]);
        assert_eq!(loc(r#"{"episode_id": 3, "action": {}}"#), [["body", "episode_id"]]);
        assert_eq!(loc(r#"{"action": {}, "episode_id": "e", "why": 1}"#), [["body", "why"]]);
        assert_eq!(loc("[1]"), [["body"]]);
        assert_eq!(loc("{nope"), [["body"]]);
        assert_eq!(loc(""), [vec!["body".to_string(), "action".into()], vec!["body".into(), "episode_id".into()]]);
        let (action, id) = step_request(br#"{"action": {"reply": "x"}, "episode_id": "e", "timeout_s": 5}"#).unwrap();
        assert_eq!((action, id.as_str()), (json!({"reply": "x"}), "e"));
    }
}
