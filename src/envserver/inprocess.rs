//! `/ws/batch` without the socket: [`InProcessBatch`] takes the batch
//! messages a `/ws/batch` connection takes and answers exactly what it
//! answers, in the caller's process. The Python package's native vector
//! (`python/native`, through PyO3) steps its sessions this way, so a
//! training run pays no WebSocket, no syscall and no thread wake-up per
//! step; the sessions, the episodes and the answers are env-server's own.

use super::ws::{Batch, MAX_BATCH_SESSIONS, WsReply};
use super::{EnvServerConfig, EnvServerState};
use std::sync::Arc;
use std::time::Duration;

/// The sessions of one `/ws/batch` connection, held in-process.
pub struct InProcessBatch {
    state: Arc<EnvServerState>,
    batch: Batch,
}

impl Default for InProcessBatch {
    fn default() -> Self {
        Self::new()
    }
}

impl InProcessBatch {
    /// Up to 64 sessions, as one `/ws/batch` connection holds.
    pub fn new() -> InProcessBatch {
        // Only the session bound applies without a socket; the others
        // bound what a network peer can do.
        let config = EnvServerConfig {
            max_sessions: MAX_BATCH_SESSIONS,
            session_timeout: Duration::MAX,
            max_message_bytes: usize::MAX,
            max_connections: 1,
            read_timeout: Duration::MAX,
            stall_timeout: Duration::MAX,
            shutdown_grace: Duration::ZERO,
            token: None,
        };
        InProcessBatch { state: Arc::new(EnvServerState::new(config)), batch: Batch::default() }
    }

    /// One message (`{"type": "batch", "data": [...]}` or `{"type":
    /// "close"}`) and `/ws/batch`'s answer to it; None for `close`, after
    /// which the sessions are gone.
    pub fn message(&mut self, text: &str) -> Option<String> {
        match self.batch.message(&self.state, text) {
            WsReply::Text(text) => Some(text),
            WsReply::Send(value) => Some(value.to_string()),
            WsReply::Close => {
                self.batch = Batch::default();
                None
            }
        }
    }

    /// `GET /metadata`'s document.
    pub fn metadata() -> String {
        super::schema::metadata().to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::{Value, json};

    /// The same messages through a `/ws/batch` connection's handler and
    /// in-process give the same answers, byte for byte.
    #[test]
    fn in_process_answers_are_the_connections() {
        let state = Arc::new(super::super::tests::state());
        let mut connection = Batch::default();
        let mut local = InProcessBatch::new();
        let reset = |seed: u64| json!({"type": "reset", "data": {"scenario": "contested_merge", "tier": 1, "seed": seed, "view": "features", "episode_id": format!("e{seed}")}});
        let step = json!({"type": "step", "data": {"maneuver": "proceed", "acceleration": 0.6}});
        let mut rounds = vec![json!({"type": "batch", "data": [reset(1), reset(2), Value::Null]}).to_string()];
        rounds.extend((0..30).map(|_| json!({"type": "batch", "data": [step, step]}).to_string()));
        rounds.push("not json".into());
        for round in &rounds {
            let want = match connection.message(&state, round) {
                WsReply::Text(t) => t,
                WsReply::Send(v) => v.to_string(),
                WsReply::Close => unreachable!(),
            };
            assert_eq!(local.message(round), Some(want));
        }
        assert_eq!(local.message(r#"{"type": "close"}"#), None);
        let meta: Value = serde_json::from_str(&InProcessBatch::metadata()).unwrap();
        assert_eq!(meta["discrete_actions"].as_array().unwrap().len(), 10);
    }
}
