//! `negotiator serve` as a child process.

use super::support::{Server, negotiator};

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

/// Both servers start the same way: a port already in use is one line
/// naming the address, exit 4 (not the user's input, not a panic).
#[test]
fn a_taken_port_is_one_line_naming_the_address_for_both_servers() {
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = taken.local_addr().unwrap().port().to_string();
    for args in [vec!["serve", "--policy", "expert"], vec!["env-server"]] {
        let out = negotiator().args(&args).args(["--port", &port]).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(4), "{args:?}: {stderr}");
        let errors: Vec<&str> = stderr.lines().filter(|l| l.starts_with("Error:")).collect();
        assert_eq!(errors.len(), 1, "{args:?}: {stderr}");
        assert!(errors[0].starts_with(&format!("Error: serving on 127.0.0.1:{port}: ")), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    }
}

/// `"stream": true` gets OpenAI's server-sent events: chunks whose deltas
/// add up to the non-streamed reply, the usage last when asked for, then
/// `[DONE]`.
#[test]
fn streams_like_an_openai_server() {
    let server = Server::start(&["--policy", "expert"]);
    let text = scene(negotiator::scenario::ScenarioKind::YieldStandoff);
    let plain = serde_json::json!({"model": "expert", "messages": [{"role": "user", "content": text}]});
    let (status, whole) = post(server.port, &plain);
    assert_eq!(status, 200);
    let mut streamed = plain.clone();
    streamed["stream"] = serde_json::json!(true);
    streamed["stream_options"] = serde_json::json!({"include_usage": true});
    let rt = tokio::runtime::Builder::new_current_thread().enable_all().build().unwrap();
    let (content_type, body) = rt.block_on(async {
        let r = reqwest::Client::new()
            .post(format!("http://127.0.0.1:{}/v1/chat/completions", server.port))
            .json(&streamed)
            .send()
            .await
            .unwrap();
        let ct = r.headers()["content-type"].to_str().unwrap().to_string();
        (ct, r.text().await.unwrap())
    });
    assert_eq!(content_type, "text/event-stream");
    let events: Vec<&str> =
        body.split("\n\n").filter(|e| !e.is_empty()).map(|e| e.strip_prefix("data: ").unwrap()).collect();
    assert_eq!(*events.last().unwrap(), "[DONE]");
    let chunks: Vec<serde_json::Value> =
        events[..events.len() - 1].iter().map(|e| serde_json::from_str(e).unwrap()).collect();
    assert!(chunks.iter().all(|c| c["object"] == "chat.completion.chunk"));
    let content: String =
        chunks.iter().filter_map(|c| c["choices"][0]["delta"]["content"].as_str()).collect::<Vec<_>>().concat();
    assert_eq!(content, whole["choices"][0]["message"]["content"].as_str().unwrap());
    assert_eq!(chunks[0]["choices"][0]["delta"]["role"], "assistant");
    let finish: Vec<&serde_json::Value> =
        chunks.iter().filter_map(|c| c["choices"][0].get("finish_reason")).filter(|f| !f.is_null()).collect();
    assert_eq!(finish, [&serde_json::json!("stop")]);
    let last = chunks.last().unwrap();
    assert_eq!(last["choices"], serde_json::json!([]));
    assert!(last["usage"]["total_tokens"].as_u64().unwrap() > 0);
}

/// A harness that forwards an environment's observation as JSON (the scene
/// text inside, with the instructions before it) gets the answer the bare
/// scene gets.
#[test]
fn reads_a_scene_wrapped_in_a_json_observation() {
    let server = Server::start(&["--policy", "expert"]);
    for kind in negotiator::scenario::ScenarioKind::ALL {
        let text = scene(kind);
        let ask = |content: String| {
            let body = serde_json::json!({"model": "expert", "messages": [{"role": "user", "content": content}]});
            let (status, reply) = post(server.port, &body);
            assert_eq!(status, 200);
            reply["choices"][0]["message"]["content"].as_str().unwrap().to_string()
        };
        let wrapped = serde_json::json!({
            "observation": {"prompt": format!("You are the driver.\n\n{text}"), "turn": 1, "done": false},
            "action_schema": {"type": "object", "properties": {"maneuver": {"type": "string"}}},
        });
        let bare = ask(text.clone());
        assert_eq!(ask(wrapped.to_string()), bare, "{kind}");
        assert!(!bare.contains("no readable scene"), "{bare}");
    }
}
