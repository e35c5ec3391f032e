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
