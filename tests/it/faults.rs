//! `eval` and `report` against endpoints and machines that misbehave the way
//! real ones do: keys echoed back, duplicate work, overflowing contexts,
//! unreachable hosts, oversized or malformed replies, closed pipes. Each
//! test drives the binary against a mock server started inside the test.

pub use crate::support::{Request, mock, reply, respond, run, stderr, stdout};
use crate::support::{Server, jsonl, negotiator, scratch};
use serde_json::{Value, json};
use std::path::Path;
use std::process::{Command, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering::SeqCst};
pub const STOP: &str = r#"{"maneuver":"stop","acceleration":0}"#;

/// `eval --base-url URL --model scripted --output OUT --run-name run` with
/// fast retries; `--quiet` is left to the caller.
pub fn eval(base_url: &str, out: &Path, args: &[&str]) -> Command {
    let mut c = crate::support::eval_command(base_url, "scripted", out, "run");
    c.args(["--backoff-base-ms", "10", "--backoff-max", "0.05", "--progress-interval", "0.2"]).args(args);
    c
}

/// Every file under `dir`, recursively, as lossy text.
fn every_file(dir: &Path) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.push((p.display().to_string(), String::from_utf8_lossy(&std::fs::read(&p).unwrap()).into_owned()));
            }
        }
    }
    out
}

fn assert_nowhere(needles: &[&str], dir: &Path, streams: &[&str]) {
    for (path, text) in every_file(dir) {
        for n in needles {
            assert!(!text.contains(n), "{n:?} leaked into {path}");
        }
    }
    for s in streams {
        for n in needles {
            assert!(!s.contains(n), "{n:?} leaked to the terminal: {s}");
        }
    }
}

pub fn rollout_lines(out: &Path) -> Vec<Value> {
    jsonl(&out.join("run/rollouts.jsonl"))
}

pub fn run_json(out: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(out.join("run/run.json")).unwrap()).unwrap()
}

// ---------------------------------------------------------------------
// Secrets (issue items 1-3)

const KEY: &str = "sk-proj-Zq7u2LkP9xW4vB1nM6tR3yH8cJ5fD0gA";
const PARTIAL: &str = "sk-proj-****************************D0gA";

#[test]
fn a_401_echoing_the_key_never_shows_it_on_the_terminal() {
    let url = mock(Arc::new(|r: &Request| {
        let sent = r.headers.get("authorization").and_then(|v| v.to_str().ok()).unwrap_or("").to_string();
        respond(
            401,
            json!({"error": {"message": format!("Incorrect API key provided: {PARTIAL}. You sent {sent} (full: {KEY})")}}),
        )
    }));
    let out = scratch("secret-401");
    let mut c = eval(&url, &out, &["-n", "2", "--api-key-var", "NEGOTIATOR_LEAK_KEY"]);
    c.env("NEGOTIATOR_LEAK_KEY", KEY);
    let r = run(c);
    assert_eq!(r.status.code(), Some(3), "{}", stderr(&r));
    let err = stderr(&r);
    assert!(err.contains("401") && err.contains("Incorrect API key provided"), "{err}");
    assert_nowhere(&[KEY, PARTIAL, "sk-proj-Zq7u", "D0gA"], &out, &[&err, &stdout(&r)]);
}

#[test]
fn key_echoes_in_errors_replies_and_url_userinfo_reach_no_file_and_no_terminal() {
    // Request 0: a 500 echoing the key; 1: a 200 carrying an error object
    // echoing it (retries run out: errors.jsonl). Then replies whose content
    // echoes the key, a bearer token and the URL's password.
    let url = mock(Arc::new(|r: &Request| match r.index {
        0 => respond(500, json!({"error": {"message": format!("internal error for key {KEY}")}})),
        1 => respond(200, json!({"error": {"message": format!("upstream rejected Bearer {KEY}")}})),
        _ => reply(&format!("{STOP} my key is {KEY}, header Bearer tok-Zq7u2LkP, url http://bob:hunter2-pw@x/v1")),
    }));
    let with_userinfo = url.replace("http://", "http://bob:hunter2-pw@");
    let out = scratch("secret-files");
    let mut c = eval(
        &with_userinfo,
        &out,
        &[
            "--scenario",
            "yield_standoff",
            "-n",
            "2",
            "-c",
            "1",
            "--max-retries",
            "1",
            "--api-key-var",
            "NEGOTIATOR_LEAK_KEY",
        ],
    );
    c.env("NEGOTIATOR_LEAK_KEY", KEY);
    let r = run(c);
    let errors = std::fs::read_to_string(out.join("run/errors.jsonl")).unwrap();
    assert!(errors.contains("internal error for key") || errors.contains("upstream rejected"), "{errors}");
    assert_eq!(rollout_lines(&out).len(), 1, "{}", stderr(&r));
    // The summary's last column counts missing episodes and says so.
    assert!(stdout(&r).lines().any(|l| l.trim_end().ends_with("| missing |")), "{}", stdout(&r));
    let run_json = run_json(&out);
    assert!(run_json["last_invocation"]["endpoint"]["base_url"].as_str().unwrap().starts_with("http://127.0.0.1:"));
    // The report of that directory leaks nothing either.
    let report = negotiator()
        .arg("report")
        .arg(out.join("run"))
        .arg("--out")
        .arg(out.join("report"))
        .args(["--resamples", "10000", "--tiers", "all"])
        .output()
        .unwrap();
    assert!(out.join("report/report.html").exists(), "{}", String::from_utf8_lossy(&report.stderr));
    let streams = [stderr(&r), stdout(&r), stderr(&report), stdout(&report)];
    let streams: Vec<&str> = streams.iter().map(String::as_str).collect();
    assert_nowhere(&[KEY, "sk-proj-Zq7u", "tok-Zq7u2LkP", "hunter2-pw"], &out, &streams);
}

// ---------------------------------------------------------------------
// Results integrity (items 4, 5) and bounded inputs (item 11)

#[test]
fn a_repeated_scenario_or_tier_is_a_usage_error_not_a_double_count() {
    for (flag, value) in [("--tier", "1,1"), ("--scenario", "yield_standoff,yield_standoff"), ("--tier", "1, 2,1")] {
        let out = scratch("repeat");
        let r = run(eval("http://127.0.0.1:9/v1", &out, &[flag, value, "-n", "3"]));
        assert_eq!(r.status.code(), Some(2), "{flag} {value}: {}", stderr(&r));
        let err = stderr(&r);
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(err.contains(flag) && err.contains("twice"), "{err}");
        assert!(!out.join("run").exists(), "nothing may be created for a refused selection");
    }
}

#[test]
fn huge_episode_counts_are_refused_without_a_panic() {
    let out = scratch("huge");
    for args in [&["-n", "100000000"][..], &["-n", "18446744073709551615", "-r", "4294967295"]] {
        let r = run(eval("http://127.0.0.1:9/v1", &out, args));
        assert_eq!(r.status.code(), Some(2), "{}", stderr(&r));
        assert!(stderr(&r).contains("1000000 episodes"), "{}", stderr(&r));
    }
    let r = run({
        let mut c = negotiator();
        c.args(["baselines", "-n", "18446744073709551615"]);
        c
    });
    assert_eq!(r.status.code(), Some(2), "{}", stderr(&r));
    assert!(stderr(&r).contains("-n/--episodes: at most 1000000"), "{}", stderr(&r));
}

#[test]
fn a_second_eval_on_a_busy_run_directory_is_refused_with_one_line() {
    let server = Server::start(&["--policy", "expert", "--latency-ms", "20"]);
    let out = scratch("locked");
    let args = ["--scenario", "yield_standoff", "-n", "40", "-c", "1", "--quiet"];
    let mut first = eval(&server.base_url(), &out, &args).stdout(Stdio::null()).stderr(Stdio::null()).spawn().unwrap();
    // run.json is written once the lock is held.
    let mut waited = 0;
    while !out.join("run/run.json").exists() {
        assert!(first.try_wait().unwrap().is_none(), "the first eval ended early");
        std::thread::sleep(std::time::Duration::from_millis(10));
        waited += 1;
        assert!(waited < 3000, "the first eval never started");
    }
    let second = run(eval(&server.base_url(), &out, &args));
    let still_running = first.try_wait().unwrap().is_none();
    first.kill().unwrap();
    first.wait().unwrap();
    assert!(still_running, "the first eval finished before the second started: nothing was tested");
    assert_eq!(second.status.code(), Some(4), "{}", stderr(&second));
    let err = stderr(&second);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("another eval is running"), "{err}");
    // The lock dies with its holder (killed above): a resume runs.
    let r = run(eval(&server.base_url(), &out, &args));
    assert_eq!(r.status.code(), Some(0), "{}", stderr(&r));
    let lines = rollout_lines(&out);
    let keys: std::collections::HashSet<u64> = lines.iter().map(|l| l["seed"].as_u64().unwrap()).collect();
    assert_eq!((lines.len(), keys.len()), (40, 40));
}

// ---------------------------------------------------------------------
// Run identity (item 17)

#[test]
fn two_servers_of_one_model_id_are_two_runs_and_aliases_are_applied_or_refused() {
    let (a, b) = (Server::start(&["--policy", "expert"]), Server::start(&["--policy", "always_stop"]));
    let out = scratch("identity");
    for url in [a.base_url(), b.base_url()] {
        let mut c = negotiator();
        c.args([
            "eval",
            "--base-url",
            &url,
            "--model",
            "same-id",
            "--quiet",
            "-n",
            "2",
            "--scenario",
            "yield_standoff",
        ])
        .arg("--output")
        .arg(&out);
        assert_eq!(run(c).status.code(), Some(0));
    }
    let dirs: Vec<_> = std::fs::read_dir(&out).unwrap().flatten().map(|e| e.path()).collect();
    assert_eq!(dirs.len(), 2, "{dirs:?}");
    for d in &dirs {
        let rj: Value = serde_json::from_str(&std::fs::read_to_string(d.join("run.json")).unwrap()).unwrap();
        assert!(rj["config"]["endpoint"].as_str().unwrap().starts_with("http://127.0.0.1:"), "{rj}");
    }

    // An alias with --base-url is applied: its model id is what is sent.
    let models = Arc::new(std::sync::Mutex::new(Vec::<String>::new()));
    let seen = models.clone();
    let url = mock(Arc::new(move |r: &Request| {
        seen.lock().unwrap().push(r.body["model"].as_str().unwrap_or("").to_string());
        reply(STOP)
    }));
    let file = out.join("endpoints.toml");
    std::fs::write(
        &file,
        "[endpoints.far]\nbase_url = \"http://127.0.0.1:9/v1\"\n[endpoints.near]\nbase_url = \"http://127.0.0.1:9/v1\"\n\
         [models.fast]\nendpoint = \"far\"\nid = \"vendor/fast-1\"\n",
    )
    .unwrap();
    let alias = |extra: &[&str]| {
        let mut c = negotiator();
        c.args(["eval", "--model", "fast", "--quiet", "-n", "1", "--scenario", "yield_standoff", "--endpoints-file"])
            .arg(&file)
            .arg("--output")
            .arg(out.join("alias"))
            .args(extra);
        run(c)
    };
    assert_eq!(alias(&["--base-url", &url]).status.code(), Some(0));
    assert!(!models.lock().unwrap().is_empty());
    assert!(models.lock().unwrap().iter().all(|m| m == "vendor/fast-1"), "{:?}", models.lock().unwrap());
    let refused = alias(&["--endpoint", "near"]);
    assert_eq!(refused.status.code(), Some(2));
    assert!(stderr(&refused).contains("alias") && stderr(&refused).contains("--endpoint near"), "{}", stderr(&refused));
}

// ---------------------------------------------------------------------
// Process faults (items 14, 15)

#[test]
fn closed_stdout_and_stderr_are_not_errors_and_run_json_is_finalized() {
    let server = Server::start(&["--policy", "expert"]);
    let out = scratch("closed-pipes");
    let mut child = eval(&server.base_url(), &out, &["--scenario", "yield_standoff", "-n", "4"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Close the reading ends before eval writes anything.
    drop(child.stdout.take());
    drop(child.stderr.take());
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(0));
    let rj = run_json(&out);
    assert_eq!(rj["last_invocation"]["status"], "finished");
    assert_eq!(rj["totals"]["episodes"], 4);

    let mut child = negotiator()
        .arg("report")
        .arg(out.join("run"))
        .arg("--out")
        .arg(out.join("report"))
        .args(["--tiers", "all"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    drop(child.stderr.take());
    assert_eq!(child.wait().unwrap().code(), Some(0));
    assert!(out.join("report/report.html").exists());
}

#[test]
fn a_report_that_cannot_be_written_names_the_file_and_keeps_the_old_one_whole() {
    let server = Server::start(&["--policy", "expert"]);
    let out = scratch("report-atomic");
    assert_eq!(
        run(eval(&server.base_url(), &out, &["--scenario", "yield_standoff", "-n", "3", "--quiet"])).status.code(),
        Some(0)
    );
    let report = |dest: &Path| {
        let mut c = negotiator();
        c.arg("report").arg(out.join("run")).arg("--out").arg(dest).args(["--tiers", "all", "-q"]);
        run(c)
    };
    let dest = out.join("report");
    assert_eq!(report(&dest).status.code(), Some(0));
    let before: Vec<(String, String)> = every_file(&dest);
    // report.md cannot be replaced (a directory is in its way).
    std::fs::remove_file(dest.join("report.md")).unwrap();
    std::fs::create_dir(dest.join("report.md")).unwrap();
    std::fs::write(dest.join("report.md/keep"), "x").unwrap();
    let r = report(&dest);
    assert_ne!(r.status.code(), Some(0));
    let err = stderr(&r);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("report.md"), "{err}");
    let after = every_file(&dest);
    assert!(!after.iter().any(|(p, _)| p.ends_with(".tmp")), "temporary files left: {after:?}");
    for (path, text) in &before {
        if path.ends_with("report.md") {
            continue;
        }
        let now = after.iter().find(|(p, _)| p == path).unwrap_or_else(|| panic!("{path} was removed"));
        // Files renamed before the failure hold the new report, whole; files
        // after it the old one. Either way no file is truncated or missing.
        assert!(now.1.len() * 2 > text.len() || text.len() < 64, "{path} looks truncated");
    }
    assert!(!every_file(&dest.join("plots")).is_empty(), "plots/ emptied");
}

// ---------------------------------------------------------------------
// Work never thrown away (items 8, 9)

const PROCEED: &str = r#"{"maneuver":"proceed","acceleration":1.0}"#;

fn user_turns(body: &Value) -> usize {
    body["messages"].as_array().map_or(0, |m| m.iter().filter(|m| m["role"] == "user").count())
}

#[test]
fn a_context_overflow_keeps_every_finished_episode_and_names_the_remedy() {
    // Full acceleration: yield_standoff seeds 1-3 end within 9 turns, seed 0
    // needs 12; the endpoint's context holds 10 turns.
    let url = mock(Arc::new(|r: &Request| {
        if user_turns(&r.body) > 10 {
            respond(
                400,
                json!({"error": {"message": "This model's maximum context length is 8192 tokens.", "code": "context_length_exceeded"}}),
            )
        } else {
            reply(PROCEED)
        }
    }));
    let out = scratch("overflow");
    let r = run(eval(&url, &out, &["--scenario", "yield_standoff", "-n", "4", "-c", "4", "--quiet"]));
    assert_eq!(r.status.code(), Some(3), "{}", stderr(&r));
    let err = stderr(&r);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("context") && err.contains("--history last:"), "{err}");
    let seeds: Vec<u64> = rollout_lines(&out).iter().map(|l| l["seed"].as_u64().unwrap()).collect();
    assert_eq!(seeds.len(), 3, "every finished episode is on disk: {seeds:?}");
    assert!(!seeds.contains(&0));
    let errors = std::fs::read_to_string(out.join("run/errors.jsonl")).unwrap();
    let errors: Vec<Value> = errors.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(errors.len(), 1);
    assert_eq!((errors[0]["seed"].as_u64(), errors[0]["turn"].as_u64()), (Some(0), Some(11)));
    let rj = run_json(&out);
    assert_eq!(rj["last_invocation"]["status"], "refused");
    assert_eq!(rj["totals"]["missing"], 1, "the overflowing episode stays in the denominator as missing");
}

/// A port on 127.0.0.1 that nothing listens on.
fn dead_port() -> u16 {
    let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    l.local_addr().unwrap().port()
}

#[test]
fn an_unreachable_endpoint_ends_the_run_at_the_preflight_with_one_line() {
    let out = scratch("unreachable");
    // Default retry schedule: without a preflight this takes minutes.
    let refused = format!("http://127.0.0.1:{}/v1", dead_port());
    let mut c = negotiator();
    c.args(["eval", "--base-url", &refused, "--model", "m", "-q", "-n", "50", "--run-name", "r", "--output"]).arg(&out);
    let r = run(c);
    assert_eq!(r.status.code(), Some(3), "{}", stderr(&r));
    let err = stderr(&r);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("unreachable") && err.contains("connection refused"), "{err}");
    // TLS spoken to a plain-HTTP server.
    let plain = mock(Arc::new(|_: &Request| reply(STOP)));
    let mut c = negotiator();
    c.args(["eval", "--base-url", &plain.replace("http://", "https://"), "--model", "m", "-q", "-n", "50"])
        .args(["--run-name", "tls", "--output"])
        .arg(&out);
    let r = run(c);
    assert_eq!(r.status.code(), Some(3), "{}", stderr(&r));
    assert!(stderr(&r).contains("TLS"), "{}", stderr(&r));
    // A 400 on the first request: one request, one line.
    let count = Arc::new(AtomicUsize::new(0));
    let seen = count.clone();
    let url = mock(Arc::new(move |_: &Request| {
        seen.fetch_add(1, SeqCst);
        respond(400, json!({"error": {"message": "the request body could not be processed"}}))
    }));
    let r = run(eval(&url, &out, &["-n", "50", "-c", "8", "--quiet"]));
    assert_eq!(r.status.code(), Some(3), "{}", stderr(&r));
    assert_eq!(stderr(&r).trim().lines().count(), 1, "{}", stderr(&r));
    assert!(stderr(&r).contains("could not be processed") && stderr(&r).contains("--sampling-args"), "{}", stderr(&r));
    assert_eq!(count.load(SeqCst), 1, "the fleet never started");
}

#[test]
fn an_outage_prints_its_cause_on_the_progress_line() {
    let url = mock(Arc::new(|r: &Request| {
        if r.index < 4 {
            respond(503, json!({"error": {"message": "upstream overloaded, try later"}}))
        } else {
            reply(STOP)
        }
    }));
    let out = scratch("outage-cause");
    let mut c = negotiator();
    c.args(["eval", "--base-url", &url, "--model", "m", "--run-name", "r", "--scenario", "yield_standoff", "-n", "1"])
        .args(["--backoff-base-ms", "300", "--backoff-max", "2", "--events", "lines", "--progress-interval", "0.2"])
        .arg("--output")
        .arg(&out);
    let r = run(c);
    assert_eq!(r.status.code(), Some(0), "{}", stderr(&r));
    let err = stderr(&r);
    assert!(
        err.lines()
            .any(|l| l.contains("episodes |") && l.contains("last error: 503") && l.contains("upstream overloaded")),
        "{err}"
    );
}

// ---------------------------------------------------------------------
// Bounded inputs (items 10, 12)

#[test]
fn huge_replies_are_capped_stored_and_resent_cut_and_scored_as_parse_errors() {
    let longest_resent = Arc::new(AtomicUsize::new(0));
    let seen = longest_resent.clone();
    let url = mock(Arc::new(move |r: &Request| {
        let longest = r.body["messages"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|m| m["role"] == "assistant")
            .map(|m| m["content"].as_str().unwrap_or("").len())
            .max()
            .unwrap_or(0);
        seen.fetch_max(longest, SeqCst);
        // Odd turns: 200 KB of content; even turns: a 3 MB body, past the
        // hard limit on the body read.
        let size = if r.index.is_multiple_of(2) { 200_000 } else { 3_000_000 };
        reply(&format!("{STOP}{}", "z".repeat(size)))
    }));
    let out = scratch("huge-reply");
    let r = run(eval(&url, &out, &["--scenario", "yield_standoff", "-n", "1", "--quiet"]));
    assert_eq!(r.status.code(), Some(0), "{}", stderr(&r));
    let text = std::fs::read_to_string(out.join("run/rollouts.jsonl")).unwrap();
    let line: Value = serde_json::from_str(text.lines().next().unwrap()).unwrap();
    let turns = line["turns"].as_array().unwrap();
    assert!(turns.len() > 2);
    for t in turns {
        assert!(t["reply"].as_str().unwrap().len() <= 64 * 1024);
        assert_eq!(t["reply_capped"], true);
        assert_eq!(t["parse_errors"][0]["kind"], "oversized", "{}", t["parse_errors"]);
        assert_eq!(t["action"]["maneuver"], "stop");
        assert_eq!(t["attempts"], 1, "a capped reply is not retried");
    }
    assert_eq!(line["parse_error_turns"], line["turns_taken"]);
    assert!(longest_resent.load(SeqCst) <= 64 * 1024, "resent {} bytes", longest_resent.load(SeqCst));
    assert!(text.len() < turns.len() * 70 * 1024, "the stored line is bounded");
}

#[test]
fn an_unrequested_event_stream_is_diagnosed_once_with_its_cause() {
    use axum::response::IntoResponse;
    let count = Arc::new(AtomicUsize::new(0));
    let seen = count.clone();
    let url = mock(Arc::new(move |_: &Request| {
        seen.fetch_add(1, SeqCst);
        let body = format!("data: {}\n\ndata: [DONE]\n\n", json!({"choices": [{"delta": {"content": STOP}}]}));
        ([(axum::http::header::CONTENT_TYPE, "text/event-stream")], body).into_response()
    }));
    let out = scratch("sse");
    let r = run(eval(&url, &out, &["-n", "20", "-c", "8", "--quiet"]));
    assert_eq!(r.status.code(), Some(3), "{}", stderr(&r));
    let err = stderr(&r);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("server-sent event stream") && err.contains("text/event-stream"), "{err}");
    assert_eq!(count.load(SeqCst), 1);
}

#[test]
fn invalid_utf8_in_a_reply_is_a_parse_error_not_an_outage() {
    use axum::response::IntoResponse;
    let url = mock(Arc::new(|_: &Request| {
        let mut body =
            br#"{"choices":[{"message":{"role":"assistant","content":"{\"maneuver\":\"proceed\",\"acceleration\":1} "#
                .to_vec();
        body.extend_from_slice(&[0xc3, 0x28, 0xff]);
        body.extend_from_slice(br#""},"finish_reason":"stop"}]}"#);
        ([(axum::http::header::CONTENT_TYPE, "application/json")], body).into_response()
    }));
    let out = scratch("utf8");
    let r = run(eval(&url, &out, &["--scenario", "pedestrian_feint", "-n", "1", "--quiet", "--max-retries", "2"]));
    assert_eq!(r.status.code(), Some(0), "{}", stderr(&r));
    let lines = rollout_lines(&out);
    assert_eq!(lines.len(), 1);
    for t in lines[0]["turns"].as_array().unwrap() {
        assert_eq!(t["attempts"], 1, "never retried");
        assert!(t["reply"].as_str().unwrap().contains('\u{fffd}'));
        assert!(t["parse_errors"].as_array().unwrap().iter().any(|e| e["kind"] == "invalid_utf8"));
        assert_eq!(t["action"]["maneuver"], "stop");
    }
}

// ---------------------------------------------------------------------
// One reader for eval and report (item 6)

#[test]
fn glued_lines_are_skipped_with_a_warning_and_rerun_without_duplicates() {
    let server = Server::start(&["--policy", "expert"]);
    let out = scratch("glued");
    let args = ["--scenario", "yield_standoff", "-n", "4", "--quiet"];
    assert_eq!(run(eval(&server.base_url(), &out, &args)).status.code(), Some(0));
    let path = out.join("run/rollouts.jsonl");
    let text = std::fs::read_to_string(&path).unwrap();
    let mut lines: Vec<&str> = text.lines().collect();
    let glued = format!("{}{}", lines[1], lines[2]);
    lines.splice(1..3, [glued.as_str()]);
    std::fs::write(&path, lines.join("\n") + "\n").unwrap();
    // eval re-runs both halves of the glued line, appending one line each.
    assert_eq!(run(eval(&server.base_url(), &out, &args)).status.code(), Some(0));
    let all: Vec<String> = std::fs::read_to_string(&path).unwrap().lines().map(str::to_string).collect();
    assert_eq!(all.len(), 5);
    let readable: Vec<Value> = all.iter().filter_map(|l| serde_json::from_str(l).ok()).collect();
    let seeds: std::collections::HashSet<u64> = readable.iter().map(|l| l["seed"].as_u64().unwrap()).collect();
    assert_eq!((readable.len(), seeds.len()), (4, 4), "one readable line per episode");
    // report counts the four episodes and warns about the skipped line.
    let mut c = negotiator();
    c.arg("report").arg(out.join("run")).arg("--out").arg(out.join("report")).args(["--tiers", "all"]);
    let r = run(c);
    assert_eq!(r.status.code(), Some(0), "{}", stderr(&r));
    assert!(stderr(&r).contains("warning") && stderr(&r).contains("line"), "{}", stderr(&r));
    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report/report.json")).unwrap()).unwrap();
    assert_eq!(report["models"][0]["episodes"], 4);
}
