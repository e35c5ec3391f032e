//! The expert ceiling and the `always_proceed` floor: read from the
//! committed baseline table (`baselines.csv` in `--baselines DIR`, default
//! `results/baselines`), or, when the default directory is absent, computed
//! in-process with the built-in scenarios (n = 200 seeds from 0, the same
//! protocol as `negotiator baselines`, about 30 ms).

use super::ReportError;
use crate::baselines::{GridSpec, run_grid};
use crate::policy::PolicyKind;
use crate::scenario::{ScenarioKind, ScenarioSet, Tier};
use serde::{Deserialize, Serialize};
use std::path::Path;

pub(crate) const CEILING: &str = "expert";
pub(crate) const FLOOR: &str = "always_proceed";

/// One baseline cell (normal-approximation intervals, as in the table).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ReferenceCell {
    pub scenario: ScenarioKind,
    pub tier: Tier,
    pub policy: String,
    pub n: usize,
    pub success: f64,
    pub success_lo: f64,
    pub success_hi: f64,
    pub decision_correctness: f64,
    /// Share of the committed episodes that committed before the evidence
    /// (absent from baseline tables written before evidence timing).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub guess_rate: Option<f64>,
    /// Mean turns from the evidence to the commitment.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub evidence_lag: Option<f64>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct References {
    /// Where the cells came from.
    pub source: String,
    pub cells: Vec<ReferenceCell>,
}

impl References {
    fn cell(&self, policy: &str, scenario: ScenarioKind, tier: Tier) -> Option<&ReferenceCell> {
        self.cells.iter().find(|c| c.policy == policy && c.scenario == scenario && c.tier == tier)
    }

    /// Success of `policy` on `scenario`, averaged over `tiers` (every tier
    /// must be in the table).
    pub(crate) fn success(&self, policy: &str, scenario: ScenarioKind, tiers: &[Tier]) -> Option<f64> {
        let xs: Option<Vec<f64>> = tiers.iter().map(|&t| self.cell(policy, scenario, t).map(|c| c.success)).collect();
        let xs = xs?;
        (!xs.is_empty()).then(|| xs.iter().sum::<f64>() / xs.len() as f64)
    }

    /// Decision correctness of `policy`, averaged like [`Self::success`].
    pub(crate) fn correctness(&self, policy: &str, scenario: ScenarioKind, tiers: &[Tier]) -> Option<f64> {
        let xs: Option<Vec<f64>> =
            tiers.iter().map(|&t| self.cell(policy, scenario, t).map(|c| c.decision_correctness)).collect();
        let xs = xs?;
        (!xs.is_empty()).then(|| xs.iter().sum::<f64>() / xs.len() as f64)
    }

    /// Guess rate of `policy`, averaged like [`Self::success`].
    pub(crate) fn guess_rate(&self, policy: &str, scenario: ScenarioKind, tiers: &[Tier]) -> Option<f64> {
        mean_over(tiers, |t| self.cell(policy, scenario, t).and_then(|c| c.guess_rate))
    }

    /// Evidence-to-commitment lag of `policy`, averaged like [`Self::success`].
    pub(crate) fn evidence_lag(&self, policy: &str, scenario: ScenarioKind, tiers: &[Tier]) -> Option<f64> {
        mean_over(tiers, |t| self.cell(policy, scenario, t).and_then(|c| c.evidence_lag))
    }
}

/// Mean of a finite value over every tier (None if a tier lacks it).
fn mean_over(tiers: &[Tier], value: impl Fn(Tier) -> Option<f64>) -> Option<f64> {
    let xs: Option<Vec<f64>> = tiers.iter().map(|&t| value(t).filter(|x| x.is_finite())).collect();
    let xs = xs?;
    (!xs.is_empty()).then(|| xs.iter().sum::<f64>() / xs.len() as f64)
}

/// Read the reference cells in `dir`: each scenario's own table
/// (`<scenario>.csv`, as the committed ones are kept, each written by
/// `negotiator baselines --scenario <scenario> --format csv`) and a whole
/// grid's `baselines.csv` (as `negotiator baselines --format csv` writes
/// it), a scenario's own table first. A scenario no table covers is run
/// in-process (a new scenario before its table is committed), and the
/// source says so. `explicit`: the directory was given with `--baselines`;
/// then a directory without any table is an error (otherwise everything is
/// computed in-process).
pub(crate) fn load(dir: &Path, explicit: bool) -> Result<References, ReportError> {
    let mut files: Vec<std::path::PathBuf> = ScenarioKind::ALL.iter().map(|k| dir.join(format!("{k}.csv"))).collect();
    files.push(dir.join("baselines.csv"));
    let mut cells: Vec<ReferenceCell> = Vec::new();
    let mut sources = Vec::new();
    for path in files {
        let bad = |message: String| ReportError::Baselines { path: path.display().to_string(), message };
        let text = match std::fs::read_to_string(&path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => continue,
            Err(e) => return Err(bad(e.to_string())),
        };
        let mut reader = csv::Reader::from_reader(text.as_bytes());
        let mut references = 0;
        for (i, row) in reader.deserialize::<ReferenceCell>().enumerate() {
            let cell = row.map_err(|e| bad(format!("row {}: {e}", i + 1)))?;
            if ![CEILING, FLOOR].contains(&cell.policy.as_str()) {
                continue;
            }
            references += 1;
            let key = (cell.scenario, cell.tier, cell.policy.as_str());
            if !cells.iter().any(|c| (c.scenario, c.tier, c.policy.as_str()) == key) {
                cells.push(cell);
            }
        }
        if references == 0 {
            return Err(bad(format!("no '{CEILING}' or '{FLOOR}' rows")));
        }
        sources.push(path.display().to_string());
    }
    if sources.is_empty() {
        if explicit {
            let path = dir.join("<scenario>.csv or baselines.csv").display().to_string();
            return Err(ReportError::Baselines { path, message: "no baseline table".into() });
        }
        return Ok(compute());
    }
    let missing: Vec<ScenarioKind> =
        ScenarioKind::ALL.into_iter().filter(|k| !cells.iter().any(|c| c.scenario == *k)).collect();
    if !missing.is_empty() {
        cells.extend(compute_for(&missing).cells);
        let names: Vec<String> = missing.iter().map(ToString::to_string).collect();
        sources.push(format!("computed in-process for {} (no table in {})", names.join(", "), dir.display()));
    }
    Ok(References { source: sources.join("; "), cells })
}

/// The two reference policies on every scenario and tier, n = 200.
pub(crate) fn compute() -> References {
    compute_for(&ScenarioKind::ALL)
}

/// The two reference policies on `scenarios`, every tier, n = 200.
fn compute_for(scenarios: &[ScenarioKind]) -> References {
    let spec = GridSpec {
        scenarios: scenarios.to_vec(),
        tiers: Tier::ALL.to_vec(),
        policies: vec![PolicyKind::Expert, PolicyKind::AlwaysProceed],
        episodes: 200,
        seed_base: 0,
    };
    let cells = run_grid(&ScenarioSet::default(), &spec, &|_, _| {})
        .into_iter()
        .map(|c| ReferenceCell {
            scenario: c.cell.scenario,
            tier: c.cell.tier,
            policy: c.cell.policy.to_string(),
            n: c.n,
            success: c.success.estimate,
            success_lo: c.success.lo,
            success_hi: c.success.hi,
            decision_correctness: c.decision_correctness.estimate,
            guess_rate: Some(c.guess_rate.estimate).filter(|x| x.is_finite()),
            evidence_lag: Some(c.evidence_lag.estimate).filter(|x| x.is_finite()),
        })
        .collect();
    References { source: "computed in-process (built-in scenarios, n = 200; no baseline table found)".into(), cells }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn committed_table_and_in_process_cover_every_cell() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("results/baselines");
        let table = load(&dir, true).unwrap();
        let computed = compute();
        for refs in [&table, &computed] {
            for policy in [CEILING, FLOOR] {
                for s in ScenarioKind::ALL {
                    let x = refs.success(policy, s, &Tier::ALL).unwrap();
                    assert!((0.0..=1.0).contains(&x), "{policy} {s}: {x}");
                }
            }
        }
        // The ceiling's and the floor's row of every cell.
        assert_eq!(table.cells.len(), 2 * ScenarioKind::ALL.len() * Tier::ALL.len());
        assert!(table.success("cue_follower", ScenarioKind::YieldStandoff, &[Tier::T1]).is_none());
        assert!(load(Path::new("/nonexistent"), true).is_err());
        assert!(load(Path::new("/nonexistent"), false).unwrap().source.contains("in-process"));
    }

    /// The committed tables are one file per scenario; a scenario without
    /// one (a new scenario) is run in-process beside them, and the source
    /// says which.
    #[test]
    fn a_scenario_without_its_table_is_run_in_process_beside_the_others() {
        let committed = Path::new(env!("CARGO_MANIFEST_DIR")).join("results/baselines");
        let dir = std::env::temp_dir().join(format!("negotiator-refs-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let [first, rest @ ..] = ScenarioKind::ALL;
        // (A scenario the tests add has no committed table: in-process too.)
        for k in rest.iter().filter(|k| committed.join(format!("{k}.csv")).exists()) {
            std::fs::copy(committed.join(format!("{k}.csv")), dir.join(format!("{k}.csv"))).unwrap();
        }
        let refs = load(&dir, true).unwrap();
        assert_eq!(refs.cells.len(), 2 * ScenarioKind::ALL.len() * Tier::ALL.len());
        let in_process = |r: &References| r.source.split("computed in-process for ").nth(1).map(str::to_string);
        assert!(in_process(&refs).is_some_and(|s| s.starts_with(first.name())), "{}", refs.source);
        let whole = load(&committed, true).unwrap();
        assert_eq!(refs.success(CEILING, first, &Tier::ALL), whole.success(CEILING, first, &Tier::ALL));
        assert!(!in_process(&whole).is_some_and(|s| s.contains(first.name())), "{}", whole.source);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
