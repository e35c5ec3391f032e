//! The run directory's schema: every type written to or read from a run
//! directory, and the one place that reads and writes them. `eval` writes
//! through these types and `report` reads through them.
//!
//! Files: `run.json` ([`RunInfo`]); `rollouts.jsonl`, one
//! [`record::RolloutRecord`] per finished episode; `errors.jsonl`, one
//! [`record::InfraErrorRecord`] per rollout given up (re-run later);
//! `summary.json` / `summary.md`, eval's leaderboard (written, never read).
//! [`lines`] is the one reader of the JSON-lines files.
//!
//! Versions: `schema_version` ([`SCHEMA_VERSION`]) is written in run.json
//! and in every line. Version 0 is the format before the field existed (a
//! missing field reads as 0); version 1 adds only the field, so one
//! rollouts file may mix both after a resume. A run.json of a newer version
//! than this build knows is refused rather than misread.

pub mod lines;
pub mod record;

use crate::scenario::{ScenarioKind, Tier};
use record::EpisodeKey;
use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};
use std::path::Path;

/// The run-directory schema this build writes, and the newest it reads.
/// Version 2 adds the evidence timing (`evidence_turn`, `commitment_turn`,
/// `choice`, `first_in`) to every rollout line. Version 3 adds the ideal
/// observer's belief to every turn (`ideal_belief`), and on belief-probe
/// runs the stated belief per turn (`belief`, `belief_error`) and the
/// episode's belief metrics (`belief`); earlier lines read with none.
pub const SCHEMA_VERSION: u32 = 3;

pub const ROLLOUTS: &str = "rollouts.jsonl";
pub const ERRORS: &str = "errors.jsonl";
pub const RUN_JSON: &str = "run.json";
/// The summary `eval` writes at the end of each invocation (JSON and Markdown).
pub const SUMMARY_JSON: &str = "summary.json";
pub const SUMMARY_MD: &str = "summary.md";

#[derive(Debug, thiserror::Error)]
pub enum RunDirError {
    #[error("{path}: {source}")]
    Io { path: String, source: std::io::Error },
    #[error("{path}: unreadable run.json ({message})")]
    BadRunJson { path: String, message: String },
}

/// What each user turn shows the model (`eval --observation`): the scene
/// text (the default), the bird's-eye picture with one short line, or both.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum ObservationMode {
    #[default]
    Text,
    Image,
    Both,
}

impl ObservationMode {
    pub fn name(self) -> &'static str {
        match self {
            ObservationMode::Text => "text",
            ObservationMode::Image => "image",
            ObservationMode::Both => "both",
        }
    }
}

impl std::fmt::Display for ObservationMode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// The `detail` of an OpenAI image content part (`--image-detail`): how
/// finely the provider looks at the picture, and so what it costs.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum ImageDetail {
    Low,
    High,
    #[default]
    Auto,
}

impl ImageDetail {
    pub fn name(self) -> &'static str {
        match self {
            ImageDetail::Low => "low",
            ImageDetail::High => "high",
            ImageDetail::Auto => "auto",
        }
    }
}

/// How a run shows the scene as a picture (`--observation image|both`),
/// part of the run's identity: what the model is shown changes what it
/// does, so a picture run is its own run directory and leaderboard row.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct PictureSettings {
    /// `image` or `both` (never `text`: a text run has no settings).
    pub observation: ObservationMode,
    /// The content part's `detail`.
    pub detail: ImageDetail,
    /// Pictures are kept only in the last K user turns (`--image-history`);
    /// absent: in every turn the history window keeps.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub history: Option<u32>,
}

/// History window sent to the model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(into = "String", try_from = "String")]
pub enum HistoryWindow {
    /// Every earlier turn.
    Full,
    /// Only the last K earlier (scene, reply) pairs.
    Last(usize),
}

impl std::str::FromStr for HistoryWindow {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let s = s.trim();
        if s == "full" {
            return Ok(HistoryWindow::Full);
        }
        s.strip_prefix("last:")
            .and_then(|k| k.trim().parse().ok())
            .map(HistoryWindow::Last)
            .ok_or_else(|| format!("'{s}' is not 'full' or 'last:K' with K a whole number"))
    }
}

impl From<HistoryWindow> for String {
    fn from(h: HistoryWindow) -> String {
        h.to_string()
    }
}

impl TryFrom<String> for HistoryWindow {
    type Error = String;
    fn try_from(s: String) -> Result<Self, Self::Error> {
        s.parse()
    }
}

impl std::fmt::Display for HistoryWindow {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            HistoryWindow::Full => f.write_str("full"),
            HistoryWindow::Last(k) => write!(f, "last:{k}"),
        }
    }
}

/// Deterministic 1/N of the seeds: seed index i (0-based from the base
/// seed) belongs to shard K of N when i mod N == K - 1. Whole seeds go to one
/// shard, with all their tiers and rollouts, so paired comparisons and
/// pass^k stay within a shard.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(into = "String", try_from = "String")]
pub struct Shard {
    pub index: u64,
    pub count: u64,
}

impl Shard {
    pub const WHOLE: Shard = Shard { index: 1, count: 1 };

    pub fn contains(&self, seed_index: u64) -> bool {
        seed_index % self.count == self.index - 1
    }
}

impl std::str::FromStr for Shard {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let bad = || format!("'{s}' is not K/N with 1 <= K <= N");
        let (k, n) = s.trim().split_once('/').ok_or_else(bad)?;
        let (index, count): (u64, u64) = (k.trim().parse().map_err(|_| bad())?, n.trim().parse().map_err(|_| bad())?);
        if index == 0 || count == 0 || index > count {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }
}

impl From<Shard> for String {
    fn from(s: Shard) -> String {
        s.to_string()
    }
}

impl TryFrom<String> for Shard {
    type Error = String;
    fn try_from(s: String) -> Result<Self, Self::Error> {
        s.parse()
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// What makes two invocations the same experiment, so that they may share a
/// run directory: everything that can change how an episode plays out, and
/// the server that played it.
/// Deliberately left out (recorded in run.json, free to change on resume):
/// the selection of episodes (scenarios, tiers, n, r, base seed, shard;
/// episodes are keyed, so a resume may extend or merge), headers, and
/// operational knobs (concurrency, retries, timeouts, token budget).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunConfig {
    pub model: String,
    /// Request parameters merged into every request.
    pub request_params: Map<String, Value>,
    pub history: HistoryWindow,
    /// Hash of the system prompt text.
    pub prompt_hash: String,
    /// Hash of the scenario parameters in force (built-ins or overrides).
    pub scenarios_hash: String,
    /// The endpoint's identity: its base URL without userinfo. Two servers
    /// answering to one model id are two experiments. Absent in runs made
    /// before it existed (their hash is unchanged).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub endpoint: String,
    /// The probe added to every answer (`--probe belief`): a probe run is
    /// its own experiment. Absent without a probe (earlier runs' hashes
    /// are unchanged).
    #[serde(default, skip_serializing_if = "crate::probe::Probe::is_none")]
    pub probe: crate::probe::Probe,
    /// `negotiator play`: a person at the terminal, and what they were
    /// shown and allowed (each setting is its own experiment). Absent for
    /// models (earlier runs' hashes are unchanged).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub human: Option<HumanSettings>,
    /// `--observation image|both`: the scene shown as a picture. Absent for
    /// text runs (earlier runs' hashes are unchanged).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pictures: Option<PictureSettings>,
}

impl RunConfig {
    /// What each user turn shows (`text` without picture settings).
    pub fn observation(&self) -> ObservationMode {
        self.pictures.map_or(ObservationMode::Text, |p| p.observation)
    }
}

/// How a person played (`negotiator play`), part of the run's identity:
/// a real-time clock, a plan view or feedback after each episode make a
/// different experiment from the model's (untimed, text only, no feedback).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HumanSettings {
    /// Seconds per turn (`--turn-seconds`); absent: untimed, as a model is.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub turn_seconds: Option<f64>,
    /// `text` (the scene text only, as the model) or `plan` (a plan view
    /// drawn beside it: more than the model sees).
    pub view: String,
    /// Each episode's outcome and the other road user's intent were shown
    /// right after it (`--feedback`).
    pub feedback: bool,
}

impl RunConfig {
    /// 16 hex digits of FNV-1a over the canonical JSON of the config. Not
    /// cryptographic: it names directories and detects edits.
    pub fn hash(&self) -> String {
        crate::hash::fnv1a64_hex(&serde_json::to_string(self).expect("config serialises"))
    }

    /// Human-readable differences, one per changed field
    /// (`request_params.temperature: 0.0 -> 0.7`).
    pub fn diff(&self, other: &RunConfig) -> Vec<String> {
        let a = serde_json::to_value(self).expect("config serialises");
        let b = serde_json::to_value(other).expect("config serialises");
        let mut out = Vec::new();
        diff_values("", &a, &b, &mut out);
        out
    }
}

fn diff_values(path: &str, a: &Value, b: &Value, out: &mut Vec<String>) {
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            let keys: std::collections::BTreeSet<&String> = x.keys().chain(y.keys()).collect();
            for k in keys {
                let p = if path.is_empty() { k.clone() } else { format!("{path}.{k}") };
                diff_values(&p, x.get(k).unwrap_or(&Value::Null), y.get(k).unwrap_or(&Value::Null), out);
            }
        }
        _ if a != b => {
            let show = |v: &Value| if v.is_null() { "(unset)".to_string() } else { v.to_string() };
            out.push(format!("{path}: {} -> {}", show(a), show(b)));
        }
        _ => {}
    }
}

/// Which episodes an `eval` invocation plays (run.json `selection`).
/// Fields in alphabetical order, as version 0 wrote them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Selection {
    /// First seed; seeds are `base_seed .. base_seed + seeds - 1`.
    pub base_seed: u64,
    /// Rollouts per seed.
    pub rollouts: u32,
    pub scenarios: Vec<ScenarioKind>,
    /// Seeds per scenario and tier (before sharding).
    pub seeds: u64,
    #[serde(default = "whole")]
    pub shard: Shard,
    pub tiers: Vec<Tier>,
}

fn whole() -> Shard {
    Shard::WHOLE
}

impl Selection {
    /// The selected keys in a fixed order: scenario, tier, seed, rollout.
    pub fn keys(&self) -> Vec<EpisodeKey> {
        let mut keys = Vec::new();
        for &scenario in &self.scenarios {
            for &tier in &self.tiers {
                for i in (0..self.seeds).filter(|i| self.shard.contains(*i)) {
                    for rollout in 0..self.rollouts {
                        keys.push(EpisodeKey { scenario, tier, seed: self.base_seed.wrapping_add(i), rollout });
                    }
                }
            }
        }
        keys
    }
}

/// Where the requests went (run.json `endpoint`). Names only: header values
/// and the key may carry credentials and are never written.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Endpoint {
    /// Name of the environment variable holding the API key.
    pub api_key_env: Option<String>,
    pub base_url: String,
    pub header_names: Vec<String>,
    /// The request profile that shaped the body (absent before profiles).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub profile: Option<String>,
}

/// Operational knobs of an invocation (run.json `settings`); free to change
/// on resume.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Settings {
    pub backoff_base_ms: u64,
    pub backoff_max_s: f64,
    pub concurrency: usize,
    pub max_retries: u32,
    pub max_total_tokens: Option<u64>,
    /// `--max-cost` (USD), absent when not given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_cost_usd: Option<f64>,
    pub request_timeout_s: f64,
}

/// How an invocation ended (run.json `last_invocation.status`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RunStatus {
    /// Still running, or killed without a chance to record its end.
    Running,
    /// Every episode of the selection finished.
    Finished,
    /// Episodes are missing (infrastructure errors, token budget, outage).
    Incomplete,
    /// Stopped by Ctrl-C.
    Interrupted,
    /// The endpoint refused the run (authentication, unknown model).
    Refused,
    /// The endpoint rejected a request, or the run failed (I/O, a task).
    Failed,
}

/// Per-invocation facts kept in run.json (the last invocation's).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Invocation {
    pub started_at: String,
    pub ended_at: Option<String>,
    pub status: RunStatus,
    pub selection: Selection,
    pub endpoint: Endpoint,
    pub settings: Settings,
    pub episodes: u64,
    pub infra_errors: u64,
    pub retries: u64,
    pub tokens: u64,
    /// Decision turns answered (requests that succeeded).
    #[serde(default)]
    pub turns: u64,
    /// Estimated cost of this invocation's finished episodes (USD); `null`
    /// when the price is unknown.
    #[serde(default)]
    pub cost_usd: Option<f64>,
    pub wall_s: f64,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Totals {
    /// Finished episodes in rollouts.jsonl.
    pub episodes: u64,
    /// Rollouts given up as infrastructure errors, over all invocations
    /// (each is re-run by the next invocation).
    pub infra_errors: u64,
    /// Episodes of the last selection still missing.
    pub missing: u64,
    /// Retried requests, over all invocations.
    pub retries: u64,
    /// Tokens of the finished episodes.
    pub tokens: u64,
    /// Estimated cost of the finished episodes (USD); `null` when any of
    /// them has no known cost.
    #[serde(default)]
    pub cost_usd: Option<f64>,
    /// Wall time, over all invocations (s).
    pub wall_s: f64,
}

/// The token prices a run is billed at (run.json `pricing`), from the
/// prices file (`configs/prices.toml`, or `--prices-file` over it). USD per
/// million tokens. An estimate: see the prices file's header.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Pricing {
    /// The provider entry that bills the endpoint's host (`openai`,
    /// `local`, ...).
    pub provider: String,
    /// The model entry that matched: the id, a `*` pattern, or `*` for a
    /// free provider.
    pub entry: String,
    pub input: f64,
    /// Prompt tokens served from the provider's cache.
    pub cached_input: f64,
    /// Completion tokens, reasoning included.
    pub output: f64,
    /// When the figures were read from the provider's pricing page.
    pub as_of: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub source: Option<String>,
    /// How the provider counts a picture's input tokens (the prices file's
    /// `images` rule for this model); absent when the file gives none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub image_tokens: Option<ImageTokenRule>,
}

/// How a provider counts the input tokens of one picture, as its pricing
/// documentation states it (the prices file's `images` tables).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "rule", rename_all = "snake_case")]
pub enum ImageTokenRule {
    /// OpenAI's tiles: `low` for a low-detail picture; otherwise the
    /// picture is fitted within 2048 x 2048, its shorter side scaled down
    /// to 768 px, and it costs `base` plus `per_tile` for each 512 px tile.
    Tiles { base: u64, per_tile: u64, low: u64 },
    /// OpenAI's patches (the mini and nano models): one 32 x 32 px patch
    /// per token (at most 1536), times the model's `multiplier`.
    Patches { multiplier: f64 },
    /// Anthropic's area rule: width x height / `px_per_token`.
    Area { px_per_token: f64 },
    /// A fixed count per picture (Gemini's 258 for a picture this size).
    PerImage { tokens: u64 },
}

impl ImageTokenRule {
    /// OpenAI's tiles for gpt-4o and gpt-4.1: what a picture is counted at
    /// when the prices file has no rule for the model (and what `serve`
    /// reports).
    pub const OPENAI_TILES: ImageTokenRule = ImageTokenRule::Tiles { base: 85, per_tile: 170, low: 85 };

    /// The input tokens of one `width` x `height` picture sent at `detail`.
    pub fn tokens(&self, width: u32, height: u32, detail: ImageDetail) -> u64 {
        let (w, h) = (f64::from(width), f64::from(height));
        match *self {
            ImageTokenRule::Tiles { low, .. } if detail == ImageDetail::Low => low,
            ImageTokenRule::Tiles { base, per_tile, .. } => {
                let fit = (2048.0 / w.max(h)).min(1.0);
                let (w, h) = (w * fit, h * fit);
                let shorter = (768.0 / w.min(h)).min(1.0);
                let (w, h) = (w * shorter, h * shorter);
                base + per_tile * ((w / 512.0).ceil() * (h / 512.0).ceil()) as u64
            }
            ImageTokenRule::Patches { multiplier } => {
                let patches = ((w / 32.0).ceil() * (h / 32.0).ceil()).min(1536.0);
                (patches * multiplier).ceil() as u64
            }
            ImageTokenRule::Area { px_per_token } => (w * h / px_per_token).ceil() as u64,
            ImageTokenRule::PerImage { tokens } => tokens,
        }
    }
}

impl Pricing {
    /// USD for one request: `prompt` tokens of which `cached` were served
    /// from the cache (clamped to `prompt`), and `output` billed output
    /// tokens (hidden reasoning included).
    pub fn cost(&self, prompt: u64, cached: u64, output: u64) -> f64 {
        let cached = cached.min(prompt);
        ((prompt - cached) as f64 * self.input + cached as f64 * self.cached_input + output as f64 * self.output) / 1e6
    }
}

/// `run.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunInfo {
    /// [`SCHEMA_VERSION`] when written; 0 for files without it.
    #[serde(default)]
    pub schema_version: u32,
    pub run_name: String,
    pub config: RunConfig,
    pub config_hash: String,
    pub crate_version: String,
    pub git_revision: String,
    /// First invocation's start.
    pub started_at: String,
    /// Last invocation's end.
    pub ended_at: Option<String>,
    pub invocations: u32,
    pub last_invocation: Invocation,
    pub totals: Totals,
    /// The prices the run is billed at; `null` when the prices file has
    /// none for this model and host (the cost is then unknown).
    #[serde(default)]
    pub pricing: Option<Pricing>,
    /// A run played by another harness and imported (`import-inspect`):
    /// where its episodes come from. Absent for runs `eval` and `play` made.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub imported_from: Option<ImportSource>,
}

/// The log an imported run was read from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ImportSource {
    /// The harness that played the episodes (`inspect_ai`) and its version.
    pub harness: String,
    pub harness_version: String,
    /// The log file's name.
    pub log: String,
    /// The harness's own identifiers of the evaluation and its task.
    pub eval_id: String,
    pub run_id: String,
    pub task: String,
    /// The task's arguments as the harness recorded them.
    pub task_args: Map<String, Value>,
}

/// Read `dir/run.json`; `None` if there is none. A file of a newer schema
/// than this build reads is an error.
pub fn read_run_info(dir: &Path) -> Result<Option<RunInfo>, RunDirError> {
    let path = dir.join(RUN_JSON);
    let bad = |message: String| RunDirError::BadRunJson { path: path.display().to_string(), message };
    let text = match std::fs::read_to_string(&path) {
        Ok(text) => text,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(source) => return Err(RunDirError::Io { path: path.display().to_string(), source }),
    };
    let info: RunInfo = serde_json::from_str(&text).map_err(|e| bad(e.to_string()))?;
    if info.schema_version > SCHEMA_VERSION {
        return Err(bad(format!(
            "schema_version {} is newer than this negotiator reads (up to {SCHEMA_VERSION}); use a newer negotiator",
            info.schema_version
        )));
    }
    Ok(Some(info))
}

/// Write `run.json` atomically (temporary file, then rename), so a kill
/// never leaves half a file.
pub fn write_run_info(dir: &Path, info: &RunInfo) -> Result<(), RunDirError> {
    write_atomic(&dir.join(RUN_JSON), &serde_json::to_vec_pretty(info).expect("run info serialises"))
}

/// Write a file atomically (temporary file in the same directory, fsync,
/// rename), scrubbed of secrets. On failure the temporary file is removed
/// and the error names the file that could not be written.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), RunDirError> {
    crate::atomic::write(path, &crate::redact::scrub_bytes(bytes))
        .map_err(|source| RunDirError::Io { path: path.display().to_string(), source })
}

/// A directory-safe rendering of a model id: `openai/gpt-4o` -> `openai_gpt-4o`.
pub fn sanitize_name(model: &str) -> String {
    let s: String = model
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() || matches!(c, '-' | '.' | '_') { c } else { '_' })
        .collect();
    let s = s.trim_matches(|c| c == '.' || c == '_').to_string();
    if s.is_empty() { "model".to_string() } else { s.chars().take(80).collect() }
}

/// `$0.0123`, `$4.56`, `$1234`: enough digits to see a small run's cost.
pub fn usd(x: f64) -> String {
    if x >= 100.0 {
        format!("${x:.0}")
    } else if x >= 1.0 {
        format!("${x:.2}")
    } else {
        format!("${x:.4}")
    }
}

/// An optional cost for display: "unknown" when the price is not known.
pub fn usd_or_unknown(x: Option<f64>) -> String {
    x.map_or_else(|| "unknown".to_string(), usd)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_directory_safe() {
        assert_eq!(sanitize_name("openai/gpt-4o"), "openai_gpt-4o");
        assert_eq!(sanitize_name("../.."), "model");
        assert_eq!(sanitize_name("qwen3:30b"), "qwen3_30b");
    }

    #[test]
    fn dollars_show_enough_digits() {
        assert_eq!(usd(0.012345), "$0.0123");
        assert_eq!(usd(4.561), "$4.56");
        assert_eq!(usd(1234.4), "$1234");
        assert_eq!(usd_or_unknown(None), "unknown");
    }

    fn config() -> RunConfig {
        let mut params = Map::new();
        params.insert("temperature".into(), Value::from(0.0));
        RunConfig {
            model: "m".into(),
            request_params: params,
            history: HistoryWindow::Full,
            prompt_hash: "p".into(),
            scenarios_hash: "s".into(),
            endpoint: "http://127.0.0.1:1/v1".into(),
            probe: crate::probe::Probe::NONE,
            human: None,
            pictures: None,
        }
    }

    #[test]
    fn shards_partition_the_seeds() {
        let shards: Vec<Shard> = (1..=3).map(|k| format!("{k}/3").parse().unwrap()).collect();
        for i in 0..100u64 {
            assert_eq!(shards.iter().filter(|s| s.contains(i)).count(), 1, "seed index {i}");
        }
        assert!(Shard::WHOLE.contains(17));
        for bad in ["0/3", "4/3", "1/0", "x", "1/2/3", ""] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
    }

    #[test]
    fn history_window_parses() {
        assert_eq!("full".parse::<HistoryWindow>().unwrap(), HistoryWindow::Full);
        assert_eq!("last:3".parse::<HistoryWindow>().unwrap(), HistoryWindow::Last(3));
        assert!("last:".parse::<HistoryWindow>().is_err());
        assert!("some".parse::<HistoryWindow>().is_err());
        assert_eq!(HistoryWindow::Last(2).to_string(), "last:2");
    }

    #[test]
    fn config_changes_are_named() {
        let a = config();
        let mut b = config();
        assert!(a.diff(&b).is_empty());
        assert_eq!(a.hash(), b.hash());
        b.request_params.insert("temperature".into(), Value::from(0.7));
        b.request_params.insert("top_p".into(), Value::from(0.9));
        b.history = HistoryWindow::Last(4);
        b.probe = crate::probe::Probe::BELIEF;
        let d = a.diff(&b);
        assert_eq!(d.len(), 4, "{d:?}");
        assert!(d.iter().any(|l| l == "probe: (unset) -> \"belief\""), "{d:?}");
        assert!(d.iter().any(|l| l.starts_with("request_params.temperature: 0.0 -> 0.7")), "{d:?}");
        assert!(d.iter().any(|l| l.starts_with("request_params.top_p: (unset) -> 0.9")), "{d:?}");
        assert!(d.iter().any(|l| l.starts_with("history:")), "{d:?}");
        assert_ne!(a.hash(), b.hash());
    }

    #[test]
    fn selection_keys_follow_shards() {
        let sel = Selection {
            base_seed: 10,
            rollouts: 2,
            scenarios: vec![ScenarioKind::YieldStandoff],
            seeds: 5,
            shard: "2/2".parse().unwrap(),
            tiers: vec![Tier::T1],
        };
        let seeds: Vec<(u64, u32)> = sel.keys().iter().map(|k| (k.seed, k.rollout)).collect();
        assert_eq!(seeds, vec![(11, 0), (11, 1), (13, 0), (13, 1)]);
        // As version 0 wrote it: the shard as "K/N", absent meaning the whole.
        let v0: Selection = serde_json::from_str(
            r#"{"base_seed":10,"rollouts":2,"scenarios":["yield_standoff"],"seeds":5,"shard":"2/2","tiers":[1]}"#,
        )
        .unwrap();
        assert_eq!(v0, sel);
        assert_eq!(serde_json::to_value(&sel).unwrap()["shard"], "2/2");
        let unsharded: Selection = serde_json::from_str(
            r#"{"base_seed":0,"rollouts":1,"scenarios":["yield_standoff"],"seeds":3,"tiers":[1]}"#,
        )
        .unwrap();
        assert_eq!(unsharded.keys().len(), 3);
        assert!(
            serde_json::from_str::<Selection>(
                r#"{"base_seed":0,"rollouts":1,"scenarios":[],"seeds":3,"shard":"3/2","tiers":[]}"#
            )
            .is_err()
        );
    }

    #[test]
    fn a_newer_run_json_is_refused_and_a_v0_one_read() {
        let dir = std::env::temp_dir().join(format!("negotiator-rundir-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let v0 = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/run_v0/expert");
        let mut info = read_run_info(&v0).unwrap().unwrap();
        assert_eq!((info.schema_version, info.last_invocation.status), (0, RunStatus::Finished));
        assert_eq!(info.last_invocation.selection.keys().len(), 54);
        info.schema_version = SCHEMA_VERSION + 1;
        write_run_info(&dir, &info).unwrap();
        let err = read_run_info(&dir).unwrap_err().to_string();
        assert!(err.contains(&format!("schema_version {} is newer", SCHEMA_VERSION + 1)), "{err}");
        assert!(read_run_info(&dir.join("absent")).unwrap().is_none());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
