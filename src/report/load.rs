//! Reading run directories: `run.json`, `rollouts.jsonl` (streamed, one
//! line at a time, only the per-episode scalars kept), `errors.jsonl`; and
//! merging them into one episode list per model.
//!
//! A "model" is one run configuration (one config hash). Run directories
//! with the same config hash are shards (or copies) of one run and are
//! joined; the same (scenario, tier, seed, rollout) key twice within a
//! model is an error naming both lines, never a double count.
//!
//! Speed: every line is read (the file is streamed through a 1 MiB
//! buffer), but only its head is parsed. Records written by `eval` put the
//! scalars before the transcript, so the line is cut at its top-level
//! `,"turns":` key and the head (closed with `}`) is deserialized; a line
//! that does not allow this is parsed whole. Files are read in parallel.

use super::ReportError;
use crate::episode::Outcome;
use crate::eval::record::{EpisodeKey, InfraErrorRecord};
use crate::eval::store::{self, ERRORS, ROLLOUTS, RUN_JSON, RunInfo, StoreError};
use crate::par::par_map;
use crate::scenario::{Disposition, ScenarioKind, Tier};
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, HashSet};
use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};

/// Where an episode's line is, for error messages and for re-reading its
/// transcript.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Source {
    /// Index into [`Dataset::runs`].
    pub run: u32,
    /// 1-based line number.
    pub line: u32,
    pub offset: u64,
    pub len: u32,
}

/// The per-episode scalars the report needs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Episode {
    pub scenario: ScenarioKind,
    pub tier: Tier,
    pub seed: u64,
    pub rollout: u32,
    pub disposition: Disposition,
    pub outcome: Outcome,
    pub reward: f64,
    pub decision_correctness: f64,
    pub turns_taken: u32,
    pub parse_error_turns: u32,
    pub tokens: u64,
    pub prompt_tokens: u64,
    pub completion_tokens: u64,
    pub latency_ms: u64,
    pub retries: u32,
    pub source: Source,
}

impl Episode {
    pub fn key(&self) -> EpisodeKey {
        EpisodeKey { scenario: self.scenario, tier: self.tier, seed: self.seed, rollout: self.rollout }
    }

    pub fn success(&self) -> bool {
        self.outcome == Outcome::Success
    }
}

/// What a rollouts.jsonl line is read as (serde skips every other field).
#[derive(Debug, Deserialize)]
struct LineScalars {
    scenario: ScenarioKind,
    tier: Tier,
    seed: u64,
    rollout: u32,
    disposition: Disposition,
    outcome: Outcome,
    reward: f64,
    decision_correctness: f64,
    turns_taken: u32,
    parse_error_turns: u32,
    tokens: u64,
    #[serde(default)]
    prompt_tokens: u64,
    #[serde(default)]
    completion_tokens: u64,
    #[serde(default)]
    latency_ms: u64,
    #[serde(default)]
    retries: u32,
}

#[derive(Debug, Deserialize)]
struct LineIdentity {
    model: String,
    #[serde(default)]
    config_hash: Option<String>,
}

/// The episode selection of an `eval` invocation (run.json).
#[derive(Debug, Clone, Deserialize)]
struct Selection {
    base_seed: u64,
    rollouts: u32,
    scenarios: Vec<ScenarioKind>,
    seeds: u64,
    #[serde(default)]
    shard: Option<String>,
    tiers: Vec<Tier>,
}

impl Selection {
    fn keys(&self) -> Vec<EpisodeKey> {
        let (k, n) = self
            .shard
            .as_deref()
            .and_then(|s| s.split_once('/'))
            .and_then(|(k, n)| Some((k.trim().parse::<u64>().ok()?, n.trim().parse::<u64>().ok()?)))
            .filter(|&(k, n)| n >= 1 && (1..=n).contains(&k))
            .unwrap_or((1, 1));
        let mut out = Vec::new();
        for &scenario in &self.scenarios {
            for &tier in &self.tiers {
                for i in (0..self.seeds).filter(|i| i % n == k - 1) {
                    for rollout in 0..self.rollouts {
                        out.push(EpisodeKey { scenario, tier, seed: self.base_seed.wrapping_add(i), rollout });
                    }
                }
            }
        }
        out
    }
}

/// One run directory as read.
#[derive(Debug, Clone, Serialize)]
pub struct RunSource {
    pub dir: PathBuf,
    pub model: String,
    pub config_hash: String,
    /// Finished episodes read from rollouts.jsonl.
    pub episodes: usize,
    /// Complete lines that could not be read (ignored).
    pub bad_lines: usize,
    /// Whether the file ended in a torn (unterminated) line, ignored.
    pub torn_last_line: bool,
    /// Lines in errors.jsonl (infrastructure failures, each later re-run or
    /// still missing).
    pub infra_error_lines: usize,
    /// `selection.shard` of the last invocation, e.g. "1/2".
    pub shard: Option<String>,
    #[serde(skip)]
    pub(crate) selection: Option<serde_json::Value>,
    #[serde(skip)]
    pub(crate) infra_keys: Vec<EpisodeKey>,
    #[serde(skip)]
    pub(crate) rollouts_declared: Option<u32>,
}

impl RunSource {
    pub fn rollouts_path(&self) -> PathBuf {
        self.dir.join(ROLLOUTS)
    }
}

/// One model: the merged episodes of all its run directories.
#[derive(Debug, Clone)]
pub struct ModelData {
    /// Display name: the model id, plus the config hash when two
    /// configurations of one model id are reported.
    pub label: String,
    pub model: String,
    pub config_hash: String,
    /// Indices into [`Dataset::runs`].
    pub runs: Vec<usize>,
    /// Sorted by key; no key twice.
    pub episodes: Vec<Episode>,
    /// Keys in errors.jsonl with no finished episode (still missing).
    pub infra_unresolved: usize,
    /// Episodes of the runs' selections (run.json) not finished; `None`
    /// when no run.json declares a selection.
    pub missing: Option<usize>,
    /// Rollouts per seed: the largest declared in run.json, else the most
    /// seen for any seed.
    pub rollouts: u32,
}

#[derive(Debug, Clone, Default)]
pub struct Dataset {
    pub runs: Vec<RunSource>,
    pub models: Vec<ModelData>,
    pub warnings: Vec<String>,
}

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> ReportError + '_ {
    move |source| ReportError::Io { path: path.display().to_string(), source }
}

fn is_run_dir(dir: &Path) -> bool {
    dir.join(RUN_JSON).is_file() || dir.join(ROLLOUTS).is_file()
}

/// The run directories named on the command line: each argument is a run
/// directory, or a directory whose immediate subdirectories include run
/// directories (those are taken, in name order).
pub fn resolve_dirs(args: &[PathBuf]) -> Result<Vec<PathBuf>, ReportError> {
    let mut out: Vec<PathBuf> = Vec::new();
    let mut seen: HashSet<PathBuf> = HashSet::new();
    let mut push = |dir: PathBuf, out: &mut Vec<PathBuf>| -> Result<(), ReportError> {
        let canon = dir.canonicalize().map_err(io_err(&dir))?;
        if !seen.insert(canon) {
            return Err(ReportError::GivenTwice(dir.display().to_string()));
        }
        out.push(dir);
        Ok(())
    };
    for arg in args {
        if !arg.exists() {
            return Err(ReportError::MissingDir(arg.display().to_string()));
        }
        if !arg.is_dir() {
            return Err(ReportError::NotARunDir(arg.display().to_string()));
        }
        if is_run_dir(arg) {
            push(arg.clone(), &mut out)?;
            continue;
        }
        let mut children: Vec<PathBuf> = std::fs::read_dir(arg)
            .map_err(io_err(arg))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.is_dir() && is_run_dir(p))
            .collect();
        if children.is_empty() {
            return Err(ReportError::NotARunDir(arg.display().to_string()));
        }
        children.sort();
        for c in children {
            push(c, &mut out)?;
        }
    }
    Ok(out)
}

/// What one rollouts.jsonl holds.
#[derive(Debug, Default)]
struct Parsed {
    episodes: Vec<Episode>,
    bad_lines: Vec<u32>,
    torn: bool,
    identity: Option<(String, Option<String>)>,
}

/// Byte position of the top-level `,"turns":` key, if the line has one.
fn turns_key(line: &[u8]) -> Option<usize> {
    const KEY: &[u8] = b",\"turns\":";
    line.windows(KEY.len()).position(|w| w == KEY)
}

fn parse_line(line: &[u8], scratch: &mut Vec<u8>) -> Option<LineScalars> {
    // Fast path: the head before the transcript, closed. A cut inside a
    // nested value leaves unbalanced braces and fails, falling through.
    if let Some(cut) = turns_key(line) {
        scratch.clear();
        scratch.extend_from_slice(&line[..cut]);
        scratch.push(b'}');
        if let Ok(s) = serde_json::from_slice::<LineScalars>(scratch) {
            return Some(s);
        }
    }
    serde_json::from_slice::<LineScalars>(line).ok()
}

/// Stream one rollouts.jsonl. A missing file is an empty run.
fn parse_rollouts(path: &Path, run: u32) -> Result<Parsed, ReportError> {
    let mut parsed = Parsed::default();
    let file = match File::open(path) {
        Ok(f) => f,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(parsed),
        Err(e) => return Err(io_err(path)(e)),
    };
    let mut reader = BufReader::with_capacity(1 << 20, file);
    let mut buf = Vec::with_capacity(1 << 16);
    let mut scratch = Vec::with_capacity(4096);
    let mut offset: u64 = 0;
    let mut line_no: u32 = 0;
    loop {
        buf.clear();
        let n = reader.read_until(b'\n', &mut buf).map_err(io_err(path))?;
        if n == 0 {
            break;
        }
        line_no += 1;
        let start = offset;
        offset += n as u64;
        if buf.last() != Some(&b'\n') {
            // A line the writer never finished (eval cuts it off on resume).
            parsed.torn = true;
            break;
        }
        let line = &buf[..n - 1];
        if line.iter().all(u8::is_ascii_whitespace) {
            continue;
        }
        match parse_line(line, &mut scratch) {
            Some(s) => {
                if parsed.identity.is_none() {
                    // Once per file: the whole line.
                    parsed.identity =
                        serde_json::from_slice::<LineIdentity>(line).ok().map(|i| (i.model, i.config_hash));
                }
                parsed.episodes.push(Episode {
                    scenario: s.scenario,
                    tier: s.tier,
                    seed: s.seed,
                    rollout: s.rollout,
                    disposition: s.disposition,
                    outcome: s.outcome,
                    reward: s.reward,
                    decision_correctness: s.decision_correctness,
                    turns_taken: s.turns_taken,
                    parse_error_turns: s.parse_error_turns,
                    tokens: s.tokens,
                    prompt_tokens: s.prompt_tokens,
                    completion_tokens: s.completion_tokens,
                    latency_ms: s.latency_ms,
                    retries: s.retries,
                    source: Source { run, line: line_no, offset: start, len: (n - 1) as u32 },
                });
            }
            None => parsed.bad_lines.push(line_no),
        }
    }
    Ok(parsed)
}

fn parse_errors_file(path: &Path) -> Result<InfraLines, ReportError> {
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok((0, Vec::new())),
        Err(e) => return Err(io_err(path)(e)),
    };
    let mut lines = 0;
    let mut keys = Vec::new();
    for line in text.lines().filter(|l| !l.trim().is_empty()) {
        lines += 1;
        if let Ok(r) = serde_json::from_str::<InfraErrorRecord>(line) {
            keys.push(EpisodeKey { scenario: r.scenario, tier: r.tier, seed: r.seed, rollout: r.rollout });
        }
    }
    Ok((lines, keys))
}

fn read_info(dir: &Path) -> Result<Option<RunInfo>, ReportError> {
    store::read_run_info(dir).map_err(|e| match e {
        StoreError::BadRunJson { path, message } => ReportError::BadRunJson { path, message },
        StoreError::Io { path, source } => ReportError::Io { path, source },
        other => ReportError::Io { path: dir.display().to_string(), source: std::io::Error::other(other.to_string()) },
    })
}

fn location(runs: &[RunSource], s: Source) -> String {
    format!("{} line {}", runs[s.run as usize].rollouts_path().display(), s.line)
}

/// errors.jsonl: its line count and the keys it names.
type InfraLines = (usize, Vec<EpisodeKey>);

/// Read and merge the run directories (already resolved).
pub fn load(dirs: &[PathBuf]) -> Result<Dataset, ReportError> {
    let infos: Vec<Option<RunInfo>> = dirs.iter().map(|d| read_info(d)).collect::<Result<_, _>>()?;
    let indexed: Vec<(u32, &PathBuf)> = dirs.iter().enumerate().map(|(i, d)| (i as u32, d)).collect();
    let parsed: Vec<Result<(Parsed, InfraLines), ReportError>> =
        par_map(&indexed, |(i, d)| Ok((parse_rollouts(&d.join(ROLLOUTS), *i)?, parse_errors_file(&d.join(ERRORS))?)));
    let mut data = Dataset::default();
    let mut per_run: Vec<Vec<Episode>> = Vec::with_capacity(dirs.len());
    for ((dir, info), p) in dirs.iter().zip(infos).zip(parsed) {
        let (p, (infra_lines, infra_keys)) = p?;
        let (model, config_hash) = match (&info, &p.identity) {
            (Some(info), _) => (info.config.model.clone(), info.config_hash.clone()),
            (None, Some((m, h))) => (m.clone(), h.clone().unwrap_or_else(|| "unknown".into())),
            (None, None) => {
                data.warnings.push(format!("{}: no run.json and no readable episode; skipped", dir.display()));
                continue;
            }
        };
        if !p.bad_lines.is_empty() {
            data.warnings.push(format!(
                "{}: {} unreadable line(s) ignored (first: line {})",
                dir.join(ROLLOUTS).display(),
                p.bad_lines.len(),
                p.bad_lines[0]
            ));
        }
        if p.episodes.is_empty() {
            data.warnings.push(format!("{}: no finished episode", dir.display()));
        }
        if p.torn {
            data.warnings.push(format!(
                "{}: the last line is unterminated (an interrupted write) and was ignored",
                dir.join(ROLLOUTS).display()
            ));
        }
        let selection = info.as_ref().map(|i| i.last_invocation.selection.clone());
        let shard = selection.as_ref().and_then(|s| s.get("shard")).and_then(|s| s.as_str()).map(str::to_string);
        let rollouts_declared = selection
            .as_ref()
            .and_then(|s| s.get("rollouts"))
            .and_then(|r| r.as_u64())
            .and_then(|r| u32::try_from(r).ok());
        data.runs.push(RunSource {
            dir: dir.clone(),
            model,
            config_hash,
            episodes: p.episodes.len(),
            bad_lines: p.bad_lines.len(),
            torn_last_line: p.torn,
            infra_error_lines: infra_lines,
            shard,
            selection,
            infra_keys,
            rollouts_declared,
        });
        let run_index = (data.runs.len() - 1) as u32;
        let mut eps = p.episodes;
        for e in &mut eps {
            e.source.run = run_index;
        }
        per_run.push(eps);
    }
    if data.runs.is_empty() {
        return Err(ReportError::Empty("no run directory holds a readable episode".into()));
    }

    // Group by config hash, in the order first seen.
    let mut groups: Vec<(String, Vec<usize>)> = Vec::new();
    for (i, r) in data.runs.iter().enumerate() {
        match groups.iter_mut().find(|(h, g)| *h == r.config_hash && data.runs[g[0]].model == r.model) {
            Some((_, g)) => g.push(i),
            None => groups.push((r.config_hash.clone(), vec![i])),
        }
    }
    let mut name_count: BTreeMap<&str, usize> = BTreeMap::new();
    for (_, g) in &groups {
        *name_count.entry(data.runs[g[0]].model.as_str()).or_default() += 1;
    }
    let mut models = Vec::with_capacity(groups.len());
    for (hash, group) in &groups {
        let model = data.runs[group[0]].model.clone();
        let label = if name_count[model.as_str()] > 1 {
            format!("{model} ({})", &hash[..hash.len().min(8)])
        } else {
            model.clone()
        };
        let mut episodes: Vec<Episode> = group.iter().flat_map(|&i| per_run[i].iter().copied()).collect();
        episodes.sort_by_key(|e| (e.key(), e.source.run, e.source.line));
        if let Some(w) = episodes.windows(2).find(|w| w[0].key() == w[1].key()) {
            return Err(ReportError::DuplicateEpisode {
                key: w[0].key().to_string(),
                model: label,
                first: location(&data.runs, w[0].source),
                second: location(&data.runs, w[1].source),
            });
        }
        let finished: HashSet<EpisodeKey> = episodes.iter().map(Episode::key).collect();
        let infra: HashSet<EpisodeKey> = group
            .iter()
            .flat_map(|&i| data.runs[i].infra_keys.iter().copied())
            .filter(|k| !finished.contains(k))
            .collect();
        let mut expected: HashSet<EpisodeKey> = HashSet::new();
        let mut any_selection = false;
        for &i in group {
            if let Some(sel) =
                data.runs[i].selection.as_ref().and_then(|v| serde_json::from_value::<Selection>(v.clone()).ok())
            {
                any_selection = true;
                expected.extend(sel.keys());
            }
        }
        let missing = any_selection.then(|| expected.iter().filter(|k| !finished.contains(k)).count());
        let declared = group.iter().filter_map(|&i| data.runs[i].rollouts_declared).max();
        let seen = max_rollouts_seen(&episodes);
        models.push(ModelData {
            label,
            model,
            config_hash: hash.clone(),
            runs: group.clone(),
            episodes,
            infra_unresolved: infra.len(),
            missing,
            rollouts: declared.unwrap_or(seen).max(seen).max(1),
        });
    }
    data.models = models;
    Ok(data)
}

/// The most rollouts any (scenario, tier, seed) has.
fn max_rollouts_seen(sorted: &[Episode]) -> u32 {
    let mut best = 0u32;
    let mut i = 0;
    while i < sorted.len() {
        let j = i + sorted[i..].iter().take_while(|e| same_unit(e, &sorted[i])).count();
        best = best.max((j - i) as u32);
        i = j;
    }
    best
}

pub fn same_unit(a: &Episode, b: &Episode) -> bool {
    a.scenario == b.scenario && a.tier == b.tier && a.seed == b.seed
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_path_and_fallback_agree() {
        let head = r#"{"model":"m","config_hash":"h","scenario":"yield_standoff","tier":2,"seed":7,"rollout":1,"disposition":"committed","outcome":"timeout","reward":-0.2,"decision_correctness":0.5,"diagnostics":{"a":{"b":[1,2]}},"turns_taken":40,"parse_error_turns":3,"tokens":99"#;
        let mut scratch = Vec::new();
        // Transcript after the scalars: fast path.
        let line = format!(r#"{head},"turns":[{{"scene":"x,\"turns\":[","turns":1}}],"trajectory":null}}"#);
        let a = parse_line(line.as_bytes(), &mut scratch).unwrap();
        assert_eq!((a.seed, a.rollout, a.parse_error_turns, a.tier), (7, 1, 3, Tier::T2));
        // Transcript first: the cut head lacks fields, so the whole line is parsed.
        let reordered = format!(r#"{{"turns":[],{}}}"#, &head[1..]);
        let b = parse_line(reordered.as_bytes(), &mut scratch).unwrap();
        assert_eq!((b.seed, b.outcome), (7, Outcome::Timeout));
        // A nested "turns" key before the scalars' end cannot fool the cut.
        let nested = head.replace(r#""diagnostics":{"a":{"b":[1,2]}}"#, r#""diagnostics":{"x":1,"turns":[]}"#) + "}";
        let c = parse_line(nested.as_bytes(), &mut scratch).unwrap();
        assert_eq!(c.tokens, 99);
        assert!(parse_line(b"{\"seed\":1}", &mut scratch).is_none());
    }

    #[test]
    fn selection_keys_follow_shards() {
        let sel = Selection {
            base_seed: 10,
            rollouts: 2,
            scenarios: vec![ScenarioKind::YieldStandoff],
            seeds: 5,
            shard: Some("2/2".into()),
            tiers: vec![Tier::T1],
        };
        let seeds: Vec<(u64, u32)> = sel.keys().iter().map(|k| (k.seed, k.rollout)).collect();
        assert_eq!(seeds, vec![(11, 0), (11, 1), (13, 0), (13, 1)]);
    }
}
