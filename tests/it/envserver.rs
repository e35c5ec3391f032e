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

/// Defects a careless or hostile client could use against everyone else
/// on a shared env-server, one test each.
mod shared_cluster {
    use super::*;
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    use tokio::net::TcpStream;

    fn post_raw(port: u16, path: &str, body: &[u8]) -> (u16, Value, usize) {
        runtime().block_on(async {
            let r = reqwest::Client::new()
                .post(format!("http://127.0.0.1:{port}{path}"))
                .header("content-type", "application/json")
                .body(body.to_vec())
                .send()
                .await
                .unwrap();
            let status = r.status().as_u16();
            let bytes = r.bytes().await.unwrap();
            (status, serde_json::from_slice(&bytes).unwrap_or(Value::Null), bytes.len())
        })
    }

    /// A 1 MB body of 100,000 unknown keys gets a small 422 (a few errors
    /// and a count), not a reply that lists them all.
    #[test]
    fn an_error_reply_does_not_grow_with_the_request() {
        let server = EnvServer::start(&[]);
        let keys: Vec<String> = (0..100_000).map(|i| format!("\"{i}\":0")).collect();
        let body = format!("{{{}}}", keys.join(","));
        assert!(body.len() > 900_000);
        let (status, reply, size) = post_raw(server.port(), "/reset", body.as_bytes());
        assert_eq!(status, 422, "{reply}");
        assert!(size < 2048, "{size} bytes");
        let listed = reply["detail"].as_array().unwrap();
        assert_eq!(listed.last().unwrap()["msg"], "99995 more errors not listed", "{reply}");
    }

    /// A body over the limit gets OpenEnv's JSON error, not plain text.
    #[test]
    fn an_oversized_body_gets_a_json_413() {
        let server = EnvServer::start(&["--max-message-bytes", "140000"]);
        let (status, reply, _) = post_raw(server.port(), "/reset", &vec![b' '; 150_000]);
        assert_eq!(status, 413);
        assert!(reply["detail"].as_str().unwrap().contains("140000"), "{reply}");
    }

    /// Episode ids carry 128 random bits, and a reset that names a live
    /// one is refused: nobody takes over another client's episode.
    #[test]
    fn an_episode_id_is_unguessable_and_cannot_be_taken_over() {
        let server = EnvServer::start(&[]);
        let (status, first, _) = post_raw(server.port(), "/reset", b"{\"seed\": 1}");
        assert_eq!(status, 200);
        let id = first["observation"]["episode_id"].as_str().unwrap().to_string();
        let hex = id.strip_prefix("ep-").unwrap();
        assert_eq!(hex.len(), 32, "{id}");
        let (_, second, _) = post_raw(server.port(), "/reset", b"{}");
        assert_ne!(second["observation"]["episode_id"], first["observation"]["episode_id"]);
        let (status, refusal, _) = post_raw(server.port(), "/reset", json!({"episode_id": id}).to_string().as_bytes());
        assert_eq!(status, 409, "{refusal}");
        // The owner's episode is untouched: its first step still answers.
        let step = json!({"episode_id": id, "action": {"maneuver": "stop", "acceleration": 0.5}});
        let (status, reply, _) = post_raw(server.port(), "/step", step.to_string().as_bytes());
        assert_eq!((status, reply["observation"]["turn"].clone()), (200, json!(2)), "{reply}");
    }

    /// A client that sends a reset and thousands of messages in one go and
    /// never reads is closed once it has read nothing for the stall
    /// timeout: its session goes back to the pool for the next client.
    #[test]
    fn a_client_that_never_reads_loses_its_session() {
        let server = EnvServer::start(&["--max-sessions", "1", "--stall-timeout", "0.5", "--session-timeout", "600"]);
        runtime().block_on(async {
            let mut hog = connect(server.port()).await;
            hog.send(Message::text(json!({"type": "reset", "data": {"seed": 1}}).to_string())).await.unwrap();
            let state = Message::text(json!({"type": "state"}).to_string());
            // Send without reading until the server stops taking them.
            let flood = async {
                for _ in 0..50_000 {
                    if hog.send(state.clone()).await.is_err() {
                        break;
                    }
                }
            };
            let _ = tokio::time::timeout(Duration::from_secs(20), flood).await;
            let mut served = None;
            for _ in 0..100 {
                let mut next = connect(server.port()).await;
                let reply = exchange(&mut next, &json!({"type": "reset", "data": {"seed": 2}})).await;
                if reply.as_ref().is_some_and(|r| r["type"] == "observation") {
                    served = reply;
                    break;
                }
                tokio::time::sleep(Duration::from_millis(200)).await;
            }
            assert!(served.is_some(), "the stalled session was never released");
        });
    }

    /// Pings (a client library's keepalive) do not keep an abandoned
    /// session open past its idle timeout.
    #[test]
    fn pings_do_not_keep_a_session_alive() {
        let server = EnvServer::start(&["--session-timeout", "1"]);
        runtime().block_on(async {
            let mut ws = connect(server.port()).await;
            let reset = json!({"type": "reset", "data": {"seed": 1}});
            assert_eq!(exchange(&mut ws, &reset).await.unwrap()["type"], "observation");
            let pinging = async {
                loop {
                    ws.send(Message::Ping(vec![1].into())).await.unwrap();
                    match tokio::time::timeout(Duration::from_millis(200), ws.next()).await {
                        Ok(Some(Ok(Message::Text(t)))) => return serde_json::from_str::<Value>(t.as_str()).unwrap(),
                        Ok(Some(Ok(_))) | Err(_) => continue,
                        Ok(None) | Ok(Some(Err(_))) => return Value::Null,
                    }
                }
            };
            let notice = tokio::time::timeout(Duration::from_secs(10), pinging).await.expect("closed while pinging");
            assert_eq!(notice["data"]["code"], "SESSION_ERROR", "{notice}");
        });
    }

    /// A client that sends its headers a line at a time, slowly, is cut off
    /// at the read timeout; and such a client does not hold up shutdown.
    #[test]
    fn a_slow_header_client_is_cut_off_and_does_not_hold_up_shutdown() {
        let mut server =
            EnvServer::start(&["--read-timeout", "1", "--shutdown-grace", "1", "--session-timeout", "600"]);
        let port = server.port();
        runtime().block_on(async {
            let mut slow = TcpStream::connect(("127.0.0.1", port)).await.unwrap();
            slow.write_all(b"POST /reset HTTP/1.1\r\nHost: x\r\n").await.unwrap();
            let dribble = async {
                for i in 0..100 {
                    tokio::time::sleep(Duration::from_millis(300)).await;
                    if slow.write_all(format!("X-Slow-{i}: 1\r\n").as_bytes()).await.is_err() {
                        return true;
                    }
                    let mut buf = [0u8; 512];
                    if let Ok(Ok(n)) = tokio::time::timeout(Duration::from_millis(10), slow.read(&mut buf)).await {
                        // 0: closed; otherwise hyper's 408 before it closes.
                        return n == 0 || String::from_utf8_lossy(&buf[..n]).contains("408");
                    }
                }
                false
            };
            assert!(tokio::time::timeout(Duration::from_secs(20), dribble).await.unwrap(), "never cut off");
        });
        // Shutdown with another slow client connected.
        let holdout = std::net::TcpStream::connect(("127.0.0.1", port)).unwrap();
        std::io::Write::write_all(&mut &holdout, b"POST /reset HTTP/1.1\r\n").unwrap();
        let pid = server.0.pid().to_string();
        assert!(std::process::Command::new("kill").args(["-TERM", &pid]).status().unwrap().success());
        let status = server.0.exited_within(Duration::from_secs(15)).expect("SIGTERM did not stop the server");
        assert!(status.success(), "{status:?}");
        drop(holdout);
    }

    /// A text frame over the limit, or one that is not UTF-8, gets
    /// OpenEnv's structured error and then the close code for it (1009,
    /// 1007), not a dropped connection.
    #[test]
    fn an_unreadable_frame_gets_an_error_and_its_close_code() {
        use tokio_tungstenite::tungstenite::protocol::frame::coding::{Data, OpCode};
        use tokio_tungstenite::tungstenite::protocol::frame::{Frame, FrameHeader};
        let server = EnvServer::start(&["--max-message-bytes", "140000"]);
        runtime().block_on(async {
            let close_code = |ws: Socket| async move {
                let mut ws = ws;
                let mut error = Value::Null;
                loop {
                    match tokio::time::timeout(Duration::from_secs(5), ws.next()).await.unwrap() {
                        Some(Ok(Message::Text(t))) => error = serde_json::from_str(t.as_str()).unwrap(),
                        Some(Ok(Message::Close(frame))) => return (error, frame.map(|f| u16::from(f.code))),
                        Some(Ok(_)) => continue,
                        None | Some(Err(_)) => return (error, None),
                    }
                }
            };
            let mut big = connect(server.port()).await;
            big.send(Message::text("x".repeat(150_000))).await.unwrap();
            let (error, code) = close_code(big).await;
            assert_eq!(error["type"], "error", "{error}");
            assert_eq!(code, Some(1009), "{error}");

            let mut bad = connect(server.port()).await;
            let header = FrameHeader { is_final: true, opcode: OpCode::Data(Data::Text), ..FrameHeader::default() };
            bad.send(Message::Frame(Frame::from_payload(header, vec![0xff, 0xfe, 0x7b].into()))).await.unwrap();
            let (error, code) = close_code(bad).await;
            assert_eq!(error["data"]["code"], "INVALID_JSON", "{error}");
            assert_eq!(code, Some(1007), "{error}");
        });
    }

    /// With `--token-var`, every request but /health needs the bearer token,
    /// WebSocket upgrades included.
    #[test]
    fn a_bearer_token_guards_every_route_but_health() {
        let server = EnvServer(super::super::support::Server::spawn_with_env(
            "env-server",
            &["--token-var", "NEGOTIATOR_IT_TOKEN"],
            "",
            &[("NEGOTIATOR_IT_TOKEN", "s3cret-token")],
        ));
        runtime().block_on(async {
            let http = reqwest::Client::new();
            let health = http.get(server.url("/health")).send().await.unwrap();
            assert_eq!(health.status().as_u16(), 200);
            let refused = http.post(server.url("/reset")).body("{}").send().await.unwrap();
            assert_eq!(refused.status().as_u16(), 401);
            let body: Value = refused.json().await.unwrap();
            assert!(body["detail"].is_string());
            let wrong = http.get(server.url("/schema")).bearer_auth("nope").send().await.unwrap();
            assert_eq!(wrong.status().as_u16(), 401);
            let ok = http.post(server.url("/reset")).bearer_auth("s3cret-token").body("{}").send().await.unwrap();
            assert_eq!(ok.status().as_u16(), 200);
            assert!(tokio_tungstenite::connect_async(format!("ws://127.0.0.1:{}/ws", server.port())).await.is_err());
            let mut request = tokio_tungstenite::tungstenite::client::IntoClientRequest::into_client_request(format!(
                "ws://127.0.0.1:{}/ws",
                server.port()
            ))
            .unwrap();
            request.headers_mut().insert("authorization", "Bearer s3cret-token".parse().unwrap());
            let (mut ws, _) = tokio_tungstenite::connect_async(request).await.unwrap();
            let reply = exchange(&mut ws, &json!({"type": "reset", "data": {"seed": 1}})).await.unwrap();
            assert_eq!(reply["type"], "observation");
        });
    }
}
