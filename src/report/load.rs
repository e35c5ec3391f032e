//! Reading run directories: `run.json`, `rollouts.jsonl` (streamed, one
//! line at a time, only the per-episode scalars kept), `errors.jsonl`; and
//! merging them into one episode list per model.
//!
//! A "model" is one run configuration (one config hash). Run directories
//! with the same config hash are shards (or copies) of one run and are
//! joined; the same (scenario, tier, seed, rollout) key twice within a
//! model is an error naming both lines, never a double count.
//!
//! The files are read through [`crate::rundir`] (which parses only the
//! head of each line); files are read in parallel.

use super::ReportError;
use crate::par::par_map;
use crate::rundir::lines::{read_infra_errors, read_rollouts};
use crate::rundir::record::{EpisodeKey, EpisodeScalars};
use crate::rundir::{ERRORS, ObservationMode, ROLLOUTS, RUN_JSON, RunDirError, RunInfo, Selection};
use crate::scenario::Tier;
use serde::Serialize;
use std::collections::{BTreeMap, BTreeSet, HashSet};
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

/// One episode as the report sees it: the line's scalars and where the
/// line is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Episode {
    pub scalars: EpisodeScalars,
    pub source: Source,
}

/// The report reads the scalars everywhere (`e.tier`, `e.success()`); the
/// source is an annotation for messages and transcripts.
impl std::ops::Deref for Episode {
    type Target = EpisodeScalars;
    fn deref(&self) -> &EpisodeScalars {
        &self.scalars
    }
}

/// One run directory as read.
#[derive(Debug, Clone, Serialize)]
pub struct RunSource {
    pub dir: PathBuf,
    pub model: String,
    pub config_hash: String,
    /// What the model was shown each turn (`eval --observation`); `text`
    /// for runs without a run.json.
    #[serde(skip_serializing_if = "is_text")]
    pub observation: ObservationMode,
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
    pub(crate) selection: Option<Selection>,
    #[serde(skip)]
    pub(crate) infra_keys: Vec<EpisodeKey>,
}

fn is_text(o: &ObservationMode) -> bool {
    *o == ObservationMode::Text
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
    /// What the model was shown each turn: one model id under two
    /// observations is two models (`model (image)`), compared pair by pair
    /// in the text-against-picture table.
    pub observation: ObservationMode,
    /// Indices into [`Dataset::runs`].
    pub runs: Vec<usize>,
    /// Sorted by key; no key twice.
    pub episodes: Vec<Episode>,
    /// Errored: keys in errors.jsonl with no finished episode (a request
    /// failed after every retry), sorted.
    pub errored: Vec<EpisodeKey>,
    /// Missing: keys of the runs' selections (run.json) neither finished nor
    /// errored (never started: interrupted, token budget), sorted; `None`
    /// when no run.json declares a selection.
    pub not_run: Option<Vec<EpisodeKey>>,
    /// Episodes of the runs' selections; `None` without a selection.
    pub expected: Option<usize>,
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

/// Stream one rollouts.jsonl. A missing file is an empty run.
fn parse_rollouts(path: &Path, run: u32) -> Result<Parsed, ReportError> {
    let mut episodes = Vec::new();
    let read = read_rollouts(path, |scalars, at| {
        episodes.push(Episode { scalars, source: Source { run, line: at.line, offset: at.offset, len: at.len } });
    })
    .map_err(io_err(path))?;
    Ok(Parsed {
        episodes,
        bad_lines: read.bad_lines,
        torn: read.torn.is_some(),
        identity: read.model.map(|m| (m, read.config_hash)),
    })
}

fn read_info(dir: &Path) -> Result<Option<RunInfo>, ReportError> {
    crate::rundir::read_run_info(dir).map_err(|e| match e {
        RunDirError::BadRunJson { path, message } => ReportError::BadRunJson { path, message },
        RunDirError::Io { path, source } => ReportError::Io { path, source },
    })
}

fn location(runs: &[RunSource], s: Source) -> String {
    format!("{} line {}", runs[s.run as usize].rollouts_path().display(), s.line)
}

/// errors.jsonl: its line count and the keys it names.
type InfraLines = (usize, Vec<EpisodeKey>);

/// Read and merge the run directories (already resolved).
pub fn load(dirs: &[PathBuf]) -> Result<Dataset, ReportError> {
    let (mut data, per_run) = read_runs(dirs)?;
    if data.runs.is_empty() {
        return Err(ReportError::Empty("no run directory holds a readable episode".into()));
    }
    let groups = group_by_config(&data.runs);
    // A picture run is named by its observation: `gpt-4o (image)`.
    let name = |run: &RunSource| match run.observation {
        ObservationMode::Text => run.model.clone(),
        seen => format!("{} ({seen})", run.model),
    };
    let mut name_count: BTreeMap<String, usize> = BTreeMap::new();
    for (_, g) in &groups {
        *name_count.entry(name(&data.runs[g[0]])).or_default() += 1;
    }
    let mut models = Vec::with_capacity(groups.len());
    for (hash, group) in &groups {
        let model = name(&data.runs[group[0]]);
        let label =
            if name_count[&model] > 1 { format!("{model} ({})", &hash[..hash.len().min(8)]) } else { model.clone() };
        models.push(merge_model(&data.runs, &per_run, hash, group, label)?);
    }
    data.models = models;
    Ok(data)
}

/// Read every run directory (in parallel): the runs that hold something,
/// each with its episodes (whose `source.run` indexes the runs), and the
/// warnings about what was skipped or ignored.
fn read_runs(dirs: &[PathBuf]) -> Result<(Dataset, Vec<Vec<Episode>>), ReportError> {
    let infos: Vec<Option<RunInfo>> = dirs.iter().map(|d| read_info(d)).collect::<Result<_, _>>()?;
    let indexed: Vec<(u32, &PathBuf)> = dirs.iter().enumerate().map(|(i, d)| (i as u32, d)).collect();
    let parsed: Vec<Result<(Parsed, InfraLines), ReportError>> = par_map(&indexed, |(i, d)| {
        let errors = d.join(ERRORS);
        Ok((parse_rollouts(&d.join(ROLLOUTS), *i)?, read_infra_errors(&errors).map_err(io_err(&errors))?))
    });
    let mut data = Dataset::default();
    let mut per_run: Vec<Vec<Episode>> = Vec::with_capacity(dirs.len());
    for ((dir, info), p) in dirs.iter().zip(infos).zip(parsed) {
        let (p, (infra_lines, infra_keys)) = p?;
        let (model, config_hash, observation) = match (&info, &p.identity) {
            (Some(info), _) => (info.config.model.clone(), info.config_hash.clone(), info.config.observation()),
            (None, Some((m, h))) => (m.clone(), h.clone().unwrap_or_else(|| "unknown".into()), ObservationMode::Text),
            (None, None) => {
                data.warnings.push(format!("{}: no run.json and no readable episode; skipped", dir.display()));
                continue;
            }
        };
        warn_about(dir, &p, &mut data.warnings);
        let selection = info.map(|i| i.last_invocation.selection);
        data.runs.push(RunSource {
            dir: dir.clone(),
            model,
            config_hash,
            observation,
            episodes: p.episodes.len(),
            bad_lines: p.bad_lines.len(),
            torn_last_line: p.torn,
            infra_error_lines: infra_lines,
            shard: selection.as_ref().map(|s| s.shard.to_string()),
            selection,
            infra_keys,
        });
        let run_index = (data.runs.len() - 1) as u32;
        let mut eps = p.episodes;
        for e in &mut eps {
            e.source.run = run_index;
        }
        per_run.push(eps);
    }
    Ok((data, per_run))
}

/// Unreadable lines, an empty run, a torn last line.
fn warn_about(dir: &Path, p: &Parsed, warnings: &mut Vec<String>) {
    if !p.bad_lines.is_empty() {
        warnings.push(format!(
            "{}: {} unreadable line(s) ignored (first: line {})",
            dir.join(ROLLOUTS).display(),
            p.bad_lines.len(),
            p.bad_lines[0]
        ));
    }
    if p.episodes.is_empty() {
        warnings.push(format!("{}: no finished episode", dir.display()));
    }
    if p.torn {
        warnings.push(format!(
            "{}: the last line is unterminated (an interrupted write) and was ignored",
            dir.join(ROLLOUTS).display()
        ));
    }
}

/// Runs of one configuration (model and config hash), in the order first
/// seen: each group is one model.
fn group_by_config(runs: &[RunSource]) -> Vec<(String, Vec<usize>)> {
    let mut groups: Vec<(String, Vec<usize>)> = Vec::new();
    for (i, r) in runs.iter().enumerate() {
        match groups.iter_mut().find(|(h, g)| *h == r.config_hash && runs[g[0]].model == r.model) {
            Some((_, g)) => g.push(i),
            None => groups.push((r.config_hash.clone(), vec![i])),
        }
    }
    groups
}

/// One model from its runs: the episodes sorted by key (the same key twice
/// is an error), unresolved infrastructure errors, missing episodes of the
/// runs' selections, and rollouts per seed.
fn merge_model(
    runs: &[RunSource],
    per_run: &[Vec<Episode>],
    hash: &str,
    group: &[usize],
    label: String,
) -> Result<ModelData, ReportError> {
    let mut episodes: Vec<Episode> = group.iter().flat_map(|&i| per_run[i].iter().copied()).collect();
    episodes.sort_by_key(|e| (e.key(), e.source.run, e.source.line));
    if let Some(w) = episodes.windows(2).find(|w| w[0].key() == w[1].key()) {
        return Err(ReportError::DuplicateEpisode {
            key: w[0].key().to_string(),
            model: label,
            first: location(runs, w[0].source),
            second: location(runs, w[1].source),
        });
    }
    let finished: HashSet<EpisodeKey> = episodes.iter().map(|e| e.key()).collect();
    let errored: BTreeSet<EpisodeKey> =
        group.iter().flat_map(|&i| runs[i].infra_keys.iter().copied()).filter(|k| !finished.contains(k)).collect();
    let selections: Vec<&Selection> = group.iter().filter_map(|&i| runs[i].selection.as_ref()).collect();
    let expected: BTreeSet<EpisodeKey> = selections.iter().flat_map(|s| s.keys()).collect();
    let not_run = (!selections.is_empty())
        .then(|| expected.iter().filter(|k| !finished.contains(k) && !errored.contains(k)).copied().collect());
    let declared = selections.iter().map(|s| s.rollouts).max();
    let seen = max_rollouts_seen(&episodes);
    Ok(ModelData {
        label,
        model: runs[group[0]].model.clone(),
        config_hash: hash.to_string(),
        observation: runs[group[0]].observation,
        runs: group.to_vec(),
        episodes,
        errored: errored.into_iter().collect(),
        not_run,
        expected: (!selections.is_empty()).then_some(expected.len()),
        rollouts: declared.unwrap_or(seen).max(seen).max(1),
    })
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

impl ModelData {
    /// Missing (never started) episodes of the selection; `None` without one.
    pub fn missing(&self) -> Option<usize> {
        self.not_run.as_ref().map(Vec::len)
    }

    /// Errored and missing (never started) episodes of the selection within
    /// `tiers`; missing is `None` without a selection.
    pub(crate) fn unfinished_in(&self, tiers: &[Tier]) -> (usize, Option<usize>) {
        let count = |keys: &[EpisodeKey]| keys.iter().filter(|k| tiers.contains(&k.tier)).count();
        (count(&self.errored), self.not_run.as_deref().map(count))
    }
}

pub fn same_unit(a: &Episode, b: &Episode) -> bool {
    a.scenario == b.scenario && a.tier == b.tier && a.seed == b.seed
}
