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
//! - `GET /ws/batch`: the same messages for up to 64 sessions at once, one
//!   message each way per batch (for vectorised trainers; [`ws`] has the
//!   format). Not part of OpenEnv's protocol.
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
//! [`crate::episode::Episode`] as `eval`: no second episode loop. Each
//! transport has its file ([`http`], [`ws`], [`mcp`]); what a client sends
//! is checked once, by [`request`], whichever carried it.
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

mod http;
mod inprocess;
mod mcp;
mod net;
mod request;
mod schema;
mod session;
mod wire;
mod ws;

pub use inprocess::InProcessBatch;

use axum::Router;
use axum::body::Bytes;
use axum::extract::{DefaultBodyLimit, State};
use axum::http::StatusCode;
use axum::routing::{get, post};
use http::{http_reset, http_state, http_step, json_bytes, require_token};
use serde_json::{Value, json};
use session::Session;
use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering::Relaxed};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use tokio::sync::watch;

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
        .route("/mcp", post(mcp::http_mcp))
        .route("/ws", get(ws::ws_upgrade))
        .route("/ws/batch", get(ws::ws_batch_upgrade))
        .fallback(|| async { (StatusCode::NOT_FOUND, axum::Json(json!({"detail": "Not Found"}))) })
        .layer(axum::middleware::from_fn_with_state(state.clone(), require_token))
        // Handlers read their bodies themselves (`read_body`), under the
        // read deadline and with OpenEnv's JSON error past the limit.
        .layer(DefaultBodyLimit::disable())
        .with_state(state)
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
pub(super) mod tests {
    use super::*;

    pub(crate) fn state() -> EnvServerState {
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
    fn capacity_is_counted_and_given_back() {
        let s = Arc::new(state());
        let slots: Vec<Slot> = (0..4).map(|_| s.acquire().unwrap()).collect();
        let Err(refused) = s.acquire() else { panic!("a fifth slot") };
        assert_eq!((refused.active, refused.max), (4, 4));
        drop(slots);
        assert_eq!(s.active_sessions(), 0);
        assert!(s.acquire().is_ok());
    }
}
