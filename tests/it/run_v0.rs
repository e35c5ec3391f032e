//! The version-0 run directories in `tests/fixtures/run_v0/` (written before
//! the run-directory schema was versioned): `report` must read them and give
//! byte-identical output to the golden files in `expected/`.

use crate::support::{negotiator, scratch};
use std::path::Path;

const FIXTURE: &str = "tests/fixtures/run_v0";

/// The golden report.json stores the crate version as `VERSION`.
fn normalise_version(report_json: &str) -> String {
    report_json.replacen(
        &format!("\"negotiator_version\": \"{}\",", env!("CARGO_PKG_VERSION")),
        "\"negotiator_version\": \"VERSION\",",
        1,
    )
}

#[test]
fn report_on_the_v0_fixture_is_byte_identical_to_the_golden_files() {
    let out = scratch("golden-v0");
    // Paths are reported as given, so run from the crate root with the same
    // relative paths the golden files were made with.
    let result = negotiator()
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["report", "-q", "--baselines", &format!("{FIXTURE}/baselines"), "--out"])
        .arg(&out)
        .args([format!("{FIXTURE}/expert"), format!("{FIXTURE}/cue_follower")])
        .output()
        .unwrap();
    assert!(result.status.success(), "{}", String::from_utf8_lossy(&result.stderr));
    let expected = Path::new(env!("CARGO_MANIFEST_DIR")).join(FIXTURE).join("expected");
    for file in ["report.md", "leaderboard.csv", "report.json"] {
        let got = std::fs::read_to_string(out.join(file)).unwrap();
        let got = if file == "report.json" { normalise_version(&got) } else { got };
        let want = std::fs::read_to_string(expected.join(file)).unwrap();
        if got != want {
            let line = got.lines().zip(want.lines()).position(|(g, w)| g != w);
            let line = line.unwrap_or(got.lines().count().min(want.lines().count())) + 1;
            panic!(
                "{file} differs from {} (first differing line {line}: got {:?}, want {:?})",
                expected.join(file).display(),
                got.lines().nth(line.saturating_sub(1)).unwrap_or(""),
                want.lines().nth(line.saturating_sub(1)).unwrap_or("")
            );
        }
    }
    let _ = std::fs::remove_dir_all(&out);
}

/// Copy a fixture run directory into `dest`.
fn copy_run(name: &str, dest: &Path) {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join(FIXTURE).join(name);
    std::fs::create_dir_all(dest).unwrap();
    for file in ["run.json", "rollouts.jsonl"] {
        std::fs::copy(src.join(file), dest.join(file)).unwrap();
    }
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

#[test]
fn the_v0_fixture_loads_with_every_episode_and_no_missing_one() {
    use negotiator::report::load;
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join(FIXTURE);
    let data = load::load(&[root.join("expert"), root.join("cue_follower")]).unwrap();
    assert!(data.warnings.is_empty(), "{:?}", data.warnings);
    let models: Vec<(&str, usize, Option<usize>, u32)> =
        data.models.iter().map(|m| (m.model.as_str(), m.episodes.len(), m.missing(), m.rollouts)).collect();
    assert_eq!(models, [("expert", 54, Some(0), 2), ("cue_follower", 54, Some(0), 2)]);
    // Version 0 lines carry no schema_version: read as 0.
    assert!(data.models.iter().flat_map(|m| &m.episodes).all(|e| e.schema_version == 0));
    assert_eq!(data.runs[0].shard.as_deref(), Some("1/1"));
}

/// `eval` refuses to resume a version-0 run written with other scenario
/// parameters (the built-in scenarios have changed since): the refusal names
/// the changed field and touches nothing. A new run of the current version
/// beside it, and the old run, are read by one `report`.
#[test]
fn eval_refuses_a_changed_v0_run_and_report_reads_old_and_new_runs() {
    let server = crate::support::Server::start(&["--policy", "expert"]);
    let root = scratch("resume-v0");
    copy_run("expert", &root.join("expert"));
    let before = std::fs::read(root.join("expert/rollouts.jsonl")).unwrap();
    let eval = |name: &str| {
        negotiator()
            .args(["eval", "--base-url", &server.base_url(), "--model", "expert", "--quiet", "--output"])
            .arg(&root)
            .args(["--run-name", name, "--scenario", "all", "--tier", "all", "-r", "2", "-n", "3"])
            .args(["--no-trajectories", "-c", "4"])
            .output()
            .unwrap()
    };
    let refused = eval("expert");
    assert_eq!(refused.status.code(), Some(2), "{}", String::from_utf8_lossy(&refused.stderr));
    assert!(String::from_utf8_lossy(&refused.stderr).contains("scenarios_hash"));
    assert_eq!(std::fs::read(root.join("expert/rollouts.jsonl")).unwrap(), before, "nothing touched");
    let fresh = eval("expert-now");
    assert!(fresh.status.success(), "{}", String::from_utf8_lossy(&fresh.stderr));
    let text = std::fs::read_to_string(root.join("expert-now/rollouts.jsonl")).unwrap();
    let new: Vec<serde_json::Value> = text.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(new.len(), 2 * 3 * crate::support::cells());
    assert!(new.iter().all(|l| l["schema_version"] == negotiator::rundir::SCHEMA_VERSION));
    // The evidence timing is in every new line.
    assert!(new.iter().all(|l| l.get("evidence_turn").is_some() && l.get("commitment_turn").is_some()));

    let out = root.join("report");
    let report = negotiator()
        .args(["report", "-q", "--baselines", &format!("{}/{FIXTURE}/baselines", env!("CARGO_MANIFEST_DIR"))])
        .arg("--out")
        .arg(&out)
        .arg(root.join("expert"))
        .arg(root.join("expert-now"))
        .output()
        .unwrap();
    assert!(report.status.success(), "{}", String::from_utf8_lossy(&report.stderr));
    let report = json(&out.join("report.json"));
    let models = report["models"].as_array().unwrap();
    assert_eq!(models.len(), 2, "two configurations, two rows");
    // The fixture's 54 episodes, and the new run's of every scenario.
    let episodes: Vec<u64> = models.iter().map(|m| m["episodes"].as_u64().unwrap()).collect();
    assert!(episodes.contains(&54) && episodes.contains(&(2 * 3 * crate::support::cells() as u64)), "{episodes:?}");
    assert!(report["runs"].as_array().unwrap().iter().all(|r| r["bad_lines"] == 0));
    let _ = std::fs::remove_dir_all(&root);
}
