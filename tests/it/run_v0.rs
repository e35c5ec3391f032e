//! The version-0 run directories in `tests/fixtures/run_v0/` (written before
//! the run-directory schema was versioned): `report` must read them and give
//! byte-identical output to the golden files in `expected/`.

use crate::serve::{negotiator, scratch};
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
        data.models.iter().map(|m| (m.model.as_str(), m.episodes.len(), m.missing, m.rollouts)).collect();
    assert_eq!(models, [("expert", 54, Some(0), 2), ("cue_follower", 54, Some(0), 2)]);
    // Version 0 lines carry no schema_version: read as 0.
    assert!(data.models.iter().flat_map(|m| &m.episodes).all(|e| e.schema_version == 0));
    assert_eq!(data.runs[0].shard.as_deref(), Some("1/1"));
}

/// `eval` resumes a version-0 run directory: nothing is re-run, the
/// selection can be extended, the new lines and run.json carry the current
/// schema version, and `report` reads the mixed file.
#[test]
fn eval_resumes_a_v0_run_and_report_reads_the_mixed_file() {
    let server = crate::serve::Server::start(&["--policy", "expert"]);
    let root = scratch("resume-v0");
    copy_run("expert", &root.join("expert"));
    let before = std::fs::read(root.join("expert/rollouts.jsonl")).unwrap();
    let eval = |seeds: &str| {
        let out = negotiator()
            .args(["eval", "--base-url", &server.base_url(), "--model", "expert", "--quiet", "--output"])
            .arg(&root)
            .args(["--run-name", "expert", "--scenario", "all", "--tier", "all", "-r", "2", "-n", seeds])
            .args(["--no-trajectories", "-c", "4"])
            .output()
            .unwrap();
        assert!(out.status.success(), "exit {:?}: {}", out.status.code(), String::from_utf8_lossy(&out.stderr));
        String::from_utf8(out.stdout).unwrap()
    };
    // The same selection: everything is already there.
    let stdout = eval("3");
    assert!(stdout.contains("54 episodes scored, 0 missing"), "{stdout}");
    assert_eq!(std::fs::read(root.join("expert/rollouts.jsonl")).unwrap(), before, "nothing re-run");
    let run = json(&root.join("expert/run.json"));
    assert_eq!(run["schema_version"], negotiator::rundir::SCHEMA_VERSION);
    assert_eq!((run["invocations"].as_u64(), run["last_invocation"]["status"].as_str()), (Some(2), Some("finished")));
    // One more seed: 3 scenarios x 3 tiers x 2 rollouts new lines, versioned.
    let stdout = eval("4");
    assert!(stdout.contains("72 episodes scored, 0 missing"), "{stdout}");
    let text = std::fs::read_to_string(root.join("expert/rollouts.jsonl")).unwrap();
    assert!(text.as_bytes().starts_with(&before));
    let new: Vec<serde_json::Value> = text[before.len()..].lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(new.len(), 18);
    assert!(new.iter().all(|l| l["schema_version"] == negotiator::rundir::SCHEMA_VERSION && l["seed"] == 3));

    let out = root.join("report");
    let report = negotiator()
        .args(["report", "-q", "--baselines", &format!("{}/{FIXTURE}/baselines", env!("CARGO_MANIFEST_DIR"))])
        .arg("--out")
        .arg(&out)
        .arg(root.join("expert"))
        .output()
        .unwrap();
    assert!(report.status.success(), "{}", String::from_utf8_lossy(&report.stderr));
    let report = json(&out.join("report.json"));
    assert_eq!(report["models"][0]["episodes"], 72);
    assert_eq!(report["runs"][0]["bad_lines"], 0);
    let _ = std::fs::remove_dir_all(&root);
}
