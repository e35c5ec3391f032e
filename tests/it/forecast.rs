//! The forecast probe end to end: `eval --probe forecast` against
//! `serve --probe forecast` (the rules forecaster answering from the scene
//! text), the references against the simulator, and the twin.

use crate::support::{Server, negotiator, scratch};
use negotiator::episode::Episode;
use negotiator::forecast::{ForecasterKind, HORIZONS_S, Reference, play_with_references_and_truth};
use negotiator::observation::{parse_scene, render_scene};
use negotiator::policy::PolicyKind;
use negotiator::scenario::{ScenarioKind, ScenarioSet, Tier};
use serde_json::Value;
use std::path::Path;
use std::process::Command;

fn eval(base_url: &str, out: &Path, run_name: &str, args: &[&str]) -> Command {
    let mut c = crate::support::eval_command(base_url, "scripted", out, run_name);
    c.args(["--quiet", "-c", "8"]).args(args);
    c
}

fn lines(dir: &Path) -> Vec<Value> {
    crate::support::jsonl(&dir.join("rollouts.jsonl"))
}

#[test]
fn eval_scores_the_served_rules_forecaster_as_the_reference_and_keeps_the_action_apart() {
    let server = Server::start(&["--policy", "expert", "--probe", "forecast"]);
    let out = scratch("forecast-expert");
    let args = ["--scenario", "all", "--tier", "all", "-n", "4"];
    crate::support::ok(eval(&server.base_url(), &out, "probe", &[&["--probe", "forecast"][..], &args].concat()));
    crate::support::ok(eval(&server.base_url(), &out, "plain", &args));
    let sorted = |mut v: Vec<Value>| {
        v.sort_by_key(|l| (l["scenario"].as_str().map(String::from), l["tier"].as_u64(), l["seed"].as_u64()));
        v
    };
    let (probe, plain) = (sorted(lines(&out.join("probe"))), sorted(lines(&out.join("plain"))));
    assert_eq!(probe.len(), 4 * crate::support::cells());
    for (a, b) in probe.iter().zip(&plain) {
        // The probe changes neither the episode nor the action's scoring.
        assert_eq!((&a["outcome"], &a["reward"], &a["seed"]), (&b["outcome"], &b["reward"], &b["seed"]));
        assert!(b.get("forecast").is_none() && b.get("forecast_truth").is_none());
        let m = &a["forecast"];
        assert_eq!(m["probe_errors"], 0, "{m}");
        assert_eq!(m["stated_turns"], a["turns_taken"]);
        // Every decision's truth is stored (one more: the end of the last
        // full interval), under both dispositions.
        let truth = a["forecast_truth"].as_array().unwrap();
        assert!(truth.len() >= a["turns_taken"].as_u64().unwrap() as usize, "{}", truth.len());
        for t in a["turns"].as_array().unwrap() {
            assert!(t.get("forecast_error").is_none(), "{t}");
            assert!(t["forecast"]["lets_you_go"].is_array() && t["forecast"]["does_not"].is_array());
        }
    }
    // The summary's forecast table: the rules forecaster, read back from
    // its own answers, beats constant velocity on the noise-free crossings.
    let summary: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("probe/summary.json")).unwrap()).unwrap();
    for cell in summary["cells"].as_array().unwrap() {
        let f = &cell["forecast"];
        assert_eq!(f["probe_error_rate"], 0.0, "{cell}");
        if cell["scenario"] == "yield_standoff" {
            assert!(f["skill_true"][1].as_f64().unwrap() > 0.3, "{cell}");
        }
    }
    let md = std::fs::read_to_string(out.join("probe/summary.md")).unwrap();
    assert!(md.contains("Forecast probe"), "{md}");
    let probe_run: Value = serde_json::from_str(&std::fs::read_to_string(out.join("probe/run.json")).unwrap()).unwrap();
    assert_eq!(probe_run["config"]["probe"], "forecast");
    // Resuming the probe run without the probe is refused.
    let refused = eval(&server.base_url(), &out, "probe", &args).output().unwrap();
    assert!(!refused.status.success());
    assert!(String::from_utf8_lossy(&refused.stderr).contains("probe"));
    // The report's forecast table: the model's rows, then the references'.
    let rep = out.join("report");
    let status = negotiator()
        .args(["report", "--quiet", "--format", "md", "--out"])
        .arg(&rep)
        .arg(out.join("probe"))
        .status()
        .unwrap();
    assert!(status.success());
    let csv = std::fs::read_to_string(rep.join("forecast.csv")).unwrap();
    assert!(csv.contains("rules*") && csv.contains("same_future*") && csv.contains("scripted"), "{csv}");
    let figure = std::fs::read_to_string(rep.join("plots/forecast_by_turn.svg")).unwrap();
    assert!(figure.contains("scripted") && figure.contains("rules* (reference)"), "{figure}");
    // A report of runs without the probe has neither the table nor the figure.
    let plain = out.join("report-plain");
    let status = negotiator().args(["report", "--quiet", "--out"]).arg(&plain).arg(out.join("plain")).status().unwrap();
    assert!(status.success());
    assert!(!plain.join("forecast.csv").exists() && !plain.join("plots/forecast_by_turn.svg").exists());
}

/// The constant-velocity reference is taken from the scene as printed: a
/// model that forecasts constant velocity from the text it reads (here
/// `serve --forecaster constant_velocity`, reading the scene back) makes
/// exactly the reference's errors, a skill of 0.00 in every cell, noisy
/// tiers included.
#[test]
fn a_constant_velocity_forecast_read_from_the_text_scores_a_skill_of_zero_in_every_cell() {
    let server = Server::start(&["--policy", "expert", "--probe", "forecast", "--forecaster", "constant_velocity"]);
    let out = scratch("forecast-cv");
    let args = ["--probe", "forecast", "--scenario", "all", "--tier", "all", "-n", "4"];
    crate::support::ok(eval(&server.base_url(), &out, "cv", &args));
    let summary: Value = serde_json::from_str(&std::fs::read_to_string(out.join("cv/summary.json")).unwrap()).unwrap();
    let cells = summary["cells"].as_array().unwrap();
    assert_eq!(cells.len(), crate::support::cells());
    for cell in cells {
        let f = &cell["forecast"];
        assert_eq!(f["probe_error_rate"], 0.0, "{cell}");
        for k in 0..2 {
            assert_eq!(f["error_true_m"][k], f["cv_error_true_m"][k], "{cell}");
            assert_eq!(f["error_other_m"][k], f["cv_error_other_m"][k], "{cell}");
            // NaN (no constant-velocity error to beat) is written as null.
            for skill in [&f["skill_true"][k], &f["skill_other"][k]] {
                assert!(skill.is_null() || skill.as_f64() == Some(0.0), "{cell}");
            }
        }
        assert!(f["skill_true"][1].as_f64() == Some(0.0), "{cell}");
    }
}

#[test]
fn a_missing_or_malformed_forecast_is_a_probe_error_and_both_probes_combine() {
    // A server without the probe: every forecast is missing, every belief
    // too, and the actions are read as ever.
    let server = Server::start(&["--policy", "expert"]);
    let out = scratch("forecast-missing");
    let args = ["--probe", "belief,forecast", "--scenario", "contested_merge", "--tier", "1", "-n", "3"];
    crate::support::ok(eval(&server.base_url(), &out, "run", &args));
    for line in lines(&out.join("run")) {
        assert_eq!(line["parse_error_turns"], 0);
        assert_eq!(line["forecast"]["probe_errors"], line["turns_taken"]);
        assert_eq!(line["belief"]["probe_errors"], line["turns_taken"]);
        for t in line["turns"].as_array().unwrap() {
            assert_eq!(t["forecast_error"]["kind"], "missing");
        }
    }
    let run: Value = serde_json::from_str(&std::fs::read_to_string(out.join("run/run.json")).unwrap()).unwrap();
    assert_eq!(run["config"]["probe"], "belief,forecast");
}

/// The references scored along an episode: the oracle that knows both
/// worlds' futures scores 0 under both intents; the same future under both
/// scores 0 under the true one only; and before the reveal knowing the
/// disposition gains nothing, since the twin is where the episode is.
#[test]
fn twin_driven_references_score_zero_where_they_should_and_knowing_the_disposition_gains_nothing_before_the_reveal() {
    let set = ScenarioSet::default();
    let same_future = Reference::ALL.iter().position(|r| *r == Reference::SameFuture).unwrap();
    for kind in ScenarioKind::ALL {
        for tier in Tier::ALL {
            let mut apart_after = 0.0;
            for seed in 70_000..70_040 {
                let mut policy = PolicyKind::Expert.build();
                let config = set.get(kind);
                let (record, scores, truth) = play_with_references_and_truth(config, tier, seed, policy.as_mut());
                let s = scores[same_future];
                assert_eq!(s.error_true_sum_m, [0.0, 0.0], "{kind} t{tier} seed {seed}");
                apart_after += s.error_other_sum_m[1];
                // The oracle: each intent's own world.
                let relative = kind.positions_relative_to_ego();
                let oracle: Vec<negotiator::forecast::ForecastTurn> = (0..truth.len())
                    .map(|i| {
                        let at = |other: bool| -> Vec<[f64; 2]> {
                            (0..truth[i].actual.len())
                                .map(|r| {
                                    HORIZONS_S.map(|h| {
                                        let j = (i + (h / 0.5) as usize).min(truth.len() - 1);
                                        let shift =
                                            if relative { truth[j].ego_travel_m - truth[i].ego_travel_m } else { 0.0 };
                                        (if other { truth[j].other[r] } else { truth[j].actual[r] }) + shift
                                    })
                                })
                                .collect()
                        };
                        let lets = record.disposition.ego_should_go();
                        let (lets_you_go, does_not) = if lets { (at(false), at(true)) } else { (at(true), at(false)) };
                        negotiator::forecast::ForecastTurn {
                            turn: i as u32 + 1,
                            time_s: truth[i].time_s,
                            forecast: Some(negotiator::forecast::Forecast { lets_you_go, does_not }),
                            constant_velocity: at(false),
                        }
                    })
                    .collect();
                let m = negotiator::forecast::ForecastMetrics::compute(
                    kind,
                    &oracle,
                    &truth,
                    record.disposition.ego_should_go(),
                    record.timing.evidence_turn,
                );
                assert!(m.points[1] > 0);
                assert_eq!((m.error_true_sum_m, m.error_other_sum_m), ([0.0; 2], [0.0; 2]), "{kind} t{tier} {seed}");
                for t in truth.iter().filter(|t| !t.revealed) {
                    assert_eq!(t.actual, t.other, "{kind} t{tier} seed {seed} at {} s", t.time_s);
                }
            }
            // The worlds part after the evidence: one future for both
            // intents is wrong about the other.
            assert!(apart_after > 0.0, "{kind} t{tier}");
        }
    }
}

/// What the probe adds that a player sees (the prompt's paragraph, and the
/// rules forecaster's answer from the scene) is the same under both
/// dispositions until the evidence.
#[test]
fn the_probes_sentence_and_the_served_forecast_are_the_same_under_both_dispositions_before_the_evidence() {
    let set = ScenarioSet::default();
    for kind in ScenarioKind::ALL {
        let [a, b] = kind.dispositions();
        for tier in Tier::ALL {
            for seed in 71_000..71_020 {
                let config = set.get(kind);
                let mut first = Episode::with_disposition(config, tier, seed, a);
                let mut second = Episode::with_disposition(config, tier, seed, b);
                let mut policy = PolicyKind::Expert.build();
                let mut rules = ForecasterKind::Rules.build();
                while !first.is_done() && !second.is_done() {
                    let (tx, ty) = (render_scene(first.observation()), render_scene(second.observation()));
                    if tx != ty {
                        break;
                    }
                    let (px, py) = (parse_scene(&tx).unwrap(), parse_scene(&ty).unwrap());
                    assert_eq!(rules.forecast(&px), rules.forecast(&py), "{kind} t{tier} seed {seed}");
                    let action = policy.act(first.observation());
                    first.step(action);
                    second.step(action);
                }
            }
        }
        let paragraph = negotiator::forecast::prompt_paragraph(kind);
        assert!(paragraph.contains("1 s and 2 s"), "{paragraph}");
    }
}

/// The validate line fails a rules forecaster no better than constant
/// velocity on one cell, and a twin apart from the episode before the
/// reveal; it passes the committed worlds' figures.
#[test]
fn the_forecast_line_catches_a_forecaster_no_better_than_constant_velocity_and_a_twin_that_leaks() {
    use negotiator::forecast::{ForecastMetrics, ForecastSummary};
    use negotiator::validate::{ForecastCell, check_forecast};
    let summary = |error: f64, cv: f64| {
        let m = ForecastMetrics {
            stated_turns: 10,
            points: [10, 10],
            error_true_sum_m: [error * 10.0; 2],
            cv_error_true_sum_m: [cv * 10.0; 2],
            ..ForecastMetrics::default()
        };
        ForecastSummary::of(std::iter::once(&m))
    };
    let cell = |scenario, error, apart| ForecastCell {
        scenario,
        tier: Tier::T1,
        rules: summary(error, 1.0),
        before_reveal: 100,
        twin_apart: apart,
    };
    let good = [cell(ScenarioKind::YieldStandoff, 0.5, 0), cell(ScenarioKind::ContestedMerge, 0.9, 0)];
    assert!(check_forecast(&good).pass, "{}", check_forecast(&good).figure);
    let flat = [cell(ScenarioKind::YieldStandoff, 0.5, 0), cell(ScenarioKind::ContestedMerge, 1.0, 0)];
    let c = check_forecast(&flat);
    assert!(!c.pass && c.figure.contains("0.00 on contested_merge/t1"), "{}", c.figure);
    let leak = [cell(ScenarioKind::YieldStandoff, 0.5, 1)];
    let c = check_forecast(&leak);
    assert!(!c.pass && c.figure.contains("at 1 of 100 decisions"), "{}", c.figure);
}
