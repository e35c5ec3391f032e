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
//! message or body above `--max-message-bytes` (OpenEnv's error, then close
//! 1009; HTTP 413 with a JSON body); a session with no message for
//! `--session-timeout` is closed (pings do not count). A session holds one
//! episode (a few KB, bounded by the turn budget), an error reply lists at
//! most a few fields, and a connection whose client stops reading is closed
//! ([`net`]), so memory is bounded per connection and in total. Episode ids
//! are 128 random bits: an HTTP episode's id is its capability, and a reset
//! never takes over a live one. `--token-var` requires a bearer token.

mod net;
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
use session::{FieldError, FieldErrors, ResetRequest, Session, SessionError, clip};
use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering::Relaxed};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use tokio::sync::watch;

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
    /// Connections served at once (HTTP, and WebSocket until upgraded).
    pub max_connections: usize,
    /// Headers, and a request's body, must arrive within this.
    pub read_timeout: Duration,
    /// A connection whose client reads nothing for this long is closed.
    pub stall_timeout: Duration,
    /// How long shutdown waits for open connections before it drops them.
    pub shutdown_grace: Duration,
    /// The bearer token every request but `/health` must carry, if any.
    pub token: Option<String>,
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
    /// WebSocket sessions running now (shutdown waits for them).
    ws_open: AtomicUsize,
    /// Set when shutdown begins: every WebSocket session closes (1001).
    stop: watch::Sender<bool>,
    documents: Documents,
    pub stats: EnvStats,
}

/// One running WebSocket session, counted in `ws_open` while it lives.
struct WsOpen(Arc<EnvServerState>);

impl Drop for WsOpen {
    fn drop(&mut self) {
        self.0.ws_open.fetch_sub(1, Relaxed);
    }
}

/// Random bytes from the operating system's source (ChaCha seeded from it
/// if the call fails): episode ids and drawn seeds are never predictable
/// from earlier ones.
fn os_random<const N: usize>() -> [u8; N] {
    let mut bytes = [0u8; N];
    if getrandom::fill(&mut bytes).is_err() {
        rand::fill(&mut bytes);
    }
    bytes
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
        let bytes = |v: Value| Bytes::from(serde_json::to_vec(&v).expect("a JSON value serialises"));
        EnvServerState {
            config,
            scenarios: crate::scenario::ScenarioSet::default(),
            active: AtomicUsize::new(0),
            http: Mutex::new(HashMap::new()),
            ws_open: AtomicUsize::new(0),
            stop: watch::channel(false).0,
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

    fn draw_seed(&self) -> u64 {
        u64::from_le_bytes(os_random()) % session::DRAWN_SEED_LIMIT
    }

    /// 128 random bits: an HTTP episode's id is its capability (whoever
    /// holds it may play it), so it must not be guessable.
    fn new_episode_id(&self) -> String {
        format!("ep-{:032x}", u128::from_le_bytes(os_random()))
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
        .layer(axum::middleware::from_fn_with_state(state.clone(), require_token))
        // Handlers read their bodies themselves (`read_body`), under the
        // read deadline and with OpenEnv's JSON error past the limit.
        .layer(DefaultBodyLimit::disable())
        .with_state(state)
}

/// With `--token-var`, every request but `/health` (a probe's) carries
/// `Authorization: Bearer TOKEN`; others get 401 with OpenEnv's JSON error.
async fn require_token(
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
async fn read_body(state: &EnvServerState, body: axum::body::Body) -> Result<Bytes, Response> {
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
            if let Some(first) = e.loc.first_mut() {
                *first = "body".to_string();
            }
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

async fn http_reset(State(state): State<Arc<EnvServerState>>, body: axum::body::Body) -> Response {
    let body = match read_body(&state, body).await {
        Ok(b) => b,
        Err(r) => return r,
    };
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

async fn http_step(State(state): State<Arc<EnvServerState>>, body: axum::body::Body) -> Response {
    let body = match read_body(&state, body).await {
        Ok(b) => b,
        Err(r) => return r,
    };
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
    let mut errors = FieldErrors::default();
    if action.is_none() {
        errors.push(|| missing("action", "Field required"));
    }
    let id = match id {
        Some(Value::String(id)) => Some(id),
        _ => {
            errors.push(|| {
                missing(
                    "episode_id",
                    "Field required: the episode_id /reset returned (or use the WebSocket session on /ws)",
                )
            });
            None
        }
    };
    for extra in fields.keys().filter(|k| !matches!(k.as_str(), "timeout_s" | "request_id")) {
        errors.push(|| FieldError {
            kind: "extra_forbidden",
            loc: vec!["body".to_string(), clip(extra).into_owned()],
            msg: "unknown field".to_string(),
        });
    }
    let (Some(action), Some(id), true) = (action, id, errors.is_empty()) else {
        state.stats.errors.fetch_add(1, Relaxed);
        let list = errors.into_list();
        return detail(StatusCode::UNPROCESSABLE_ENTITY, serde_json::to_value(list).expect("serialises"));
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
        None => detail(StatusCode::NOT_FOUND, json!(format!("unknown episode_id '{}'", clip(&id)))),
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

async fn http_mcp(State(state): State<Arc<EnvServerState>>, body: axum::body::Body) -> Response {
    let body = match read_body(&state, body).await {
        Ok(b) => b,
        Err(r) => return r,
    };
    let reply = match serde_json::from_slice::<Value>(&body) {
        Ok(request) => mcp_response(&request),
        Err(_) => json!({"jsonrpc": "2.0", "id": null, "error": {"code": -32700, "message": "Parse error"}}),
    };
    axum::Json(reply).into_response()
}

async fn ws_upgrade(State(state): State<Arc<EnvServerState>>, ws: WebSocketUpgrade) -> Response {
    let limit = state.config.max_message_bytes;
    // Small read and write buffers: a message is a few KB, and a large
    // buffer is zeroed on every read. Outgoing bytes are capped: the server
    // writes one bounded reply at a time, and a client that stops reading is
    // closed by the connection's stall guard.
    ws.max_message_size(limit)
        .max_frame_size(limit)
        .read_buffer_size(WS_BUFFER_BYTES)
        .write_buffer_size(WS_BUFFER_BYTES)
        .max_write_buffer_size(MAX_WS_OUTGOING_BYTES)
        .on_upgrade(move |socket| ws_session(socket, state))
}

/// Most bytes a session may have written and not yet sent: the largest
/// reply with its framing, twice.
const MAX_WS_OUTGOING_BYTES: usize = WS_BUFFER_BYTES + 2 * (2 * session::MAX_REPLY_BYTES + 4096);

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
        _ => return WsReply::Send(ws_error("UNKNOWN_TYPE", format!("Unknown message type: {}", clip(kind)))),
    };
    let mut extra = FieldErrors::default();
    for k in fields.keys().filter(|k| !allowed.contains(&k.as_str())) {
        extra.push(|| FieldError {
            kind: "extra_forbidden",
            loc: vec![clip(k).into_owned()],
            msg: "Extra inputs are not permitted".to_string(),
        });
    }
    if !extra.is_empty() {
        return WsReply::Send(invalid(extra.into_list()));
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

/// Resolves once the server's shutdown has begun.
async fn stopping(stop: &mut watch::Receiver<bool>) {
    let _ = stop.wait_for(|stopping| *stopping).await;
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
    state.ws_open.fetch_add(1, Relaxed);
    let _open = WsOpen(state.clone());
    let mut stop = state.stop.subscribe();
    let mut session = Session::default();
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
            Message::Text(text) => ws_message(&state, &mut session, text.as_str()),
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

/// Serve on `listener` until Ctrl-C (or SIGTERM), then close within the
/// shutdown grace ([`net::serve`]); idle HTTP episodes are reaped in the
/// background.
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
    let c = &state.config;
    let limits = net::NetLimits {
        max_connections: c.max_connections,
        read_timeout: c.read_timeout,
        stall_timeout: c.stall_timeout,
        shutdown_grace: c.shutdown_grace,
    };
    let open = state.clone();
    let served = net::serve(
        listener,
        router(state.clone()),
        limits,
        crate::shutdown::shutdown(),
        state.stop.clone(),
        move || open.ws_open.load(Relaxed),
    )
    .await;
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
            max_connections: 16,
            read_timeout: Duration::from_secs(10),
            stall_timeout: Duration::from_secs(10),
            shutdown_grace: Duration::from_secs(1),
            token: None,
        })
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
        assert_eq!(errors.len(), session::MAX_LISTED_ERRORS + 1, "{text}");
        assert_eq!(errors.last().unwrap()["msg"], "99996 more errors not listed", "{text}");
    }

    #[test]
    fn episode_ids_carry_128_random_bits() {
        let state = state();
        let ids: std::collections::HashSet<String> = (0..1000).map(|_| state.new_episode_id()).collect();
        assert_eq!(ids.len(), 1000);
        for id in &ids {
            let hex = id.strip_prefix("ep-").unwrap();
            assert_eq!(hex.len(), 32, "{id}");
            assert!(u128::from_str_radix(hex, 16).is_ok(), "{id}");
        }
        // Not a counter: consecutive ids share no long prefix.
        let a = state.new_episode_id();
        let b = state.new_episode_id();
        assert_ne!(a[..11], b[..11]);
    }

    #[test]
    fn secrets_compare_by_content_and_length() {
        assert!(same_secret(b"s3cret", b"s3cret"));
        assert!(!same_secret(b"s3cret", b"s3creT"));
        assert!(!same_secret(b"s3cret", b"s3cret!"));
        assert!(!same_secret(b"", b"x"));
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
