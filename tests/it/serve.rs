//! `negotiator serve` as a child process, plus helpers the eval tests share.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

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
        let mut child = negotiator()
            .args(["serve", "--port", "0"])
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("start negotiator serve");
        let mut line = String::new();
        BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).unwrap();
        let port = line
            .trim()
            .strip_prefix("listening on http://127.0.0.1:")
            .and_then(|r| r.strip_suffix("/v1"))
            .unwrap_or_else(|| panic!("unexpected first line {line:?}"))
            .parse()
            .unwrap();
        Server { child, port }
    }

    pub fn base_url(&self) -> String {
        format!("http://127.0.0.1:{}/v1", self.port)
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn post(port: u16, body: &serde_json::Value) -> (u16, serde_json::Value) {
    let rt = tokio::runtime::Builder::new_current_thread().enable_all().build().unwrap();
    rt.block_on(async {
        let r = reqwest::Client::new()
            .post(format!("http://127.0.0.1:{port}/v1/chat/completions"))
            .json(body)
            .send()
            .await
            .unwrap();
        let status = r.status().as_u16();
        (status, r.json().await.unwrap())
    })
}

fn scene(kind: negotiator::scenario::ScenarioKind) -> String {
    let config = negotiator::scenario::ScenarioConfig::builtin(kind);
    let ep = negotiator::episode::Episode::new(&config, negotiator::scenario::Tier::T1, 0);
    negotiator::observation::render_scene(ep.observation())
}

#[test]
fn answers_like_an_openai_server() {
    let server = Server::start(&["--policy", "expert"]);
    let rt = tokio::runtime::Builder::new_current_thread().enable_all().build().unwrap();
    let models: serde_json::Value = rt
        .block_on(async { reqwest::get(format!("{}/models", server.base_url())).await.unwrap().json().await.unwrap() });
    assert_eq!(models["object"], "list");
    assert_eq!(models["data"][0]["id"], "expert");

    let body = serde_json::json!({
        "model": "expert",
        "messages": [
            {"role": "system", "content": "drive"},
            {"role": "user", "content": "an older scene"},
            {"role": "assistant", "content": "{}"},
            {"role": "user", "content": scene(negotiator::scenario::ScenarioKind::YieldStandoff)},
        ],
    });
    let (status, r) = post(server.port, &body);
    assert_eq!(status, 200);
    assert!(r["id"].as_str().unwrap().starts_with("chatcmpl-"));
    assert_eq!(r["object"], "chat.completion");
    assert!(r["created"].as_u64().unwrap() > 0);
    assert_eq!(r["model"], "expert");
    assert_eq!(r["choices"][0]["index"], 0);
    assert_eq!(r["choices"][0]["message"]["role"], "assistant");
    assert_eq!(r["choices"][0]["finish_reason"], "stop");
    let usage = &r["usage"];
    assert_eq!(
        usage["total_tokens"].as_u64().unwrap(),
        usage["prompt_tokens"].as_u64().unwrap() + usage["completion_tokens"].as_u64().unwrap()
    );
    let content = r["choices"][0]["message"]["content"].as_str().unwrap();
    let parsed = negotiator::action::parse_action(content);
    assert!(parsed.is_clean(), "{content}");
    let reply: serde_json::Value = serde_json::from_str(content).unwrap();
    for k in ["reasoning", "acceleration", "steering", "maneuver"] {
        assert!(reply.get(k).is_some(), "{k} in {content}");
    }
}

#[test]
fn an_unreadable_scene_gets_the_conservative_stop_not_an_error() {
    let server = Server::start(&["--policy", "always_proceed"]);
    let (status, r) =
        post(server.port, &serde_json::json!({"model": "x", "messages": [{"role": "user", "content": "hello"}]}));
    assert_eq!(status, 200);
    let parsed = negotiator::action::parse_action(r["choices"][0]["message"]["content"].as_str().unwrap());
    assert!(parsed.is_clean());
    assert_eq!(parsed.action, negotiator::action::Action::CONSERVATIVE);
    // No messages at all: still an answer.
    let (status, _) = post(server.port, &serde_json::json!({"model": "x", "messages": []}));
    assert_eq!(status, 200);
}

#[test]
fn fault_injection_is_deterministic_per_request_count() {
    let statuses = || {
        let server = Server::start(&["--policy", "expert", "--fail-rate", "0.5", "--seed", "3"]);
        let body = serde_json::json!({"model": "x", "messages": [{"role": "user", "content": scene(negotiator::scenario::ScenarioKind::ContestedMerge)}]});
        (0..30)
            .map(|_| {
                let (s, r) = post(server.port, &body);
                (s, r.get("error").is_some())
            })
            .collect::<Vec<_>>()
    };
    let a = statuses();
    assert!(a.iter().any(|(_, e)| *e) && a.iter().any(|(_, e)| !*e), "{a:?}");
    assert_eq!(a, statuses());
}

#[test]
fn bad_flags_are_usage_errors() {
    let out = negotiator().args(["serve", "--policy", "nobody"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let out = negotiator().args(["serve", "--policy", "expert", "--fail-rate", "2"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--fail-rate"));
}
