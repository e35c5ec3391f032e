//! `negotiator env-server`: the benchmark as an OpenEnv environment.
use super::usage;
use crate::envserver::{EnvServerConfig, EnvServerState};
use crate::redact::eline;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::Ordering::Relaxed;
use std::time::Duration;

#[derive(Debug, clap::Args)]
pub struct EnvServerArgs {
    /// Address to bind (0.0.0.0 to serve other machines, e.g. in a pod).
    #[arg(long, default_value = "127.0.0.1")]
    pub host: String,
    /// Port to bind; 0 picks a free port. The address is printed on stdout
    /// as `listening on http://HOST:PORT`.
    #[arg(long, default_value_t = 8000)]
    pub port: u16,
    /// Most sessions open at once: WebSocket connections and open HTTP
    /// episodes together. Past it, a WebSocket gets OpenEnv's
    /// CAPACITY_REACHED error and an HTTP reset gets 503.
    #[arg(long, default_value_t = 1024)]
    pub max_sessions: usize,
    /// Seconds a session may stay idle before it is closed.
    #[arg(long, default_value_t = 300.0)]
    pub session_timeout: f64,
    /// Largest WebSocket message or HTTP body read, in bytes.
    #[arg(long, default_value_t = 1 << 20)]
    pub max_message_bytes: usize,
    /// Most connections served at once (HTTP connections, and WebSocket
    /// ones until they become sessions); past it the server stops accepting
    /// until one closes.
    #[arg(long, default_value_t = 2048)]
    pub max_connections: usize,
    /// Seconds a client has to send a request's headers, and then its body.
    #[arg(long, default_value_t = 10.0)]
    pub read_timeout: f64,
    /// Seconds a connection may go without its client reading anything the
    /// server wrote before it is closed (a client that sends and never reads
    /// holds one reply, not a growing queue).
    #[arg(long, default_value_t = 10.0)]
    pub stall_timeout: f64,
    /// Seconds shutdown (Ctrl-C, SIGTERM) waits for open connections and
    /// sessions before it closes what is left.
    #[arg(long, default_value_t = 5.0)]
    pub shutdown_grace: f64,
    /// Require `Authorization: Bearer TOKEN` on every request but /health,
    /// TOKEN read from this environment variable (never printed or logged).
    #[arg(long, value_name = "NAME")]
    pub token_var: Option<String>,
}

/// A number of seconds from a flag, within `range`.
fn seconds(flag: &str, value: f64, range: std::ops::RangeInclusive<f64>) -> anyhow::Result<Duration> {
    if value.is_finite() && range.contains(&value) {
        Ok(Duration::from_secs_f64(value))
    } else {
        Err(usage(format!("{flag}: expected {} to {} seconds, got {value}", range.start(), range.end())))
    }
}

impl EnvServerArgs {
    fn config(&self) -> anyhow::Result<EnvServerConfig> {
        if !(1..=1_000_000).contains(&self.max_sessions) {
            return Err(usage(format!("--max-sessions: expected 1 to 1000000, got {}", self.max_sessions)));
        }
        if !(self.session_timeout.is_finite() && (0.1..=86_400.0).contains(&self.session_timeout)) {
            return Err(usage(format!(
                "--session-timeout: expected 0.1 to 86400 seconds, got {}",
                self.session_timeout
            )));
        }
        let min = crate::envserver::MIN_MESSAGE_BYTES;
        if !(min..=64 << 20).contains(&self.max_message_bytes) {
            return Err(usage(format!(
                "--max-message-bytes: expected {min} to 67108864, got {}",
                self.max_message_bytes
            )));
        }
        if !(1..=1_000_000).contains(&self.max_connections) {
            return Err(usage(format!("--max-connections: expected 1 to 1000000, got {}", self.max_connections)));
        }
        let token = match &self.token_var {
            None => None,
            Some(name) => match std::env::var(name) {
                Ok(token) if !token.trim().is_empty() => {
                    crate::redact::register_secret(&token);
                    Some(token)
                }
                _ => return Err(usage(format!("--token-var: the environment variable {name} is not set or empty"))),
            },
        };
        Ok(EnvServerConfig {
            max_sessions: self.max_sessions,
            session_timeout: Duration::from_secs_f64(self.session_timeout),
            max_message_bytes: self.max_message_bytes,
            max_connections: self.max_connections,
            read_timeout: seconds("--read-timeout", self.read_timeout, 0.1..=3600.0)?,
            stall_timeout: seconds("--stall-timeout", self.stall_timeout, 0.1..=3600.0)?,
            shutdown_grace: seconds("--shutdown-grace", self.shutdown_grace, 0.0..=3600.0)?,
            token,
        })
    }

    pub fn run(self) -> anyhow::Result<ExitCode> {
        let config = self.config()?;
        let state = Arc::new(EnvServerState::new(config));
        super::serve_on(&self.host, self.port, "", |listener| crate::envserver::run(listener, state.clone()))?;
        let s = &state.stats;
        eline!(
            "served {} sessions ({} refused at capacity, {} expired idle): {} steps, {} episodes finished, {} errors",
            s.sessions.load(Relaxed),
            s.refused.load(Relaxed),
            s.expired.load(Relaxed),
            s.steps.load(Relaxed),
            s.episodes_done.load(Relaxed),
            s.errors.load(Relaxed)
        );
        Ok(ExitCode::SUCCESS)
    }
}
