//! Which episodes the trajectory figures and the maneuver timelines draw.
//!
//! Trajectories: the episodes named with `--episode`, else per (model,
//! scenario) in the leaderboard scope the first collision by seed, else the
//! first timeout, else the first success, among the episodes whose
//! transcripts were read. Timelines: for each (scenario, tier, seed) drawn
//! as a trajectory, every model's episode of that seed (the same rollout
//! when the model has it, else its lowest), so the rows compare models on
//! one situation.

use super::ReportError;
use super::drill::{self, Loaded};
use super::load::Dataset;
use super::tables::Leaderboard;
use crate::episode::Outcome;
use crate::scenario::{ScenarioKind, Tier};
use std::str::FromStr;

/// One `--episode MODEL:SCENARIO:TIER:SEED[:ROLLOUT]` value.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EpisodePick {
    /// As given (for error messages).
    pub given: String,
    /// A model label as the report prints it (`model` or `model (hash8)`).
    pub model: String,
    pub scenario: ScenarioKind,
    pub tier: Tier,
    pub seed: u64,
    /// `None`: the model's lowest rollout of that seed.
    pub rollout: Option<u32>,
}

/// A malformed `--episode` value; the message names the flag and the value.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("--episode '{given}': {message}")]
pub struct BadPick {
    pub given: String,
    pub message: String,
}

/// The form `--episode` expects, for messages.
pub const PICK_FORM: &str = "MODEL:SCENARIO:TIER:SEED[:ROLLOUT]";

impl FromStr for EpisodePick {
    type Err = BadPick;

    /// Fields are read from the right, so a model name may itself hold
    /// colons (`qwen3:30b:pedestrian_feint:1:4`): with five fields or more
    /// the last four are tried as SCENARIO:TIER:SEED:ROLLOUT, then the last
    /// three as SCENARIO:TIER:SEED.
    fn from_str(given: &str) -> Result<Self, Self::Err> {
        let bad = |message: String| BadPick { given: given.to_string(), message };
        let parts: Vec<&str> = given.split(':').collect();
        if parts.len() < 4 {
            return Err(bad(format!("expected {PICK_FORM}")));
        }
        let with_rollout = if parts.len() >= 5 { Some(fields(&parts, 4)) } else { None };
        let picked = match with_rollout {
            Some(Ok(p)) => Ok(p),
            // The 4-field reading failed: report its error only when its scenario was one.
            Some(Err(e)) if parts[parts.len() - 4].parse::<ScenarioKind>().is_ok() => fields(&parts, 3).map_err(|_| e),
            _ => fields(&parts, 3),
        };
        let (model, scenario, tier, seed, rollout) = picked.map_err(bad)?;
        if model.is_empty() {
            return Err(bad(format!("empty model name (expected {PICK_FORM})")));
        }
        Ok(EpisodePick { given: given.to_string(), model, scenario, tier, seed, rollout })
    }
}

type Fields = (String, ScenarioKind, Tier, u64, Option<u32>);

/// The last `k` fields (3: SCENARIO:TIER:SEED, 4: with ROLLOUT) and the
/// model before them.
fn fields(parts: &[&str], k: usize) -> Result<Fields, String> {
    let at = parts.len() - k;
    let scenario: ScenarioKind = parts[at].parse().map_err(|e: crate::scenario::UnknownScenario| e.to_string())?;
    let tier: Tier = parts[at + 1].parse().map_err(|e: crate::scenario::UnknownTier| e.to_string())?;
    let seed: u64 = parts[at + 2].parse().map_err(|_| format!("seed '{}' is not a whole number", parts[at + 2]))?;
    let rollout = match parts.get(at + 3) {
        Some(r) => Some(r.parse::<u32>().map_err(|_| format!("rollout '{r}' is not a whole number"))?),
        None => None,
    };
    Ok((parts[..at].join(":"), scenario, tier, seed, rollout))
}

/// The named episodes as (model, episode index), in the order given, each
/// once. Errors name the value: an unknown model (with the models there
/// are) or an episode no run of the model holds.
pub(crate) fn resolve(picks: &[EpisodePick], data: &Dataset) -> Result<Vec<(usize, usize)>, ReportError> {
    let mut out: Vec<(usize, usize)> = Vec::new();
    for p in picks {
        let bad = |message: String| ReportError::Pick(BadPick { given: p.given.clone(), message });
        let Some(m) = data.models.iter().position(|d| d.label == p.model) else {
            let labels: Vec<&str> = data.models.iter().map(|d| d.label.as_str()).collect();
            return Err(bad(format!("unknown model '{}' (the runs hold: {})", p.model, labels.join(", "))));
        };
        let same_seed = |e: &&super::load::Episode| e.scenario == p.scenario && e.tier == p.tier && e.seed == p.seed;
        let episodes = &data.models[m].episodes;
        let found = match p.rollout {
            Some(r) => episodes.iter().position(|e| same_seed(&e) && e.rollout == r),
            None => {
                episodes.iter().enumerate().filter(|(_, e)| same_seed(e)).min_by_key(|(_, e)| e.rollout).map(|(i, _)| i)
            }
        };
        let Some(i) = found else {
            let rollout = p.rollout.map_or(String::new(), |r| format!(" rollout {r}"));
            return Err(bad(format!(
                "no such episode in the runs of '{}' ({} tier {} seed {}{rollout} was not run or did not finish)",
                p.model, p.scenario, p.tier, p.seed
            )));
        };
        if !out.contains(&(m, i)) {
            out.push((m, i));
        }
    }
    Ok(out)
}

fn outcome_rank(o: Outcome) -> u8 {
    match o {
        Outcome::Collision => 0,
        Outcome::Timeout => 1,
        Outcome::Success => 2,
    }
}

/// The default trajectory episodes: per model (leaderboard order) and
/// scenario in scope, the first collision by (tier, seed, rollout), else
/// timeout, else success, among `transcripts` with a recorded trajectory.
pub(crate) fn default_trajectories(lb: &Leaderboard, data: &Dataset, transcripts: &[Loaded]) -> Vec<Loaded> {
    let mut out = Vec::new();
    for row in &lb.rows {
        let Some(m) = data.models.iter().position(|d| d.label == row.model) else { continue };
        for &s in &lb.scenarios {
            let best = transcripts
                .iter()
                .filter(|l| {
                    l.model == m
                        && l.record.scenario == s
                        && lb.tiers.contains(&l.record.tier)
                        && l.record.trajectory.as_ref().is_some_and(|t| !t.is_empty())
                })
                .min_by_key(|l| (outcome_rank(l.record.outcome), l.record.tier, l.record.seed, l.record.rollout));
            out.extend(best.cloned());
        }
    }
    out
}

/// The episodes the default maneuver timelines are drawn for: per model
/// and scenario, its trajectory episode, or, when none of its transcripts
/// has a trajectory (runs made with `--no-trajectories`), the episode the
/// same rule picks among them all (a timeline needs only the turns).
pub(crate) fn default_timeline_sources(
    lb: &Leaderboard,
    data: &Dataset,
    transcripts: &[Loaded],
    trajectories: &[Loaded],
) -> Vec<Loaded> {
    let mut out = Vec::new();
    for row in &lb.rows {
        let Some(m) = data.models.iter().position(|d| d.label == row.model) else { continue };
        for &s in &lb.scenarios {
            let of = |l: &&Loaded| l.model == m && l.record.scenario == s;
            let best =
                trajectories.iter().find(of).or_else(|| {
                    transcripts.iter().filter(of).filter(|l| lb.tiers.contains(&l.record.tier)).min_by_key(|l| {
                        (outcome_rank(l.record.outcome), l.record.tier, l.record.seed, l.record.rollout)
                    })
                });
            out.extend(best.cloned());
        }
    }
    out
}

/// One maneuver timeline: a (scenario, tier, seed) and every model's
/// episode of it, one row per model in the models' (leaderboard) order.
#[derive(Debug, Clone)]
pub struct Timeline {
    pub scenario: ScenarioKind,
    pub tier: Tier,
    pub seed: u64,
    /// The rollout preferred in every row.
    pub rollout: u32,
    /// Per model: its episode of the seed, or `None` when it has none.
    pub rows: Vec<Option<Loaded>>,
}

/// The timelines of the `sources`' (scenario, tier, seed)s, in the
/// sources' order, each once. Episodes not among `known` are read.
pub(crate) fn timelines(data: &Dataset, sources: &[Loaded], known: &[Loaded]) -> Result<Vec<Timeline>, ReportError> {
    let mut keys: Vec<(ScenarioKind, Tier, u64, u32)> = Vec::new();
    for l in sources {
        let r = &l.record;
        if !keys.iter().any(|k| (k.0, k.1, k.2) == (r.scenario, r.tier, r.seed)) {
            keys.push((r.scenario, r.tier, r.seed, r.rollout));
        }
    }
    // Per key and model, the episode index (same rollout, else the lowest).
    let wanted: Vec<Vec<Option<usize>>> = keys
        .iter()
        .map(|&(s, t, seed, rollout)| {
            data.models
                .iter()
                .map(|m| {
                    let of_seed =
                        m.episodes.iter().enumerate().filter(|(_, e)| (e.scenario, e.tier, e.seed) == (s, t, seed));
                    of_seed.min_by_key(|(_, e)| (e.rollout != rollout, e.rollout)).map(|(i, _)| i)
                })
                .collect()
        })
        .collect();
    let have = |m: usize, i: usize| known.iter().chain(sources).find(|l| (l.model, l.episode) == (m, i));
    let mut missing: Vec<(usize, usize)> = Vec::new();
    for row in &wanted {
        for (m, i) in row.iter().enumerate() {
            if let Some(i) = *i
                && have(m, i).is_none()
                && !missing.contains(&(m, i))
            {
                missing.push((m, i));
            }
        }
    }
    let read = drill::load(data, &missing)?;
    let find =
        |m: usize, i: usize| have(m, i).or_else(|| read.iter().find(|l| (l.model, l.episode) == (m, i))).cloned();
    Ok(keys
        .iter()
        .zip(wanted)
        .map(|(&(scenario, tier, seed, rollout), row)| Timeline {
            scenario,
            tier,
            seed,
            rollout,
            rows: row.iter().enumerate().map(|(m, i)| i.and_then(|i| find(m, i))).collect(),
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn picks_are_read_from_the_right() {
        let p: EpisodePick = "qwen3:30b:pedestrian_feint:2:17:1".parse().unwrap();
        assert_eq!(
            (p.model.as_str(), p.scenario, p.tier, p.seed, p.rollout),
            ("qwen3:30b", ScenarioKind::PedestrianFeint, Tier::T2, 17, Some(1))
        );
        let p: EpisodePick = "gpt-4o (1a2b3c4d):contested_merge:1:3".parse().unwrap();
        assert_eq!((p.model.as_str(), p.rollout), ("gpt-4o (1a2b3c4d)", None));
        let err = |s: &str| s.parse::<EpisodePick>().unwrap_err().to_string();
        let unknown = err("m:merge:1:3");
        assert!(unknown.starts_with("--episode 'm:merge:1:3': unknown scenario 'merge' (expected yield_standoff, "));
        assert!(ScenarioKind::ALL.iter().all(|k| unknown.contains(k.name())), "{unknown}");
        assert_eq!(
            err("m:contested_merge:4:3"),
            "--episode 'm:contested_merge:4:3': unknown tier '4' (expected 1, 2 or 3)"
        );
        assert_eq!(err("m:contested_merge:1:x"), "--episode 'm:contested_merge:1:x': seed 'x' is not a whole number");
        assert_eq!(
            err("m:contested_merge:1:2:-1"),
            "--episode 'm:contested_merge:1:2:-1': rollout '-1' is not a whole number"
        );
        assert_eq!(err("m:1:2"), "--episode 'm:1:2': expected MODEL:SCENARIO:TIER:SEED[:ROLLOUT]");
        assert!(err(":yield_standoff:1:2").contains("empty model name"));
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]
        #[test]
        fn any_model_name_round_trips(
            model in "[a-z0-9:/_ ().-]{1,24}",
            scenario in 0usize..3,
            tier in 0usize..3,
            seed in any::<u64>(),
            rollout in proptest::option::of(any::<u32>()),
        ) {
            let (scenario, tier) = (ScenarioKind::ALL[scenario], Tier::ALL[tier]);
            let text = format!("{model}:{scenario}:{tier}:{seed}{}", rollout.map_or(String::new(), |r| format!(":{r}")));
            let p: EpisodePick = text.parse().unwrap();
            prop_assert_eq!((p.model.as_str(), p.scenario, p.tier, p.seed, p.rollout), (model.as_str(), scenario, tier, seed, rollout));
        }
    }
}
