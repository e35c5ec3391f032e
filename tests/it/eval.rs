//! `negotiator eval` end to end: against `negotiator serve` (child process)
//! and against small in-test mock servers for the cases serve does not
//! produce. Sizes are small so the suite stays fast on two cores; the
//! full-size figures come from scripts/bench_eval.sh.

use crate::support::{Server, negotiator, scratch};
use crate::support::{ok, run};
use negotiator::episode::{Outcome, run_episode};
use negotiator::policy::PolicyKind;
use negotiator::scenario::{ScenarioConfig, ScenarioKind, Tier};
use serde_json::Value;
use std::collections::HashSet;
use std::path::Path;
use std::process::Command;
use std::time::Duration;

fn eval(base_url: &str, out: &Path, args: &[&str]) -> Command {
    let mut c = crate::support::eval_command(base_url, "scripted", out, "run");
    c.args(["--quiet", "--backoff-base-ms", "20", "--backoff-max", "0.5"]).args(args);
    c
}

fn keys(lines: &[Value]) -> Vec<(String, u64, u64, u64)> {
    lines
        .iter()
        .map(|l| {
            (
                l["scenario"].as_str().unwrap().to_string(),
                l["tier"].as_u64().unwrap(),
                l["seed"].as_u64().unwrap(),
                l["rollout"].as_u64().unwrap(),
            )
        })
        .collect()
}

fn assert_one_line_per_key(lines: &[Value], expected: usize) {
    let k = keys(lines);
    let unique: HashSet<_> = k.iter().collect();
    assert_eq!(unique.len(), k.len(), "duplicate keys");
    assert_eq!(k.len(), expected);
}

fn lines(dir: &Path) -> Vec<Value> {
    crate::support::jsonl(&dir.join("run/rollouts.jsonl"))
}

fn cells(dir: &Path) -> Value {
    let s: Value = serde_json::from_str(&std::fs::read_to_string(dir.join("run/summary.json")).unwrap()).unwrap();
    s["cells"].clone()
}

/// `eval` against `serve --policy P` on every cell, n = 30: the run
/// directory, and each cell's served success checked against `P` in process.
fn served_scores_like_in_process(policy: PolicyKind, n: usize) -> std::path::PathBuf {
    let server = Server::start(&["--policy", policy.name()]);
    let out = scratch(policy.name());
    ok(eval(&server.base_url(), &out, &["--scenario", "all", "--tier", "all", "-n", &n.to_string(), "-c", "16"]));
    for cell in cells(&out).as_array().unwrap() {
        let kind: ScenarioKind = cell["scenario"].as_str().unwrap().parse().unwrap();
        let tier: Tier = cell["tier"].as_u64().unwrap().to_string().parse().unwrap();
        let config = ScenarioConfig::builtin(kind);
        let mut in_process = policy.build();
        let wins = (0..n as u64)
            .filter(|s| run_episode(&config, tier, *s, in_process.as_mut()).outcome == Outcome::Success)
            .count();
        let in_process = wins as f64 / n as f64;
        let served = cell["success"]["estimate"].as_f64().unwrap();
        // The served expert reads the scene text, rounded to its printed
        // precision: a knife-edge decision may flip one episode, no more.
        assert!(
            (served - in_process).abs() <= 1.0 / n as f64 + 1e-9,
            "{policy} {kind} tier {tier}: served {served}, in-process {in_process}"
        );
        assert_eq!(cell["parse_error_rate"].as_f64().unwrap(), 0.0);
        assert_eq!(cell["missing"].as_u64().unwrap(), 0);
    }
    out
}

/// `serve --policy expert_late` sees one turn at a time, yet it reads the
/// conversation's earlier scenes as the in-process late expert remembers
/// them.
#[test]
fn eval_against_served_late_expert_scores_like_the_in_process_one() {
    served_scores_like_in_process(PolicyKind::ExpertLate, 30);
}

#[test]
fn eval_against_served_expert_scores_like_the_in_process_expert() {
    let n = 30;
    let out = served_scores_like_in_process(PolicyKind::Expert, n);
    let lines = lines(&out);
    assert_one_line_per_key(&lines, crate::support::cells() * n);
    // The transcript is complete.
    let first = &lines[0];
    let turn = &first["turns"][0];
    for k in ["scene", "reply", "action", "parse_errors", "usage", "tokens", "latency_ms", "attempts"] {
        assert!(turn.get(k).is_some(), "turn field {k}");
    }
    for k in ["disposition", "outcome", "reward", "decision_correctness", "diagnostics", "model", "rollout"] {
        assert!(first.get(k).is_some(), "field {k}");
    }
    let run: Value = serde_json::from_str(&std::fs::read_to_string(out.join("run/run.json")).unwrap()).unwrap();
    assert_eq!(run["totals"]["episodes"], (crate::support::cells() * n) as u64);
    assert_eq!(run["last_invocation"]["status"], "finished");
    assert!(run["config_hash"].as_str().unwrap().len() == 16);
    assert!(run["git_revision"].is_string() && run["crate_version"].is_string());
}

#[test]
fn faults_are_retried_and_scores_equal_a_fault_free_run() {
    let faulty = Server::start(&[
        "--policy",
        "expert",
        "--fail-rate",
        "0.2",
        "--rate-limit",
        "50",
        "--drop-rate",
        "0.1",
        "--seed",
        "9",
    ]);
    let clean = Server::start(&["--policy", "expert"]);
    let (a, b) = (scratch("faulty"), scratch("clean"));
    let args = ["--scenario", "all", "--tier", "1", "-n", "4", "-r", "2", "-c", "16", "--max-retries", "30"];
    ok(eval(&faulty.base_url(), &a, &args));
    ok(eval(&clean.base_url(), &b, &args));
    let la = lines(&a);
    assert_one_line_per_key(&la, 3 * 4 * 2);
    assert!(la.iter().map(|l| l["retries"].as_u64().unwrap()).sum::<u64>() > 0, "the faults were never hit");
    assert_eq!(cells(&a), cells(&b));
    let run: Value = serde_json::from_str(&std::fs::read_to_string(a.join("run/run.json")).unwrap()).unwrap();
    assert!(run["totals"]["retries"].as_u64().unwrap() > 0);
    assert_eq!(run["totals"]["infra_errors"], 0);
}

#[test]
fn kill_9_then_resume_gives_one_line_per_episode_and_the_same_summary() {
    let server = Server::start(&["--policy", "expert", "--latency-ms", "15"]);
    let (killed, whole) = (scratch("killed"), scratch("whole"));
    let args = ["--scenario", "all", "--tier", "1,3", "-n", "8", "-c", "4"];
    let total = 3 * 2 * 8;
    let mut child = eval(&server.base_url(), &killed, &args).spawn().unwrap();
    let file = killed.join("run/rollouts.jsonl");
    let mut waited = 0;
    loop {
        let n = std::fs::read_to_string(&file).map(|s| s.lines().count()).unwrap_or(0);
        if n >= 5 {
            break;
        }
        assert!(child.try_wait().unwrap().is_none(), "eval finished before it could be killed");
        std::thread::sleep(Duration::from_millis(20));
        waited += 1;
        assert!(waited < 3000, "no progress");
    }
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    let before = lines(&killed).len();
    assert!(before < total, "killed too late to test anything");
    // What a kill in the middle of a write leaves behind.
    let mut torn = std::fs::OpenOptions::new().append(true).open(&file).unwrap();
    std::io::Write::write_all(&mut torn, br#"{"model":"scripted","config_hash":"x","scen"#).unwrap();
    drop(torn);

    ok(eval(&server.base_url(), &killed, &args));
    ok(eval(&server.base_url(), &whole, &args));
    let resumed = lines(&killed);
    assert_one_line_per_key(&resumed, total);
    assert_eq!(cells(&killed), cells(&whole));
    // Running it a third time does nothing and changes nothing.
    let out = ok(eval(&server.base_url(), &killed, &args));
    assert_eq!(lines(&killed).len(), total);
    assert!(String::from_utf8_lossy(&out.stdout).contains("| yield_standoff | 1 | 8x1 |"));
}

#[test]
fn garbage_replies_are_scored_as_parse_error_driving() {
    let server = Server::start(&["--policy", "expert", "--garbage-rate", "1.0"]);
    let out = scratch("garbage");
    // Some garbage replies are cut off ("length"): scored, not stopped.
    let args = ["--scenario", "all", "--tier", "1", "-n", "5", "-c", "8", "--allow-truncation"];
    ok(eval(&server.base_url(), &out, &args));
    let lines = lines(&out);
    assert_one_line_per_key(&lines, 15);
    for l in &lines {
        let unreadable = l["parse_error_turns"].as_u64().unwrap() + l["truncated_turns"].as_u64().unwrap();
        assert_eq!(unreadable, l["turns_taken"].as_u64().unwrap(), "a turn is a parse error or truncated");
        assert_ne!(l["outcome"], "success", "braking every turn never reaches the goal");
        for t in l["turns"].as_array().unwrap() {
            assert_eq!(t["action"]["maneuver"], "stop");
        }
    }
    for c in cells(&out).as_array().unwrap() {
        let rate = c["parse_error_rate"].as_f64().unwrap() + c["truncated_rate"].as_f64().unwrap();
        assert!((rate - 1.0).abs() < 1e-12, "{c}");
        assert!(c["truncated_rate"].as_f64().unwrap() > 0.0, "{c}");
        assert_eq!(c["missing"], 0);
    }
}

#[test]
fn shards_split_the_seeds_and_merge_into_one_run() {
    let server = Server::start(&["--policy", "cue_follower"]);
    let (sharded, whole) = (scratch("sharded"), scratch("unsharded"));
    let args = ["--scenario", "yield_standoff", "--tier", "2", "-n", "9", "-c", "8"];
    ok(eval(&server.base_url(), &sharded, &[&args[..], &["--shard", "1/2"]].concat()));
    let first: HashSet<_> = keys(&lines(&sharded)).into_iter().collect();
    assert_eq!(first.len(), 5, "seed indices 0, 2, 4, 6, 8");
    ok(eval(&server.base_url(), &sharded, &[&args[..], &["--shard", "2/2"]].concat()));
    ok(eval(&server.base_url(), &whole, &args));
    let merged = lines(&sharded);
    assert_one_line_per_key(&merged, 9);
    let mut a = keys(&merged);
    let mut b = keys(&lines(&whole));
    a.sort();
    b.sort();
    assert_eq!(a, b);
    let out = run(eval(&server.base_url(), &sharded, &["--shard", "3/2"]));
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn a_changed_config_is_refused_by_name() {
    let server = Server::start(&["--policy", "always_stop"]);
    let out = scratch("changed");
    let args = ["--scenario", "pedestrian_feint", "-n", "2"];
    ok(eval(&server.base_url(), &out, &args));
    let refused =
        run(eval(&server.base_url(), &out, &[&args[..], &["--temperature", "0.5", "--history", "last:3"]].concat()));
    assert_eq!(refused.status.code(), Some(2));
    let err = String::from_utf8_lossy(&refused.stderr);
    assert!(err.contains("temperature") && err.contains("history"), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    // Without --run-name, the directory follows the config: no clash.
    let mut c = negotiator();
    c.args([
        "eval",
        "--base-url",
        &server.base_url(),
        "--model",
        "m",
        "--quiet",
        "-n",
        "1",
        "--scenario",
        "yield_standoff",
        "--output",
    ])
    .arg(&out);
    ok(c);
    let mut c = negotiator();
    c.args([
        "eval",
        "--base-url",
        &server.base_url(),
        "--model",
        "m",
        "--quiet",
        "-n",
        "1",
        "--scenario",
        "yield_standoff",
        "--temperature",
        "0.2",
        "--output",
    ])
    .arg(&out);
    ok(c);
    let dirs: Vec<_> = std::fs::read_dir(&out).unwrap().filter_map(|e| e.ok()).map(|e| e.file_name()).collect();
    assert_eq!(dirs.len(), 3, "{dirs:?}");
}

#[test]
fn a_token_budget_stops_early_and_a_rerun_finishes() {
    let server = Server::start(&["--policy", "expert"]);
    let out = scratch("budget");
    let args = ["--scenario", "yield_standoff", "-n", "12", "-c", "2"];
    let stopped = run(eval(&server.base_url(), &out, &[&args[..], &["--max-total-tokens", "1"]].concat()));
    assert_eq!(stopped.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&stopped.stderr).contains("missing"));
    let partial = lines(&out).len();
    assert!((1..12).contains(&partial), "{partial}");
    ok(eval(&server.base_url(), &out, &args));
    assert_one_line_per_key(&lines(&out), 12);
}

// ---------------------------------------------------------------------
// In-test mock servers for replies `serve` never gives.

type Handler = std::sync::Arc<dyn Fn(usize, &axum::http::HeaderMap) -> axum::response::Response + Send + Sync>;

/// `support::mock` with a handler of the request's index and headers.
fn mock(handler: Handler) -> String {
    crate::support::mock(std::sync::Arc::new(move |r: &crate::support::Request| handler(r.index, &r.headers)))
}

fn json_response(status: u16, body: Value) -> axum::response::Response {
    crate::support::respond(status, body)
}

#[test]
fn unauthorized_stops_the_run_at_once_with_one_clear_line() {
    let requests = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let seen = requests.clone();
    let url = mock(std::sync::Arc::new(move |_, _| {
        seen.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
        json_response(401, serde_json::json!({"error": {"message": "Invalid API key"}}))
    }));
    let out = scratch("unauthorized");
    let r = run(eval(&url, &out, &["-n", "50", "-c", "8"]));
    assert_eq!(r.status.code(), Some(3));
    let err = String::from_utf8_lossy(&r.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("401") && err.contains("Invalid API key"), "{err}");
    // Never retried: at most one request per episode in flight (-c 8).
    let n = requests.load(std::sync::atomic::Ordering::SeqCst);
    assert!((1..=8).contains(&n), "{n} requests for a permanent 401");
    let run_json: Value = serde_json::from_str(&std::fs::read_to_string(out.join("run/run.json")).unwrap()).unwrap();
    assert_eq!(run_json["last_invocation"]["status"], "refused");

    let url = mock(std::sync::Arc::new(|_, _| {
        json_response(404, serde_json::json!({"error": {"message": "model not found"}}))
    }));
    let r = run(eval(&url, &scratch("notfound"), &["-n", "3"]));
    assert_eq!(r.status.code(), Some(3));
    assert!(String::from_utf8_lossy(&r.stderr).contains("--model"));
}

#[test]
fn odd_replies_are_tolerated_and_the_key_is_never_written() {
    use axum::response::IntoResponse;
    let seen_auth = std::sync::Arc::new(std::sync::Mutex::new(Vec::<String>::new()));
    let seen = seen_auth.clone();
    let url = mock(std::sync::Arc::new(move |i, headers| {
        seen.lock().unwrap().push(headers.get("authorization").and_then(|v| v.to_str().ok()).unwrap_or("").to_string());
        let content = |c: Value, finish: &str| serde_json::json!({"choices": [{"message": {"content": c}, "finish_reason": finish}], "weird": [1, 2]});
        match i {
            // 429 with an HTTP-date Retry-After (one second ahead), then an
            // overloaded 503 with a seconds Retry-After.
            0 => {
                let when = httpdate::fmt_http_date(std::time::SystemTime::now() + Duration::from_secs(1));
                let mut r = json_response(429, serde_json::json!({"error": "slow down"}));
                r.headers_mut().insert("retry-after", when.parse().unwrap());
                r
            }
            1 => {
                let mut r = json_response(503, serde_json::json!({"error": {"message": "overloaded"}}));
                r.headers_mut().insert("retry-after", "0".parse().unwrap());
                r
            }
            2 => json_response(200, content(Value::Null, "stop")),
            3 => json_response(200, content("{\"maneuver\": \"yield\", \"accel".into(), "length")),
            4 => json_response(
                200,
                content("<think>watch it</think>{\"maneuver\":\"stop\",\"acceleration\":0.2}".into(), ""),
            ),
            5 => (axum::http::StatusCode::OK, "this is not json").into_response(),
            _ => json_response(
                200,
                serde_json::json!({"choices": [{"message": {"content": "{\"maneuver\":\"yield\",\"acceleration\":0.1}",
                    "reasoning_content": "thinking"}}], "usage": null}),
            ),
        }
    }));
    let out = scratch("odd");
    let mut c = eval(
        &url,
        &out,
        &[
            "--scenario",
            "yield_standoff",
            "-n",
            "1",
            "--allow-truncation",
            "--api-key-var",
            "NEGOTIATOR_TEST_KEY",
            "--header",
            "X-Secret-Token: hdr-secret-456",
        ],
    );
    c.env("NEGOTIATOR_TEST_KEY", "sk-test-secret-123");
    ok(c);
    assert!(seen_auth.lock().unwrap().iter().all(|a| a == "Bearer sk-test-secret-123"));
    let lines = lines(&out);
    assert_eq!(lines.len(), 1);
    let turns = lines[0]["turns"].as_array().unwrap();
    // Turn 1 needed attempts 0, 1, 2 (429, 503, then null content).
    assert_eq!(turns[0]["attempts"], 3);
    assert_eq!(turns[0]["reply"], Value::Null);
    assert!(!turns[0]["parse_errors"].as_array().unwrap().is_empty());
    assert_eq!(turns[1]["finish_reason"], "length");
    assert!(!turns[1]["parse_errors"].as_array().unwrap().is_empty(), "cut-off JSON does not parse");
    assert_eq!(turns[1]["truncated"], true, "and is counted as truncated");
    assert_eq!(turns[2]["reasoning"], "watch it");
    assert!(turns[2]["parse_errors"].as_array().unwrap().is_empty());
    assert_eq!(turns[2]["action"]["maneuver"], "stop");
    // The unreadable body was retried: turn 4 is the request after it.
    assert_eq!(turns[3]["attempts"], 2);
    assert_eq!(turns[3]["reasoning"], "thinking");
    assert_eq!(turns[3]["tokens_estimated"], true);
    assert_eq!(turns[3]["usage"], Value::Null);
    // Secrets appear in no file of the run.
    for entry in std::fs::read_dir(out.join("run")).unwrap() {
        let text = std::fs::read_to_string(entry.unwrap().path()).unwrap();
        assert!(!text.contains("sk-test-secret-123") && !text.contains("hdr-secret-456"));
    }
    let run_json = std::fs::read_to_string(out.join("run/run.json")).unwrap();
    assert!(run_json.contains("NEGOTIATOR_TEST_KEY") && run_json.contains("x-secret-token"));
}

#[test]
fn retries_running_out_are_infrastructure_errors_rerun_later() {
    let down = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(true));
    let flag = down.clone();
    let url = mock(std::sync::Arc::new(move |_, _| {
        if flag.load(std::sync::atomic::Ordering::SeqCst) {
            json_response(502, serde_json::json!({"error": "bad gateway"}))
        } else {
            json_response(
                200,
                serde_json::json!({"choices": [{"message": {"content": "{\"maneuver\":\"stop\",\"acceleration\":0}"}}]}),
            )
        }
    }));
    let out = scratch("outage");
    let args = ["--scenario", "pedestrian_feint", "-n", "3", "--max-retries", "2"];
    let r = run(eval(&url, &out, &args));
    assert_eq!(r.status.code(), Some(1));
    let stdout = String::from_utf8_lossy(&r.stdout);
    assert!(stdout.contains("| pedestrian_feint | 1 | 0x0 | - |") && stdout.contains("| 3 |"), "{stdout}");
    assert_eq!(std::fs::read_to_string(out.join("run/rollouts.jsonl")).unwrap(), "");
    assert_eq!(std::fs::read_to_string(out.join("run/errors.jsonl")).unwrap().lines().count(), 3);
    down.store(false, std::sync::atomic::Ordering::SeqCst);
    ok(eval(&url, &out, &args));
    assert_one_line_per_key(&lines(&out), 3);
    let run_json: Value = serde_json::from_str(&std::fs::read_to_string(out.join("run/run.json")).unwrap()).unwrap();
    assert_eq!(run_json["totals"]["infra_errors"], 3);
    assert_eq!(run_json["totals"]["missing"], 0);
}

#[test]
fn a_dead_endpoint_stops_the_run_instead_of_retrying_for_hours() {
    let url = mock(std::sync::Arc::new(|_, _| json_response(502, serde_json::json!({"error": "bad gateway"}))));
    let out = scratch("dead");
    let r = run(eval(&url, &out, &["--scenario", "yield_standoff", "-n", "40", "-c", "2", "--max-retries", "1"]));
    assert_eq!(r.status.code(), Some(1));
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(err.contains("the endpoint looks down"), "{err}");
    let errors = std::fs::read_to_string(out.join("run/errors.jsonl")).unwrap().lines().count();
    assert!((3..=4).contains(&errors), "{errors} episodes attempted");
    let run_json: Value = serde_json::from_str(&std::fs::read_to_string(out.join("run/run.json")).unwrap()).unwrap();
    assert_eq!(run_json["totals"]["missing"], 40);
}

/// `eval --events json`: every stderr line is one JSON event.
fn eval_events(base_url: &str, out: &Path, args: &[&str]) -> (Option<i32>, Vec<Value>) {
    let r = run({
        let mut c = negotiator();
        c.args(["eval", "--base-url", base_url, "--model", "scripted", "--events", "json", "--output"])
            .arg(out)
            .args(["--run-name", "run", "--backoff-base-ms", "1", "--backoff-max", "0.1"])
            .args(args);
        c
    });
    let stderr = String::from_utf8(r.stderr).unwrap();
    let events = stderr
        .lines()
        .map(|l| serde_json::from_str::<Value>(l).unwrap_or_else(|e| panic!("not a JSON event ({e}): {l:?}")))
        .collect();
    (r.status.code(), events)
}

fn names(events: &[Value]) -> Vec<&str> {
    events.iter().map(|e| e["event"].as_str().expect("every event names itself")).collect()
}

#[test]
fn json_events_tell_the_whole_run_in_order() {
    let server = Server::start(&["--policy", "expert"]);
    let out = scratch("events-json");
    let args = ["--scenario", "all", "--tier", "1", "-n", "2", "-c", "3"];
    let (code, events) = eval_events(&server.base_url(), &out, &args);
    assert_eq!(code, Some(0));
    // Two seeds of tier 1 of every scenario.
    let selected = 2 * crate::support::scenarios();
    let mut expected = vec!["planned"];
    expected.extend(vec!["episode_finished"; selected]);
    expected.push("finished");
    assert_eq!(names(&events), expected);
    let run_dir = out.join("run").display().to_string();
    assert_eq!(
        events[0],
        serde_json::json!({"event": "planned", "run_dir": run_dir, "selected": selected, "finished": 0, "to_run": selected})
    );
    // One episode_finished per key of the selection, with its outcome.
    let finished: HashSet<(String, u64)> = events[1..=selected]
        .iter()
        .map(|e| {
            assert_eq!((e["tier"].as_u64(), e["rollout"].as_u64()), (Some(1), Some(0)), "{e}");
            assert!(e["outcome"].is_string() && e["turns"].as_u64().unwrap() > 0, "{e}");
            (e["scenario"].as_str().unwrap().to_string(), e["seed"].as_u64().unwrap())
        })
        .collect();
    assert_eq!(finished.len(), selected);
    let end = &events[selected + 1];
    assert_eq!(
        (end["status"].as_str(), end["missing"].as_u64(), end["episodes"].as_u64()),
        (Some("finished"), Some(0), Some(selected as u64))
    );
    assert!(end["stop"].is_null(), "{end}");
    let tokens: u64 = events[1..=selected].iter().map(|e| e["tokens"].as_u64().unwrap()).sum();
    assert_eq!(end["tokens"].as_u64(), Some(tokens));

    // Again: the run is resumed and there is nothing to do.
    let (code, events) = eval_events(&server.base_url(), &out, &args);
    assert_eq!(code, Some(0));
    assert_eq!(names(&events), ["resumed", "planned", "finished"]);
    assert_eq!(
        events[0],
        serde_json::json!({"event": "resumed", "run_dir": run_dir, "finished": 6, "torn_bytes": 0, "bad_lines": 0})
    );
    assert_eq!((events[1]["to_run"].as_u64(), events[2]["episodes"].as_u64()), (Some(0), Some(0)));
}

#[test]
fn json_events_report_infrastructure_errors_and_the_outage_that_stops_a_run() {
    let url = mock(std::sync::Arc::new(|_, _| json_response(502, serde_json::json!({"error": "bad gateway"}))));
    let out = scratch("events-outage");
    let (code, events) =
        eval_events(&url, &out, &["--scenario", "yield_standoff", "-n", "40", "-c", "1", "--max-retries", "0"]);
    assert_eq!(code, Some(1));
    // With one episode in flight, the third error in a row stops the run.
    assert_eq!(
        names(&events),
        ["planned", "infra_error", "infra_error", "infra_error", "outage", "stopped", "finished"]
    );
    assert_eq!((events[1]["scenario"].as_str(), events[1]["turn"].as_u64()), (Some("yield_standoff"), Some(1)));
    assert!(events[1]["error"].as_str().unwrap().contains("502"), "{}", events[1]);
    assert_eq!(events[4]["streak"], 3);
    assert_eq!(events[5], serde_json::json!({"event": "stopped", "reason": "outage", "streak": 3}));
    let end = &events[6];
    assert_eq!((end["status"].as_str(), end["missing"].as_u64()), (Some("incomplete"), Some(40)));
    assert_eq!(end["stop"], serde_json::json!({"reason": "outage", "streak": 3}));
    assert_eq!(end["infra_errors"], 3);
    let run_json: Value = serde_json::from_str(&std::fs::read_to_string(out.join("run/run.json")).unwrap()).unwrap();
    assert_eq!(run_json["last_invocation"]["status"], "incomplete");
}
