//! Helpers every integration test shares: the binary, scratch
//! directories, `serve` (and any subcommand that prints `listening on`) as
//! a child process, a mock chat endpoint for replies `serve` never gives,
//! running a command without a panic, and the one reader of JSON-lines
//! files.

use serde_json::{Value, json};
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};

pub fn negotiator() -> Command {
    Command::new(env!("CARGO_BIN_EXE_negotiator"))
}

/// A fresh directory under the target's test scratch space.
pub fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("it-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// `negotiator serve --port 0 ARGS`, killed on drop.
pub struct Server {
    child: Child,
    pub port: u16,
}

impl Server {
    pub fn start(args: &[&str]) -> Server {
        Server::spawn("serve", args, "/v1")
    }

    /// `negotiator SUBCOMMAND --port 0 ARGS`, its port read from the first
    /// line `listening on http://127.0.0.1:PORT{suffix}`.
    pub fn spawn(subcommand: &str, args: &[&str], suffix: &str) -> Server {
        Server::spawn_with_env(subcommand, args, suffix, &[])
    }

    /// [`Server::spawn`] with extra environment variables.
    pub fn spawn_with_env(subcommand: &str, args: &[&str], suffix: &str, env: &[(&str, &str)]) -> Server {
        let mut child = negotiator()
            .args([subcommand, "--port", "0"])
            .args(args)
            .envs(env.iter().copied())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .unwrap_or_else(|e| panic!("start negotiator {subcommand}: {e}"));
        let mut line = String::new();
        BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).unwrap();
        let port = line
            .trim()
            .strip_prefix("listening on http://127.0.0.1:")
            .and_then(|r| r.strip_suffix(suffix))
            .unwrap_or_else(|| panic!("unexpected first line {line:?}"))
            .parse()
            .unwrap();
        Server { child, port }
    }

    pub fn base_url(&self) -> String {
        format!("http://127.0.0.1:{}/v1", self.port)
    }

    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    /// Wait up to `limit` for the process to exit by itself.
    pub fn exited_within(&mut self, limit: std::time::Duration) -> Option<std::process::ExitStatus> {
        let start = std::time::Instant::now();
        while start.elapsed() < limit {
            if let Some(status) = self.child.try_wait().unwrap() {
                return Some(status);
            }
            std::thread::sleep(std::time::Duration::from_millis(50));
        }
        None
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// `negotiator eval --base-url URL --model MODEL --output OUT --run-name
/// NAME`: each suite adds its own flags.
pub fn eval_command(base_url: &str, model: &str, out: &Path, run_name: &str) -> Command {
    let mut c = negotiator();
    c.args(["eval", "--base-url", base_url, "--model", model, "--output"]).arg(out).args(["--run-name", run_name]);
    c
}

/// Every line of a JSON-lines file (none when it does not exist).
pub fn jsonl(path: &Path) -> Vec<Value> {
    std::fs::read_to_string(path).unwrap_or_default().lines().map(|l| serde_json::from_str(l).unwrap()).collect()
}

pub fn read_json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

pub fn run(mut c: Command) -> Output {
    let out = c.output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked") && !err.contains("RUST_BACKTRACE"), "panic: {err}");
    out
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// `run`, and it must have succeeded.
pub fn ok(c: Command) -> Output {
    let out = run(c);
    assert!(out.status.success(), "exit {:?}: {}", out.status.code(), stderr(&out));
    out
}

use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering::SeqCst};

/// What a mock sees of one chat request.
pub struct Request {
    /// 0-based index of the request, in arrival order.
    pub index: usize,
    pub headers: axum::http::HeaderMap,
    pub body: Value,
}

pub type Handler = Arc<dyn Fn(&Request) -> axum::response::Response + Send + Sync>;

/// An axum server on a background thread answering
/// `POST /v1/chat/completions` with `handler`; returns its base URL.
pub fn mock(handler: Handler) -> String {
    use axum::routing::post;
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let rt = tokio::runtime::Builder::new_current_thread().enable_all().build().unwrap();
        rt.block_on(async move {
            let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
            tx.send(listener.local_addr().unwrap().port()).unwrap();
            let count = Arc::new(AtomicUsize::new(0));
            let app = axum::Router::new().route(
                "/v1/chat/completions",
                post(move |headers: axum::http::HeaderMap, body: axum::body::Bytes| {
                    let index = count.fetch_add(1, SeqCst);
                    let handler = handler.clone();
                    async move {
                        let body = serde_json::from_slice(&body).unwrap_or(Value::Null);
                        handler(&Request { index, headers, body })
                    }
                }),
            );
            // Conversations of pictures outgrow axum's 2 MB default.
            let app = app.layer(axum::extract::DefaultBodyLimit::max(64 << 20));
            axum::serve(listener, app).await.unwrap();
        });
    });
    format!("http://127.0.0.1:{}/v1", rx.recv().unwrap())
}

pub fn respond(status: u16, body: Value) -> axum::response::Response {
    use axum::response::IntoResponse;
    (axum::http::StatusCode::from_u16(status).unwrap(), axum::Json(body)).into_response()
}

/// A 200 whose content is `content`.
pub fn reply(content: &str) -> axum::response::Response {
    respond(200, json!({"choices": [{"message": {"role": "assistant", "content": content}, "finish_reason": "stop"}]}))
}

/// Whether an outside tool a test drives (Chromium, tmux) is there. In CI
/// (`CI=true`) a missing one fails the test: `.ci/run` installs it, and a
/// test that skipped there would pass having checked nothing. Elsewhere the
/// test says "skipped" and goes on without it.
pub fn tool_available(available: bool, what: &str) -> bool {
    if available {
        return true;
    }
    assert!(
        std::env::var("CI").as_deref() != Ok("true"),
        "{what} is not installed, and CI must run this test (.ci/run installs it)"
    );
    eprintln!("skipped: {what} not installed");
    false
}

/// How many scenarios the benchmark holds: tests count them, never write
/// the number, so that a scenario added through the registry changes none.
pub fn scenarios() -> usize {
    negotiator::scenario::ScenarioKind::ALL.len()
}

/// How many (scenario, tier) cells `--scenario all --tier all` selects.
pub fn cells() -> usize {
    scenarios() * negotiator::scenario::Tier::ALL.len()
}
