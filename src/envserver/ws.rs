//! The WebSocket endpoints. `GET /ws`: one connection is one session, as
//! OpenEnv's server holds it. Messages are checked by [`super::request`],
//! as the HTTP bodies are; an error is OpenEnv's structured one
//! (`VALIDATION_ERROR` with each field located in the message) and leaves
//! the session as it was. A session ends when its client closes it, sends
//! `close`, or stays idle past the session timeout; a frame too large or
//! not UTF-8 gets its error and RFC 6455's close code.
//!
//! `GET /ws/batch`: one connection holds up to [`MAX_BATCH_SESSIONS`]
//! sessions, for a vectorised trainer that would otherwise pay one
//! message each way per environment and step. The client sends
//! `{"type": "batch", "data": [m0, m1, ...]}`, entry i being the message
//! `/ws` takes (`reset`, `step` or `state`) for session i, or `null` to
//! leave session i alone; the answer is `{"type": "batch", "data": [a0,
//! a1, ...]}`, entry i being what `/ws` answers that message (an error
//! entry included), or `null`. Session i opens with its first message and
//! takes a place under `--max-sessions` (past it, that entry is
//! `CAPACITY_REACHED`); all close with the connection or on `close`, and
//! the idle timeout is the connection's (a message to any session keeps
//! all of them open).

use super::EnvServerState;
use super::mcp::mcp_response;
use super::request::{self, FieldError, Names, clip, located};
use super::session::{self, ResetRequest, Session, SessionError};
use super::{AtCapacity, wire};
use axum::extract::State;
use axum::extract::ws::{CloseFrame, Message, WebSocket, WebSocketUpgrade};
use axum::response::Response;
use serde_json::{Value, json};
use std::sync::Arc;
use std::sync::atomic::Ordering::Relaxed;
use tokio::sync::watch;

/// The WebSocket read and write buffer of one session.
const WS_BUFFER_BYTES: usize = 8 * 1024;

/// One running WebSocket session, counted in `ws_open` while it lives.
struct WsOpen(Arc<EnvServerState>);

impl Drop for WsOpen {
    fn drop(&mut self) {
        self.0.ws_open.fetch_sub(1, Relaxed);
    }
}

pub(super) async fn ws_upgrade(State(state): State<Arc<EnvServerState>>, ws: WebSocketUpgrade) -> Response {
    upgrade(state, ws, 1)
}

pub(super) async fn ws_batch_upgrade(State(state): State<Arc<EnvServerState>>, ws: WebSocketUpgrade) -> Response {
    upgrade(state, ws, MAX_BATCH_SESSIONS)
}

fn upgrade(state: Arc<EnvServerState>, ws: WebSocketUpgrade, sessions: usize) -> Response {
    let limit = state.config.max_message_bytes;
    // Small read and write buffers: a message is a few KB, and a large
    // buffer is zeroed on every read. Outgoing bytes are capped: the server
    // writes one bounded reply at a time, and a client that stops reading is
    // closed by the connection's stall guard.
    ws.max_message_size(limit)
        .max_frame_size(limit)
        .read_buffer_size(WS_BUFFER_BYTES)
        .write_buffer_size(WS_BUFFER_BYTES)
        .max_write_buffer_size(WS_BUFFER_BYTES + sessions * MAX_WS_OUTGOING_BYTES_PER_SESSION)
        .on_upgrade(move |socket| ws_connection(socket, state, sessions > 1))
}

/// Most bytes one session's answers may have written and not yet sent:
/// the largest reply with its framing, twice. A batch connection may hold
/// that for each of its sessions, so memory stays bounded per session.
const MAX_WS_OUTGOING_BYTES_PER_SESSION: usize = 2 * (2 * session::MAX_REPLY_BYTES + 4096);

/// Most sessions one `/ws/batch` connection holds (a vectorised trainer's
/// environments; more take another connection).
pub(crate) const MAX_BATCH_SESSIONS: usize = 64;

/// What a frame the session could not read gets: OpenEnv's structured
/// error, then the close code RFC 6455 gives the fault (1009: too big,
/// 1007: not UTF-8); None for a connection that is simply gone.
fn unreadable(e: &axum::Error, limit: usize) -> Option<(Value, u16)> {
    let inner = std::error::Error::source(e)?.downcast_ref::<tungstenite::Error>()?;
    match inner {
        tungstenite::Error::Capacity(_) => {
            Some((ws_error("VALIDATION_ERROR", format!("message larger than {limit} bytes: closed")), 1009))
        }
        tungstenite::Error::Utf8(_) => Some((ws_error("INVALID_JSON", "text frame is not valid UTF-8: closed"), 1007)),
        _ => None,
    }
}

/// OpenEnv's error message.
fn ws_error(code: &str, message: impl Into<String>) -> Value {
    json!({"type": "error", "data": {"message": message.into(), "code": code}})
}

/// What a connection serves.
enum Sessions {
    One(Box<Session>),
    Batch(Batch),
}

/// What one WebSocket message does to its session.
pub(super) enum WsReply {
    Send(Value),
    /// An answer already serialised (observations and states, written
    /// straight from their types: no intermediate JSON tree per step).
    Text(String),
    Close,
}

/// Room for an answer: a full observation is 2 to 4 KB, and a buffer
/// grown by doubling from serde_json's 128 bytes is copied five times.
const ANSWER_CAPACITY: usize = 4096;

/// `{"type": kind, "data": data}`.
fn outgoing<T: serde::Serialize>(kind: &'static str, data: &T) -> String {
    #[derive(serde::Serialize)]
    struct Outgoing<'a, T> {
        #[serde(rename = "type")]
        kind: &'static str,
        data: &'a T,
    }
    wire::to_json(&Outgoing { kind, data }, ANSWER_CAPACITY)
}

/// The names each kind of message takes: `type`, and `data` where it
/// carries something (a step must).
fn names(kind: &str) -> Option<Names> {
    match kind {
        "reset" | "mcp" => Some(Names { required: &["type"], optional: &["data"] }),
        "step" => Some(Names { required: &["type", "data"], optional: &[] }),
        "state" | "close" => Some(Names { required: &["type"], optional: &[] }),
        _ => None,
    }
}

/// Handle one text message of a WebSocket session.
fn ws_message(state: &EnvServerState, session: &mut Session, text: &str) -> WsReply {
    match serde_json::from_str(text) {
        Ok(message) => session_message(state, session, &message),
        Err(e) => WsReply::Send(ws_error("INVALID_JSON", format!("Invalid JSON: {e}"))),
    }
}

/// Handle one message to a session, parsed.
fn session_message(state: &EnvServerState, session: &mut Session, message: &Value) -> WsReply {
    let fields = match request::object(message, "a JSON object with a type") {
        Ok(fields) => fields,
        Err(e) => return WsReply::Send(invalid(vec![e])),
    };
    let kind = fields.get("type").and_then(Value::as_str).unwrap_or("");
    let Some(names) = names(kind) else {
        return WsReply::Send(ws_error("UNKNOWN_TYPE", format!("Unknown message type: {}", clip(kind))));
    };
    if let Err(errors) = names.check(fields) {
        return WsReply::Send(invalid(errors));
    }
    let data = fields.get("data").unwrap_or(&Value::Null);
    let reply = match kind {
        "reset" => ResetRequest::from_data(data)
            .map(|request| session.reset(&state.scenarios, request, || state.draw_seed(), || state.new_episode_id())),
        "step" => session.step(data).inspect(|r| {
            state.stats.steps.fetch_add(1, Relaxed);
            if r.done {
                state.stats.episodes_done.fetch_add(1, Relaxed);
            }
        }),
        "state" => return WsReply::Text(outgoing("state", &session.state())),
        "mcp" => return WsReply::Send(json!({"type": "mcp", "data": mcp_response(data)})),
        _ => return WsReply::Close,
    };
    match reply {
        Ok(r) => WsReply::Text(outgoing("observation", &r)),
        Err(e) => {
            state.stats.errors.fetch_add(1, Relaxed);
            WsReply::Send(match e {
                SessionError::Invalid(errors) => invalid(located(errors, &["data"])),
                other => ws_error("EXECUTION_ERROR", other.to_string()),
            })
        }
    }
}

/// The sessions of a `/ws/batch` connection, opened as their index is
/// first used, each holding its place under `--max-sessions`.
#[derive(Default)]
pub(super) struct Batch {
    sessions: Vec<Option<(Session, super::Slot)>>,
}

impl Batch {
    /// Handle one text message of a batch connection.
    pub(super) fn message(&mut self, state: &Arc<EnvServerState>, text: &str) -> WsReply {
        let message: Value = match serde_json::from_str(text) {
            Ok(m) => m,
            Err(e) => return WsReply::Send(ws_error("INVALID_JSON", format!("Invalid JSON: {e}"))),
        };
        let fields = match request::object(&message, "a JSON object with a type") {
            Ok(fields) => fields,
            Err(e) => return WsReply::Send(invalid(vec![e])),
        };
        let kind = fields.get("type").and_then(Value::as_str).unwrap_or("");
        let names = match kind {
            "batch" => Names { required: &["type", "data"], optional: &[] },
            "close" => Names { required: &["type"], optional: &[] },
            _ => return WsReply::Send(ws_error("UNKNOWN_TYPE", format!("Unknown message type: {}", clip(kind)))),
        };
        if let Err(errors) = names.check(fields) {
            return WsReply::Send(invalid(errors));
        }
        if kind == "close" {
            return WsReply::Close;
        }
        let entries = match fields.get("data") {
            Some(Value::Array(entries)) if entries.len() <= MAX_BATCH_SESSIONS => entries,
            _ => {
                let expected = format!("an array of at most {MAX_BATCH_SESSIONS} messages (or nulls), one per session");
                return WsReply::Send(invalid(vec![FieldError::new("list_type", "data", expected)]));
            }
        };
        let mut out = String::with_capacity(32 + entries.len() * ANSWER_CAPACITY / 4);
        out.push_str(r#"{"type":"batch","data":["#);
        for (i, entry) in entries.iter().enumerate() {
            if i > 0 {
                out.push(',');
            }
            match self.entry(state, i, entry) {
                None => out.push_str("null"),
                Some(WsReply::Text(text)) => out.push_str(&text),
                Some(WsReply::Send(value)) => out.push_str(&value.to_string()),
                Some(WsReply::Close) => unreachable!("a batch entry never closes"),
            }
        }
        out.push_str("]}");
        WsReply::Text(out)
    }

    /// Entry `i` of a batch: what `/ws` answers it, or None for `null`.
    fn entry(&mut self, state: &Arc<EnvServerState>, i: usize, entry: &Value) -> Option<WsReply> {
        if entry.is_null() {
            return None;
        }
        let kind = match request::object(entry, "a JSON object with a type") {
            Ok(fields) => fields.get("type").and_then(Value::as_str).unwrap_or(""),
            Err(e) => return Some(WsReply::Send(invalid(vec![e]))),
        };
        if !matches!(kind, "reset" | "step" | "state") {
            let message = format!("Unknown message type in a batch: {} (reset, step or state)", clip(kind));
            return Some(WsReply::Send(ws_error("UNKNOWN_TYPE", message)));
        }
        if self.sessions.len() <= i {
            self.sessions.resize_with(i + 1, || None);
        }
        let place = &mut self.sessions[i];
        if place.is_none() {
            match state.acquire() {
                Ok(slot) => *place = Some((Session::default(), slot)),
                Err(full) => return Some(WsReply::Send(at_capacity(&full))),
            }
        }
        let (session, _) = place.as_mut().expect("opened above");
        Some(session_message(state, session, entry))
    }
}

/// The error a session refused for capacity gets.
fn at_capacity(full: &AtCapacity) -> Value {
    json!({"type": "error", "data": {
        "message": format!("Server at capacity: {} of {} sessions in use", full.active, full.max),
        "code": "CAPACITY_REACHED",
        "active_sessions": full.active,
        "max_sessions": full.max,
    }})
}

fn invalid(errors: Vec<FieldError>) -> Value {
    json!({"type": "error", "data": {"message": "Invalid message", "code": "VALIDATION_ERROR", "errors": errors}})
}

async fn send(socket: &mut WebSocket, value: &Value) -> bool {
    socket.send(Message::Text(value.to_string().into())).await.is_ok()
}

/// Resolves once the server's shutdown has begun.
async fn stopping(stop: &mut watch::Receiver<bool>) {
    let _ = stop.wait_for(|stopping| *stopping).await;
}

/// One WebSocket connection: one session (or, `batch`, a batch of them),
/// until the client closes it, sends `close`, or stays idle past the
/// session timeout.
async fn ws_connection(mut socket: WebSocket, state: Arc<EnvServerState>, batch: bool) {
    // A single session takes its place now; a batch's sessions as they open.
    let (_slot, mut sessions) = if batch {
        (None, Sessions::Batch(Batch::default()))
    } else {
        match state.acquire() {
            Ok(slot) => (Some(slot), Sessions::One(Box::default())),
            Err(full) => {
                let _ = send(&mut socket, &at_capacity(&full)).await;
                let close = CloseFrame { code: 1013, reason: "at capacity".into() };
                let _ = socket.send(Message::Close(Some(close))).await;
                return;
            }
        }
    };
    state.ws_open.fetch_add(1, Relaxed);
    let _open = WsOpen(state.clone());
    let mut stop = state.stop.subscribe();
    let timeout = state.config.session_timeout;
    // One idle timer for the session, pushed back on each message: moving a
    // deadline later is an atomic store, where a `timeout` per message would
    // insert and remove a timer entry under the timer's lock every step.
    // Only a message pushes it back: a ping (a client library's keepalive)
    // does not keep an abandoned session open. A client that stops reading
    // is closed by the connection's stall guard (a send then fails).
    let idle = tokio::time::sleep(timeout);
    tokio::pin!(idle);
    loop {
        let message = tokio::select! {
            biased;
            () = stopping(&mut stop) => {
                let _ = socket
                    .send(Message::Close(Some(CloseFrame { code: 1001, reason: "server shutting down".into() })))
                    .await;
                return;
            }
            message = socket.recv() => message,
            () = &mut idle => {
                state.stats.expired.fetch_add(1, Relaxed);
                let notice = ws_error(
                    "SESSION_ERROR",
                    format!("session idle for more than {} s: closed", timeout.as_secs_f64()),
                );
                let _ = send(&mut socket, &notice).await;
                break;
            }
        };
        let message = match message {
            None => return,
            Some(Err(e)) => {
                if let Some((error, code)) = unreadable(&e, state.config.max_message_bytes) {
                    state.stats.errors.fetch_add(1, Relaxed);
                    let _ = send(&mut socket, &error).await;
                    let reason = if code == 1009 { "message too big" } else { "invalid UTF-8" };
                    let _ = socket.send(Message::Close(Some(CloseFrame { code, reason: reason.into() }))).await;
                }
                return;
            }
            Some(Ok(m)) => m,
        };
        let reply = match message {
            Message::Text(text) => match &mut sessions {
                Sessions::One(session) => ws_message(&state, session, text.as_str()),
                Sessions::Batch(batch) => batch.message(&state, text.as_str()),
            },
            Message::Binary(_) => WsReply::Send(ws_error("INVALID_JSON", "binary frames are not read: send JSON text")),
            Message::Close(_) => return,
            Message::Ping(_) | Message::Pong(_) => continue,
        };
        idle.as_mut().reset(tokio::time::Instant::now() + timeout);
        let text = match reply {
            WsReply::Send(value) => value.to_string(),
            WsReply::Text(text) => text,
            WsReply::Close => break,
        };
        if socket.send(Message::Text(text.into())).await.is_err() {
            return;
        }
    }
    let _ = socket.send(Message::Close(Some(CloseFrame { code: 1000, reason: "".into() }))).await;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::envserver::tests::state;
    use serde_json::Map;

    fn send_text(state: &EnvServerState, session: &mut Session, text: &str) -> Value {
        match ws_message(state, session, text) {
            WsReply::Send(v) => v,
            WsReply::Text(t) => serde_json::from_str(&t).unwrap(),
            WsReply::Close => json!("closed"),
        }
    }

    /// An error reply never grows with the request: a message with 100,000
    /// unknown fields (and a reset with as many) lists a few, counts the
    /// rest, and echoes no field name longer than the clip.
    #[test]
    fn error_replies_are_bounded_whatever_the_request() {
        let state = state();
        let mut session = Session::default();
        let long = "k".repeat(10_000);
        let mut fields: Map<String, Value> = (0..100_000).map(|i| (format!("{i}"), json!(0))).collect();
        fields.insert(long.clone(), json!(0));
        let message = json!({"type": "state", "junk": 1, &long: 2}).to_string();
        let bounded = |reply: &Value| {
            let text = reply.to_string();
            assert!(text.len() < 2048, "{} bytes", text.len());
            text
        };
        let reply = send_text(&state, &mut session, &message);
        assert_eq!(reply["data"]["code"], "VALIDATION_ERROR");
        bounded(&reply);
        let mut wrapped = Map::new();
        wrapped.insert("type".into(), json!("reset"));
        wrapped.insert("data".into(), Value::Object(fields));
        let reply = send_text(&state, &mut session, &Value::Object(wrapped).to_string());
        let text = bounded(&reply);
        let errors = reply["data"]["errors"].as_array().unwrap();
        assert_eq!(errors.len(), request::MAX_LISTED_ERRORS + 1, "{text}");
        assert_eq!(errors.last().unwrap()["msg"], "99996 more errors not listed", "{text}");
        assert_eq!(errors.last().unwrap()["loc"], json!(["data"]), "{text}");
    }

    #[test]
    fn bad_messages_get_openenvs_errors_and_the_session_survives_them() {
        let s = state();
        let mut session = Session::default();
        let code = |v: &Value| v["data"]["code"].as_str().unwrap_or("").to_string();
        let loc = |v: &Value| v["data"]["errors"][0]["loc"].clone();
        assert_eq!(code(&send_text(&s, &mut session, "{not json")), "INVALID_JSON");
        assert_eq!(code(&send_text(&s, &mut session, r#"{"type": "dance"}"#)), "UNKNOWN_TYPE");
        assert_eq!(code(&send_text(&s, &mut session, r#"[1, 2]"#)), "VALIDATION_ERROR");
        assert_eq!(
            code(&send_text(&s, &mut session, r#"{"type": "step", "data": {"reply": "{}"}}"#)),
            "EXECUTION_ERROR"
        );
        let bad = send_text(&s, &mut session, r#"{"type": "reset", "data": {"scenario": "roundabout"}}"#);
        assert_eq!(code(&bad), "VALIDATION_ERROR");
        assert_eq!(loc(&bad), json!(["data", "scenario"]));
        let extra = send_text(&s, &mut session, r#"{"type": "state", "data": {}}"#);
        assert_eq!(loc(&extra), json!(["data"]));
        assert_eq!(loc(&send_text(&s, &mut session, r#"{"type": "reset", "data": 3}"#)), json!(["data"]));
        let ok =
            send_text(&s, &mut session, r#"{"type": "reset", "data": {"scenario": "pedestrian_feint", "seed": 5}}"#);
        assert_eq!(ok["type"], "observation");
        assert_eq!(ok["data"]["observation"]["seed"], 5);
        let missing = send_text(&s, &mut session, r#"{"type": "step"}"#);
        assert_eq!((code(&missing), loc(&missing)), ("VALIDATION_ERROR".to_string(), json!(["data"])));
        assert_eq!(code(&send_text(&s, &mut session, r#"{"type": "step", "data": "proceed"}"#)), "VALIDATION_ERROR");
        let both = send_text(&s, &mut session, r#"{"type": "step", "data": {"reply": "x", "maneuver": "stop"}}"#);
        assert_eq!(loc(&both), json!(["data", "maneuver"]));
        let stepped = send_text(&s, &mut session, r#"{"type": "step", "data": {"reply": "no idea"}}"#);
        assert_eq!(stepped["data"]["observation"]["turn"], 2, "{stepped}");
        assert!(!stepped["data"]["observation"]["parse_errors"].as_array().unwrap().is_empty());
        assert_eq!(send_text(&s, &mut session, r#"{"type": "state"}"#)["data"]["step_count"], 1);
        assert_eq!(send_text(&s, &mut session, r#"{"type": "close"}"#), json!("closed"));
    }

    fn batch_text(state: &Arc<EnvServerState>, batch: &mut Batch, text: &str) -> Value {
        match batch.message(state, text) {
            WsReply::Send(v) => v,
            WsReply::Text(t) => serde_json::from_str(&t).unwrap(),
            WsReply::Close => json!("closed"),
        }
    }

    /// `value` without its episode ids (random per session).
    fn without_ids(value: &Value) -> Value {
        match value {
            Value::Object(fields) => {
                fields.iter().filter(|(k, _)| *k != "episode_id").map(|(k, v)| (k.clone(), without_ids(v))).collect()
            }
            other => other.clone(),
        }
    }

    /// Entry i of a batch is what `/ws` answers session i's
    /// message, whatever the others do (nulls leave a session alone).
    #[test]
    fn a_batch_answers_each_session_as_its_own_connection_would() {
        let state = Arc::new(state());
        let mut batch = Batch::default();
        let mut alone = [Session::default(), Session::default(), Session::default()];
        let reset = |seed: u64, scenario: &str| json!({"type": "reset", "data": {"scenario": scenario, "tier": 2, "seed": seed, "view": "features"}});
        let step = |maneuver: &str| json!({"type": "step", "data": {"maneuver": maneuver, "acceleration": 0.5}});
        let rounds = [
            vec![reset(7, "yield_standoff"), reset(8, "pedestrian_feint"), reset(9, "contested_merge")],
            vec![step("proceed"), Value::Null, step("yield")],
            vec![step("stop"), step("proceed"), json!({"type": "state"})],
            vec![json!({"type": "step", "data": {"maneuver": "fly"}}), step("yield"), step("proceed")],
        ];
        for round in rounds {
            let answer = batch_text(&state, &mut batch, &json!({"type": "batch", "data": round}).to_string());
            assert_eq!(answer["type"], "batch");
            for (i, message) in round.iter().enumerate() {
                let expected = if message.is_null() {
                    Value::Null
                } else {
                    send_text(&state, &mut alone[i], &message.to_string())
                };
                assert_eq!(without_ids(&answer["data"][i]), without_ids(&expected), "session {i} of {round:?}");
            }
        }
        // Three sessions hold three places, given back with the batch.
        assert_eq!(state.active_sessions(), 3);
        drop(batch);
        assert_eq!(state.active_sessions(), 0);
    }

    #[test]
    fn a_bad_batch_gets_an_error_and_its_sessions_survive_it() {
        let state = Arc::new(state());
        let mut batch = Batch::default();
        let code = |v: &Value| v["data"]["code"].as_str().unwrap_or("").to_string();
        let opened =
            batch_text(&state, &mut batch, r#"{"type": "batch", "data": [{"type": "reset", "data": {"seed": 3}}]}"#);
        assert_eq!(opened["data"][0]["type"], "observation", "{opened}");
        assert_eq!(code(&batch_text(&state, &mut batch, "[")), "INVALID_JSON");
        assert_eq!(code(&batch_text(&state, &mut batch, r#"{"type": "step"}"#)), "UNKNOWN_TYPE");
        assert_eq!(code(&batch_text(&state, &mut batch, r#"{"type": "batch", "data": {}}"#)), "VALIDATION_ERROR");
        let too_many = json!({"type": "batch", "data": vec![Value::Null; MAX_BATCH_SESSIONS + 1]}).to_string();
        let refused = batch_text(&state, &mut batch, &too_many);
        assert_eq!(refused["data"]["errors"][0]["loc"], json!(["data"]), "{refused}");
        let inner = batch_text(&state, &mut batch, r#"{"type": "batch", "data": [{"type": "close"}, 3]}"#);
        assert_eq!(
            (code(&inner["data"][0]), code(&inner["data"][1])),
            ("UNKNOWN_TYPE".into(), "VALIDATION_ERROR".into())
        );
        // Past --max-sessions (4 here), a session's entry is refused alone.
        let five: Vec<Value> = (0..5).map(|_| json!({"type": "state"})).collect();
        let answer = batch_text(&state, &mut batch, &json!({"type": "batch", "data": five}).to_string());
        assert_eq!(answer["data"][0]["data"]["seed"], 3, "{answer}");
        assert_eq!(code(&answer["data"][4]), "CAPACITY_REACHED", "{answer}");
        assert_eq!(answer["data"][3]["type"], "state", "{answer}");
        assert_eq!(batch_text(&state, &mut batch, r#"{"type": "close"}"#), json!("closed"));
    }

    #[test]
    fn a_reset_without_a_seed_draws_one_below_the_exact_double_limit_and_returns_it() {
        let s = state();
        let mut seen = std::collections::HashSet::new();
        for _ in 0..50 {
            let mut session = Session::default();
            let v = send_text(&s, &mut session, r#"{"type": "reset"}"#);
            let seed = v["data"]["observation"]["seed"].as_u64().unwrap();
            assert!(seed < session::DRAWN_SEED_LIMIT);
            assert_eq!(session.state().seed, Some(seed));
            seen.insert(seed);
        }
        assert_eq!(seen.len(), 50);
    }
}
