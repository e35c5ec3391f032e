//! `negotiator env-server` as a child process, spoken to over real HTTP and
//! WebSocket connections (the Python clients' checks are in
//! `scripts/openenv_check.sh`).

use super::support::Server;
use futures_util::{SinkExt, StreamExt};
use negotiator::action::{Action, Maneuver};
use negotiator::episode::run_episode;
use negotiator::observation::Observation;
use negotiator::policy::PolicyKind;
use negotiator::scenario::{ScenarioKind, ScenarioSet, Tier};
use serde_json::{Value, json};
use std::time::Duration;
use tokio_tungstenite::tungstenite::Message;

/// `negotiator env-server --port 0 ARGS`, killed on drop.
struct EnvServer(Server);

impl EnvServer {
    fn start(args: &[&str]) -> EnvServer {
        EnvServer(Server::spawn("env-server", args, ""))
    }

    fn port(&self) -> u16 {
        self.0.port
    }

    fn url(&self, path: &str) -> String {
        format!("http://127.0.0.1:{}{path}", self.0.port)
    }
}

fn runtime() -> tokio::runtime::Runtime {
    tokio::runtime::Builder::new_current_thread().enable_all().build().unwrap()
}

type Socket = tokio_tungstenite::WebSocketStream<tokio_tungstenite::MaybeTlsStream<tokio::net::TcpStream>>;

async fn connect(port: u16) -> Socket {
    tokio_tungstenite::connect_async(format!("ws://127.0.0.1:{port}/ws")).await.unwrap().0
}

/// Send one message and read the answer (None: the server closed).
async fn exchange(ws: &mut Socket, message: &Value) -> Option<Value> {
    ws.send(Message::text(message.to_string())).await.ok()?;
    next_json(ws).await
}

async fn next_json(ws: &mut Socket) -> Option<Value> {
    loop {
        match ws.next().await? {
            Ok(Message::Text(t)) => return Some(serde_json::from_str(t.as_str()).unwrap()),
            Ok(Message::Close(_)) | Err(_) => return None,
            Ok(_) => continue,
        }
    }
}

/// A blind schedule: its action depends on the turn only.
fn schedule(turn: u32) -> Action {
    match turn {
        1..=3 => Action::new(Maneuver::Yield, 0.6),
        4..=6 => Action::new(Maneuver::NudgeForward, 0.5),
        _ => Action::new(Maneuver::Proceed, 0.8),
    }
}

struct Scheduled;

impl negotiator::policy::Policy for Scheduled {
    fn act(&mut self, o: &negotiator::observation::Observation) -> Action {
        schedule(o.turn)
    }
}

fn blind_policies() -> Vec<Box<dyn negotiator::policy::Policy>> {
    vec![PolicyKind::AlwaysProceed.build(), Box::new(Scheduled)]
}

#[test]
fn websocket_episodes_are_the_episodes_the_rust_loop_plays() {
    let server = EnvServer::start(&[]);
    let set = ScenarioSet::default();
    runtime().block_on(async {
        let mut ws = connect(server.port()).await;
        for kind in ScenarioKind::ALL {
            for tier in Tier::ALL {
                for seed in 0..6u64 {
                    for (which, (mut policy, mut twin)) in blind_policies().into_iter().zip(blind_policies()).enumerate() {
                        let reference = run_episode(set.get(kind), tier, seed, twin.as_mut());
                        let reset = json!({"type": "reset", "data": {"scenario": kind.name(), "tier": tier.number(), "seed": seed}});
                        let mut reply = exchange(&mut ws, &reset).await.unwrap();
                        let mut total = 0.0;
                        let mut turns = 0;
                        while !reply["data"]["done"].as_bool().unwrap() {
                            let seen: Observation = serde_json::from_value(reply["data"]["observation"]["public"].clone()).unwrap();
                            let action = policy.act(&seen);
                            reply = exchange(&mut ws, &json!({"type": "step", "data": action})).await.unwrap();
                            assert_eq!(reply["type"], "observation", "{reply}");
                            total += reply["data"]["reward"].as_f64().unwrap();
                            turns += 1;
                        }
                        let meta = &reply["data"]["metadata"];
                        let at = format!("{kind} t{tier} seed {seed} policy {which}");
                        assert_eq!(meta["outcome"], reference.outcome.name(), "{at}");
                        assert_eq!(total, reference.grades.reward, "{at}");
                        assert_eq!(turns, reference.decisions.len(), "{at}");
                        assert_eq!(meta["disposition"], reference.disposition.name(), "{at}");
                        assert_eq!(meta["evidence_turn"], json!(reference.timing.evidence_turn), "{at}");
                    }
                }
            }
        }
    });
}

#[test]
fn http_plays_an_episode_under_its_id_and_refuses_bad_requests_clearly() {
    let server = EnvServer::start(&[]);
    runtime().block_on(async {
        let http = reqwest::Client::new();
        let post = |path: &str, body: Value| {
            let request = http.post(server.url(path)).json(&body);
            async move {
                let r = request.send().await.unwrap();
                (r.status().as_u16(), r.json::<Value>().await.unwrap())
            }
        };
        let (status, first) = post("/reset", json!({"scenario": "contested_merge", "tier": 3, "seed": 9})).await;
        assert_eq!(status, 200);
        let id = first["observation"]["episode_id"].as_str().unwrap().to_string();
        assert!(first["reward"].is_null() && first["done"] == false);
        assert!(first["observation"]["instructions"].as_str().unwrap().starts_with("You are the driver"));

        let (status, bad) = post("/step", json!({"action": {"maneuver": "stop", "acceleration": 0.5}})).await;
        assert_eq!(status, 422);
        assert_eq!(bad["detail"][0]["loc"], json!(["body", "episode_id"]));
        let (status, bad) = post("/reset", json!({"tier": 7})).await;
        assert_eq!((status, bad["detail"][0]["loc"].clone()), (422, json!(["body", "tier"])));
        let (status, _) = post("/step", json!({"action": {}, "episode_id": "nope"})).await;
        assert_eq!(status, 404);

        let state: Value =
            http.get(server.url(&format!("/state?episode_id={id}"))).send().await.unwrap().json().await.unwrap();
        assert_eq!((state["step_count"].clone(), state["disposition"].clone()), (json!(0), Value::Null));
        let mut last = first;
        while last["done"] == false {
            let (status, reply) = post(
                "/step",
                json!({"action": {"reply": "{\"maneuver\": \"proceed\", \"acceleration\": 1}"}, "episode_id": id}),
            )
            .await;
            assert_eq!(status, 200, "{reply}");
            last = reply;
        }
        assert!(last["metadata"]["outcome"].is_string() && last["reward"].is_number());
        let (status, _) = post("/step", json!({"action": {"reply": "{}"}, "episode_id": id})).await;
        assert_eq!(status, 404, "an HTTP episode is forgotten once it ends");

        let health: Value = http.get(server.url("/health")).send().await.unwrap().json().await.unwrap();
        assert_eq!(health["status"], "healthy");
        let schema: Value = http.get(server.url("/schema")).send().await.unwrap().json().await.unwrap();
        for part in ["action", "observation", "state"] {
            assert!(schema[part].is_object(), "{part}");
        }
        assert_eq!(schema["action"]["required"], json!(["reply"]));
        let openapi: Value = http.get(server.url("/openapi.json")).send().await.unwrap().json().await.unwrap();
        assert!(openapi["info"]["version"].is_string());
        for path in ["/reset", "/step", "/state"] {
            assert!(openapi["paths"][path].is_object(), "{path}");
        }
        let mcp: Value = http.post(server.url("/mcp")).json(&json!({})).send().await.unwrap().json().await.unwrap();
        assert_eq!(mcp["jsonrpc"], "2.0");
        let meta: Value = http.get(server.url("/metadata")).send().await.unwrap().json().await.unwrap();
        assert_eq!(meta["name"], "negotiator");
        assert_eq!(meta["scenarios"].as_array().unwrap().len(), ScenarioKind::ALL.len());
        assert_eq!(
            meta["feature_names"].as_array().unwrap().len(),
            last["observation"]["features"].as_array().unwrap().len()
        );
    });
}

#[test]
fn sessions_past_the_limit_are_refused_with_the_capacity_error_and_idle_ones_expire() {
    let server = EnvServer::start(&["--max-sessions", "2", "--session-timeout", "0.5"]);
    runtime().block_on(async {
        let reset = json!({"type": "reset", "data": {"seed": 1}});
        let mut a = connect(server.port()).await;
        let mut b = connect(server.port()).await;
        assert_eq!(exchange(&mut a, &reset).await.unwrap()["type"], "observation");
        assert_eq!(exchange(&mut b, &reset).await.unwrap()["type"], "observation");
        let mut c = connect(server.port()).await;
        let refusal = next_json(&mut c).await.unwrap();
        assert_eq!(refusal["data"]["code"], "CAPACITY_REACHED", "{refusal}");
        assert_eq!(refusal["data"]["max_sessions"], 2);
        assert!(next_json(&mut c).await.is_none(), "the refused connection is closed");
        drop(b);
        // `a` stays idle: the server closes it with a notice.
        let notice = tokio::time::timeout(Duration::from_secs(5), next_json(&mut a)).await.unwrap().unwrap();
        assert_eq!(notice["data"]["code"], "SESSION_ERROR", "{notice}");
        let mut d = connect(server.port()).await;
        assert_eq!(exchange(&mut d, &reset).await.unwrap()["type"], "observation");
    });
}

#[test]
fn a_session_in_use_outlives_its_idle_timeout() {
    // Each message pushes the idle deadline back: a client answering every
    // 0.25 s keeps a session with a 1 s timeout for 2.5 s, then loses it
    // once it goes quiet.
    let server = EnvServer::start(&["--session-timeout", "1"]);
    runtime().block_on(async {
        let mut ws = connect(server.port()).await;
        let reset = json!({"type": "reset", "data": {"seed": 1}});
        assert_eq!(exchange(&mut ws, &reset).await.unwrap()["type"], "observation");
        for _ in 0..10 {
            tokio::time::sleep(Duration::from_millis(250)).await;
            let state = exchange(&mut ws, &json!({"type": "state"})).await.expect("the session is still open");
            assert_eq!(state["type"], "state", "{state}");
        }
        let notice = tokio::time::timeout(Duration::from_secs(5), next_json(&mut ws)).await.unwrap().unwrap();
        assert_eq!(notice["data"]["code"], "SESSION_ERROR", "{notice}");
    });
}

#[test]
fn bad_flags_are_one_line_usage_errors() {
    for args in [
        &["env-server", "--max-sessions", "0"][..],
        &["env-server", "--session-timeout", "nan"],
        &["env-server", "--max-message-bytes", "10"],
    ] {
        let out = super::support::negotiator().args(args).output().unwrap();
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(err.trim().lines().count(), 1, "{err}");
    }
}
