//! The per-episode drill-down data embedded in report.html, and the full
//! records of the episodes whose transcripts it carries.
//!
//! Bounded size: every episode's scalars are embedded (about 60 bytes
//! each), but transcripts only for up to `per_cell` episodes of each
//! (model, scenario, tier) cell — the first collision, the first timeout
//! and the first success by seed, then the lowest seeds — taken cell by
//! cell in rounds until `TRANSCRIPT_BUDGET` bytes of transcript JSON are
//! embedded. Replies and provider reasoning longer than `MAX_TEXT`
//! characters are cut, and scene lines are stored once (a string table).

use super::ReportError;
use super::load::{Dataset, Episode};
use crate::episode::Outcome;
use crate::par::par_map;
use crate::rundir::lines::{LineRef, read_records_at};
use crate::rundir::record::RolloutRecord;
use crate::scenario::{Disposition, ScenarioKind};
use serde::Serialize;
use std::collections::HashMap;

/// Embedded transcript JSON, at most (the last transcript may cross it).
pub(crate) const TRANSCRIPT_BUDGET: usize = 6_000_000;
/// Longest reply or reasoning text embedded per turn (characters).
pub(crate) const MAX_TEXT: usize = 4_000;

/// A transcript chosen for the drill-down, with its full record.
#[derive(Debug, Clone)]
pub struct Loaded {
    pub model: usize,
    /// Index into the model's episodes.
    pub episode: usize,
    pub record: RolloutRecord,
}

/// Per cell, the episodes to carry transcripts for, in priority order.
fn choose_in_cell(cell: &[(usize, &Episode)], per_cell: usize) -> Vec<usize> {
    let mut chosen: Vec<usize> = Vec::new();
    for o in [Outcome::Collision, Outcome::Timeout, Outcome::Success] {
        if let Some((i, _)) = cell.iter().find(|(_, e)| e.outcome == o) {
            chosen.push(*i);
        }
    }
    for (i, _) in cell {
        if chosen.len() >= per_cell {
            break;
        }
        if !chosen.contains(i) {
            chosen.push(*i);
        }
    }
    chosen.truncate(per_cell);
    chosen
}

/// A (scenario, tier) cell of one model: its episodes with their indices.
type Cell<'a> = ((ScenarioKind, u8), Vec<(usize, &'a Episode)>);

/// (model, episode index) pairs in embedding order: round 0 of every cell,
/// then round 1, and so on.
pub(crate) fn choose(data: &Dataset, per_cell: usize) -> Vec<(usize, usize)> {
    let mut ranked: Vec<(usize, usize, usize)> = Vec::new(); // (rank, model, episode)
    for (m, model) in data.models.iter().enumerate() {
        let mut cells: Vec<Cell> = Vec::new();
        for (i, e) in model.episodes.iter().enumerate() {
            let key = (e.scenario, e.tier.number());
            match cells.last_mut() {
                Some((k, v)) if *k == key => v.push((i, e)),
                _ => cells.push((key, vec![(i, e)])),
            }
        }
        for (_, cell) in &cells {
            for (rank, i) in choose_in_cell(cell, per_cell).into_iter().enumerate() {
                ranked.push((rank, m, i));
            }
        }
    }
    ranked.sort_unstable();
    ranked.into_iter().map(|(_, m, i)| (m, i)).collect()
}

/// A run index and its chosen (order, model, episode) items.
type RunItems = (usize, Vec<(usize, usize, usize)>);

/// Read the chosen episodes' full lines (one open per run file).
pub(crate) fn load(data: &Dataset, chosen: &[(usize, usize)]) -> Result<Vec<Loaded>, ReportError> {
    let mut by_run: Vec<Vec<(usize, usize, usize)>> = vec![Vec::new(); data.runs.len()]; // (order, model, episode)
    for (order, &(m, i)) in chosen.iter().enumerate() {
        let run = data.models[m].episodes[i].source.run as usize;
        by_run[run].push((order, m, i));
    }
    let runs: Vec<RunItems> = by_run.into_iter().enumerate().filter(|(_, v)| !v.is_empty()).collect();
    let read = par_map(&runs, |(run, items)| -> Result<Vec<(usize, Option<Loaded>)>, ReportError> {
        let path = data.runs[*run].rollouts_path();
        let places: Vec<LineRef> = items
            .iter()
            .map(|&(_, m, i)| {
                let src = data.models[m].episodes[i].source;
                LineRef { line: 0, offset: src.offset, len: src.len }
            })
            .collect();
        let records = read_records_at(&path, &places)
            .map_err(|source| ReportError::Io { path: path.display().to_string(), source })?;
        let out: Vec<(usize, Option<Loaded>)> = items
            .iter()
            .zip(records)
            .map(|(&(order, m, i), record)| (order, record.map(|record| Loaded { model: m, episode: i, record })))
            .collect();
        Ok(out)
    });
    let mut all: Vec<(usize, Option<Loaded>)> = Vec::new();
    for r in read {
        all.extend(r?);
    }
    all.sort_by_key(|(order, _)| *order);
    Ok(all.into_iter().filter_map(|(_, l)| l).collect())
}

fn round2(x: f64) -> f64 {
    if x.is_finite() { (x * 100.0).round() / 100.0 } else { 0.0 }
}

fn round3(x: f64) -> f64 {
    if x.is_finite() { (x * 1000.0).round() / 1000.0 } else { 0.0 }
}

fn cut(s: &str) -> String {
    match s.char_indices().nth(MAX_TEXT) {
        Some((at, _)) => format!("{}… [{} more characters not embedded]", &s[..at], s[at..].chars().count()),
        None => s.to_string(),
    }
}

#[derive(Debug, Serialize)]
struct TurnOut {
    /// Turn number.
    t: u32,
    /// Time (s) from the trajectory, when recorded.
    #[serde(skip_serializing_if = "Option::is_none")]
    time: Option<f64>,
    /// Scene lines (string table indices).
    s: Vec<u32>,
    /// Raw reply.
    r: Option<String>,
    /// Provider reasoning.
    #[serde(skip_serializing_if = "Option::is_none")]
    z: Option<String>,
    /// Parsed (executed) maneuver and acceleration.
    m: &'static str,
    a: f64,
    /// Parse errors.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    e: Vec<String>,
    k: u64,
    l: u64,
    n: u32,
    /// Belief probe: the stated belief and the ideal observer's.
    #[serde(skip_serializing_if = "Option::is_none")]
    b: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    ib: Option<f64>,
    /// Ego and other road users: [x, y, v] in the plan view.
    #[serde(skip_serializing_if = "Option::is_none")]
    ego: Option<[f64; 3]>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    o: Vec<[f64; 3]>,
    /// Each other road user's position in its scenario's lateral frame
    /// (the pedestrian from the near kerb, as the scene text gives it);
    /// `null` for one without. Absent when none has one.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    f: Vec<Option<f64>>,
}

/// How a scenario's road users are named and placed (from
/// [`ScenarioKind::plan_axes`]), indexed like `scenarios`.
#[derive(Debug, Serialize)]
struct SceneOut {
    /// The other road users' roles, in the order of `o`.
    roles: Vec<&'static str>,
    /// Their lateral frames, `null` for one without.
    lateral: Vec<Option<FrameOut>>,
}

#[derive(Debug, Serialize)]
struct FrameOut {
    /// What the value measures ("from the near kerb").
    measured: &'static str,
    /// Value = plan y + offset.
    offset: f64,
    /// The frame's lines: [value, label].
    marks: [(f64, &'static str); 2],
    /// In the ego's path: [lo, hi].
    path: [f64; 2],
}

fn scene_out(kind: ScenarioKind) -> SceneOut {
    let users = kind.plan_axes().road_users;
    SceneOut {
        roles: users.iter().map(|u| u.role).collect(),
        lateral: users
            .iter()
            .map(|u| {
                u.lateral.map(|f| FrameOut {
                    measured: f.measured,
                    offset: f.plan_offset,
                    marks: f.marks,
                    path: [round2(f.in_path.0), round2(f.in_path.1)],
                })
            })
            .collect(),
    }
}

#[derive(Debug, Serialize)]
struct TranscriptOut {
    turns: Vec<TurnOut>,
    /// The evidence turn, if any.
    #[serde(skip_serializing_if = "Option::is_none")]
    ev: Option<u32>,
    /// Made with the belief probe.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    p: bool,
    /// Shown as pictures (`eval --observation image|both`): the stem of
    /// each turn's picture file, `pictures/<transcript>-<turn>.png`.
    #[serde(skip_serializing_if = "Option::is_none")]
    g: Option<String>,
}

/// A picture the report writes beside report.html: its path under the
/// report directory and the scene text it is drawn from.
#[derive(Debug, Clone)]
pub(crate) struct PictureFile {
    pub(crate) path: String,
    pub(crate) scene: String,
}

/// One episode's scalars: model, scenario, tier, seed, rollout, outcome
/// (0 success, 1 collision, 2 timeout), disposition, reward, decision
/// correctness, turns, parse-error turns, tokens, latency (ms), transcript
/// index (-1: none), run index, line.
type EpisodeRow = (u16, u8, u8, u64, u32, u8, u8, f64, f64, u32, u32, u64, u64, i32, u32, u32);

#[derive(Serialize)]
pub struct DrillData {
    models: Vec<String>,
    scenarios: Vec<&'static str>,
    scenes: Vec<SceneOut>,
    outcomes: [&'static str; 3],
    dispositions: Vec<&'static str>,
    runs: Vec<String>,
    per_cell: usize,
    budget_bytes: usize,
    /// Transcripts chosen but left out by the byte budget.
    dropped: usize,
    strings: Vec<String>,
    episodes: Vec<EpisodeRow>,
    transcripts: Vec<TranscriptOut>,
    /// The pictures of the transcripts shown as pictures, written as files
    /// beside report.html (not embedded: tens of kilobytes each).
    #[serde(skip)]
    pub(crate) pictures: Vec<PictureFile>,
}

fn outcome_code(o: Outcome) -> u8 {
    match o {
        Outcome::Success => 0,
        Outcome::Collision => 1,
        Outcome::Timeout => 2,
    }
}

/// Scene lines, stored once.
#[derive(Default)]
struct Interner {
    strings: Vec<String>,
    index: HashMap<String, u32>,
    /// Approximate JSON size of the table.
    bytes: usize,
}

impl Interner {
    fn intern(&mut self, s: &str) -> u32 {
        if let Some(&i) = self.index.get(s) {
            return i;
        }
        let i = self.strings.len() as u32;
        self.strings.push(s.to_string());
        self.index.insert(s.to_string(), i);
        self.bytes += s.len() + 3;
        i
    }
}

/// Build the embedded data. `loaded` in embedding order.
pub(crate) fn build(data: &Dataset, loaded: &[Loaded], per_cell: usize) -> Result<DrillData, ReportError> {
    let mut table = Interner::default();
    let mut transcripts = Vec::new();
    let mut transcript_of: HashMap<(usize, usize), i32> = HashMap::new();
    let mut bytes = 0usize;
    let mut dropped = 0usize;
    let mut pictures = Vec::new();
    for l in loaded {
        if bytes + table.bytes >= TRANSCRIPT_BUDGET {
            dropped += 1;
            continue;
        }
        let traj = l.record.trajectory.as_deref().unwrap_or(&[]);
        let users = l.record.scenario.plan_axes().road_users;
        let in_frames = |agents: &[crate::scenario::world::PlanPoint]| -> Vec<Option<f64>> {
            if users.iter().all(|u| u.lateral.is_none()) {
                return Vec::new();
            }
            let others = agents.iter().skip(1).enumerate();
            others.map(|(k, a)| users.get(k).and_then(|u| u.lateral).map(|f| round2(f.of(a)))).collect()
        };
        let turns: Vec<TurnOut> = l
            .record
            .turns
            .iter()
            .map(|t| {
                let point = (t.turn as usize).checked_sub(1).and_then(|i| traj.get(i));
                TurnOut {
                    t: t.turn,
                    time: point.map(|p| round2(p.time_s)),
                    s: t.scene.trim_end_matches('\n').split('\n').map(|line| table.intern(line)).collect(),
                    r: t.reply.as_deref().map(cut),
                    z: t.reasoning.as_deref().map(cut),
                    m: t.action.maneuver.name(),
                    a: round2(t.action.acceleration),
                    e: t.parse_errors.iter().map(|e| e.to_string()).collect(),
                    k: t.tokens,
                    l: t.latency_ms,
                    n: t.attempts,
                    b: t.belief.map(round3),
                    ib: t.ideal_belief.map(round3),
                    ego: point.and_then(|p| p.agents.first()).map(|a| [round2(a.x), round2(a.y), round2(a.v)]),
                    o: point
                        .map(|p| p.agents.iter().skip(1).map(|a| [round2(a.x), round2(a.y), round2(a.v)]).collect())
                        .unwrap_or_default(),
                    f: point.map(|p| in_frames(&p.agents)).unwrap_or_default(),
                }
            })
            .collect();
        let pictured = data.models[l.model].observation != crate::rundir::ObservationMode::Text;
        let stem = pictured.then(|| format!("pictures/{}", transcripts.len()));
        if let Some(stem) = &stem {
            pictures.extend(
                l.record
                    .turns
                    .iter()
                    .map(|t| PictureFile { path: format!("{stem}-{}.png", t.turn), scene: t.scene.clone() }),
            );
        }
        let out = TranscriptOut { turns, ev: l.record.timing.evidence_turn, p: l.record.belief.is_some(), g: stem };
        bytes += serde_json::to_string(&out).map_or(0, |s| s.len());
        transcript_of.insert((l.model, l.episode), transcripts.len() as i32);
        transcripts.push(out);
    }
    // The labels the page shows, as the scenarios declare them: an episode
    // whose label is not among them is refused, never shown as another.
    let dispositions = Disposition::all();
    let mut episodes = Vec::new();
    for (m, model) in data.models.iter().enumerate() {
        for (i, e) in model.episodes.iter().enumerate() {
            let undeclared = |what: &'static str, name: &str| ReportError::Undeclared {
                at: format!("{}:{}", data.runs[e.source.run as usize].rollouts_path().display(), e.source.line),
                what,
                name: name.to_string(),
            };
            let scenario = e.scenario.index().ok_or_else(|| undeclared("scenario", e.scenario.name()))?;
            let disposition = dispositions
                .iter()
                .position(|&d| d == e.disposition)
                .ok_or_else(|| undeclared("disposition", e.disposition.name()))?;
            episodes.push((
                m as u16,
                scenario as u8,
                e.tier.number(),
                e.seed,
                e.rollout,
                outcome_code(e.outcome),
                disposition as u8,
                round3(e.reward),
                round3(e.decision_correctness),
                e.turns_taken,
                e.parse_error_turns,
                e.tokens,
                e.latency_ms,
                transcript_of.get(&(m, i)).copied().unwrap_or(-1),
                e.source.run,
                e.source.line,
            ));
        }
    }
    Ok(DrillData {
        models: data.models.iter().map(|m| m.label.clone()).collect(),
        scenarios: ScenarioKind::ALL.iter().map(|s| s.name()).collect(),
        scenes: ScenarioKind::ALL.into_iter().map(scene_out).collect(),
        outcomes: ["success", "collision", "timeout"],
        dispositions: dispositions.iter().map(|d| d.name()).collect(),
        runs: data.runs.iter().map(|r| r.rollouts_path().display().to_string()).collect(),
        per_cell,
        budget_bytes: TRANSCRIPT_BUDGET,
        dropped,
        strings: table.strings,
        episodes,
        transcripts,
        pictures,
    })
}

impl DrillData {
    pub(crate) fn transcripts(&self) -> usize {
        self.transcripts.len()
    }

    pub(crate) fn per_cell(&self) -> usize {
        self.per_cell
    }

    pub(crate) fn dropped(&self) -> usize {
        self.dropped
    }
}

/// JSON safe inside a `<script>` element: `<` is written as `\u003c`, so
/// no `</script>` or `<!--` can appear.
pub(crate) fn script_json<T: Serialize>(value: &T) -> String {
    serde_json::to_string(value).unwrap_or_else(|_| "null".into()).replace('<', "\\u003c")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_is_cut_and_script_json_is_safe() {
        let long = "é".repeat(MAX_TEXT + 5);
        let c = cut(&long);
        assert!(c.starts_with(&"é".repeat(MAX_TEXT)) && c.ends_with("[5 more characters not embedded]"));
        assert_eq!(cut("short"), "short");
        let j = script_json(&vec!["</script><!--"]);
        assert!(!j.contains('<'));
        let back: Vec<String> = serde_json::from_str(&j).unwrap();
        assert_eq!(back, vec!["</script><!--"]);
    }
}
