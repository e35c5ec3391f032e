//! `negotiator env-server`: the benchmark as an OpenEnv environment, for
//! trainers and other harnesses (verifiers' OpenEnv taskset, TRL, OpenEnv's
//! own `GenericEnvClient`), over HTTP and WebSocket on axum.
//!
//! The protocol is OpenEnv's, as its server (`openenv.core.env_server`)
//! speaks it:
//! - `GET /ws`: one WebSocket connection is one session. The client sends
//!   `{"type": "reset", "data": {...}}`, `{"type": "step", "data": action}`,
//!   `{"type": "state"}` and `{"type": "close"}`; the server answers
//!   `{"type": "observation", "data": {"observation", "reward", "done",
//!   "metadata"}}`, `{"type": "state", "data": state}` or `{"type": "error",
//!   "data": {"message", "code"}}` with OpenEnv's codes (`INVALID_JSON`,
//!   `UNKNOWN_TYPE`, `VALIDATION_ERROR` with the fields' `errors`,
//!   `EXECUTION_ERROR`, `CAPACITY_REACHED`, `SESSION_ERROR`). An error
//!   leaves the session as it was.
//! - `POST /reset`, `POST /step`, `GET /state`: the same over HTTP. OpenEnv's
//!   own HTTP endpoints play each request on a fresh environment; here
//!   `/reset` opens an episode held under its `episode_id` and `/step` takes
//!   that id next to the action, so a client without WebSockets (curl) can
//!   play a whole episode. An HTTP episode is forgotten when it ends (its
//!   last response carries everything) or after `--session-timeout` idle.
//! - `GET /schema`, `GET /metadata`, `GET /health`, `GET /openapi.json`,
//!   `POST /mcp` (JSON-RPC; this environment has no MCP tools).
//!
//! Stepping is [`session::Session`], which drives the same
//! [`crate::episode::Episode`] as `eval`: no second episode loop.
//!
//! Bounds: at most `--max-sessions` sessions (WebSocket connections and
//! open HTTP episodes together; past it a WebSocket gets the
//! `CAPACITY_REACHED` error and is closed, an HTTP reset gets 503); no
//! message or body above `--max-message-bytes`; a session idle for
//! `--session-timeout` is closed. A session holds one episode (a few KB,
//! bounded by the turn budget), so memory is bounded per session and in
//! total.

mod features;
mod schema;
mod session;
mod wire;

use axum::Router;
use axum::body::Bytes;
use axum::extract::ws::{CloseFrame, Message, WebSocket, WebSocketUpgrade};
use axum::extract::{DefaultBodyLimit, Query, State};
use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use serde_json::{Map, Value, json};
use session::{FieldError, ResetRequest, Session, SessionError};
use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering::Relaxed};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// The WebSocket read and write buffer of one session.
const WS_BUFFER_BYTES: usize = 8 * 1024;

/// The smallest `--max-message-bytes`: a reply of the size `eval` reads
/// must fit, with room for its JSON escaping.
pub(crate) const MIN_MESSAGE_BYTES: usize = 2 * session::MAX_REPLY_BYTES + 4096;

/// Limits of one server.
#[derive(Debug, Clone)]
pub(crate) struct EnvServerConfig {
    pub max_sessions: usize,
    pub session_timeout: Duration,
    pub max_message_bytes: usize,
}

/// Counts of what was served (for the shutdown line and tests).
#[derive(Debug, Default)]
pub(crate) struct EnvStats {
    pub sessions: AtomicU64,
    pub steps: AtomicU64,
    pub episodes_done: AtomicU64,
    pub errors: AtomicU64,
    pub refused: AtomicU64,
    pub expired: AtomicU64,
}

struct HttpEpisode {
    session: Session,
    last_used: Instant,
    _slot: Slot,
}

pub(crate) struct EnvServerState {
    config: EnvServerConfig,
    scenarios: crate::scenario::ScenarioSet,
    active: AtomicUsize,
    http: Mutex<HashMap<String, HttpEpisode>>,
    /// Drawn seeds and generated episode ids: a SplitMix64 stream from a
    /// per-process start, so replicas do not repeat each other's ids.
    counter: AtomicU64,
    start: u64,
    documents: Documents,
    pub stats: EnvStats,
}

/// The documents served as they are (computed once).
struct Documents {
    schema: Bytes,
    metadata: Bytes,
    openapi: Bytes,
}

/// One session's place under `--max-sessions`, given back when dropped.
struct Slot(Arc<EnvServerState>);

impl Drop for Slot {
    fn drop(&mut self) {
        self.0.active.fetch_sub(1, Relaxed);
    }
}

/// Every slot is taken.
#[derive(Debug)]
struct AtCapacity {
    active: usize,
    max: usize,
}

impl EnvServerState {
    pub(crate) fn new(config: EnvServerConfig) -> EnvServerState {
        let nanos =
            std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos() as u64);
        let bytes = |v: Value| Bytes::from(serde_json::to_vec(&v).expect("a JSON value serialises"));
        EnvServerState {
            config,
            scenarios: crate::scenario::ScenarioSet::default(),
            active: AtomicUsize::new(0),
            http: Mutex::new(HashMap::new()),
            counter: AtomicU64::new(0),
            start: crate::hash::splitmix64(nanos ^ ((std::process::id() as u64) << 32)),
            documents: Documents {
                schema: bytes(schema::schemas()),
                metadata: bytes(schema::metadata()),
                openapi: bytes(schema::openapi()),
            },
            stats: EnvStats::default(),
        }
    }

    fn acquire(self: &Arc<Self>) -> Result<Slot, AtCapacity> {
        let max = self.config.max_sessions;
        self.active
            .fetch_update(Relaxed, Relaxed, |n| (n < max).then_some(n + 1))
            .map(|_| {
                self.stats.sessions.fetch_add(1, Relaxed);
                Slot(self.clone())
            })
            .map_err(|active| {
                self.stats.refused.fetch_add(1, Relaxed);
                AtCapacity { active, max }
            })
    }

    fn next_random(&self) -> u64 {
        let k = self.counter.fetch_add(1, Relaxed);
        crate::hash::splitmix64(self.start.wrapping_add(k.wrapping_mul(crate::hash::GOLDEN_GAMMA)))
    }

    fn draw_seed(&self) -> u64 {
        self.next_random() % session::DRAWN_SEED_LIMIT
    }

    fn new_episode_id(&self) -> String {
        format!("ep-{:016x}", self.next_random())
    }

    fn http_episodes(&self) -> std::sync::MutexGuard<'_, HashMap<String, HttpEpisode>> {
        self.http.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Forget HTTP episodes idle for longer than the session timeout.
    fn reap(&self) {
        let timeout = self.config.session_timeout;
        let mut episodes = self.http_episodes();
        let before = episodes.len();
        episodes.retain(|_, e| e.last_used.elapsed() < timeout);
        self.stats.expired.fetch_add((before - episodes.len()) as u64, Relaxed);
    }

    /// Sessions open now (WebSocket connections and HTTP episodes).
    #[cfg(test)]
    fn active_sessions(&self) -> usize {
        self.active.load(Relaxed)
    }
}

pub(crate) fn router(state: Arc<EnvServerState>) -> Router {
    let limit = state.config.max_message_bytes;
    Router::new()
        .route("/reset", post(http_reset))
        .route("/step", post(http_step))
        .route("/state", get(http_state))
        .route(
            "/schema",
            get(|State(s): State<Arc<EnvServerState>>| async move { json_bytes(s.documents.schema.clone()) }),
        )
        .route(
            "/metadata",
            get(|State(s): State<Arc<EnvServerState>>| async move { json_bytes(s.documents.metadata.clone()) }),
        )
        .route(
            "/openapi.json",
            get(|State(s): State<Arc<EnvServerState>>| async move { json_bytes(s.documents.openapi.clone()) }),
        )
        .route("/health", get(|| async { axum::Json(json!({"status": "healthy"})) }))
        .route("/mcp", post(http_mcp))
        .route("/ws", get(ws_upgrade))
        .fallback(|| async { (StatusCode::NOT_FOUND, axum::Json(json!({"detail": "Not Found"}))) })
        .layer(DefaultBodyLimit::max(limit))
        .with_state(state)
}

fn json_bytes(body: Bytes) -> Response {
    ([(axum::http::header::CONTENT_TYPE, "application/json")], body).into_response()
}

fn detail(status: StatusCode, detail: Value) -> Response {
    (status, axum::Json(json!({ "detail": detail }))).into_response()
}

/// Validation errors as FastAPI reports them (422, `detail` a list), with
/// the field located in the request body.
fn unprocessable(errors: Vec<FieldError>) -> Response {
    let list: Vec<Value> = errors
        .into_iter()
        .map(|mut e| {
            e.loc[0] = "body".to_string();
            serde_json::to_value(e).expect("a field error serialises")
        })
        .collect();
    detail(StatusCode::UNPROCESSABLE_ENTITY, Value::Array(list))
}

/// A request body as a JSON object (an empty body is `{}`).
fn body_object(body: &[u8]) -> Result<Map<String, Value>, Box<Response>> {
    if body.iter().all(u8::is_ascii_whitespace) {
        return Ok(Map::new());
    }
    match serde_json::from_slice::<Value>(body) {
        Ok(Value::Object(map)) => Ok(map),
        Ok(_) => Err(Box::new(unprocessable(vec![FieldError {
            kind: "dict_type",
            loc: vec!["body".to_string()],
            msg: "expected a JSON object".to_string(),
        }]))),
        Err(e) => Err(Box::new(unprocessable(vec![FieldError {
            kind: "json_invalid",
            loc: vec!["body".to_string()],
            msg: format!("JSON decode error: {e}"),
        }]))),
    }
}

fn session_error(state: &EnvServerState, e: SessionError) -> Response {
    state.stats.errors.fetch_add(1, Relaxed);
    match e {
        SessionError::Invalid(errors) => unprocessable(errors),
        SessionError::NotReset => detail(StatusCode::CONFLICT, json!(e.to_string())),
        SessionError::EpisodeOver(_) => detail(StatusCode::CONFLICT, json!(e.to_string())),
    }
}

async fn http_reset(State(state): State<Arc<EnvServerState>>, body: Bytes) -> Response {
    let fields = match body_object(&body) {
        Ok(f) => f,
        Err(r) => return *r,
    };
    let request = match ResetRequest::from_fields(&fields) {
        Ok(r) => r,
        Err(e) => return session_error(&state, e),
    };
    let id = request.episode_id.clone().unwrap_or_else(|| state.new_episode_id());
    let request = ResetRequest { episode_id: Some(id.clone()), ..request };
    state.reap();
    let mut episodes = state.http_episodes();
    let slot = match episodes.remove(&id) {
        Some(old) => old._slot,
        None => match state.acquire() {
            Ok(slot) => slot,
            Err(AtCapacity { active, max }) => {
                return detail(
                    StatusCode::SERVICE_UNAVAILABLE,
                    json!(format!("server at capacity: {active} of {max} sessions in use; retry later")),
                );
            }
        },
    };
    let mut session = Session::default();
    let reply = session.reset(&state.scenarios, request, || state.draw_seed(), || unreachable!("the id is set"));
    episodes.insert(id, HttpEpisode { session, last_used: Instant::now(), _slot: slot });
    axum::Json(reply).into_response()
}

async fn http_step(State(state): State<Arc<EnvServerState>>, body: Bytes) -> Response {
    let mut fields = match body_object(&body) {
        Ok(f) => f,
        Err(r) => return *r,
    };
    let missing = |field: &str, msg: &str| FieldError {
        kind: "missing",
        loc: vec!["body".to_string(), field.to_string()],
        msg: msg.to_string(),
    };
    let action = fields.remove("action");
    let id = fields.remove("episode_id");
    let mut errors = Vec::new();
    if action.is_none() {
        errors.push(missing("action", "Field required"));
    }
    let id = match id {
        Some(Value::String(id)) => Some(id),
        _ => {
            errors.push(missing(
                "episode_id",
                "Field required: the episode_id /reset returned (or use the WebSocket session on /ws)",
            ));
            None
        }
    };
    for extra in fields.keys().filter(|k| !matches!(k.as_str(), "timeout_s" | "request_id")) {
        errors.push(FieldError {
            kind: "extra_forbidden",
            loc: vec!["body".to_string(), extra.clone()],
            msg: "unknown field".to_string(),
        });
    }
    let (Some(action), Some(id), true) = (action, id, errors.is_empty()) else {
        state.stats.errors.fetch_add(1, Relaxed);
        return detail(StatusCode::UNPROCESSABLE_ENTITY, serde_json::to_value(errors).expect("serialises"));
    };
    let mut episodes = state.http_episodes();
    let Some(entry) = episodes.get_mut(&id) else {
        state.stats.errors.fetch_add(1, Relaxed);
        return detail(
            StatusCode::NOT_FOUND,
            json!(format!(
                "unknown episode_id '{id}': reset first (an HTTP episode is forgotten when it ends or after {} s idle)",
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
        Err(e) => session_error(&state, e),
    }
}

#[derive(serde::Deserialize)]
struct StateQuery {
    episode_id: Option<String>,
}

async fn http_state(State(state): State<Arc<EnvServerState>>, Query(q): Query<StateQuery>) -> Response {
    let Some(id) = q.episode_id else {
        return axum::Json(Session::default().state()).into_response();
    };
    match state.http_episodes().get(&id) {
        Some(e) => axum::Json(e.session.state()).into_response(),
        None => detail(StatusCode::NOT_FOUND, json!(format!("unknown episode_id '{id}'"))),
    }
}

/// JSON-RPC 2.0 for MCP clients: this environment exposes no tools.
fn mcp_response(request: &Value) -> Value {
    let id = request.get("id").cloned().unwrap_or(Value::Null);
    let error =
        |code: i64, message: &str| json!({"jsonrpc": "2.0", "id": id, "error": {"code": code, "message": message}});
    let valid = request.get("jsonrpc").and_then(Value::as_str) == Some("2.0");
    match (valid, request.get("method").and_then(Value::as_str)) {
        (true, Some("tools/list")) => json!({"jsonrpc": "2.0", "id": id, "result": {"tools": []}}),
        (true, Some(_)) => error(-32601, "Method not found: this environment has no MCP tools"),
        _ => error(-32600, "Invalid Request"),
    }
}

async fn http_mcp(body: Bytes) -> Response {
    let reply = match serde_json::from_slice::<Value>(&body) {
        Ok(request) => mcp_response(&request),
        Err(_) => json!({"jsonrpc": "2.0", "id": null, "error": {"code": -32700, "message": "Parse error"}}),
    };
    axum::Json(reply).into_response()
}

async fn ws_upgrade(State(state): State<Arc<EnvServerState>>, ws: WebSocketUpgrade) -> Response {
    let limit = state.config.max_message_bytes;
    // Small read and write buffers: a message is a few KB, and a large
    // buffer is zeroed on every read.
    ws.max_message_size(limit)
        .max_frame_size(limit)
        .read_buffer_size(WS_BUFFER_BYTES)
        .write_buffer_size(WS_BUFFER_BYTES)
        .on_upgrade(move |socket| ws_session(socket, state))
}

/// OpenEnv's error message.
fn ws_error(code: &str, message: impl Into<String>) -> Value {
    json!({"type": "error", "data": {"message": message.into(), "code": code}})
}

/// What one WebSocket message does to its session.
enum WsReply {
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

/// Handle one text message of a WebSocket session.
fn ws_message(state: &EnvServerState, session: &mut Session, text: &str) -> WsReply {
    let message: Value = match serde_json::from_str(text) {
        Ok(m) => m,
        Err(e) => return WsReply::Send(ws_error("INVALID_JSON", format!("Invalid JSON: {e}"))),
    };
    let Some(fields) = message.as_object() else {
        return WsReply::Send(invalid(vec![FieldError {
            kind: "dict_type",
            loc: vec![],
            msg: "expected a JSON object with a type".to_string(),
        }]));
    };
    let kind = fields.get("type").and_then(Value::as_str).unwrap_or("");
    let allowed: &[&str] = match kind {
        "reset" | "step" | "mcp" => &["type", "data"],
        "state" | "close" => &["type"],
        _ => return WsReply::Send(ws_error("UNKNOWN_TYPE", format!("Unknown message type: {kind}"))),
    };
    let extra: Vec<FieldError> = fields
        .keys()
        .filter(|k| !allowed.contains(&k.as_str()))
        .map(|k| FieldError {
            kind: "extra_forbidden",
            loc: vec![k.clone()],
            msg: "Extra inputs are not permitted".to_string(),
        })
        .collect();
    if !extra.is_empty() {
        return WsReply::Send(invalid(extra));
    }
    let data = fields.get("data");
    let reply = match kind {
        "reset" => {
            let empty = Map::new();
            let data = match data {
                None | Some(Value::Null) => &empty,
                Some(Value::Object(m)) => m,
                Some(_) => {
                    return WsReply::Send(invalid(vec![FieldError {
                        kind: "dict_type",
                        loc: vec!["data".to_string()],
                        msg: "expected an object of reset fields".to_string(),
                    }]));
                }
            };
            ResetRequest::from_fields(data).map(|request| {
                session.reset(&state.scenarios, request, || state.draw_seed(), || state.new_episode_id())
            })
        }
        "step" => match data {
            None => Err(SessionError::Invalid(vec![FieldError {
                kind: "missing",
                loc: vec!["data".to_string()],
                msg: "Field required".to_string(),
            }])),
            Some(action) => session.step(action).inspect(|r| {
                state.stats.steps.fetch_add(1, Relaxed);
                if r.done {
                    state.stats.episodes_done.fetch_add(1, Relaxed);
                }
            }),
        },
        "state" => return WsReply::Text(outgoing("state", &session.state())),
        "mcp" => {
            return WsReply::Send(json!({"type": "mcp", "data": mcp_response(data.unwrap_or(&Value::Null))}));
        }
        _ => return WsReply::Close,
    };
    match reply {
        Ok(r) => WsReply::Text(outgoing("observation", &r)),
        Err(e) => {
            state.stats.errors.fetch_add(1, Relaxed);
            WsReply::Send(match e {
                SessionError::Invalid(errors) => invalid(errors),
                other => ws_error("EXECUTION_ERROR", other.to_string()),
            })
        }
    }
}

fn invalid(errors: Vec<FieldError>) -> Value {
    json!({"type": "error", "data": {"message": "Invalid message", "code": "VALIDATION_ERROR", "errors": errors}})
}

async fn send(socket: &mut WebSocket, value: &Value) -> bool {
    socket.send(Message::Text(value.to_string().into())).await.is_ok()
}

/// One WebSocket connection: one session, until the client closes it,
/// sends `close`, or stays idle past the session timeout.
async fn ws_session(mut socket: WebSocket, state: Arc<EnvServerState>) {
    let _slot = match state.acquire() {
        Ok(slot) => slot,
        Err(AtCapacity { active, max }) => {
            let refusal = json!({"type": "error", "data": {
                "message": format!("Server at capacity: {active} of {max} sessions in use"),
                "code": "CAPACITY_REACHED",
                "active_sessions": active,
                "max_sessions": max,
            }});
            let _ = send(&mut socket, &refusal).await;
            let _ = socket.send(Message::Close(Some(CloseFrame { code: 1013, reason: "at capacity".into() }))).await;
            return;
        }
    };
    let mut session = Session::default();
    let timeout = state.config.session_timeout;
    // One idle timer for the session, pushed back on each message: moving a
    // deadline later is an atomic store, where a `timeout` per message would
    // insert and remove a timer entry under the timer's lock every step.
    let idle = tokio::time::sleep(timeout);
    tokio::pin!(idle);
    loop {
        let message = tokio::select! {
            biased;
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
            None | Some(Err(_)) => return,
            Some(Ok(m)) => m,
        };
        idle.as_mut().reset(tokio::time::Instant::now() + timeout);
        let reply = match message {
            Message::Text(text) => ws_message(&state, &mut session, text.as_str()),
            Message::Binary(_) => WsReply::Send(ws_error("INVALID_JSON", "binary frames are not read: send JSON text")),
            Message::Close(_) => return,
            Message::Ping(_) | Message::Pong(_) => continue,
        };
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

/// Serve on `listener` until Ctrl-C (or SIGTERM); idle HTTP episodes are
/// reaped in the background.
pub(crate) async fn run(listener: tokio::net::TcpListener, state: Arc<EnvServerState>) -> std::io::Result<()> {
    let reaper = {
        let state = state.clone();
        let every = (state.config.session_timeout / 4).clamp(Duration::from_millis(100), Duration::from_secs(30));
        tokio::spawn(async move {
            let mut tick = tokio::time::interval(every);
            loop {
                tick.tick().await;
                state.reap();
            }
        })
    };
    let served = axum::serve(listener, router(state)).with_graceful_shutdown(crate::serve::shutdown()).await;
    reaper.abort();
    served
}

#[cfg(test)]
mod tests {
    use super::*;

    fn state() -> EnvServerState {
        EnvServerState::new(EnvServerConfig {
            max_sessions: 4,
            session_timeout: Duration::from_secs(60),
            max_message_bytes: 1 << 20,
        })
    }

    fn send_text(state: &EnvServerState, session: &mut Session, text: &str) -> Value {
        match ws_message(state, session, text) {
            WsReply::Send(v) => v,
            WsReply::Text(t) => serde_json::from_str(&t).unwrap(),
            WsReply::Close => json!("closed"),
        }
    }

    #[test]
    fn bad_messages_get_openenvs_errors_and_the_session_survives_them() {
        let s = state();
        let mut session = Session::default();
        let code = |v: &Value| v["data"]["code"].as_str().unwrap_or("").to_string();
        assert_eq!(code(&send_text(&s, &mut session, "{not json")), "INVALID_JSON");
        assert_eq!(code(&send_text(&s, &mut session, r#"{"type": "dance"}"#)), "UNKNOWN_TYPE");
        assert_eq!(code(&send_text(&s, &mut session, r#"[1, 2]"#)), "VALIDATION_ERROR");
        assert_eq!(
            code(&send_text(&s, &mut session, r#"{"type": "step", "data": {"reply": "{}"}}"#)),
            "EXECUTION_ERROR"
        );
        let bad = send_text(&s, &mut session, r#"{"type": "reset", "data": {"scenario": "roundabout"}}"#);
        assert_eq!(code(&bad), "VALIDATION_ERROR");
        assert_eq!(bad["data"]["errors"][0]["loc"], json!(["data", "scenario"]));
        let extra = send_text(&s, &mut session, r#"{"type": "state", "data": {}}"#);
        assert_eq!(extra["data"]["errors"][0]["loc"], json!(["data"]));
        let ok =
            send_text(&s, &mut session, r#"{"type": "reset", "data": {"scenario": "pedestrian_feint", "seed": 5}}"#);
        assert_eq!(ok["type"], "observation");
        assert_eq!(ok["data"]["observation"]["seed"], 5);
        assert_eq!(code(&send_text(&s, &mut session, r#"{"type": "step"}"#)), "VALIDATION_ERROR");
        assert_eq!(code(&send_text(&s, &mut session, r#"{"type": "step", "data": "proceed"}"#)), "VALIDATION_ERROR");
        let stepped = send_text(&s, &mut session, r#"{"type": "step", "data": {"reply": "no idea"}}"#);
        assert_eq!(stepped["data"]["observation"]["turn"], 2, "{stepped}");
        assert!(!stepped["data"]["observation"]["parse_errors"].as_array().unwrap().is_empty());
        assert_eq!(send_text(&s, &mut session, r#"{"type": "state"}"#)["data"]["step_count"], 1);
        assert_eq!(send_text(&s, &mut session, r#"{"type": "close"}"#), json!("closed"));
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

    #[test]
    fn capacity_is_counted_and_given_back() {
        let s = Arc::new(state());
        let slots: Vec<Slot> = (0..4).map(|_| s.acquire().unwrap()).collect();
        let Err(refused) = s.acquire() else { panic!("a fifth slot") };
        assert_eq!((refused.active, refused.max), (4, 4));
        drop(slots);
        assert_eq!(s.active_sessions(), 0);
        assert!(s.acquire().is_ok());
    }

    #[test]
    fn mcp_answers_json_rpc_with_no_tools() {
        assert_eq!(mcp_response(&json!({}))["error"]["code"], -32600);
        assert_eq!(
            mcp_response(&json!({"jsonrpc": "2.0", "method": "tools/list", "id": 1}))["result"]["tools"],
            json!([])
        );
        assert_eq!(mcp_response(&json!({"jsonrpc": "2.0", "method": "tools/call", "id": 2}))["error"]["code"], -32601);
    }
}
