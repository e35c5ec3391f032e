//! `negotiator report`: the report's own logic on constructed runs (merge,
//! duplicate episodes, shards, pass^k exclusion, paired comparison, a
//! leaderboard snapshot), then end to end on small runs made with `serve`
//! and `eval`, including the offline HTML rendered by headless Chromium,
//! and the paper style's figures (text size at print width, titles, PDFs).

use crate::support::{Server, negotiator, scratch};
use negotiator::episode::Outcome;
use negotiator::export::Format;
use negotiator::report::reference::{ReferenceCell, References};
use negotiator::report::{self, ReportError, ReportOptions, load};
use negotiator::rundir::record::RolloutRecord;
use negotiator::rundir::{
    Endpoint, HistoryWindow, Invocation, RunConfig, RunInfo, RunStatus, SCHEMA_VERSION, Selection, Settings, Totals,
    write_run_info,
};
use negotiator::scenario::{ScenarioKind, Tier};
use negotiator::stats::mcnemar_exact;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

// ---------------------------------------------------------------------------
// Constructed runs

/// One episode line as `eval` writes it (full record, two turns).
fn line(model: &str, hash: &str, s: ScenarioKind, tier: u8, seed: u64, rollout: u32, outcome: Outcome) -> String {
    let success = outcome == Outcome::Success;
    let turn = |t: u32| {
        json!({"turn": t, "scene": format!("Scenario: {s}\nTime: {}\n", f64::from(t - 1) * 0.5),
               "reply": "{\"maneuver\":\"proceed\"}", "finish_reason": "stop",
               "action": {"maneuver": "proceed", "acceleration": 1.0, "steering": 0.0},
               "parse_errors": [], "usage": null, "tokens": 100, "latency_ms": 20, "attempts": 1,
               "after_resolution": false})
    };
    let v = json!({
        "model": model, "config_hash": hash, "scenario": s, "tier": tier, "seed": seed, "rollout": rollout,
        "disposition": s.dispositions()[(seed % 2) as usize], "outcome": outcome,
        "reward": if success { 0.9 } else { -1.0 }, "decision_correctness": if seed.is_multiple_of(3) { 0.5 } else { 1.0 },
        "diagnostics": {"min_ttc_s": null, "min_gap_m": 1.0, "hard_brakes": 0, "right_of_way_violations": 0,
            "time_to_goal_s": null, "free_flow_time_s": 5.0, "efficiency": 0.0, "progress": 0.5,
            "peak_accel_mps2": 3.0, "peak_decel_mps2": 0.0, "peak_jerk_mps3": 0.0, "comfort": 1.0,
            "decisions": 2, "duration_s": 1.0},
        "turns_taken": 2, "parse_error_turns": 0, "tokens": 200, "prompt_tokens": 180, "completion_tokens": 20,
        "latency_ms": 40, "retries": 0, "wall_ms": 50, "finished_at": "2026-01-01T00:00:00Z",
        "turns": [turn(1), turn(2)],
        "trajectory": [{"time_s": 0.0, "agents": [{"x": 0.0, "y": -40.0, "v": 10.0}, {"x": -40.0, "y": 0.0, "v": 10.0}]},
                       {"time_s": 0.5, "agents": [{"x": 0.0, "y": -35.0, "v": 10.0}, {"x": -35.0, "y": 0.0, "v": 9.0}]}]
    });
    // The line is a real record.
    serde_json::from_value::<RolloutRecord>(v.clone()).expect("a complete record");
    format!("{v}\n")
}

/// The DOM headless Chromium leaves after loading `url` and running its
/// scripts.
fn dump_dom(chromium: &Path, profile: &Path, url: &str) -> String {
    let out = Command::new(chromium)
        .args(["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking"])
        .args(["--disable-component-update", "--disable-sync", "--no-first-run", "--dump-dom"])
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg(url)
        .output()
        .unwrap();
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// A run directory: run.json (config for `model`, selection) and lines.
struct RunSpec<'a> {
    model: &'a str,
    temperature: Option<f64>,
    seeds: u64,
    rollouts: u32,
    shard: &'a str,
    scenarios: &'a [ScenarioKind],
}

fn config(model: &str, temperature: Option<f64>) -> RunConfig {
    let mut params = serde_json::Map::new();
    if let Some(t) = temperature {
        params.insert("temperature".into(), json!(t));
    }
    RunConfig {
        model: model.into(),
        request_params: params,
        history: HistoryWindow::Full,
        prompt_hash: "p".into(),
        scenarios_hash: "s".into(),
        endpoint: String::new(),
        probe: Default::default(),
        human: None,
        pictures: None,
    }
}

fn write_run(dir: &Path, spec: &RunSpec, lines: &[String]) {
    std::fs::create_dir_all(dir).unwrap();
    let cfg = config(spec.model, spec.temperature);
    let info = RunInfo {
        schema_version: SCHEMA_VERSION,
        run_name: dir.file_name().unwrap().to_string_lossy().into(),
        config_hash: cfg.hash(),
        config: cfg,
        crate_version: "0".into(),
        git_revision: "unknown".into(),
        started_at: "t".into(),
        ended_at: None,
        invocations: 1,
        last_invocation: Invocation {
            started_at: "t".into(),
            ended_at: None,
            status: RunStatus::Finished,
            selection: Selection {
                base_seed: 0,
                rollouts: spec.rollouts,
                scenarios: spec.scenarios.to_vec(),
                seeds: spec.seeds,
                shard: spec.shard.parse().unwrap(),
                tiers: vec![Tier::T1],
            },
            endpoint: Endpoint::default(),
            settings: Settings::default(),
            episodes: lines.len() as u64,
            infra_errors: 0,
            retries: 0,
            tokens: 0,
            turns: 0,
            cost_usd: None,
            wall_s: 0.0,
        },
        totals: Totals::default(),
        pricing: None,
        imported_from: None,
    };
    write_run_info(dir, &info).unwrap();
    std::fs::write(dir.join("rollouts.jsonl"), lines.concat()).unwrap();
}

fn hash(model: &str, temperature: Option<f64>) -> String {
    config(model, temperature).hash()
}

fn spec(model: &str) -> RunSpec<'_> {
    RunSpec {
        model,
        temperature: None,
        seeds: 10,
        rollouts: 1,
        shard: "1/1",
        scenarios: &[ScenarioKind::YieldStandoff],
    }
}

fn load_dirs(dirs: &[PathBuf]) -> Result<load::Dataset, ReportError> {
    load::load(&load::resolve_dirs(dirs)?)
}

fn refs() -> References {
    let cell = |s: ScenarioKind, policy: &str, success: f64| ReferenceCell {
        scenario: s,
        tier: Tier::T1,
        policy: policy.into(),
        n: 200,
        success,
        success_lo: success,
        success_hi: success,
        decision_correctness: success,
        // The expert never guesses and commits 2.5 turns after the evidence.
        guess_rate: (policy == "expert").then_some(0.0),
        evidence_lag: (policy == "expert").then_some(2.5),
    };
    References {
        source: "test references".into(),
        cells: ScenarioKind::ALL
            .into_iter()
            .flat_map(|s| [cell(s, "expert", 1.0), cell(s, "always_proceed", 0.5)])
            .collect(),
    }
}

fn opts() -> ReportOptions {
    ReportOptions { transcripts_per_cell: 2, ..ReportOptions::default() }
}

#[test]
fn the_same_episode_twice_is_an_error_naming_it() {
    let root = scratch("report-dup");
    let h = hash("m", None);
    let ys = ScenarioKind::YieldStandoff;
    let a: Vec<String> = (0..5).map(|s| line("m", &h, ys, 1, s, 0, Outcome::Success)).collect();
    let b: Vec<String> = (4..8).map(|s| line("m", &h, ys, 1, s, 0, Outcome::Success)).collect();
    write_run(&root.join("a"), &spec("m"), &a);
    write_run(&root.join("b"), &spec("m"), &b);
    let err = load_dirs(&[root.join("a"), root.join("b")]).unwrap_err();
    let msg = err.to_string();
    assert!(matches!(err, ReportError::DuplicateEpisode { .. }), "{msg}");
    assert!(msg.contains("yield_standoff tier 1 seed 4 rollout 0") && msg.contains("model 'm'"), "{msg}");
    assert!(msg.contains("a/rollouts.jsonl line 5") && msg.contains("b/rollouts.jsonl line 1"), "{msg}");
    // Within one file too.
    let mut twice = a.clone();
    twice.push(a[2].clone());
    write_run(&root.join("c"), &spec("m"), &twice);
    let msg = load_dirs(&[root.join("c")]).unwrap_err().to_string();
    assert!(msg.contains("seed 2 rollout 0") && msg.contains("line 3") && msg.contains("line 6"), "{msg}");
    // The CLI: one line, exit 2.
    let out = negotiator()
        .args(["report", "-q", "--out"])
        .arg(root.join("out"))
        .arg(root.join("a"))
        .arg(root.join("b"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(stderr.contains("duplicate episode (yield_standoff tier 1 seed 4 rollout 0)"), "{stderr}");
    // The same directory twice.
    let msg = load_dirs(&[root.join("a"), root.join("a")]).unwrap_err().to_string();
    assert!(msg.contains("given twice"), "{msg}");
}

#[test]
fn shards_of_one_config_are_joined_and_other_configs_kept_apart() {
    let root = scratch("report-shards");
    let h = hash("m", None);
    let ys = ScenarioKind::YieldStandoff;
    let shard = |k: u64| -> Vec<String> {
        (0..10).filter(|s| s % 2 == k).map(|s| line("m", &h, ys, 1, s, 0, Outcome::Success)).collect()
    };
    write_run(&root.join("s1"), &RunSpec { shard: "1/2", ..spec("m") }, &shard(0));
    // Shard 2 lost seed 9 (e.g. an infrastructure error).
    let mut second = shard(1);
    second.pop();
    write_run(&root.join("s2"), &RunSpec { shard: "2/2", ..spec("m") }, &second);
    let h7 = hash("m", Some(0.7));
    let warm: Vec<String> = (0..10).map(|s| line("m", &h7, ys, 1, s, 0, Outcome::Collision)).collect();
    write_run(&root.join("warm"), &RunSpec { temperature: Some(0.7), ..spec("m") }, &warm);
    // A directory of run directories expands to them.
    let data = load_dirs(std::slice::from_ref(&root)).unwrap();
    assert_eq!(data.runs.len(), 3);
    assert_eq!(data.models.len(), 2);
    let joined = data.models.iter().find(|m| m.config_hash == h).unwrap();
    assert_eq!(joined.runs.len(), 2);
    assert_eq!(joined.episodes.len(), 9);
    assert_eq!(joined.missing(), Some(1));
    assert!(joined.episodes.windows(2).all(|w| w[0].key() < w[1].key()));
    // Two configurations of one model id are told apart by their hash.
    let labels: Vec<&str> = data.models.iter().map(|m| m.label.as_str()).collect();
    assert!(labels.contains(&format!("m ({})", &h[..8]).as_str()), "{labels:?}");
    assert!(labels.contains(&format!("m ({})", &h7[..8]).as_str()), "{labels:?}");
    let built = report::build_from(data, refs(), &opts()).unwrap();
    let costs = &built.report.costs;
    // The complete configuration ranks first; the joined one lacks seed 9.
    assert_eq!(costs.iter().map(|c| c.missing).collect::<Vec<_>>(), vec![Some(0), Some(1)]);
}

#[test]
fn pass_k_counts_only_seeds_with_every_rollout() {
    let root = scratch("report-passk");
    let h = hash("m", None);
    let ys = ScenarioKind::YieldStandoff;
    let (s, f) = (Outcome::Success, Outcome::Timeout);
    let lines = vec![
        // seed 0: 2 of 3; seed 1: 3 of 3; seed 2: 1 of 3; seed 3: only 2 rollouts (excluded).
        line("m", &h, ys, 1, 0, 0, s),
        line("m", &h, ys, 1, 0, 1, f),
        line("m", &h, ys, 1, 0, 2, s),
        line("m", &h, ys, 1, 1, 0, s),
        line("m", &h, ys, 1, 1, 1, s),
        line("m", &h, ys, 1, 1, 2, s),
        line("m", &h, ys, 1, 2, 0, f),
        line("m", &h, ys, 1, 2, 1, f),
        line("m", &h, ys, 1, 2, 2, s),
        line("m", &h, ys, 1, 3, 0, s),
        line("m", &h, ys, 1, 3, 2, s),
    ];
    write_run(&root.join("r3"), &RunSpec { seeds: 4, rollouts: 3, ..spec("m") }, &lines);
    let data = load_dirs(&[root.join("r3")]).unwrap();
    assert_eq!((data.models[0].rollouts, data.models[0].missing()), (3, Some(1)));
    let built = report::build_from(data, refs(), &opts()).unwrap();
    let rows = &built.report.pass_k;
    let all = rows.iter().find(|r| r.scope == "all").unwrap();
    assert_eq!((all.r, all.seeds, all.excluded), (3, 3, 1));
    let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
    // pass^1 = mean(2/3, 1, 1/3); pass^2 = mean(1/3, 1, 0); pass^3 = mean(0, 1, 0).
    assert!(close(all.pass[0], 2.0 / 3.0) && close(all.pass[1], 4.0 / 9.0) && close(all.pass[2], 1.0 / 3.0), "{all:?}");
    let table = built.report.render_table("pass_k", Format::Table).unwrap();
    // Seed 3 lacks a rollout, so the model is incomplete (marked).
    assert!(
        table.contains("seeds excluded") && table.contains("m \u{2020}    all             3  3           1"),
        "{table}"
    );
    // One model: no (empty) paired table, on the terminal or anywhere.
    assert!(built.report.render_table("paired", Format::Table).is_none());
    // The leaderboard's unit is the seed: success = mean over seeds of the rollout rates.
    let lb = &built.report.leaderboard.rows[0];
    let expected = (2.0 / 3.0 + 1.0 + 1.0 / 3.0 + 1.0) / 4.0;
    assert!(close(lb.scenarios[0].as_ref().unwrap().success.estimate, expected));
}

/// One model's run of yield_standoff tier 1 over `seeds` seeds: a success
/// where `wins`, else `loss`.
fn write_wins(root: &Path, model: &str, seeds: u64, wins: &dyn Fn(u64) -> bool, loss: Outcome) {
    let h = hash(model, None);
    let lines: Vec<String> = (0..seeds)
        .map(|s| line(model, &h, ScenarioKind::YieldStandoff, 1, s, 0, if wins(s) { Outcome::Success } else { loss }))
        .collect();
    write_run(&root.join(model), &RunSpec { seeds, ..spec(model) }, &lines);
}

#[test]
fn paired_comparison_on_a_constructed_pair() {
    let root = scratch("report-paired");
    let run = |model: &str, wins: &dyn Fn(u64) -> bool, seeds: u64| {
        write_wins(&root, model, seeds, wins, Outcome::Collision);
    };
    // Shared seeds 0..40: A wins 0..30; B wins 0..22 and 35..37. B has 10 extra seeds it wins.
    run("a", &|s| s < 30, 40);
    run("b", &|s| s < 22 || (35..37).contains(&s) || s >= 40, 50);
    let data = load_dirs(&[root.join("a"), root.join("b")]).unwrap();
    let built = report::build_from(data, refs(), &opts()).unwrap();
    let p = &built.report.paired[0];
    // a ranks first (0.75 against b's 0.68 over its 50 seeds).
    assert_eq!((p.a.as_str(), p.b.as_str(), p.keys), ("a", "b", 40), "{p:?}");
    // a - b over the shared keys only: successes 30 vs 24 of 40.
    assert!((p.diff.estimate - (30.0 - 24.0) / 40.0).abs() < 1e-12);
    assert_eq!((p.success_a, p.success_b), (0.75, 0.6));
    assert_eq!((p.a_only, p.b_only), (8, 2));
    assert_eq!(p.mcnemar_p, mcnemar_exact(8, 2));
    assert!(p.diff.lo < p.diff.estimate && p.diff.estimate < p.diff.hi);
    // McNemar p = 2 P(X <= 2 | 10, 1/2) = 0.109: whatever the CI says, no significant difference, and the
    // verdict names its 40 keys and its 10 discordant pairs.
    assert!(p.mcnemar_p > 0.05);
    assert!(p.verdict.starts_with("no significant difference"), "{p:?}");
    assert!(p.verdict.ends_with("(40 keys, only 10 discordant)"), "{p:?}");
    assert!(!p.significant);
    // Power: p10 = 8/40, p01 = 2/40 -> psi 0.25, delta 0.15:
    // (1.96 * 0.5 + 0.8416 * sqrt(0.2275))^2 / 0.0225 = 84.8 -> 85 keys, over 1 cell.
    assert_eq!(p.seeds_for_power, Some(85));
    // A clear gap is not tied.
    let root2 = scratch("report-paired2");
    let run2 = |model: &str, wins: &dyn Fn(u64) -> bool| write_wins(&root2, model, 60, wins, Outcome::Timeout);
    run2("strong", &|s| s < 55);
    run2("weak", &|s| s < 20);
    let built = report::build_from(load_dirs(std::slice::from_ref(&root2)).unwrap(), refs(), &opts()).unwrap();
    let p = &built.report.paired[0];
    assert_eq!((p.a_only, p.b_only, p.verdict.as_str()), (35, 0, "strong better (60 keys)"));
    assert!(p.diff.lo > 0.0 && p.mcnemar_p < 1e-9);
    assert_eq!((p.significant, p.seeds_for_power), (true, None));

    // A CI that excludes 0 with an exact test that does not: 4 discordant pairs of 200, all one way.
    // +0.02 [+0.005, +0.04] but McNemar p = 2/16 = 0.125: no significant difference.
    let root3 = scratch("report-paired3");
    let run3 = |model: &str, wins: &dyn Fn(u64) -> bool| write_wins(&root3, model, 200, wins, Outcome::Timeout);
    run3("hi", &|s| s < 104);
    run3("lo", &|s| s < 100);
    let built = report::build_from(load_dirs(std::slice::from_ref(&root3)).unwrap(), refs(), &opts()).unwrap();
    let p = &built.report.paired[0];
    assert_eq!((p.a_only, p.b_only), (4, 0));
    assert!((p.mcnemar_p - 0.125).abs() < 1e-12);
    assert!(p.diff.lo > 0.0, "the bootstrap CI alone would call it: {p:?}");
    assert_eq!(p.verdict, "no significant difference: CI and McNemar disagree (200 keys, only 4 discordant)");
    // p10 = 0.02, p01 = 0: (1.96 sqrt(0.02) + 0.8416 sqrt(0.0196))^2 / 0.0004 = 390.1 -> 391.
    assert_eq!(p.seeds_for_power, Some(391));
    let table = built.report.render_table("paired", Format::Table).unwrap();
    assert!(
        table.contains("seeds for 80% power") && table.trim_end().lines().nth(3).unwrap().ends_with(" 391"),
        "{table}"
    );
}

/// `line` with the evidence and commitment turns set.
fn timed_line(
    model: &str,
    s: ScenarioKind,
    seed: u64,
    outcome: Outcome,
    evidence: Option<u32>,
    commit: Option<u32>,
) -> String {
    let mut v: Value = serde_json::from_str(&line(model, &hash(model, None), s, 1, seed, 0, outcome)).unwrap();
    v["evidence_turn"] = json!(evidence);
    v["commitment_turn"] = json!(commit);
    v["choice"] = json!(commit.map(|_| "go"));
    format!("{v}\n")
}

#[test]
fn evidence_timing_known_answer_and_overplotted_points_counted() {
    let root = scratch("report-timing");
    let ys = ScenarioKind::YieldStandoff;
    // Seeds 0-2 commit at turn 1 before the evidence at 3 (guesses); seed 3
    // commits with no evidence at all (a guess); seeds 4-7 commit 0, 1, 2,
    // 3 turns after the evidence at 2 (lag 1.5); seeds 8-9 never commit
    // (out of the guess rate). Guess rate 4 / 8 = 0.5. Seeds 0-4 succeed.
    let timing = |seed: u64| match seed {
        0..=2 => (Some(3), Some(1)),
        3 => (None, Some(2)),
        4..=7 => (Some(2), Some(2 + seed as u32 - 4)),
        _ => (Some(2), None),
    };
    for model in ["a", "b"] {
        let lines: Vec<String> = (0..10u64)
            .map(|seed| {
                let o = if seed < 5 { Outcome::Success } else { Outcome::Timeout };
                let (e, c) = timing(seed);
                timed_line(model, ys, seed, o, e, c)
            })
            .collect();
        write_run(&root.join(model), &spec(model), &lines);
    }
    let built = report::build_from(load_dirs(std::slice::from_ref(&root)).unwrap(), refs(), &opts()).unwrap();
    let r = &built.report.timing;
    assert_eq!(r.len(), 2);
    let a = &r[0];
    assert_eq!((a.episodes, a.committed, a.guesses), (10, 8, 4));
    assert!((a.guess_rate.estimate - 0.5).abs() < 1e-12, "{a:?}");
    assert!(a.guess_rate.lo < 0.5 && a.guess_rate.hi > 0.5);
    assert!((a.evidence_lag - 1.5).abs() < 1e-12);
    assert!((a.success - 0.5).abs() < 1e-12);
    assert_eq!((a.expert_guess_rate, a.expert_evidence_lag), (Some(0.0), Some(2.5)));
    let csv = built.report.render_table("timing", Format::Csv).unwrap();
    let header = csv.lines().next().unwrap();
    assert_eq!(
        header,
        "model,scenario,episodes,committed,guess_rate,guess_rate_lo,guess_rate_hi,expert_guess_rate,evidence_lag,\
         expert_evidence_lag,success"
    );
    assert!(csv.lines().nth(1).unwrap().starts_with("a,yield_standoff,10,8,0.5"), "{csv}");
    let plot = |name: &str| built.report.plots.iter().find(|p| p.name == name).unwrap_or_else(|| panic!("{name}"));
    let timing_svg = &plot("evidence_timing").svg;
    assert!(timing_svg.contains("a: guess rate 0.50 (4 of 8 committed)"));
    assert!(timing_svg.contains("a: lag 1.50 turns"));
    assert!(plot("success_vs_guess_rate").svg.contains("a on yield_standoff: success 0.50, guess rate 0.50"));
    // The two models coincide on success vs correctness: translucent,
    // jittered apart, counted; the diagonal's label is off the data.
    let svg = &plot("success_vs_correctness").svg;
    assert!(svg.contains("<g fill-opacity=\"0.7\">"));
    assert!(svg.contains(">\u{d7}2</text>"), "{svg}");
    assert!(!svg.contains(">\u{d7}3</text>"));
    assert!(!svg.contains("rotate(-45"));
    let point = |model: &str| {
        let at = svg.find(&format!("<title>{model} on yield_standoff")).unwrap();
        let start = svg[..at].rfind('<').unwrap();
        svg[start..at].to_string()
    };
    assert_ne!(point("a"), point("b"), "coinciding points are jittered apart");
}

#[test]
fn leaderboard_snapshot() {
    let root = scratch("report-snapshot");
    let (ys, pf, cm) = (ScenarioKind::YieldStandoff, ScenarioKind::PedestrianFeint, ScenarioKind::ContestedMerge);
    let make = |model: &str, rate: [u64; 3]| {
        let h = hash(model, None);
        let mut lines = Vec::new();
        for (k, s) in [ys, pf, cm].into_iter().enumerate() {
            for seed in 0..20u64 {
                let o = if (seed * 7 + k as u64) % 20 < rate[k] { Outcome::Success } else { Outcome::Timeout };
                lines.push(line(model, &h, s, 1, seed, 0, o));
            }
        }
        write_run(&root.join(model), &RunSpec { seeds: 20, scenarios: &[ys, pf, cm], ..spec(model) }, &lines);
    };
    make("alpha", [18, 12, 9]);
    make("beta", [20, 6, 10]);
    let built = report::build_from(load_dirs(std::slice::from_ref(&root)).unwrap(), refs(), &opts()).unwrap();
    let table = built.report.render_table("leaderboard", Format::Md).unwrap();
    insta::assert_snapshot!(table, @r"
    ### Success rates (tier 1; 95% percentile bootstrap CIs)

    | rank | model | avg. [95% CI] | yield_standoff [95% CI] | pedestrian_feint [95% CI] | contested_merge [95% CI] | yield DC | episodes |
    |---|---|---|---|---|---|---|---|
    | 1 | alpha | 0.65 [0.53, 0.78] | 0.90 [0.75, 1.00] | 0.60 [0.40, 0.80] | 0.45 [0.25, 0.65] | 0.82 | 60 |
    | 2 | beta | 0.60 [0.48, 0.73] | 1.00 [0.84, 1.00] | 0.30 [0.10, 0.50] | 0.50 [0.30, 0.70] | 0.82 | 60 |
    |  | expert reference | 1.00 | 1.00 | 1.00 | 1.00 | 1.00 |  |
    |  | always_proceed floor | 0.50 | 0.50 | 0.50 | 0.50 | 0.50 |  |

    Per-scenario CIs resample seeds (10000 resamples); the average's CI resamples seeds jointly across scenarios (clustered bootstrap). Yield DC: decision correctness on yield_standoff. Reference rows: test references.  
    A success of 0.00 or 1.00 (every seed the same) has a Wilson score interval over the seeds instead of the percentile bootstrap, which collapses to a point there.
    ");
}

/// A pedestrian_feint line whose pedestrian walks along plan y = -3 + t
/// (the ego along x): 7 points, 0.5 s apart.
fn pedestrian_line(model: &str, seed: u64, outcome: Outcome) -> String {
    let mut v: Value =
        serde_json::from_str(&line(model, &hash(model, None), ScenarioKind::PedestrianFeint, 1, seed, 0, outcome))
            .unwrap();
    let points: Vec<Value> = (0..7)
        .map(|i| {
            let t = f64::from(i) * 0.5;
            json!({"time_s": t, "agents": [{"x": -30.0 + 10.0 * t, "y": 0.0, "v": 10.0}, {"x": 0.0, "y": -3.0 + t, "v": 1.0}]})
        })
        .collect();
    v["trajectory"] = Value::Array(points);
    format!("{v}\n")
}

/// Attribute `name` of the SVG element starting at `at`.
fn attr<'a>(svg: &'a str, at: usize, name: &str) -> &'a str {
    let tag = &svg[at..at + svg[at..].find('>').unwrap()];
    let start = tag.find(&format!(" {name}=\"")).unwrap_or_else(|| panic!("no {name} in {tag}")) + name.len() + 3;
    &tag[start..start + tag[start..].find('"').unwrap()]
}

/// Every unrotated text of `svg` lies inside its viewBox width, at the
/// figures' width estimate (0.58 × font size per character).
fn assert_texts_fit(name: &str, svg: &str) {
    let view_box = svg.split("viewBox=\"").nth(1).unwrap();
    let width: f64 = view_box.split(' ').nth(2).unwrap().parse().unwrap();
    for (at, _) in svg.match_indices("<text ") {
        let tag = &svg[at..at + svg[at..].find('>').unwrap()];
        if tag.contains("transform=") {
            continue;
        }
        let body = &svg[at + tag.len() + 1..];
        let body = &body[..body.find("</text>").unwrap()];
        let body = body.rsplit("</title>").next().unwrap();
        let chars =
            body.replace("&amp;", "&").replace("&#39;", "'").replace("&lt;", "<").replace("&gt;", ">").chars().count();
        let (x, size): (f64, f64) = (attr(svg, at, "x").parse().unwrap(), attr(svg, at, "font-size").parse().unwrap());
        let w = chars as f64 * size * 0.58;
        let (left, right) = match attr(svg, at, "text-anchor") {
            "start" => (x, x + w),
            "middle" => (x - w / 2.0, x + w / 2.0),
            _ => (x - w, x),
        };
        assert!(left >= 0.0 && right <= width, "{name}: '{body}' spans {left:.0}..{right:.0} of {width}");
    }
}

#[test]
fn the_pedestrian_is_drawn_in_the_scene_texts_kerb_frame() {
    let root = scratch("report-kerb");
    let pf = ScenarioKind::PedestrianFeint;
    let lines: Vec<String> = (0..3).map(|seed| pedestrian_line("m", seed, Outcome::Timeout)).collect();
    write_run(&root.join("m"), &RunSpec { seeds: 3, scenarios: &[pf], ..spec("m") }, &lines);
    let built = report::build_from(load_dirs(std::slice::from_ref(&root)).unwrap(), refs(), &opts()).unwrap();
    let plot = built.report.plots.iter().find(|p| p.name == "trajectory_m_pedestrian_feint_t1_s0_r0").expect("figure");
    let svg = &plot.svg;
    // Its own panel: near kerb at 0, far kerb at 7, the in-path band 0.5-3.0, all in the kerb frame.
    let panel = &svg[svg.find("pedestrian in the ego&#39;s path (0.5–3.0 m)").expect("in-path band")..];
    let panel = &panel[..panel.find(", as the scene text gives it").expect("the panel's title")];
    let kerb_lines: Vec<f64> = panel
        .match_indices("<line ")
        .filter(|(i, _)| attr(panel, *i, "stroke-dasharray") == "4 3")
        .map(|(i, _)| attr(panel, i, "y1").parse().unwrap())
        .collect();
    let [near, far] = kerb_lines[..] else { panic!("two kerb lines: {kerb_lines:?}") };
    assert!(panel.contains(">near kerb</text>") && panel.contains(">far kerb</text>"), "{panel}");
    // Read the pedestrian's line back through the two kerbs: lateral = y + 1.75 at every point.
    let at = panel.find("<polyline ").expect("the pedestrian's line");
    let values: Vec<f64> = attr(panel, at, "points")
        .split(' ')
        .map(|p| p.split(',').nth(1).unwrap().parse::<f64>().unwrap())
        .map(|py| (py - near) / (far - near) * 7.0)
        .collect();
    assert_eq!(values.len(), 7);
    for (i, v) in values.iter().enumerate() {
        let expected = -3.0 + f64::from(i as u32) * 0.5 + 1.75;
        assert!((v - expected).abs() < 0.01, "point {i}: {v} vs {expected}");
    }
    assert_texts_fit(&plot.name, svg);
    // The ego's position panel does not share its axis with the pedestrian any more.
    assert!(svg.contains(">ego position (m)</text>"), "{svg}");
    assert!(plot.caption.contains("pedestrian has its own panel in the scene text's frame, from the near kerb"));
    // The drill-down data: the same frame, named by role.
    let drill = serde_json::to_value(&built.drill).unwrap();
    assert_eq!(drill["scenes"][1]["roles"], json!(["pedestrian", "companion", "companion"]));
    assert_eq!(drill["scenes"][1]["lateral"][0]["measured"], "from the near kerb");
    assert_eq!(drill["scenes"][1]["lateral"][0]["path"], json!([0.5, 3.0]));
    assert_eq!(drill["scenes"][2]["roles"], json!(["lane car", "follower"]));
    let turns = drill["transcripts"][0]["turns"].as_array().unwrap();
    assert_eq!(turns.len(), 2);
    for (i, t) in turns.iter().enumerate() {
        let y = t["o"][0][1].as_f64().unwrap();
        assert_eq!(y, -3.0 + 0.5 * i as f64);
        assert_eq!(t["f"], json!([y + 1.75]), "turn {i}");
    }
}

/// Three models on yield_standoff seeds 0-3: `alpha` always succeeds,
/// `beta` collides on odd seeds, the long-named one always collides.
const LONG: &str = "accounts/fireworks/models/llama-v3p1-405b-instruct";

fn three_models(root: &Path) {
    let ys = ScenarioKind::YieldStandoff;
    for (model, collide) in
        [("alpha", &(|_: u64| false) as &dyn Fn(u64) -> bool), ("beta", &|s| s % 2 == 1), (LONG, &|_| true)]
    {
        let h = hash(model, None);
        let lines: Vec<String> = (0..4)
            .map(|seed| {
                line(model, &h, ys, 1, seed, 0, if collide(seed) { Outcome::Collision } else { Outcome::Success })
            })
            .collect();
        write_run(&root.join(model.replace('/', "_")), &RunSpec { seeds: 4, ..spec(model) }, &lines);
    }
}

#[test]
fn maneuver_timelines_have_one_row_per_model_in_leaderboard_order() {
    let root = scratch("report-timeline");
    three_models(&root);
    let built = report::build_from(load_dirs(std::slice::from_ref(&root)).unwrap(), refs(), &opts()).unwrap();
    let order: Vec<&str> = built.report.leaderboard.rows.iter().map(|r| r.model.as_str()).collect();
    assert_eq!(order, ["alpha", "beta", LONG]);
    // Trajectories: alpha's first success (seed 0), beta's first collision (seed 1), the long one's (seed 0).
    let names: Vec<&str> = built.report.plots.iter().map(|p| p.name.as_str()).collect();
    let timelines: Vec<&&str> = names.iter().filter(|n| n.starts_with("timeline_")).collect();
    assert_eq!(timelines, [&"timeline_yield_standoff_t1_s0_r0", &"timeline_yield_standoff_t1_s1_r0"]);
    for name in timelines {
        let svg = &built.report.plots.iter().find(|p| p.name == **name).unwrap().svg;
        // One row per model, named (shortened, the full name in the tooltip), in leaderboard order.
        let rows: Vec<usize> = order
            .iter()
            .map(|m| {
                let shown = if *m == LONG { "accounts/fir\u{2026}5b-instruct" } else { m };
                svg.find(&format!("<title>{m}</title>{shown}</text>")).unwrap_or_else(|| panic!("{m}: {svg}"))
            })
            .collect();
        assert!(rows.windows(2).all(|w| w[0] < w[1]), "{name}: rows out of order");
        assert!(!svg.contains(&format!(">{LONG}</text>")), "the long name is shortened");
        assert_texts_fit(name, svg);
        // Each row's strip has one cell per turn (two here), and its outcome at the end.
        for m in &order {
            assert_eq!(svg.matches(&format!("<title>{m}: turn ")).count(), 2, "{name}: {m}");
        }
        let seed1 = name.contains("_s1_");
        let outcomes: Vec<&str> = order
            .iter()
            .map(|m| if *m == "alpha" || (*m == "beta" && !seed1) { "success" } else { "collision" })
            .collect();
        for (m, o) in order.iter().zip(outcomes) {
            assert!(svg.contains(&format!("<title>{m}: {o} after 2 turns")), "{name}: {m} {o}");
        }
    }
}

/// Runs made with `--no-trajectories` have no trajectory figure, but their
/// maneuver timelines (which need only the turns) are drawn all the same.
#[test]
fn runs_without_trajectories_still_get_maneuver_timelines() {
    let root = scratch("report-timeline-no-traj");
    three_models(&root);
    for dir in std::fs::read_dir(&root).unwrap() {
        let path = dir.unwrap().path().join("rollouts.jsonl");
        let text = std::fs::read_to_string(&path).unwrap();
        let stripped: String = text
            .lines()
            .map(|l| {
                let mut v: serde_json::Value = serde_json::from_str(l).unwrap();
                v.as_object_mut().unwrap().remove("trajectory");
                format!("{v}\n")
            })
            .collect();
        std::fs::write(&path, stripped).unwrap();
    }
    let built = report::build_from(load_dirs(std::slice::from_ref(&root)).unwrap(), refs(), &opts()).unwrap();
    let names: Vec<&str> = built.report.plots.iter().map(|p| p.name.as_str()).collect();
    assert!(!names.iter().any(|n| n.starts_with("trajectory_")), "{names:?}");
    let timelines: Vec<&&str> = names.iter().filter(|n| n.starts_with("timeline_")).collect();
    // The same picks as with trajectories: alpha's seed 0, beta's first collision (seed 1).
    assert_eq!(timelines, [&"timeline_yield_standoff_t1_s0_r0", &"timeline_yield_standoff_t1_s1_r0"]);
    let svg = &built.report.plots.iter().find(|p| p.name == "timeline_yield_standoff_t1_s1_r0").unwrap().svg;
    assert!(svg.contains("<title>beta: collision after 2 turns"), "{svg}");
}

#[test]
fn a_model_without_the_seed_keeps_its_timeline_row_empty() {
    let root = scratch("report-timeline-gap");
    three_models(&root);
    // delta ran seeds 0-1 only (its whole selection, so it is complete).
    let h = hash("delta", None);
    let lines: Vec<String> =
        (0..2).map(|seed| line("delta", &h, ScenarioKind::YieldStandoff, 1, seed, 0, Outcome::Success)).collect();
    write_run(&root.join("delta"), &RunSpec { seeds: 2, ..spec("delta") }, &lines);
    let pick = "alpha:yield_standoff:1:3".parse::<negotiator::report::pick::EpisodePick>().unwrap();
    let built = report::build_from(
        load_dirs(std::slice::from_ref(&root)).unwrap(),
        refs(),
        &ReportOptions { episodes: vec![pick], ..opts() },
    )
    .unwrap();
    let svg =
        &built.report.plots.iter().find(|p| p.name == "timeline_yield_standoff_t1_s3_r0").expect("the timeline").svg;
    let rows = built.report.leaderboard.rows.len();
    assert_eq!(rows, 4);
    assert_eq!(svg.matches("no episode of this seed").count(), 1, "{svg}");
    let gap = svg.find("no episode of this seed").unwrap();
    assert!(svg[..gap].contains("<title>delta</title>delta</text>"), "the empty row is delta's");
    assert!(!svg.contains("<title>delta: turn "), "delta has no cells");
    for m in ["alpha", "beta", LONG] {
        assert_eq!(svg.matches(&format!("<title>{m}: turn ")).count(), 2, "{m}");
    }
}

#[test]
fn episode_flag_selects_exactly_the_named_episodes() {
    let root = scratch("report-episode");
    three_models(&root);
    let pick = |s: &str| s.parse::<negotiator::report::pick::EpisodePick>().unwrap();
    let o = ReportOptions {
        episodes: vec![pick("beta:yield_standoff:1:2"), pick(&format!("{LONG}:yield_standoff:1:3:0"))],
        ..opts()
    };
    let built = report::build_from(load_dirs(std::slice::from_ref(&root)).unwrap(), refs(), &o).unwrap();
    let names: Vec<&str> = built
        .report
        .plots
        .iter()
        .map(|p| p.name.as_str())
        .filter(|n| n.starts_with("trajectory_") || n.starts_with("timeline_"))
        .collect();
    assert_eq!(
        names,
        [
            "trajectory_beta_yield_standoff_t1_s2_r0",
            "trajectory_accounts_fireworks_models_llama-v3p1-405b-instruct_yield_standoff_t1_s3_r0",
            "timeline_yield_standoff_t1_s2_r0",
            "timeline_yield_standoff_t1_s3_r0",
        ]
    );
    // Both styles: the paper style's larger text still fits (names, outcomes, end-of-line labels).
    let paper = ReportOptions { style: negotiator::report::plots::Style::Paper, ..o.clone() };
    let paper = report::build_from(load_dirs(std::slice::from_ref(&root)).unwrap(), refs(), &paper).unwrap();
    for p in built.report.plots.iter().chain(&paper.report.plots) {
        if p.name.starts_with("trajectory_") || p.name.starts_with("timeline_") {
            assert_texts_fit(&p.name, &p.svg);
        }
        if p.name.starts_with("timeline_") {
            // Each model's name ends left of its first maneuver cell.
            for m in ["alpha", "beta", LONG] {
                let shown = if m == LONG { "accounts/fir\u{2026}5b-instruct" } else { m };
                let name = p.svg.find(&format!("><title>{m}</title>{shown}</text>")).unwrap();
                let name = p.svg[..name].rfind("<text ").unwrap();
                let size: f64 = attr(&p.svg, name, "font-size").parse().unwrap();
                let right =
                    attr(&p.svg, name, "x").parse::<f64>().unwrap() + shown.chars().count() as f64 * size * 0.58;
                let cell = p.svg[..p.svg.find(&format!("<title>{m}: turn 1 ")).unwrap()].rfind("<rect ").unwrap();
                let left: f64 = attr(&p.svg, cell, "x").parse().unwrap();
                assert!(right <= left, "{}: {m}'s name ends at {right:.0}, its strip starts at {left}", p.name);
            }
        }
    }
    // Their transcripts are in the drill-down, first.
    let drill = serde_json::to_value(&built.drill).unwrap();
    let with_transcript: Vec<(u64, u64)> = drill["episodes"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|e| e[13].as_i64() == Some(0) || e[13].as_i64() == Some(1))
        .map(|e| (e[0].as_u64().unwrap(), e[3].as_u64().unwrap()))
        .collect();
    assert_eq!(with_transcript, [(1, 2), (2, 3)]);
    // Not in the runs, unknown model: input errors naming the flag.
    for (given, expected) in [
        ("beta:yield_standoff:1:9", "--episode 'beta:yield_standoff:1:9': no such episode in the runs of 'beta'"),
        ("beta:pedestrian_feint:1:0", "no such episode"),
        ("beta:yield_standoff:1:2:1", "rollout 1 was not run"),
        (
            "gamma:yield_standoff:1:2",
            "--episode 'gamma:yield_standoff:1:2': unknown model 'gamma' (the runs hold: alpha, beta,",
        ),
    ] {
        let o = ReportOptions { episodes: vec![pick(given)], ..opts() };
        let e = report::build_from(load_dirs(std::slice::from_ref(&root)).unwrap(), refs(), &o).err().expect(given);
        assert!(e.to_string().contains(expected), "{given}: {e}");
    }
}

#[test]
fn incomplete_models_are_marked_everywhere_and_not_ranked() {
    let root = scratch("report-incomplete");
    let (ys, pf, cm) = (ScenarioKind::YieldStandoff, ScenarioKind::PedestrianFeint, ScenarioKind::ContestedMerge);
    let all = [ys, pf, cm];
    // "full": 20 seeds x 3 scenarios, success 0.5. "partial": the same selection, 4 finished (all successes,
    // no contested_merge), 2 errored, 54 never started.
    let h = hash("full", None);
    let full: Vec<String> = all
        .iter()
        .flat_map(|&s| (0..20).map(move |seed| (s, seed)))
        .map(|(s, seed)| {
            line("full", &h, s, 1, seed, 0, if seed % 2 == 0 { Outcome::Success } else { Outcome::Timeout })
        })
        .collect();
    write_run(&root.join("full"), &RunSpec { seeds: 20, scenarios: &all, ..spec("full") }, &full);
    let hp = hash("partial", None);
    let partial: Vec<String> = [(ys, 0), (ys, 1), (pf, 0), (pf, 1)]
        .iter()
        .map(|&(s, seed)| line("partial", &hp, s, 1, seed, 0, Outcome::Success))
        .collect();
    write_run(&root.join("partial"), &RunSpec { seeds: 20, scenarios: &all, ..spec("partial") }, &partial);
    let err = |seed: u64| {
        format!(
            "{}\n",
            json!({"schema_version": 2, "scenario": "contested_merge", "tier": 1, "seed": seed, "rollout": 0,
                              "turn": 1, "error": "HTTP 500", "at": "t"})
        )
    };
    std::fs::write(root.join("partial/errors.jsonl"), [err(0), err(1)].concat()).unwrap();

    let built = report::build_from(load_dirs(std::slice::from_ref(&root)).unwrap(), refs(), &opts()).unwrap();
    let r = &built.report;
    let rows: Vec<(&str, Option<usize>)> = r.leaderboard.rows.iter().map(|r| (r.model.as_str(), r.rank)).collect();
    // partial's average (1.0) beats full's (0.5), yet it is not ranked.
    assert_eq!(rows, vec![("full", Some(1)), ("partial", None)]);
    let why = r.leaderboard.rows[1].incomplete.as_deref().unwrap();
    assert_eq!(why, "4 of 60 episodes finished (2 errored, 54 missing); no contested_merge");
    assert!(r.leaderboard.rows[0].incomplete.is_none());
    let cost = r.costs.iter().find(|c| c.model == "partial").unwrap();
    assert_eq!((cost.infra_errors, cost.missing), (2, Some(54)));
    assert!(r.warnings.iter().any(|w| w.starts_with("partial is incomplete (4 of 60") && w.contains("not ranked")));
    // Marked in every table on display, plain in the data formats.
    for t in ["leaderboard", "tiers", "outcomes", "errors_cost", "paired", "runs"] {
        let text = r.render_table(t, Format::Table).unwrap();
        assert!(text.contains("partial \u{2020}"), "{t}: {text}");
        assert!(!text.contains("full \u{2020}"), "{t}: {text}");
        let csv = r.render_table(t, Format::Csv).unwrap();
        assert!(!csv.contains('\u{2020}'), "{t}: {csv}");
    }
    let lb = r.render_table("leaderboard", Format::Table).unwrap();
    let line_of = |name: &str| lb.lines().find(|l| l.contains(name)).unwrap().to_string();
    assert!(line_of("full").starts_with("1 "), "{lb}");
    assert!(line_of("partial").starts_with("- "), "{lb}");
    let cost_table = r.render_table("errors_cost", Format::Table).unwrap();
    assert!(cost_table.contains("errored") && cost_table.contains("missing"), "{cost_table}");
    // And in every figure that names models.
    for p in r.plots.iter().filter(|p| p.svg.contains(">partial")) {
        assert!(p.svg.contains("partial \u{2020}"), "{}", p.name);
    }
    assert!(r.plots.iter().any(|p| p.svg.contains("partial \u{2020}")));

    // --include-incomplete ranks it (still marked).
    let with = ReportOptions { include_incomplete: true, ..opts() };
    let built = report::build_from(load_dirs(std::slice::from_ref(&root)).unwrap(), refs(), &with).unwrap();
    let rows: Vec<(&str, Option<usize>)> =
        built.report.leaderboard.rows.iter().map(|r| (r.model.as_str(), r.rank)).collect();
    assert_eq!(rows, vec![("partial", Some(1)), ("full", Some(2))]);
    assert!(built.report.render_table("leaderboard", Format::Table).unwrap().contains("partial \u{2020}"));

    // The terminal warning.
    let out = ok(report_cmd(
        &root.join("out"),
        &[root.join("full").to_str().unwrap(), root.join("partial").to_str().unwrap()],
    ));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("warning: partial is incomplete (4 of 60 episodes finished"), "{stderr}");
}

// ---------------------------------------------------------------------------
// End to end: serve + eval + report

fn report_cmd(out: &Path, args: &[&str]) -> Command {
    let mut c = negotiator();
    c.arg("report").arg("--out").arg(out).args(args);
    c
}

fn ok(mut c: Command) -> Output {
    let out = c.output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(out.status.success(), "exit {:?}: {stderr}", out.status.code());
    out
}

/// Two small runs (expert; always_proceed with injected failures and no
/// retries, so some rollouts end as infrastructure errors) and a report.
fn end_to_end() -> (PathBuf, Output) {
    let root = scratch("report-e2e");
    let runs = root.join("runs");
    // always_proceed: 2 rollouts per seed, so eval's and report's intervals are compared with r > 1.
    for (policy, extra) in [("expert", &[][..]), ("always_proceed", &["--fail-rate", "0.02"][..])] {
        let rollouts = if policy == "expert" { "1" } else { "2" };
        let server = Server::start(&[&["--policy", policy][..], extra].concat());
        let out = negotiator()
            .args(["eval", "--base-url", &server.base_url(), "--model", policy, "--quiet", "--output"])
            .arg(&runs)
            .args(["--run-name", policy, "--scenario", "all", "--tier", "all", "-n", "4", "-c", "8"])
            .args(["--max-retries", "0", "--backoff-base-ms", "1", "-r", rollouts])
            .output()
            .unwrap();
        assert!(matches!(out.status.code(), Some(0 | 1)), "{}", String::from_utf8_lossy(&out.stderr));
    }
    let out = ok(report_cmd(
        &root.join("report"),
        &[runs.to_str().unwrap(), "--baselines", concat!(env!("CARGO_MANIFEST_DIR"), "/results/baselines")],
    ));
    (root, out)
}

/// Minimal XML well-formedness: balanced tags, no attribute twice.
fn assert_well_formed(name: &str, text: &str) {
    let mut stack: Vec<String> = Vec::new();
    let mut rest = text;
    while let Some(start) = rest.find('<') {
        let end = rest[start..].find('>').map(|e| start + e).unwrap_or_else(|| panic!("{name}: unclosed tag"));
        let tag = &rest[start + 1..end];
        rest = &rest[end + 1..];
        if tag.starts_with('?') || tag.starts_with('!') {
            continue;
        }
        if let Some(close) = tag.strip_prefix('/') {
            assert_eq!(stack.pop().as_deref(), Some(close.trim()), "{name}: mismatched </{close}>");
            continue;
        }
        let self_closing = tag.ends_with('/');
        let body = tag.trim_end_matches('/');
        let el = body.split_whitespace().next().unwrap_or_default().to_string();
        let mut names: Vec<&str> = Vec::new();
        for part in body.split('"').step_by(2) {
            if let Some(n) = part.trim().rsplit(' ').next().and_then(|a| a.strip_suffix('=')) {
                assert!(!names.contains(&n), "{name}: attribute {n} twice in <{body}>");
                names.push(n);
            }
        }
        if !self_closing {
            stack.push(el);
        }
    }
    assert!(stack.is_empty(), "{name}: unclosed {stack:?}");
}

#[test]
fn end_to_end_report_files_and_offline_html() {
    let (root, out) = end_to_end();
    let dir = root.join("report");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("Success rates (tier 1; 95% percentile bootstrap CIs)"), "{stdout}");
    assert!(stdout.contains("expert reference") && stdout.contains("always_proceed floor"), "{stdout}");
    // Which always_proceed rollouts fail is up to scheduling, so the verdict is not pinned here.
    let paired = &stdout[stdout.find("Paired comparisons").expect("paired table")..];
    assert!(paired.lines().nth(3).is_some_and(|l| l.starts_with("expert") && l.contains("always_proceed")), "{paired}");
    for f in [
        "report.html",
        "report.md",
        "report.json",
        "leaderboard.csv",
        "tiers.csv",
        "outcomes.csv",
        "paired.csv",
        "errors_cost.csv",
    ] {
        assert!(dir.join(f).is_file(), "{f} missing");
    }
    let csv = std::fs::read_to_string(dir.join("leaderboard.csv")).unwrap();
    assert!(csv.starts_with("rank,model,kind,avg,avg_lo,avg_hi,yield_standoff,yield_standoff_lo,"), "{csv}");
    let json: Value = serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap();
    assert_eq!(json["resamples"], 10000);
    assert_eq!(json["leaderboard"]["rows"][0]["model"], "expert");

    // Infrastructure errors: the report's count is the run's own.
    let run: Value =
        serde_json::from_str(&std::fs::read_to_string(root.join("runs/always_proceed/run.json")).unwrap()).unwrap();
    let cost = json["costs"].as_array().unwrap().iter().find(|c| c["model"] == "always_proceed").unwrap();
    // errored + missing (never started) = the run's unfinished episodes.
    let unfinished = cost["missing"].as_u64().unwrap() + cost["infra_errors"].as_u64().unwrap();
    assert_eq!(Some(unfinished), run["totals"]["missing"].as_u64());
    let errors = std::fs::read_to_string(root.join("runs/always_proceed/errors.jsonl")).unwrap_or_default();
    assert_eq!(cost["infra_errors"].as_u64().unwrap() as usize > 0, !errors.trim().is_empty());

    // A (scenario, tier) cell's figures are the ones in eval's summary, with 1 and with 2 rollouts per seed
    // (the interval bootstraps over seeds with the cell's seed), and eval prints n as seeds x rollouts.
    for model in ["expert", "always_proceed"] {
        let path = root.join(format!("runs/{model}/summary.json"));
        let summary: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
        for cell in summary["cells"].as_array().unwrap().iter().filter(|c| c["episodes"].as_u64() > Some(0)) {
            let row = json["tier_rows"]
                .as_array()
                .unwrap()
                .iter()
                .find(|r| r["model"] == model && r["scenario"] == cell["scenario"] && r["tier"] == cell["tier"])
                .unwrap();
            // One computation, one set of names: every figure of the cell is eval's.
            for figure in [
                "episodes",
                "seeds",
                "rollouts",
                "success",
                "collision_rate",
                "timeout_rate",
                "mean_reward",
                "decision_correctness",
                "guess_rate",
                "evidence_lag",
                "parse_error_rate",
                "truncated_rate",
                "tokens_per_episode",
            ] {
                assert!(!cell[figure].is_null() || figure.ends_with("lag"), "{figure} in summary.json");
                assert_eq!(row[figure], cell[figure], "{model} {} {figure}", cell["scenario"]);
            }
        }
    }

    // Plots: every kind, well-formed, self-contained.
    let plots: Vec<PathBuf> = std::fs::read_dir(dir.join("plots")).unwrap().map(|e| e.unwrap().path()).collect();
    for stem in ["success_by_scenario", "ranked_mean", "success_vs_correctness", "tier_ladder", "outcomes", "radar"] {
        assert!(plots.iter().any(|p| p.file_stem().unwrap() == stem), "{stem}.svg missing");
    }
    assert!(plots.iter().any(|p| p.file_name().unwrap().to_string_lossy().starts_with("trajectory_always_proceed_")));
    assert!(plots.iter().any(|p| p.file_name().unwrap().to_string_lossy().starts_with("timeline_pedestrian_feint_")));
    for p in &plots {
        let text = std::fs::read_to_string(p).unwrap();
        assert_well_formed(&p.display().to_string(), &text);
        assert_eq!(text.matches("http").count(), 1, "{}: only the SVG namespace", p.display());
    }
    // The same runs in paper style, beside the default report.
    let paper = root.join("paper");
    let runs = root.join("runs");
    let baselines = concat!(env!("CARGO_MANIFEST_DIR"), "/results/baselines");
    ok(report_cmd(&paper, &[runs.to_str().unwrap(), "--baselines", baselines, "--style", "paper", "-q"]));
    let figures = paper_style_figures(&dir.join("plots"), &paper.join("plots"));

    // report.html: one file, nothing external.
    let html = std::fs::read_to_string(dir.join("report.html")).unwrap();
    assert!(!html.contains("http"), "report.html mentions a URL");
    for bad in ["<link", "src=", "@import", "url("] {
        assert!(!html.contains(bad), "report.html contains {bad}");
    }
    assert!(html.contains("id=\"drill-data\"") && html.contains("<svg "));
    // Numbers are right-aligned; names are not.
    assert!(
        html.contains("<th class=\"num\">episodes</th>") && html.contains("<td class=\"num\">"),
        "no numeric alignment"
    );
    assert!(html.contains("<td>expert</td>"));
    assert_well_formed("report.html body", &html[html.find("<main>").unwrap()..html.find("</main>").unwrap() + 7]);

    // Headless Chromium renders it and the drill-down script fills the episode view.
    let chromium = Path::new("/usr/bin/chromium");
    if !crate::support::tool_available(chromium.exists(), "chromium (/usr/bin/chromium) for the render test") {
        return;
    }
    let profile = root.join("chromium-profile");
    let dom = dump_dom(chromium, &profile, &format!("file://{}", dir.join("report.html").display()));
    assert!(dom.contains("data-state=\"rendered\""), "the drill-down did not render: {}", &dom[..dom.len().min(400)]);
    assert!(dom.contains("class=\"turn-row\""), "no turn rows in the rendered drill-down");
    assert!(dom.contains("data-episode=\"0|"), "the first model's episode is shown");
    // The selected episode's trajectory is drawn from the embedded positions.
    let traj = &dom[dom.find("id=\"dd-traj\"").expect("trajectory box")..];
    assert!(traj[..traj.find("</div>").unwrap()].contains("<polyline"), "no trajectory drawn");
    // Switching to an episode without a transcript shows no stale turn count.
    let data_start = html.find("id=\"drill-data\">").unwrap() + "id=\"drill-data\">".len();
    let data: Value =
        serde_json::from_str(&html[data_start..data_start + html[data_start..].find("</script>").unwrap()]).unwrap();
    let bare = data["episodes"]
        .as_array()
        .unwrap()
        .iter()
        .find(|e| e[13].as_i64() < Some(0))
        .expect("an episode without transcript");
    let key = (0..5).map(|i| bare[i].to_string()).collect::<Vec<_>>().join("|");
    let dom = dump_dom(
        chromium,
        &profile,
        &format!("file://{}#episode={}", dir.join("report.html").display(), key.replace('|', "%7C")),
    );
    assert!(dom.contains(&format!("data-episode=\"{key}\"")), "episode {key} not selected");
    assert!(dom.contains("data-state=\"summary\""), "{key}: not the summary state");
    assert!(dom.contains("<span id=\"dd-count\">0</span>"), "a stale turn count is shown");
    assert!(
        !dom[dom.find("id=\"dd-traj\"").unwrap()..].starts_with("id=\"dd-traj\"><svg"),
        "a stale trajectory is shown"
    );
    // A pedestrian episode: its lateral position in the scene text's kerb frame, with both kerbs and the
    // in-path band, and the road user named by its role.
    let walker = data["episodes"]
        .as_array()
        .unwrap()
        .iter()
        .find(|e| e[1] == 1 && e[13].as_i64() >= Some(0))
        .expect("a pedestrian episode with a transcript");
    let key = (0..5).map(|i| walker[i].to_string()).collect::<Vec<_>>().join("|");
    let dom = dump_dom(
        chromium,
        &profile,
        &format!("file://{}#episode={}", dir.join("report.html").display(), key.replace('|', "%7C")),
    );
    assert!(dom.contains(&format!("data-episode=\"{key}\"")), "episode {key} not selected");
    let traj = &dom[dom.find("id=\"dd-traj\"").unwrap()..];
    let traj = &traj[..traj.find("<table class=\"turns\"").unwrap()];
    assert!(traj.contains("class=\"lateral\" data-role=\"pedestrian\""), "no lateral panel: {traj}");
    for text in ["near kerb (0)", "far kerb (7)", "in the ego's path (0.5–3.0 m)", "pedestrian, from the near kerb (m)"]
    {
        assert!(traj.contains(text), "{text} missing: {traj}");
    }
    assert!(
        dom.contains("<div>pedestrian: ") && dom.contains(" m from the near kerb, "),
        "the turn rows name the role"
    );
    render_figures(chromium, &root, &figures);
}

/// Attribute `name`'s value in the first `<svg ...>` tag of `svg`.
fn svg_attr<'a>(svg: &'a str, name: &str) -> Option<&'a str> {
    let tag = &svg[svg.find("<svg ")?..];
    let tag = &tag[..tag.find('>')?];
    let at = tag.find(&format!(" {name}=\""))? + name.len() + 3;
    Some(&tag[at..at + tag[at..].find('"')?])
}

/// Every `font-size` in `svg`, in viewBox units.
fn font_sizes(svg: &str) -> Vec<f64> {
    svg.split(" font-size=\"").skip(1).map(|s| s[..s.find('"').unwrap()].parse().unwrap()).collect()
}

/// The paper-style report's figures against the default one's (both from
/// the same runs): the same figures; in paper style every text at least
/// 8 pt when printed at the declared width (3.3 in or 7 in), no title, and
/// a PDF of each beside it, its page the print size; in the default style,
/// the titles. Returns (style, name, SVG text) of every figure of both.
pub(crate) fn paper_style_figures(default_dir: &Path, paper_dir: &Path) -> Vec<(&'static str, String, String)> {
    let stems = |dir: &Path, ext: &str| -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == ext))
            .map(|p| p.file_stem().unwrap().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    };
    let names = stems(default_dir, "svg");
    assert!(names.len() >= 8, "{names:?}");
    assert_eq!(stems(paper_dir, "svg"), names, "paper style draws the same figures");
    assert_eq!(stems(paper_dir, "pdf"), names, "a PDF beside each paper SVG");
    assert!(stems(default_dir, "pdf").is_empty(), "no PDF in the default style");
    let mut figures = Vec::new();
    for name in &names {
        let default = std::fs::read_to_string(default_dir.join(format!("{name}.svg"))).unwrap();
        let paper = std::fs::read_to_string(paper_dir.join(format!("{name}.svg"))).unwrap();
        assert_well_formed(name, &paper);
        // Titles: the default figure's title (its <title> and the bold heading) is nowhere in the paper one.
        let title = &default[default.find("<title>").unwrap() + 7..default.find("</title>").unwrap()];
        assert!(
            default.matches(&format!(">{title}</text>")).count() == 1,
            "{name}: no title drawn in the default style"
        );
        assert!(!paper.contains(title) && !paper.contains("<svg><title>"), "{name}: a title in paper style");
        // Text size at print width.
        let width = svg_attr(&paper, "width").unwrap_or_else(|| panic!("{name}: no width"));
        let inches: f64 =
            width.strip_suffix("in").unwrap_or_else(|| panic!("{name}: width {width} not in inches")).parse().unwrap();
        assert!(inches == 3.3 || inches == 7.0, "{name}: print width {inches} in is neither a column nor two");
        let view: Vec<f64> = svg_attr(&paper, "viewBox").unwrap().split(' ').map(|v| v.parse().unwrap()).collect();
        let sizes = font_sizes(&paper);
        assert!(!sizes.is_empty(), "{name}: no text");
        let smallest_pt = sizes.iter().copied().fold(f64::INFINITY, f64::min) * inches * 72.0 / view[2];
        assert!(smallest_pt >= 8.0, "{name}: text of {smallest_pt:.1} pt at {inches} in");
        // The PDF: a real one, one page of the print size, the text in an embedded font.
        let pdf = std::fs::read(paper_dir.join(format!("{name}.pdf"))).unwrap();
        assert!(pdf.starts_with(b"%PDF-") && pdf.len() > 4000, "{name}.pdf: {} bytes", pdf.len());
        let body = String::from_utf8_lossy(&pdf);
        let mb = &body[body.find("/MediaBox [").unwrap() + 11..];
        let mb: Vec<f64> = mb[..mb.find(']').unwrap()].split_whitespace().map(|v| v.parse().unwrap()).collect();
        assert!((mb[2] - mb[0] - inches * 72.0).abs() < 0.5, "{name}.pdf: page {mb:?} for {inches} in");
        assert!(body.contains("FigureSans-Regular") && body.contains("/FontFile2"), "{name}.pdf: no embedded font");
        figures.push(("default", name.clone(), default));
        figures.push(("paper", name.clone(), paper));
    }
    figures
}

#[test]
fn paper_figures_of_many_long_named_models_still_print_at_8_pt() {
    // Nine models whose names are shortened to 24 characters: the widest labels a figure gets, and shapes vary.
    let root = scratch("report-paper-wide");
    let all = ScenarioKind::ALL;
    for i in 0..9 {
        let model = format!("accounts/fireworks/models/llama-v3p1-405b-instruct-{i}");
        let h = hash(&model, None);
        let lines: Vec<String> = all
            .iter()
            .flat_map(|&s| (0..6).map(move |seed| (s, seed)))
            .map(|(s, seed)| {
                let outcome = if (seed + i) % 3 == 0 { Outcome::Collision } else { Outcome::Success };
                line(&model, &h, s, 1, seed, 0, outcome)
            })
            .collect();
        write_run(&root.join(format!("m{i}")), &RunSpec { seeds: 6, scenarios: &all, ..spec(&model) }, &lines);
    }
    let paper = ReportOptions { style: report::plots::Style::Paper, ..opts() };
    let built = report::build_from(load_dirs(std::slice::from_ref(&root)).unwrap(), refs(), &paper).unwrap();
    let plots = &built.report.plots;
    assert!(plots.len() >= 8 && plots.iter().any(|p| p.name == "success_by_scenario"));
    for p in plots {
        let inches: f64 = svg_attr(&p.svg, "width").and_then(|w| w.strip_suffix("in")).unwrap().parse().unwrap();
        let view: Vec<f64> = svg_attr(&p.svg, "viewBox").unwrap().split(' ').map(|v| v.parse().unwrap()).collect();
        let smallest = font_sizes(&p.svg).into_iter().fold(f64::INFINITY, f64::min);
        let pt = smallest * inches * 72.0 / view[2];
        assert!((inches == 3.3 || inches == 7.0) && pt >= 8.0, "{}: {pt:.2} pt at {inches} in", p.name);
    }
}

/// Every figure of both styles on one page, rendered by headless Chromium
/// in one launch: a script measures each figure as drawn (its width, each
/// text's box and computed size) and writes the result into the DOM. Every
/// figure must be drawn with all its text inside it; in paper style every
/// text at least 8 pt at the figure's print width.
pub(crate) fn render_figures(chromium: &Path, root: &Path, figures: &[(&str, String, String)]) {
    let mut page = String::from("<!doctype html><html><head><meta charset=\"utf-8\"></head><body>");
    for (style, name, svg) in figures {
        page.push_str(&format!("<div class=\"fig\" data-name=\"{style}/{name}\">{svg}</div>"));
    }
    page.push_str(
        r#"<script>
for (const fig of document.querySelectorAll('.fig')) {
  const svg = fig.querySelector('svg');
  const box = svg.getBoundingClientRect();
  const scale = box.width / svg.viewBox.baseVal.width;
  let texts = 0, drawn = 0, minPt = 1e9;
  const outside = [];
  for (const t of svg.querySelectorAll('text')) {
    texts++;
    const r = t.getBoundingClientRect();
    if (r.width > 0 && r.height > 0) drawn++;
    minPt = Math.min(minPt, parseFloat(getComputedStyle(t).fontSize) * scale * 0.75);
    if (r.left < box.left - 2 || r.right > box.right + 2 || r.top < box.top - 2 || r.bottom > box.bottom + 2)
      outside.push(t.textContent);
  }
  fig.setAttribute('data-result', [Math.round(box.width), texts, drawn, minPt.toFixed(2), outside.join('|')].join(';'));
}
document.body.setAttribute('data-done', 'yes');
</script></body></html>"#,
    );
    let file = root.join("figures.html");
    std::fs::write(&file, page).unwrap();
    let dom = dump_dom(chromium, &root.join("chromium-profile"), &format!("file://{}", file.display()));
    assert!(dom.contains("data-done=\"yes\""), "the figure page did not run: {}", &dom[..dom.len().min(300)]);
    for (style, name, _) in figures {
        let key = format!("data-name=\"{style}/{name}\" data-result=\"");
        let at = dom.find(&key).unwrap_or_else(|| panic!("{style}/{name}: not measured")) + key.len();
        let result: Vec<&str> = dom[at..at + dom[at..].find('"').unwrap()].split(';').collect();
        let (width, texts, drawn, min_pt) = (
            result[0].parse::<f64>().unwrap(),
            result[1].parse::<usize>().unwrap(),
            result[2].parse::<usize>().unwrap(),
            result[3].parse::<f64>().unwrap(),
        );
        assert!(width > 100.0 && texts > 0 && drawn == texts, "{style}/{name}: {result:?}");
        assert_eq!(result[4], "", "{style}/{name}: text outside the figure");
        if *style == "paper" {
            assert!(min_pt >= 7.99, "{style}/{name}: text of {min_pt} pt as rendered at print width");
        }
    }
}

#[test]
fn bad_input_is_a_one_line_usage_error() {
    let root = scratch("report-bad");
    let cases: [(Vec<String>, &str); 4] = [
        (vec![root.join("absent").display().to_string()], "no such directory"),
        (vec![root.display().to_string()], "not a run directory"),
        (vec![root.display().to_string(), "--tiers".into(), "4".into()], "--tiers"),
        (vec![root.display().to_string(), "--resamples".into(), "100".into()], "--resamples"),
    ];
    std::fs::create_dir_all(root.join("empty")).unwrap();
    // A choice the CLI knows is refused by clap, which names the choices.
    let out = report_cmd(&root.join("out"), &[root.to_str().unwrap(), "--style", "poster"]).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("invalid value 'poster' for '--style") && stderr.contains("[possible values: default, paper]"),
        "{stderr}"
    );
    for (args, expected) in cases {
        let out = report_cmd(&root.join("out"), &args.iter().map(String::as_str).collect::<Vec<_>>()).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(expected) && stderr.trim().lines().count() == 1, "{args:?}: {stderr}");
    }
    // An explicit --baselines directory without the table.
    let h = hash("m", None);
    write_run(&root.join("run"), &spec("m"), &[line("m", &h, ScenarioKind::YieldStandoff, 1, 0, 0, Outcome::Success)]);
    let out =
        report_cmd(&root.join("out"), &[root.join("run").to_str().unwrap(), "--baselines", root.to_str().unwrap()])
            .output()
            .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("baselines.csv"));
    // --episode: malformed, unknown scenario, bad tier, unknown model, an episode not in the run.
    let run = root.join("run");
    for (value, expected) in [
        ("m:yield_standoff:1", "expected MODEL:SCENARIO:TIER:SEED[:ROLLOUT]"),
        ("m:four_way:1:0", "unknown scenario 'four_way'"),
        ("m:yield_standoff:4:0", "unknown tier '4'"),
        ("nobody:yield_standoff:1:0", "unknown model 'nobody' (the runs hold: m)"),
        ("m:yield_standoff:1:5", "no such episode in the runs of 'm'"),
    ] {
        let out = report_cmd(&root.join("out"), &[run.to_str().unwrap(), "--episode", value]).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{value}: {stderr}");
        assert!(stderr.trim().lines().count() == 1, "{value}: {stderr}");
        assert!(stderr.contains(&format!("--episode '{value}': {expected}")), "{value}: {stderr}");
    }
}

/// Every `--format` prints the same tables: the JSON object's keys are the
/// tables written as `{name}.csv`, and the CSV stream is those files, a
/// blank line after each.
#[test]
fn every_format_prints_the_same_tables() {
    let root = scratch("report-formats");
    write_wins(&root.join("runs"), "a", 12, &|s| s % 3 != 0, Outcome::Collision);
    write_wins(&root.join("runs"), "b", 12, &|s| s % 2 == 0, Outcome::Timeout);
    let out = root.join("out");
    let json = ok(report_cmd(&out, &["--format", "json", root.join("runs").to_str().unwrap()]));
    let tables: serde_json::Map<String, Value> = serde_json::from_slice(&json.stdout).unwrap();
    let mut csv_files: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .filter_map(|n| n.strip_suffix(".csv").map(str::to_string))
        .collect();
    csv_files.sort();
    let keys: Vec<String> = tables.keys().cloned().collect();
    assert_eq!(keys, csv_files);
    let models = tables["leaderboard"].as_array().unwrap().iter().filter(|r| r["kind"] == "model").count();
    assert_eq!(models, 2, "{}", tables["leaderboard"]);
    let csv = ok(report_cmd(&out, &["--format", "csv", root.join("runs").to_str().unwrap()]));
    let stream = String::from_utf8(csv.stdout).unwrap();
    let leaderboard = std::fs::read_to_string(out.join("leaderboard.csv")).unwrap();
    assert!(stream.starts_with(&(leaderboard + "\n")), "{stream}");
    assert_eq!(stream.matches("\n\n").count(), csv_files.len(), "{stream}");
}
