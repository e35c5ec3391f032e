//! The scene as a picture end to end: `eval --observation image|both`
//! against the served expert (found behind its pictures, never reading
//! them), against a recording endpoint that checks the content parts and
//! the image history, against an endpoint that takes no images, and
//! resumed.

use crate::support::{Request, Server, eval_command, jsonl, mock, read_json, reply, respond, run, scratch, stderr};
use base64::Engine;
use negotiator::action::{Action, Maneuver};
use negotiator::episode::Episode;
use negotiator::scenario::{ScenarioKind, ScenarioSet, Tier};
use serde_json::{Value, json};
use std::collections::BTreeMap;
use std::path::Path;
use std::sync::{Arc, Mutex};

fn eval(base_url: &str, out: &Path, run_name: &str, args: &[&str]) -> std::process::Command {
    let mut c = eval_command(base_url, "scripted", out, run_name);
    c.args(["--quiet", "-c", "8"]).args(args);
    c
}

/// Each episode of a run directory by key: its outcome and its actions.
fn episodes(dir: &Path) -> BTreeMap<(String, u64, u64), (Value, Vec<Value>)> {
    jsonl(&dir.join("rollouts.jsonl"))
        .into_iter()
        .map(|l| {
            let key =
                (l["scenario"].as_str().unwrap().to_string(), l["tier"].as_u64().unwrap(), l["seed"].as_u64().unwrap());
            let actions = l["turns"].as_array().unwrap().iter().map(|t| t["action"].clone()).collect();
            (key, (l["outcome"].clone(), actions))
        })
        .collect()
}

/// The served expert answers a conversation of pictures as it answers the
/// text, seed for seed and action for action, in every cell: it finds the
/// episode from the pictures' bytes, with every picture kept or only the
/// last. `both` plays the same episodes, and the dry run's token count is
/// what the server reports.
#[test]
fn eval_with_pictures_against_the_served_expert_plays_the_text_runs_episodes() {
    let server = Server::start(&["--policy", "expert", "--probe-seeds", "0..3"]);
    let out = scratch("vision-expert");
    let grid = ["--scenario", "all", "--tier", "all", "-n", "3"];
    crate::support::ok(eval(&server.base_url(), &out, "text", &grid));
    let image: Vec<&str> = grid.iter().copied().chain(["--observation", "image"]).collect();
    crate::support::ok(eval(&server.base_url(), &out, "image", &image));
    let both: Vec<&str> = grid.iter().copied().chain(["--observation", "both", "--image-history", "2"]).collect();
    crate::support::ok(eval(&server.base_url(), &out, "both", &both));
    // With one picture per request, no earlier picture is left to find the
    // episode by: serve remembers it by the picture it expects next.
    let last_only: Vec<&str> = grid.iter().copied().chain(["--observation", "image", "--image-history", "1"]).collect();
    crate::support::ok(eval(&server.base_url(), &out, "last-only", &last_only));
    let text = episodes(&out.join("text"));
    assert_eq!(text.len(), 3 * crate::support::cells());
    assert!(text.values().all(|(outcome, _)| outcome == "success"), "the expert wins every text episode");
    assert_eq!(episodes(&out.join("image")), text);
    assert_eq!(episodes(&out.join("both")), text);
    assert_eq!(episodes(&out.join("last-only")), text);
    // Every cell won, as in the text run.
    let summary = read_json(&out.join("image/summary.json"));
    for cell in summary["cells"].as_array().unwrap() {
        assert_eq!(cell["success"]["estimate"], 1.0, "{cell}");
    }
    // A picture run says so in its configuration and its records.
    let info = read_json(&out.join("image/run.json"));
    assert_eq!(info["config"]["pictures"], json!({"observation": "image", "detail": "auto"}));
    let first = &jsonl(&out.join("image/rollouts.jsonl"))[0];
    let turn1 = &first["turns"][0];
    assert!(turn1["scene"].as_str().unwrap().starts_with("Scene: "), "the record keeps the scene text");
    assert_eq!((turn1["pictures"].as_u64(), turn1["image_tokens"].as_u64()), (Some(1), Some(255)));
    // The dry run counts the tokens the server reported, pictures included.
    let dry = run(eval(&server.base_url(), &out, "image-plan", &[&image[..], &["--dry-run"]].concat()));
    let said = String::from_utf8_lossy(&dry.stdout).into_owned();
    let planned: u64 = said
        .split_once("turns; ")
        .and_then(|(_, r)| r.split_once(" prompt tokens"))
        .map(|(n, _)| n.parse().unwrap())
        .unwrap_or_else(|| panic!("{said}"));
    let used: u64 = jsonl(&out.join("image/rollouts.jsonl"))
        .iter()
        .flat_map(|l| l["turns"].as_array().unwrap().clone())
        .map(|t| t["usage"]["prompt_tokens"].as_u64().unwrap())
        .sum();
    assert_eq!(planned, used, "{said}");
    assert!(said.contains("pictures (--observation image): "), "{said}");
}

/// What a recording endpoint saw: every request body.
type Seen = Arc<Mutex<Vec<Value>>>;

fn recording(answer: Action) -> (String, Seen) {
    let seen: Seen = Arc::default();
    let log = seen.clone();
    let content = json!({"reasoning": "recording", "maneuver": answer.maneuver.name(), "acceleration": answer.acceleration, "steering": 0.0}).to_string();
    let url = mock(Arc::new(move |r: &Request| {
        log.lock().unwrap().push(r.body.clone());
        reply(&content)
    }));
    (url, seen)
}

fn png_of(part: &Value) -> Vec<u8> {
    let url = part["image_url"]["url"].as_str().unwrap();
    let b64 = url.strip_prefix("data:image/png;base64,").unwrap_or_else(|| panic!("{url:.40}"));
    base64::engine::general_purpose::STANDARD.decode(b64).unwrap()
}

/// The requests as a provider receives them: each user turn the picture
/// then the line, as OpenAI content parts at the asked detail; pictures
/// only in the last K user turns, older turns a one-line stand-in naming
/// the turn; each picture byte for byte the one the simulator draws for
/// that turn; the system prompt saying what the picture shows. Each turn
/// records its pictures and their tokens (OpenAI's 85 at detail low).
#[test]
fn a_recording_endpoint_sees_content_parts_and_the_image_history() {
    let answer = Action::new(Maneuver::Yield, 0.2);
    let (url, seen) = recording(answer);
    let out = scratch("vision-recording");
    // A cell whose readings of the others carry noise.
    let set = ScenarioSet::default();
    let (kind, tier) = ScenarioKind::ALL
        .into_iter()
        .flat_map(|k| Tier::ALL.map(|t| (k, t)))
        .find(|&(k, t)| Episode::new(set.get(k), t, 0).observation().reading_noise.is_some())
        .unwrap();
    let tier_flag = tier.number().to_string();
    let args = [
        "--scenario",
        kind.name(),
        "--tier",
        &tier_flag,
        "-n",
        "1",
        "--observation",
        "image",
        "--image-detail",
        "low",
        "--image-history",
        "2",
    ];
    crate::support::ok(eval(&url, &out, "run", &args));
    let bodies = seen.lock().unwrap().clone();
    assert!(bodies.len() >= 4, "{} requests", bodies.len());
    let mut episode = Episode::new(set.get(kind), tier, 0);
    for (k, body) in bodies.iter().enumerate() {
        let messages = body["messages"].as_array().unwrap();
        let system = messages[0]["content"].as_str().unwrap();
        assert!(system.contains("bird's-eye picture") && system.contains("pixels per metre"), "{system:.200}");
        let users: Vec<&Value> = messages.iter().filter(|m| m["role"] == "user").collect();
        assert_eq!(users.len(), k + 1);
        for (i, user) in users.iter().enumerate() {
            let pictured = i + 2 > k;
            match &user["content"] {
                Value::Array(parts) if pictured => {
                    assert_eq!(parts.len(), 2, "{k}/{i}");
                    assert_eq!(parts[0]["type"], "image_url");
                    assert_eq!(parts[0]["image_url"]["detail"], "low");
                    assert_eq!(parts[1]["type"], "text");
                    let line = parts[1]["text"].as_str().unwrap();
                    assert!(line.starts_with(&format!("Turn {} of ", i + 1)) && !line.contains("Scene:"), "{line}");
                    // Noisy readings: the line says so, as the text would.
                    assert!(line.contains("Readings: "), "{line}");
                }
                Value::String(stand_in) if !pictured => {
                    assert_eq!(
                        stand_in,
                        &format!(
                            "Turn {} of {}: (its picture is no longer shown)",
                            i + 1,
                            episode.observation().turn_budget
                        )
                    );
                }
                other => panic!("request {k}, user turn {i}: {other:.200}"),
            }
        }
        // This turn's picture is the simulator's own.
        let now = users[k]["content"].as_array().unwrap();
        assert_eq!(png_of(&now[0]), negotiator::picture::png(episode.observation()).unwrap(), "turn {}", k + 1);
        episode.step(answer);
    }
    assert!(episode.is_done());
    let line = &jsonl(&out.join("run/rollouts.jsonl"))[0];
    for (k, turn) in line["turns"].as_array().unwrap().iter().enumerate() {
        let pictures = (k + 1).min(2) as u64;
        assert_eq!((turn["pictures"].as_u64(), turn["image_tokens"].as_u64()), (Some(pictures), Some(85 * pictures)));
    }
}

/// An endpoint whose model takes no images (OpenAI's wording) stops the
/// run at its first request with one line naming the flag, exit 3.
#[test]
fn an_endpoint_that_takes_no_images_is_named_with_the_flag() {
    let url = mock(Arc::new(|r: &Request| {
        let pictured = r.body.to_string().contains("image_url");
        if pictured {
            respond(
                400,
                json!({"error": {"message": "Invalid content type. image_url is only supported by certain models.", "type": "invalid_request_error", "param": "messages.[1].content.[0].type", "code": null}}),
            )
        } else {
            reply("{\"maneuver\": \"stop\", \"acceleration\": 0.5}")
        }
    }));
    let out = scratch("vision-rejected");
    let o =
        run(eval(&url, &out, "run", &["--scenario", ScenarioKind::ALL[0].name(), "-n", "2", "--observation", "image"]));
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    let err = stderr(&o);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("--observation image") && err.contains("--observation text"), "{err}");
}

/// A picture run resumes as a text run does (only the missing episodes
/// are played), and its directory refuses another observation, naming the
/// change; a text-only flag combination is refused before anything runs.
#[test]
fn a_picture_run_resumes_and_refuses_another_observation() {
    let server = Server::start(&["--policy", "expert", "--probe-seeds", "0..4"]);
    let out = scratch("vision-resume");
    let kind = ScenarioKind::ALL[1].name();
    let args = |n: &'static str| vec!["--scenario", kind, "--tier", "2", "-n", n, "--observation", "image"];
    crate::support::ok(eval(&server.base_url(), &out, "run", &args("2")));
    let before = jsonl(&out.join("run/rollouts.jsonl"));
    crate::support::ok(eval(&server.base_url(), &out, "run", &args("4")));
    let after = jsonl(&out.join("run/rollouts.jsonl"));
    assert_eq!(after.len(), 4);
    assert_eq!(after[..2], before[..], "the finished episodes are kept as they were");
    assert!(after.iter().all(|l| l["outcome"] == "success"));
    let o = run(eval(
        &server.base_url(),
        &out,
        "run",
        &["--scenario", kind, "--tier", "2", "-n", "4", "--observation", "both"],
    ));
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("pictures.observation: \"image\" -> \"both\""), "{}", stderr(&o));
    let o = run(eval(&server.base_url(), &out, "other", &["--scenario", kind, "--image-history", "2"]));
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("add --observation image"), "{}", stderr(&o));
}

/// A report holding one model id under two observations compares them
/// per cell on the shared seeds (a table, report.json, a figure), names
/// the picture run apart on the leaderboard, and shows each drill-down
/// turn's picture: the very PNG the model was sent.
#[test]
fn the_report_compares_text_and_picture_and_shows_the_pictures() {
    // The same model id, read well from the text and blindly from the
    // picture (a server that always proceeds), so the cells differ.
    let reader = Server::start(&["--policy", "expert"]);
    let blind = Server::start(&["--policy", "always_proceed", "--probe-seeds", "0..12"]);
    let out = scratch("vision-report");
    let grid = ["--scenario", "all", "--tier", "3", "-n", "12"];
    crate::support::ok(eval(&reader.base_url(), &out, "text", &grid));
    let image: Vec<&str> = grid.iter().copied().chain(["--observation", "image"]).collect();
    crate::support::ok(eval(&blind.base_url(), &out, "image", &image));
    let rep = out.join("report");
    let o = run({
        let mut c = crate::support::negotiator();
        c.args(["report", "--quiet", "--out"]).arg(&rep).arg(out.join("text")).arg(out.join("image"));
        c
    });
    assert!(o.status.success(), "{}", stderr(&o));
    let report = read_json(&rep.join("report.json"));
    let labels: Vec<&str> =
        report["leaderboard"]["rows"].as_array().unwrap().iter().map(|r| r["model"].as_str().unwrap()).collect();
    assert_eq!(labels, ["scripted", "scripted (image)"]);
    let rows = report["observations"].as_array().unwrap();
    assert_eq!(rows.len(), crate::support::scenarios());
    for r in rows {
        assert_eq!((r["a"].as_str(), r["b"].as_str(), r["seeds"].as_u64()), (Some("text"), Some("image"), Some(12)));
        let (a_only, b_only) = (r["a_only"].as_u64().unwrap(), r["b_only"].as_u64().unwrap());
        let wins = |k: &str| (r[k]["estimate"].as_f64().unwrap() * 12.0).round() as u64;
        assert_eq!(wins("success_a") - wins("success_b"), a_only - b_only, "{r}");
        let p = r["mcnemar_p"].as_f64().unwrap();
        assert_eq!(r["verdict"].as_str().unwrap().starts_with("text better"), p < 0.05, "{r}");
    }
    assert!(rows.iter().any(|r| r["verdict"].as_str().unwrap().starts_with("text better")), "{rows:?}");
    let csv = std::fs::read_to_string(rep.join("observations.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + crate::support::scenarios());
    let figure = std::fs::read_to_string(rep.join("plots/text_against_picture.svg")).unwrap();
    assert!(figure.contains("scripted (image)") && !figure.contains("NaN"));
    // The drill-down's pictures are the ones the image run sent.
    let html = std::fs::read_to_string(rep.join("report.html")).unwrap();
    assert!(html.contains("\"g\":\"pictures/"), "drill-down pictures");
    let pictures: Vec<_> = std::fs::read_dir(rep.join("pictures")).unwrap().flatten().map(|e| e.path()).collect();
    assert!(!pictures.is_empty());
    let set = ScenarioSet::default();
    let sent: Vec<Vec<u8>> = jsonl(&out.join("image/rollouts.jsonl"))
        .iter()
        .map(|line| {
            let kind: ScenarioKind = line["scenario"].as_str().unwrap().parse().unwrap();
            let first = Episode::new(set.get(kind), Tier::T3, line["seed"].as_u64().unwrap());
            negotiator::picture::png(first.observation()).unwrap()
        })
        .collect();
    let firsts: Vec<_> = pictures.iter().filter(|p| p.to_string_lossy().ends_with("-1.png")).collect();
    assert!(firsts.len() >= crate::support::scenarios(), "{pictures:?}");
    for p in firsts {
        assert!(sent.contains(&std::fs::read(p).unwrap()), "{}", p.display());
    }
}

/// Episodes whose first pictures are the same bytes (seeds 31 and 44 of
/// the crosswalk's tiers 2 and 3 among them) are told apart by the first
/// picture that differs, even when each request holds only its own
/// picture (`--image-history 1`): serve keeps every episode a
/// conversation may be, and the served expert plays the text run's
/// episodes, seed for seed.
#[test]
fn episodes_with_the_same_first_picture_are_told_apart() {
    let server = Server::start(&["--policy", "expert", "--probe-seeds", "30..46"]);
    let out = scratch("vision-ambiguous");
    let grid = ["--scenario", "all", "--tier", "all", "--seed", "30", "-n", "16"];
    crate::support::ok(eval(&server.base_url(), &out, "text", &grid));
    let last_only: Vec<&str> = grid.iter().copied().chain(["--observation", "image", "--image-history", "1"]).collect();
    crate::support::ok(eval(&server.base_url(), &out, "last-only", &last_only));
    let text = episodes(&out.join("text"));
    assert_eq!(text.len(), 16 * crate::support::cells());
    assert_eq!(episodes(&out.join("last-only")), text);
}

/// The belief probe through pictures: the served expert states the ideal
/// observer's belief at every turn whether the scene came as a picture
/// (found from its bytes) or as a picture beside the text (read as text).
#[test]
fn the_served_expert_states_the_ideal_belief_through_pictures() {
    let server = Server::start(&["--policy", "expert", "--probe", "belief", "--probe-seeds", "0..2"]);
    let out = scratch("vision-belief");
    for observation in ["image", "both"] {
        let args = ["--scenario", "all", "--tier", "all", "-n", "2", "--probe", "belief", "--observation", observation];
        crate::support::ok(eval(&server.base_url(), &out, observation, &args));
        let lines = jsonl(&out.join(observation).join("rollouts.jsonl"));
        assert_eq!(lines.len(), 2 * crate::support::cells());
        for line in &lines {
            for turn in line["turns"].as_array().unwrap() {
                assert_eq!(
                    turn["belief"], turn["ideal_belief"],
                    "{observation}: {} turn {}",
                    line["scenario"], turn["turn"]
                );
            }
        }
    }
}
