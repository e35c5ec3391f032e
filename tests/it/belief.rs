//! The belief probe end to end: `eval --probe belief` against
//! `serve --probe belief`, and the in-process ideal observer.

use crate::support::{Server, negotiator, scratch};
use negotiator::episode::{Episode, run_episode};
use negotiator::policy::PolicyKind;
use negotiator::scenario::{ScenarioConfig, ScenarioKind, Tier};
use serde_json::Value;
use std::path::Path;
use std::process::Command;

fn eval(base_url: &str, out: &Path, run_name: &str, args: &[&str]) -> Command {
    let mut c = crate::support::eval_command(base_url, "scripted", out, run_name);
    c.args(["--quiet", "-c", "8"]).args(args);
    c
}

fn ok(c: Command) {
    crate::support::ok(c);
}

fn lines(dir: &Path) -> Vec<Value> {
    crate::support::jsonl(&dir.join("rollouts.jsonl"))
}

fn summary_cells(dir: &Path) -> Vec<Value> {
    let s: Value = serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    s["cells"].as_array().unwrap().clone()
}

fn key(line: &Value) -> (ScenarioKind, Tier, u64) {
    let kind: ScenarioKind = line["scenario"].as_str().unwrap().parse().unwrap();
    let tier: Tier = line["tier"].as_u64().unwrap().to_string().parse().unwrap();
    (kind, tier, line["seed"].as_u64().unwrap())
}

/// The truth a belief is scored against: 1 when the other road user lets
/// the ego pass first.
fn lets_pass(disposition: &str) -> f64 {
    match disposition {
        "yielder" | "feinter" | "makes_room" => 1.0,
        "committed" | "crosser" => 0.0,
        other => panic!("unknown disposition {other}"),
    }
}

#[test]
fn eval_against_the_served_expert_reproduces_the_ideal_observer_exactly() {
    let server = Server::start(&["--policy", "expert", "--probe", "belief", "--probe-seeds", "0..20"]);
    let out = scratch("belief-expert");
    ok(eval(&server.base_url(), &out, "run", &["--probe", "belief", "--scenario", "all", "--tier", "all", "-n", "6"]));
    let lines = lines(&out.join("run"));
    assert_eq!(lines.len(), 6 * crate::support::cells());
    let mut noisy_turns_between = 0;
    for line in &lines {
        let (kind, tier, seed) = key(line);
        for turn in line["turns"].as_array().unwrap() {
            assert!(turn.get("belief_error").is_none(), "{turn}");
            assert_eq!(turn["belief"], turn["ideal_belief"], "{kind} t{tier} seed {seed} turn {}", turn["turn"]);
            let b = turn["belief"].as_f64().unwrap();
            // Noiseless tiers only know 0.5, 0 or 1 exactly.
            noisy_turns_between += usize::from(b > 1e-9 && b < 0.49 || b > 0.51 && b < 1.0 - 1e-9);
        }
        let m = &line["belief"];
        assert_eq!(m["brier_before"], m["ideal_brier_before"], "{kind} t{tier} seed {seed}");
        assert_eq!(m["brier_after"], m["ideal_brier_after"], "{kind} t{tier} seed {seed}");
        assert_eq!(m["probe_errors"], 0);
        // Replaying the recorded actions in process gives the recorded
        // ideal observer, bit for bit.
        let mut episode = Episode::new(&ScenarioConfig::builtin(kind), tier, seed);
        for turn in line["turns"].as_array().unwrap() {
            assert_eq!(turn["ideal_belief"].as_f64().unwrap(), episode.ideal_belief(), "{kind} t{tier} seed {seed}");
            episode.step(serde_json::from_value(turn["action"].clone()).unwrap());
        }
        assert!(episode.is_done());
    }
    // Only the noise tier has beliefs strictly between the certainties.
    assert!(noisy_turns_between > 0);
    // The report has the belief table, both belief figures and the beliefs
    // in the drill-down.
    let rep = out.join("report");
    let status = negotiator().args(["report", "--quiet", "--out"]).arg(&rep).arg(out.join("run")).status().unwrap();
    assert!(status.success());
    let csv = std::fs::read_to_string(rep.join("belief.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + crate::support::cells(), "{csv}");
    assert!(csv.lines().next().unwrap().contains("brier_before"), "{csv}");
    for plot in ["belief_reliability", "belief_over_time"] {
        let svg = std::fs::read_to_string(rep.join(format!("plots/{plot}.svg"))).unwrap();
        assert!(!svg.contains("NaN"), "{plot}");
    }
    let over_time = std::fs::read_to_string(rep.join("plots/belief_over_time.svg")).unwrap();
    assert!(over_time.contains("evidence turn") && over_time.contains("ideal observer"));
    let html = std::fs::read_to_string(rep.join("report.html")).unwrap();
    assert!(html.contains("\"p\":true") && html.contains("\"ib\":"), "drill-down beliefs");
    // Paper style: the belief figures too print at 8 pt or more, untitled, each with its PDF, and render in
    // headless Chromium with every text inside the figure.
    let paper = out.join("report-paper");
    let status = negotiator()
        .args(["report", "--quiet", "--style", "paper", "--out"])
        .arg(&paper)
        .arg(out.join("run"))
        .status()
        .unwrap();
    assert!(status.success());
    let figures = crate::report::paper_style_figures(&rep.join("plots"), &paper.join("plots"));
    assert!(figures.iter().any(|(style, name, _)| *style == "paper" && name == "belief_over_time"));
    let chromium = Path::new("/usr/bin/chromium");
    if crate::support::tool_available(chromium.exists(), "chromium (/usr/bin/chromium) for the belief figures") {
        crate::report::render_figures(chromium, &out, &figures);
    }
    for cell in summary_cells(&out.join("run")) {
        let b = &cell["belief"];
        for (stated, ideal) in [("brier_before", "ideal_brier_before"), ("brier_after", "ideal_brier_after")] {
            assert_eq!(b[stated], b[ideal], "{cell}");
        }
        assert_eq!(b["probe_error_rate"], 0.0);
    }
}

/// Turns of episodes where the other does not let the ego pass while its
/// bluff stands, and how many of them the policy stated a belief of at
/// least 0.9. A car's bluff stands until the evidence turn; the crosswalk's
/// tier-3 crosser bluffs after its tell (where it stopped): it stands paused
/// at the kerb, at rest in the scene, until it darts.
fn confident_and_wrong(lines: &[Value]) -> (usize, usize) {
    let (mut turns, mut confident) = (0, 0);
    for line in lines.iter().filter(|l| lets_pass(l["disposition"].as_str().unwrap()) == 0.0) {
        let evidence = line["evidence_turn"].as_u64().unwrap_or(u64::MAX);
        let bluffing = |t: &Value| {
            if line["scenario"] == "pedestrian_feint" {
                let scene = t["scene"].as_str().unwrap();
                scene.lines().any(|l| l.starts_with("Pedestrian: ") && l.ends_with("velocity 0.0 m/s"))
            } else {
                t["turn"].as_u64().unwrap() < evidence
            }
        };
        for turn in line["turns"].as_array().unwrap().iter().filter(|t| bluffing(t)) {
            turns += 1;
            confident += usize::from(turn["belief"].as_f64().unwrap() >= 0.9);
        }
    }
    (turns, confident)
}

#[test]
fn the_served_cue_follower_is_confidently_wrong_before_a_bluff_resolves() {
    let server = Server::start(&["--policy", "cue_follower", "--probe", "belief"]);
    let out = scratch("belief-cue");
    ok(eval(&server.base_url(), &out, "run", &["--probe", "belief", "--scenario", "all", "--tier", "1,3", "-n", "30"]));
    let lines = lines(&out.join("run"));
    for kind in ScenarioKind::ALL {
        let of = |tier: u64| -> Vec<Value> {
            lines.iter().filter(|l| l["scenario"] == kind.name() && l["tier"] == tier).cloned().collect()
        };
        let (turns, confident) = confident_and_wrong(&of(3));
        assert!(turns > 0, "{kind}");
        // The bluff reads as giving way: the cue follower is sure of it.
        assert!(confident * 2 > turns, "{kind} tier 3: {confident} of {turns} turns confidently wrong");
        // And its Brier score before the evidence is far worse than the
        // ideal observer's 0.25.
        let cell = summary_cells(&out.join("run"))
            .into_iter()
            .find(|c| c["scenario"] == kind.name() && c["tier"] == 3)
            .unwrap();
        assert_eq!(cell["belief"]["ideal_brier_before"], 0.25);
        assert!(cell["belief"]["brier_before"].as_f64().unwrap() > 0.35, "{cell}");
    }
}

#[test]
fn the_served_random_policy_has_a_flat_reliability_diagram() {
    let server = Server::start(&["--policy", "random", "--probe", "belief", "--seed", "4"]);
    let out = scratch("belief-random");
    ok(eval(&server.base_url(), &out, "run", &["--probe", "belief", "--scenario", "all", "--tier", "1", "-n", "40"]));
    let lines = lines(&out.join("run"));
    // Pool every cell's diagram: the observed frequency is the base rate in
    // every bin, whatever the belief.
    let (mut n, mut pos) = ([0u64; 10], [0u64; 10]);
    for line in &lines {
        let m = &line["belief"];
        for i in 0..10 {
            n[i] += m["bin_turns"][i].as_u64().unwrap();
            pos[i] += m["bin_positive"][i].as_u64().unwrap();
        }
    }
    let base = pos.iter().sum::<u64>() as f64 / n.iter().sum::<u64>() as f64;
    for i in 0..10 {
        assert!(n[i] >= 100, "bin {i}: {} turns", n[i]);
        let observed = pos[i] as f64 / n[i] as f64;
        assert!((observed - base).abs() < 0.12, "bin {i}: observed {observed:.3}, base rate {base:.3}");
    }
}

#[test]
fn a_probe_run_is_its_own_run_and_a_missing_belief_never_touches_the_action() {
    // A server that does not answer the probe: every belief is missing.
    let server = Server::start(&["--policy", "expert"]);
    let out = scratch("belief-missing");
    let args = ["--scenario", "yield_standoff", "--tier", "3", "-n", "4"];
    ok(eval(&server.base_url(), &out, "probe", &[&["--probe", "belief"][..], &args].concat()));
    ok(eval(&server.base_url(), &out, "plain", &args));
    let sorted = |mut v: Vec<Value>| {
        v.sort_by_key(|l| l["seed"].as_u64());
        v
    };
    let (probe, plain) = (sorted(lines(&out.join("probe"))), sorted(lines(&out.join("plain"))));
    assert_eq!(probe.len(), 4);
    for (a, b) in probe.iter().zip(&plain) {
        assert_eq!((&a["outcome"], &a["reward"], &a["seed"]), (&b["outcome"], &b["reward"], &b["seed"]));
        assert_eq!(a["parse_error_turns"], 0);
        assert_eq!(a["belief"]["probe_errors"], a["turns_taken"]);
        assert!(b.get("belief").is_none());
        for t in a["turns"].as_array().unwrap() {
            assert_eq!(t["belief_error"]["kind"], "missing");
        }
    }
    let cell = &summary_cells(&out.join("probe"))[0];
    assert_eq!(cell["belief"]["probe_error_rate"], 1.0);
    let probe_run: Value = serde_json::from_str(&std::fs::read_to_string(out.join("probe/run.json")).unwrap()).unwrap();
    let plain_run: Value = serde_json::from_str(&std::fs::read_to_string(out.join("plain/run.json")).unwrap()).unwrap();
    assert_eq!(probe_run["config"]["probe"], "belief");
    assert!(plain_run["config"].get("probe").is_none());
    assert_ne!(probe_run["config"]["prompt_hash"], plain_run["config"]["prompt_hash"]);
    assert_ne!(probe_run["config_hash"], plain_run["config_hash"]);
    // A report of runs without the probe has no belief table.
    let rep = out.join("report-plain");
    let status = negotiator().args(["report", "--quiet", "--out"]).arg(&rep).arg(out.join("plain")).status().unwrap();
    assert!(status.success());
    assert!(!rep.join("belief.csv").exists());
    assert!(!rep.join("plots/belief_reliability.svg").exists());
    // Resuming the probe run without the probe is refused, naming it.
    let refused = eval(&server.base_url(), &out, "probe", &args).output().unwrap();
    assert!(!refused.status.success());
    let err = String::from_utf8_lossy(&refused.stderr);
    assert!(err.contains("probe"), "{err}");
}

#[test]
fn the_ideal_observer_is_a_half_until_the_evidence_then_certain_and_calibrated_under_noise() {
    let set = negotiator::scenario::ScenarioSet::default();
    for kind in ScenarioKind::ALL {
        for tier in Tier::ALL {
            let noisy = kind == ScenarioKind::ContestedMerge && tier == Tier::T2;
            for seed in 0..40 {
                let record = run_episode(set.get(kind), tier, seed, PolicyKind::Expert.build().as_mut());
                let truth = f64::from(u8::from(record.disposition.ego_should_go()));
                let evidence = record.timing.evidence_turn.unwrap_or(u32::MAX);
                for d in &record.decisions {
                    if noisy {
                        assert!((0.0..=1.0).contains(&d.ideal_belief));
                    } else if d.turn < evidence {
                        assert_eq!(d.ideal_belief, 0.5, "{kind} t{tier} seed {seed} turn {}", d.turn);
                    } else {
                        assert_eq!(d.ideal_belief, truth, "{kind} t{tier} seed {seed} turn {}", d.turn);
                    }
                }
            }
        }
    }
    // Under noise the ideal observer is a posterior: calibrated, and ever
    // closer to the truth. Pool every turn of many episodes.
    let config = set.get(ScenarioKind::ContestedMerge);
    let (mut n, mut pos, mut sum) = ([0u32; 5], [0u32; 5], [0.0f64; 5]);
    let mut final_error = 0.0;
    let episodes = 300;
    for seed in 0..episodes {
        let mut ep = Episode::new(config, Tier::T2, seed);
        let mut expert = PolicyKind::Expert.build();
        let truth = ep.disposition().ego_should_go();
        let mut last = 0.5;
        while !ep.is_done() {
            last = ep.ideal_belief();
            let i = ((last * 5.0) as usize).min(4);
            n[i] += 1;
            pos[i] += u32::from(truth);
            sum[i] += last;
            let action = expert.act(ep.observation());
            ep.step(action);
        }
        final_error += (last - f64::from(u8::from(truth))).abs();
    }
    for i in 0..5 {
        if n[i] >= 200 {
            let (mean, observed) = (sum[i] / f64::from(n[i]), f64::from(pos[i]) / f64::from(n[i]));
            assert!(
                (mean - observed).abs() < 0.08,
                "bin {i}: mean belief {mean:.3}, observed {observed:.3}, n {}",
                n[i]
            );
        }
    }
    assert!(n[0] + n[4] > 0 && n[1] + n[2] + n[3] > 0, "{n:?}");
    assert!(final_error / (episodes as f64) < 0.1, "mean final error {}", final_error / episodes as f64);
}
