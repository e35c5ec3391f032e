//! What a run costs: prices (`configs/prices.toml`, `--prices-file`), the
//! cost of each episode from its turns' token counts, run.json, the
//! summary, `report`'s cost column, and `--max-cost`.

use crate::providers::{Handler, Seen, expert_reply, start_mock, start_mock_on};
use crate::support::read_json;
use crate::support::{negotiator, scratch};
use negotiator::scenario::ScenarioKind;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::process::Output;
use std::sync::{Arc, Mutex};

/// Every turn: 1000 prompt tokens of which 400 cached, 50 completion tokens
/// of which 20 reasoning, in OpenAI's usage shape.
fn fixed_usage_mock(host: &'static str) -> (String, Arc<Mutex<Seen>>) {
    let handler: Handler = Arc::new(|body: &Value| {
        let usage = json!({"prompt_tokens": 1000, "completion_tokens": 50, "total_tokens": 1050,
                           "prompt_tokens_details": {"cached_tokens": 400},
                           "completion_tokens_details": {"reasoning_tokens": 20}});
        (
            200,
            json!({"choices": [{"index": 0, "finish_reason": "stop",
                   "message": {"role": "assistant", "content": expert_reply(body)}}], "usage": usage}),
        )
    });
    if host == "127.0.0.1" { start_mock(handler) } else { start_mock_on(host, handler) }
}

/// USD per million: input 1000, cached 100, output 4000, so one turn costs
/// (600 x 1000 + 400 x 100 + 50 x 4000) / 1e6 = $0.84.
const TURN_USD: f64 = 0.84;

fn prices_file(dir: &Path) -> PathBuf {
    let path = dir.join("prices.toml");
    std::fs::write(
        &path,
        "as_of = \"2031-02-03\"\n[providers.local.models]\n\"priced\" = { input = 1000.0, cached_input = 100.0, output = 4000.0 }\n",
    )
    .unwrap();
    path
}

fn eval(url: &str, model: &str, out: &Path, extra: &[&str]) -> Output {
    let mut c = crate::support::eval_command(url, model, out, "run");
    c.args(["--scenario", "yield_standoff", "-c", "2", "--max-retries", "0"]).args(extra);
    crate::support::run(c)
}

fn lines(out: &Path) -> Vec<Value> {
    crate::support::jsonl(&out.join("run/rollouts.jsonl"))
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-9 * b.abs().max(1.0)
}

fn text(o: &Output) -> (String, String) {
    (String::from_utf8_lossy(&o.stdout).into_owned(), String::from_utf8_lossy(&o.stderr).into_owned())
}

#[test]
fn each_turn_is_priced_from_its_tokens_and_the_cost_reaches_run_json_the_summary_and_the_report() {
    let (url, _) = fixed_usage_mock("127.0.0.1");
    let out = scratch("cost-priced");
    let prices = prices_file(&out);
    let o = eval(&url, "priced", &out, &["-n", "3", "-q", "--prices-file", prices.to_str().unwrap()]);
    let (stdout, stderr) = text(&o);
    assert!(o.status.success(), "{stderr}");

    let lines = lines(&out);
    assert_eq!(lines.len(), 3);
    let mut total = 0.0;
    for l in &lines {
        let turns = l["turns_taken"].as_u64().unwrap() as f64;
        let cost = l["cost_usd"].as_f64().unwrap();
        assert!(close(cost, turns * TURN_USD), "{cost} for {turns} turns");
        total += cost;
    }
    let info = read_json(&out.join("run/run.json"));
    assert!(close(info["totals"]["cost_usd"].as_f64().unwrap(), total), "{}", info["totals"]);
    assert!(close(info["last_invocation"]["cost_usd"].as_f64().unwrap(), total));
    insta::assert_json_snapshot!(info["pricing"], @r#"
    {
      "as_of": "2031-02-03",
      "cached_input": 100.0,
      "entry": "priced",
      "input": 1000.0,
      "output": 4000.0,
      "provider": "local",
      "source": "a server on this machine: no per-token bill"
    }
    "#);
    let summary = read_json(&out.join("run/summary.json"));
    assert!(close(summary["cost_usd"].as_f64().unwrap(), total));
    assert_eq!(summary["prices_as_of"], "2031-02-03");
    let shown = format!("estimated cost: ${total:.2} (an estimate, at the prices of 2031-02-03");
    assert!(stdout.contains(&shown), "{shown}\n{stdout}");

    // The report's errors-and-cost table: cost, cached share, truncated turns.
    let report = out.join("report");
    let r = negotiator().args(["report", "-q", "--out"]).arg(&report).arg(out.join("run")).output().unwrap();
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let json = read_json(&report.join("report.json"));
    let row = &json["costs"][0];
    assert!(close(row["cost_usd"].as_f64().unwrap(), total), "{row}");
    let picked: Value = ["model", "truncated_turns", "truncated_rate", "cached_share"]
        .iter()
        .map(|k| (k.to_string(), row[*k].clone()))
        .collect::<serde_json::Map<String, Value>>()
        .into();
    insta::assert_json_snapshot!(picked, @r#"
    {
      "cached_share": 0.4,
      "model": "priced",
      "truncated_rate": 0.0,
      "truncated_turns": 0
    }
    "#);
    let md = std::fs::read_to_string(report.join("report.md")).unwrap();
    let header = md.lines().find(|l| l.contains("| cost (USD) |")).expect("a cost column");
    assert!(header.contains("| truncated turns |") && header.contains("| cached |"), "{header}");
    assert!(md.contains(&format!("| ${total:.2} |")), "{md}");
}

#[test]
fn a_model_without_a_price_costs_unknown_never_zero() {
    // 127.0.0.2 is this machine, but not a host the prices file knows.
    let (url, _) = fixed_usage_mock("127.0.0.2");
    let out = scratch("cost-unknown");
    let o = eval(&url, "unpriced", &out, &["-n", "2", "-q"]);
    let (stdout, stderr) = text(&o);
    assert!(o.status.success(), "{stderr}");
    assert!(lines(&out).iter().all(|l| l.get("cost_usd").is_none()));
    let info = read_json(&out.join("run/run.json"));
    assert_eq!((&info["pricing"], &info["totals"]["cost_usd"]), (&Value::Null, &Value::Null));
    assert!(stdout.contains("estimated cost: unknown (no price"), "{stdout}");
    let r = negotiator().args(["report", "--out"]).arg(out.join("report")).arg(out.join("run")).output().unwrap();
    let table = String::from_utf8_lossy(&r.stdout);
    let row = table.lines().find(|l| l.starts_with("unpriced") && l.contains("unknown")).map(str::to_string);
    assert!(row.is_some(), "the cost column says unknown:\n{table}");
    let csv = std::fs::read_to_string(out.join("report/errors_cost.csv")).unwrap();
    let column = csv.lines().next().unwrap().split(',').position(|h| h == "cost_usd").expect("a cost_usd column");
    assert_eq!(csv.lines().nth(1).unwrap().split(',').nth(column), Some(""), "empty, not 0: {csv}");

    // A budget on an unknown cost could never stop anything: refused.
    let o = eval(&url, "unpriced", &out, &["-n", "2", "-q", "--max-cost", "5"]);
    assert_eq!(o.status.code(), Some(2));
    let (_, stderr) = text(&o);
    assert!(stderr.contains("--max-cost: no price for model 'unpriced' at http://127.0.0.2:"), "{stderr}");
}

#[test]
fn a_malformed_prices_file_is_a_usage_error_naming_the_field_before_any_request() {
    let (url, seen) = fixed_usage_mock("127.0.0.1");
    let out = scratch("cost-bad-prices");
    let bad = out.join("bad.toml");
    std::fs::write(
        &bad,
        "as_of = \"2031-02-03\"\n[providers.local.models]\n\"m\" = { input = \"cheap\", output = 1.0 }\n",
    )
    .unwrap();
    let o = eval(&url, "m", &out, &["-n", "1", "-q", "--prices-file", bad.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let (_, stderr) = text(&o);
    let last = stderr.lines().last().unwrap();
    assert!(
        last.ends_with("bad.toml: providers.local.models.\"m\".input: expected USD per million tokens, got \"cheap\""),
        "{stderr}"
    );
    std::fs::write(&bad, "as_of = \"2031-02-03\"\n[providers.local.models]\n\"m\" = { input = 1.0, output = -4.0 }\n")
        .unwrap();
    let o = eval(&url, "m", &out, &["-n", "1", "-q", "--prices-file", bad.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        text(&o).1.contains("providers.local.models.\"m\".output: expected USD per million tokens"),
        "{}",
        text(&o).1
    );
    assert!(seen.lock().unwrap().bodies.is_empty(), "nothing is sent with a broken prices file");
}

#[test]
fn a_cost_budget_stops_starting_episodes_and_a_rerun_finishes() {
    let (url, _) = fixed_usage_mock("127.0.0.1");
    let out = scratch("cost-budget");
    let prices = prices_file(&out);
    let args = ["-n", "12", "--prices-file", prices.to_str().unwrap()];
    for bad in ["--max-cost=0", "--max-cost=-1", "--max-cost=NaN"] {
        let o = eval(&url, "priced", &out, &[&args[..], &["-q", bad]].concat());
        assert_eq!(o.status.code(), Some(2), "--max-cost {bad}");
        assert!(text(&o).1.contains("--max-cost: expected a positive number of US dollars"), "{}", text(&o).1);
    }
    // Every episode costs several turns at $0.84: over $1 at its first finish.
    let o = eval(&url, "priced", &out, &[&args[..], &["--max-cost", "1", "--events", "json"]].concat());
    assert_eq!(o.status.code(), Some(1), "{}", text(&o).1);
    let events: Vec<Value> = text(&o).1.lines().filter_map(|l| serde_json::from_str(l).ok()).collect();
    let stopped: Vec<&Value> = events.iter().filter(|e| e["event"] == "stopped").collect();
    assert_eq!(stopped.len(), 1, "{events:?}");
    assert_eq!(stopped[0]["reason"], "cost_budget");
    let finished = events.last().unwrap();
    assert_eq!((&finished["event"], &finished["stop"]["reason"]), (&json!("finished"), &json!("cost_budget")));
    let partial = lines(&out).len();
    assert!((1..=2).contains(&partial), "in-flight episodes finish, no new one starts: {partial}");
    assert!(close(
        finished["cost_usd"].as_f64().unwrap(),
        lines(&out).iter().map(|l| l["cost_usd"].as_f64().unwrap()).sum()
    ));
    let info = read_json(&out.join("run/run.json"));
    assert_eq!(info["last_invocation"]["settings"]["max_cost_usd"], 1.0);
    assert_eq!(info["last_invocation"]["status"], "incomplete");
    // Resumable: the same command without the budget plays the rest.
    let o = eval(&url, "priced", &out, &[&args[..], &["-q"]].concat());
    assert!(o.status.success(), "{}", text(&o).1);
    assert_eq!(lines(&out).len(), 12);
}

// ---------------------------------------------------------------------
// eval --dry-run

/// The numbers of the plan's "expected:" line: (turns, prompt tokens,
/// completion tokens).
fn expected_line(stdout: &str) -> (u64, u64, u64) {
    let line = stdout.lines().find(|l| l.starts_with("expected: ")).unwrap_or_else(|| panic!("{stdout}"));
    let num = |after: &str| -> u64 {
        let rest = &line[line.find(after).unwrap_or_else(|| panic!("{after}: {line}")) + after.len()..];
        rest.split(|c: char| !c.is_ascii_digit()).next().unwrap().parse().unwrap()
    };
    (num("expected: "), num("turns; "), num("cacheable), "))
}

#[test]
fn a_dry_run_sends_nothing_writes_nothing_and_prints_the_exact_first_request() {
    // A listener that nobody should connect to: a connection would queue.
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    listener.set_nonblocking(true).unwrap();
    let url = format!("http://127.0.0.1:{}/v1", listener.local_addr().unwrap().port());
    let out = scratch("dry-run-silent");
    let key = "sk-proj-dryrunsecretkey0123456789";
    let args = ["--endpoint", "openai", "--model", "gpt-5", "--scenario", "all", "-n", "2", "--run-name", "run"];
    let o = negotiator()
        .args(["eval", "--dry-run", "--base-url", &url, "--output"])
        .arg(out.join("results"))
        .args(args)
        .env("OPENAI_API_KEY", key)
        .output()
        .unwrap();
    let (stdout, stderr) = text(&o);
    assert!(o.status.success(), "{stderr}");
    match listener.accept() {
        Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {}
        other => panic!("the dry run contacted the endpoint: {other:?}"),
    }
    assert!(!out.join("results").exists(), "a dry run writes nothing");
    assert!(!stdout.contains(key) && !stdout.contains("sk-proj-dry") && !stderr.contains("sk-proj-dry"), "{stdout}");
    assert!(stdout.contains("\nAuthorization: Bearer [REDACTED]\n"), "{stdout}");
    assert!(stdout.contains("6 episodes selected, 0 already finished, 6 to run"), "{stdout}");
    // gpt-5's profile thinks: its expected reasoning is in the completion.
    assert!(stdout.contains("reasoning: 1500 per turn, request profile 'openai-reasoning'"), "{stdout}");
    assert!(stdout.contains("estimated cost: $0.0000 with no cache hit"), "a server on this machine is free: {stdout}");
    assert!(stdout.contains("s per turn assumed: 1 s plus the reasoning"), "{stdout}");
    let printed_body = stdout.trim_end().lines().last().unwrap().to_string();

    // The real run's first request (its preflight) is that body, byte for byte.
    let handler: Handler = Arc::new(|body: &Value| {
        (
            200,
            json!({"choices": [{"index": 0, "finish_reason": "stop",
                      "message": {"role": "assistant", "content": expert_reply(body)}}],
                     "usage": {"prompt_tokens": 10, "completion_tokens": 5}}),
        )
    });
    let (mock_url, seen) = start_mock(handler);
    let o = negotiator()
        .args(["eval", "-q", "--base-url", &mock_url, "--output"])
        .arg(out.join("results"))
        .args(args)
        .env("OPENAI_API_KEY", key)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o).1);
    let first = String::from_utf8(seen.lock().unwrap().bodies[0].clone()).unwrap();
    assert_eq!(printed_body, first);

    // A bad latency is refused like any flag.
    let o = negotiator()
        .args(["eval", "--dry-run", "--assume-latency=-2", "--base-url", &url, "--model", "m", "--output"])
        .arg(out.join("x"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o).1.contains("--assume-latency: expected a positive number of seconds"), "{}", text(&o).1);
}

#[test]
fn a_dry_run_predicts_the_turns_and_tokens_that_a_run_against_the_served_expert_reports() {
    let server = crate::support::Server::start(&["--policy", "expert"]);
    let out = scratch("dry-run-exact");
    let args = ["--model", "expert", "--scenario", "all", "--tier", "all", "-n", "3", "-c", "4", "--run-name", "run"];
    let dry = |extra: &[&str]| {
        let o = negotiator()
            .args(["eval", "--dry-run", "--base-url", &server.base_url(), "--output"])
            .arg(&out)
            .args(args)
            .args(extra)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", text(&o).1);
        text(&o).0
    };
    let plan = dry(&["--assume-latency", "0.5"]);
    let table: Vec<&str> = plan.lines().filter(|l| l.starts_with('|')).collect();
    // Each scenario's rows are pinned in a snapshot of its own
    // (tests/it/snapshots/it__cost__dry_run_<scenario>.snap).
    assert_eq!(table.len(), 2 + crate::support::cells(), "{plan}");
    for kind in ScenarioKind::ALL {
        let rows: Vec<&str> = table.iter().copied().filter(|l| l.starts_with(&format!("| {kind} |"))).collect();
        insta::assert_snapshot!(format!("dry_run_{kind}"), [&table[..2], &rows[..]].concat().join("\n"));
    }
    assert!(plan.contains("(0.5 s per turn as given by --assume-latency"), "{plan}");
    let (turns, prompt, completion) = expected_line(&plan);

    let o = negotiator()
        .args(["eval", "-q", "--base-url", &server.base_url(), "--output"])
        .arg(&out)
        .args(args)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o).1);
    let lines = std::fs::read_to_string(out.join("run/rollouts.jsonl")).unwrap();
    let sum = |field: &str| -> u64 {
        lines.lines().map(|l| serde_json::from_str::<Value>(l).unwrap()[field].as_u64().unwrap()).sum()
    };
    assert_eq!(
        (turns, prompt, completion),
        (sum("turns_taken"), sum("prompt_tokens"), sum("completion_tokens")),
        "the plan measures the requests the run sends"
    );
    // After the run, nothing is left to plan.
    let all = 3 * crate::support::cells();
    assert!(dry(&[]).contains(&format!("{all} episodes selected, {all} already finished, 0 to run")));
}
