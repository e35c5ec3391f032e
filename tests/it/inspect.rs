//! Inspect AI eval logs on the leaderboard: `import-inspect` and `report`
//! read a log Inspect itself wrote (`tests/fixtures/inspect/expert-t2.eval`:
//! the negotiator task, Inspect's `openai-api` provider against `negotiator
//! serve --policy expert`, seed 4 of tier 2 on the intersection and the
//! crosswalk), replay its replies through the episode, and write what
//! `eval` writes. A log of another version, a sample cut short and a taken
//! output directory are each refused or recorded as such.
//!
//! The fixture is regenerated (after a change to the scenes) with the
//! Inspect task as python/tests/test_inspect.py runs it, with
//! `-T scenario=yield_standoff,pedestrian_feint -T tier=2 -T seeds=1 -T seed=4`.

use crate::support::{Server, eval_command, jsonl, negotiator, ok, read_json, run, scratch, stderr};
use negotiator::episode::run_episode;
use negotiator::policy::PolicyKind;
use negotiator::scenario::{ScenarioKind, ScenarioSet, Tier};
use serde_json::{Map, Value, json};
use std::io::Read;
use std::path::{Path, PathBuf};

const FIXTURE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/inspect/expert-t2.eval");

fn import(log: &Path, out: &Path) -> std::process::Output {
    let mut c = negotiator();
    c.args(["import-inspect", log.to_str().unwrap(), "--output", out.to_str().unwrap()]);
    run(c)
}

/// The fixture as Inspect's `.json` log format (the header's fields and
/// the samples in one object), with `edit` applied to the samples.
fn as_json_log(dir: &Path, edit: impl FnOnce(&mut Vec<Value>)) -> PathBuf {
    let mut zip = zip::ZipArchive::new(std::fs::File::open(FIXTURE).unwrap()).unwrap();
    let mut read = |name: &str| -> Value {
        let mut text = String::new();
        zip.by_name(name).unwrap().read_to_string(&mut text).unwrap();
        serde_json::from_str(&text).unwrap()
    };
    let mut log: Map<String, Value> = serde_json::from_value(read("header.json")).unwrap();
    let names: Vec<String> = ["samples/yield_standoff/t2/4_epoch_1.json", "samples/pedestrian_feint/t2/4_epoch_1.json"]
        .map(String::from)
        .to_vec();
    let mut samples: Vec<Value> = names.iter().map(|n| read(n)).collect();
    edit(&mut samples);
    log.insert("samples".into(), Value::Array(samples));
    let path = dir.join("log.json");
    std::fs::write(&path, serde_json::to_vec(&log).unwrap()).unwrap();
    path
}

#[test]
fn an_inspect_log_imports_as_the_episodes_the_expert_plays() {
    let dir = scratch("inspect-import");
    let out = dir.join("run");
    let o = import(Path::new(FIXTURE), &out);
    assert!(o.status.success(), "{}", stderr(&o));
    let info = read_json(&out.join("run.json"));
    assert_eq!(info["config"]["model"], "openai-api/negotiator/expert", "the model as Inspect names it");
    assert_eq!(info["imported_from"]["harness"], "inspect_ai");
    assert_eq!(info["last_invocation"]["status"], "finished");
    let sel = &info["last_invocation"]["selection"];
    assert_eq!((sel["base_seed"].as_u64(), sel["seeds"].as_u64()), (Some(4), Some(1)), "{sel}");
    let rollouts = jsonl(&out.join("rollouts.jsonl"));
    assert_eq!(rollouts.len(), 2);
    let set = ScenarioSet::default();
    for r in &rollouts {
        let kind: ScenarioKind = r["scenario"].as_str().unwrap().parse().unwrap();
        let tier: Tier = r["tier"].to_string().parse().unwrap();
        let seed = r["seed"].as_u64().unwrap();
        // The expert in-process plays the same episode the log's replies did.
        let expert = run_episode(set.get(kind), tier, seed, PolicyKind::Expert.build().as_mut());
        let outcome = serde_json::to_value(expert.outcome).unwrap();
        assert_eq!((&r["outcome"], r["reward"].as_f64()), (&outcome, Some(expert.grades.reward)), "{kind}");
        assert_eq!(r["turns_taken"].as_u64(), Some(expert.decisions.len() as u64));
        assert_eq!(r["disposition"], serde_json::to_value(expert.disposition).unwrap());
        assert_eq!(r["parse_error_turns"], 0);
        // Per-turn usage and latency come from Inspect's model events.
        let turn = &r["turns"][0];
        assert!(turn["usage"]["prompt_tokens"].as_u64().unwrap() > 0, "{turn}");
        assert!(r["tokens"].as_u64().unwrap() > 0 && r["turns"][0]["tokens_estimated"].is_null());
        assert!(r["trajectory"].as_array().is_some_and(|t| !t.is_empty()), "trajectory for the plots");
    }
    // Importing twice into one directory never overwrites a run.
    let before = std::fs::read(out.join("rollouts.jsonl")).unwrap();
    let again = import(Path::new(FIXTURE), &out);
    assert_eq!(again.status.code(), Some(2), "{}", stderr(&again));
    assert!(stderr(&again).contains("already holds a run"), "{}", stderr(&again));
    assert_eq!(std::fs::read(out.join("rollouts.jsonl")).unwrap(), before);
}

/// The same replies through Inspect and through `eval`: the imported lines
/// are eval's, field for field, but for what only the harness knows (the
/// model's name, usage, latency, timestamps); and `report` ranks the log
/// beside eval's run directory.
#[test]
fn an_imported_log_is_the_run_eval_writes_and_report_ranks_it_beside_one() {
    let dir = scratch("inspect-parity");
    let server = Server::start(&["--policy", "expert"]);
    let mut c = eval_command(&server.base_url(), "expert", &dir, "eval");
    c.args(["--scenario", "yield_standoff,pedestrian_feint", "--tier", "2", "-n", "1", "--seed", "4", "-q"]);
    ok(c);
    ok({
        let mut c = negotiator();
        c.args(["import-inspect", FIXTURE, "--output", dir.join("imported").to_str().unwrap()]);
        c
    });
    let harness_only = [
        "model",
        "config_hash",
        "tokens",
        "prompt_tokens",
        "completion_tokens",
        "latency_ms",
        "wall_ms",
        "finished_at",
        "cost_usd",
        "turns",
    ];
    let key = |r: &Value| (r["scenario"].to_string(), r["seed"].as_u64());
    let mut ours = jsonl(&dir.join("imported/rollouts.jsonl"));
    let mut evals = jsonl(&dir.join("eval/rollouts.jsonl"));
    ours.sort_by_key(key);
    evals.sort_by_key(key);
    assert_eq!(ours.len(), 2);
    assert_eq!(ours.len(), evals.len());
    for (a, b) in ours.iter().zip(&evals) {
        for (field, value) in b.as_object().unwrap() {
            if !harness_only.contains(&field.as_str()) {
                assert_eq!(&a[field], value, "{field} of {}", b["scenario"]);
            }
        }
        for (ta, tb) in a["turns"].as_array().unwrap().iter().zip(b["turns"].as_array().unwrap()) {
            for field in ["turn", "scene", "reply", "action", "parse_errors", "after_resolution", "ideal_belief"] {
                assert_eq!(ta[field], tb[field], "turn {} {field}", tb["turn"]);
            }
        }
    }
    let out = dir.join("report");
    let mut c = negotiator();
    c.args(["report", FIXTURE, dir.join("eval").to_str().unwrap(), "--out", out.to_str().unwrap()]);
    c.args(["--baselines", concat!(env!("CARGO_MANIFEST_DIR"), "/results/baselines"), "--tiers", "2"]);
    c.args(["--include-incomplete", "-q"]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    let models: Vec<String> = read_json(&out.join("report.json"))["models"]
        .as_array()
        .map(|m| m.iter().map(|x| x["model"].as_str().unwrap_or_default().to_string()).collect())
        .unwrap_or_default();
    assert!(
        models.contains(&"openai-api/negotiator/expert".to_string()) && models.contains(&"expert".to_string()),
        "{models:?}"
    );
}

#[test]
fn a_log_whose_scenes_this_build_does_not_render_is_refused() {
    let dir = scratch("inspect-version");
    let log = as_json_log(&dir, |samples| {
        let scene = &mut samples[1]["messages"][3]["content"];
        *scene = json!(scene.as_str().unwrap().replace("Turn: 2 of", "Turn: 2 of 99 of"));
    });
    let o = import(&log, &dir.join("run"));
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("pedestrian_feint/t2/4") && err.contains("not the one this negotiator renders"), "{err}");
    assert!(err.lines().count() == 1, "one line: {err}");
    assert!(!dir.join("run").join("rollouts.jsonl").exists(), "nothing written");
}

#[test]
fn a_sample_cut_short_is_a_missing_episode_not_a_failure() {
    let dir = scratch("inspect-unfinished");
    let log = as_json_log(&dir, |samples| {
        // An Inspect limit ended the first sample after its third decision.
        let s = &mut samples[0];
        s["messages"].as_array_mut().unwrap().truncate(7);
        s["scores"] = json!({});
        let mut calls = 0;
        s["events"].as_array_mut().unwrap().retain(|e| {
            let model = e["event"] == "model";
            calls += model as usize;
            !model || calls <= 3
        });
    });
    let out = dir.join("run");
    let o = import(&log, &out);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(jsonl(&out.join("rollouts.jsonl")).len(), 1);
    let errors = jsonl(&out.join("errors.jsonl"));
    assert_eq!(errors.len(), 1, "{errors:?}");
    assert_eq!((errors[0]["scenario"].as_str(), errors[0]["turn"].as_u64()), (Some("yield_standoff"), Some(4)));
    let info = read_json(&out.join("run.json"));
    assert_eq!(info["last_invocation"]["status"], "incomplete");
}

#[test]
fn what_is_not_a_log_is_a_one_line_usage_error() {
    let dir = scratch("inspect-bad");
    let bad = dir.join("bad.eval");
    std::fs::write(&bad, b"not a zip").unwrap();
    let o = import(&bad, &dir.join("run"));
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("not an Inspect eval log") && stderr(&o).lines().count() == 1, "{}", stderr(&o));
    let missing = import(&dir.join("nothing.eval"), &dir.join("run"));
    assert_eq!(missing.status.code(), Some(2), "{}", stderr(&missing));
}

/// The fixture's samples as a picture run (`-T observation=both`) would
/// have logged them: this build's system prompt for `both`, and each user
/// message as the picture (one of the sample's attachments, as Inspect
/// condenses images) beside the scene text. `picture_of` may change what
/// a turn's picture is (the sample, the turn from 1).
fn as_picture_log(dir: &Path, picture_of: impl Fn(usize, u32, String) -> String) -> PathBuf {
    use base64::Engine as _;
    use negotiator::episode::Episode;
    as_json_log(dir, |samples| {
        let set = ScenarioSet::default();
        for (s, sample) in samples.iter_mut().enumerate() {
            let md = &sample["metadata"];
            let kind: ScenarioKind = md["scenario"].as_str().unwrap().parse().unwrap();
            let tier: Tier = md["tier"].to_string().trim_matches('"').parse().unwrap();
            let mut episode = Episode::new(set.get(kind), tier, md["seed"].as_u64().unwrap());
            let mut attachments = Map::new();
            let messages = sample["messages"].as_array_mut().unwrap();
            let system = negotiator::instructions::SYSTEM_PROMPT.to_string()
                + &negotiator::picture::prompt_paragraph(kind, true);
            messages[0]["content"] = json!(system);
            for m in messages.iter_mut().skip(1) {
                if m["role"] == "user" {
                    let obs = episode.observation();
                    let png = negotiator::picture::png(obs).unwrap();
                    let url =
                        format!("data:image/png;base64,{}", base64::engine::general_purpose::STANDARD.encode(png));
                    let hash = format!("{s}-{}", obs.turn);
                    attachments.insert(hash.clone(), json!(picture_of(s, obs.turn, url)));
                    m["content"] = json!([
                        {"type": "image", "image": format!("attachment://{hash}"), "detail": "auto"},
                        {"type": "text", "text": negotiator::observation::render_scene(obs)},
                    ]);
                } else if m["role"] == "assistant" {
                    let reply = match &m["content"] {
                        Value::String(t) => t.clone(),
                        parts => parts.as_array().unwrap().iter().filter_map(|p| p["text"].as_str()).collect(),
                    };
                    episode.step(negotiator::action::parse_action(&reply).action);
                }
            }
            sample["attachments"] = Value::Object(attachments);
        }
    })
}

/// A log of `-T observation=both` imports as eval's picture run: its own
/// row, the pictures counted per turn, and each picture Inspect kept
/// checked byte for byte against the one this build draws (a log written
/// with `--no-log-images` keeps none to check).
#[test]
fn a_picture_log_imports_as_the_picture_run_and_its_pictures_are_checked() {
    let dir = scratch("inspect-pictures");
    let log = as_picture_log(
        &dir,
        |s, turn, url| {
            if s == 1 && turn == 3 { "<base64-data-removed>".to_string() } else { url }
        },
    );
    let out = dir.join("run");
    let o = import(&log, &out);
    assert!(o.status.success(), "{}", stderr(&o));
    let info = read_json(&out.join("run.json"));
    assert_eq!(info["config"]["pictures"], json!({"observation": "both", "detail": "auto"}));
    let rollouts = jsonl(&out.join("rollouts.jsonl"));
    assert_eq!(rollouts.len(), 2);
    for r in &rollouts {
        assert_eq!(r["outcome"], "success", "{}", r["scenario"]);
        for (i, t) in r["turns"].as_array().unwrap().iter().enumerate() {
            // Inspect keeps every earlier picture; each is 255 tokens by
            // OpenAI's tiles at detail auto.
            assert_eq!(t["pictures"].as_u64(), Some(i as u64 + 1));
            assert_eq!(t["image_tokens"].as_u64(), Some(255 * (i as u64 + 1)));
        }
    }
    // The second turn shows the first turn's picture again: refused.
    let tampered = dir.join("tampered");
    std::fs::create_dir_all(&tampered).unwrap();
    let first: std::cell::RefCell<Option<String>> = Default::default();
    let log = as_picture_log(&tampered, |s, turn, url| match (s, turn) {
        (0, 1) => {
            *first.borrow_mut() = Some(url.clone());
            url
        }
        (0, 2) => first.borrow().clone().unwrap(),
        _ => url,
    });
    let o = import(&log, &tampered.join("run"));
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("the picture at turn 2 is not the one this negotiator draws"), "{err}");
    assert!(err.lines().count() == 1, "one line: {err}");
}
