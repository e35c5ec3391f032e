//! Inspect AI eval logs as run directories: `negotiator import-inspect` and
//! `report` read the `.eval` (a zip of JSON files) and `.json` logs the
//! Inspect task writes, and turn each sample into the line `eval` would
//! have written for the same episode.
//!
//! Nothing is taken on trust from the log but the model's replies: each
//! sample's episode is replayed here, reply by reply, through the same
//! `Episode` and the same parser `eval` uses, and every scene the log shows
//! must be the scene this build renders at that turn (a log from another
//! version of the benchmark, or another scenario file, is refused rather
//! than misread), and a picture run's (`-T observation=image|both`)
//! pictures, when the log keeps them, must be the bytes this build draws.
//! The grades, the evidence timing and the hidden disposition are
//! therefore this build's own; the log's score must agree with them. What
//! only the log knows is kept as the log states it: the model as Inspect
//! names it, its generate config, per-turn usage and latency (from the
//! sample's model events), and the task's arguments. The cost is unknown
//! (Inspect's own accounting is not a price).
//!
//! A sample that did not finish (an Inspect limit or an error ended it) is
//! an infrastructure error of the run (`errors.jsonl`), as in `eval`: it is
//! reported as missing, never scored as a failure of the model.

use crate::action::parse_action;
use crate::episode::Episode;
use crate::instructions::{SYSTEM_PROMPT, prompt_hash, system_prompt};
use crate::llm::Usage;
use crate::llm::types::{CompletionTokensDetails, PromptTokensDetails};
use crate::observation::render_scene;
use crate::probe::Probe;
use crate::rundir::record::{EpisodeKey, InfraErrorRecord, Provenance, RolloutRecord, TurnRecord};
use crate::rundir::{
    ERRORS, Endpoint, HistoryWindow, ImageDetail, ImageTokenRule, ImportSource, Invocation, ObservationMode,
    PictureSettings, ROLLOUTS, RUN_JSON, RunConfig, RunInfo, RunStatus, SCHEMA_VERSION, Selection, Settings, Shard,
    Totals,
};
use crate::scenario::{ScenarioKind, ScenarioSet, Tier};
use serde::Deserialize;
use serde_json::{Map, Value};
use std::io::Read;
use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum InspectLogError {
    #[error("{path}: {source}")]
    Io { path: String, source: std::io::Error },
    #[error("{path}: not an Inspect eval log ({message})")]
    Format { path: String, message: String },
    #[error("{path}: sample {sample}: {message}")]
    Sample { path: String, sample: String, message: String },
    #[error("{path}: the log has no samples (was it written with --no-log-samples?)")]
    NoSamples { path: String },
    #[error("{dir} already holds a run (run.json or rollouts.jsonl); import into a new directory")]
    OutputTaken { dir: String },
    #[error(transparent)]
    RunDir(#[from] crate::rundir::RunDirError),
}

/// An imported run: its run.json, its finished episodes and the samples
/// that did not finish.
#[derive(Debug, Clone)]
pub struct Imported {
    pub info: RunInfo,
    pub rollouts: Vec<RolloutRecord>,
    pub unfinished: Vec<InfraErrorRecord>,
}

/// Whether `path` names a file `report` should read as an Inspect log.
pub fn is_inspect_log(path: &Path) -> bool {
    path.is_file() && path.extension().is_some_and(|e| e == "eval" || e == "json")
}

/// Read an Inspect log and replay its samples (built-in scenarios).
pub fn read(path: &Path) -> Result<Imported, InspectLogError> {
    let shown = path.display().to_string();
    let (header, samples) = load(path)?;
    if samples.is_empty() {
        return Err(InspectLogError::NoSamples { path: shown });
    }
    let set = ScenarioSet::default();
    let spec = &header.eval;
    let version = spec.packages.get("inspect_ai").and_then(Value::as_str).unwrap_or("unknown").to_string();
    let endpoint = spec.model_base_url.as_deref().map(crate::redact::url_without_userinfo).unwrap_or_default();
    let mut rollouts = Vec::new();
    let mut unfinished = Vec::new();
    let mut shown_as: Option<Shown> = None;
    let sample_err = |sample: &LogSample, message: String| InspectLogError::Sample {
        path: shown.clone(),
        sample: sample.id.to_string(),
        message,
    };
    // The config (and so its hash) is settled by the first sample: how it
    // showed the scene (its system prompt says) and the detail of its
    // pictures; every sample must have shown it the same way.
    let config_of = |shown: Shown| RunConfig {
        model: spec.model.clone(),
        request_params: spec.model_generate_config.clone(),
        history: HistoryWindow::Full,
        prompt_hash: prompt_hash(Probe::NONE, shown.observation),
        scenarios_hash: set.config_hash(),
        endpoint: if endpoint.is_empty() { format!("inspect:{}", spec.model) } else { endpoint.clone() },
        probe: Probe::NONE,
        human: None,
        pictures: (shown.observation != ObservationMode::Text).then_some(PictureSettings {
            observation: shown.observation,
            detail: shown.detail,
            history: None,
        }),
    };
    for sample in &samples {
        let key = sample.key().map_err(|m| sample_err(sample, m))?;
        let shown = sample.shown(key.scenario).map_err(|m| sample_err(sample, m))?;
        if *shown_as.get_or_insert(shown) != shown {
            return Err(sample_err(
                sample,
                "it shows the scene otherwise than the first sample (its system prompt or its pictures' detail)".into(),
            ));
        }
        let config = config_of(shown);
        match replay(&set, sample, key, &config).map_err(|m| sample_err(sample, m))? {
            Replayed::Finished(record) => rollouts.push(*record),
            Replayed::Unfinished { turn, why } => {
                let at = sample.completed_at.clone().unwrap_or_default();
                unfinished.push(InfraErrorRecord::new(key, turn, why, at));
            }
        }
    }
    let config = config_of(shown_as.unwrap_or(Shown { observation: ObservationMode::Text, detail: ImageDetail::Auto }));
    let keys: Vec<EpisodeKey> =
        rollouts.iter().map(RolloutRecord::key).chain(unfinished.iter().map(InfraErrorRecord::key)).collect();
    let selection = selection(&spec.task_args, &spec.config, &keys);
    let finished = rollouts.len() as u64;
    let tokens: u64 = rollouts.iter().map(|r| r.tokens).sum();
    let stats = header.stats.unwrap_or_default();
    let started_at = stats.started_at.clone().unwrap_or_else(|| spec.created.clone());
    let wall_s = rollouts.iter().map(|r| r.wall_ms).sum::<u64>() as f64 / 1e3;
    let missing = selection.keys().len().saturating_sub(keys.len()) as u64;
    let status = if unfinished.is_empty() && missing == 0 { RunStatus::Finished } else { RunStatus::Incomplete };
    let invocation = Invocation {
        started_at: started_at.clone(),
        ended_at: stats.completed_at.clone(),
        status,
        selection,
        endpoint: Endpoint {
            api_key_env: None,
            base_url: endpoint.clone(),
            header_names: Vec::new(),
            profile: Some("inspect".to_string()),
        },
        settings: Settings::default(),
        episodes: finished,
        infra_errors: unfinished.len() as u64,
        retries: rollouts.iter().map(|r| u64::from(r.retries)).sum(),
        tokens,
        turns: rollouts.iter().map(|r| u64::from(r.turns_taken)).sum(),
        cost_usd: None,
        wall_s,
    };
    let info = RunInfo {
        schema_version: SCHEMA_VERSION,
        run_name: format!("inspect-{}-{}", crate::rundir::sanitize_name(&spec.model), spec.eval_id),
        config_hash: config.hash(),
        config,
        crate_version: spec.packages.get("negotiator").and_then(Value::as_str).unwrap_or("unknown").to_string(),
        git_revision: "unknown".to_string(),
        started_at,
        ended_at: stats.completed_at,
        invocations: 1,
        totals: Totals {
            episodes: finished,
            infra_errors: invocation.infra_errors,
            missing,
            retries: invocation.retries,
            tokens,
            cost_usd: None,
            wall_s,
        },
        last_invocation: invocation,
        pricing: None,
        imported_from: Some(ImportSource {
            harness: "inspect_ai".to_string(),
            harness_version: version,
            log: path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(),
            eval_id: spec.eval_id.clone(),
            run_id: spec.run_id.clone(),
            task: spec.task.clone(),
            task_args: spec.task_args.clone(),
        }),
    };
    Ok(Imported { info, rollouts, unfinished })
}

/// Write an imported run as a run directory (`dir` is created; it must not
/// hold a run already). Each file is written whole or not at all.
pub fn write(imported: &Imported, dir: &Path) -> Result<(), InspectLogError> {
    if dir.join(RUN_JSON).exists() || dir.join(ROLLOUTS).exists() {
        return Err(InspectLogError::OutputTaken { dir: dir.display().to_string() });
    }
    std::fs::create_dir_all(dir).map_err(|source| InspectLogError::Io { path: dir.display().to_string(), source })?;
    let lines = |values: Vec<String>| values.into_iter().map(|l| l + "\n").collect::<String>();
    let rollouts =
        lines(imported.rollouts.iter().map(|r| serde_json::to_string(r).expect("a record serialises")).collect());
    crate::rundir::write_atomic(&dir.join(ROLLOUTS), rollouts.as_bytes())?;
    if !imported.unfinished.is_empty() {
        let errors =
            lines(imported.unfinished.iter().map(|e| serde_json::to_string(e).expect("a record serialises")).collect());
        crate::rundir::write_atomic(&dir.join(ERRORS), errors.as_bytes())?;
    }
    crate::rundir::write_run_info(dir, &imported.info)?;
    Ok(())
}

/// Import the logs among `inputs` into run directories under `scratch`
/// (one per log), leaving run directories as they are: the inputs `report`
/// reads.
pub fn import_inputs(inputs: &[PathBuf], scratch: &Path) -> Result<Vec<PathBuf>, InspectLogError> {
    let mut out = Vec::with_capacity(inputs.len());
    for (i, input) in inputs.iter().enumerate() {
        if !is_inspect_log(input) {
            out.push(input.clone());
            continue;
        }
        let dir = scratch.join(format!("{i}"));
        write(&read(input)?, &dir)?;
        out.push(dir);
    }
    Ok(out)
}

enum Replayed {
    Finished(Box<RolloutRecord>),
    Unfinished { turn: u32, why: String },
}

/// Play the sample's episode again with its replies; check each scene.
fn replay(set: &ScenarioSet, sample: &LogSample, key: EpisodeKey, config: &RunConfig) -> Result<Replayed, String> {
    let mut episode = Episode::new(set.get(key.scenario), key.tier, key.seed);
    episode.record_trajectory();
    let exchanges = sample.exchanges();
    let calls: Vec<ModelCall> = sample
        .events
        .iter()
        .filter(|e| e.get("event").and_then(Value::as_str) == Some("model"))
        .filter_map(|e| serde_json::from_value(e.clone()).ok())
        .collect();
    // Per-call facts only when the events and the messages line up.
    let calls = (calls.len() == exchanges.len()).then_some(calls);
    let observation = config.observation();
    // Inspect keeps every earlier message, pictures included; each picture
    // is counted as eval counts one when the prices file has no rule.
    let per_picture = config
        .pictures
        .map_or(0, |p| ImageTokenRule::OPENAI_TILES.tokens(crate::picture::SIZE_PX, crate::picture::SIZE_PX, p.detail));
    let mut pictures = 0u32;
    let mut turns = Vec::new();
    for (i, (scene, reply)) in exchanges.iter().enumerate() {
        if episode.is_done() {
            return Err(format!("a reply after the episode ended (turn {})", i + 1));
        }
        let obs = episode.observation();
        let turn = obs.turn;
        let ours = render_scene(obs);
        pictures += u32::from(check_scene(sample, scene, obs, &ours, observation, key)?);
        let call = calls.as_ref().map(|c| &c[i]);
        let completion = call.and_then(|c| c.output.completion.clone()).or_else(|| reply.text.clone());
        let parsed = parse_action(completion.as_deref().unwrap_or(""));
        let ideal_belief = episode.ideal_belief();
        episode.step(parsed.action);
        let usage = call.and_then(|c| c.output.usage.as_ref()).map(InspectUsage::to_usage);
        let finish_reason = call.and_then(|c| c.output.stop_reason()).map(finish_reason);
        let tokens = usage.and_then(|u| u.total());
        turns.push(TurnRecord {
            turn,
            scene: ours,
            truncated: finish_reason.as_deref() == Some("length"),
            reply: completion,
            reasoning: reply.reasoning.clone(),
            finish_reason,
            action: parsed.action,
            action_reasoning: parsed.reasoning,
            parse_errors: parsed.errors,
            reasoning_tokens: usage.map_or(0, |u| u.reasoning()),
            cached_tokens: usage.map_or(0, |u| u.cached()),
            usage,
            tokens: tokens.unwrap_or(0),
            tokens_estimated: tokens.is_none(),
            reply_capped: false,
            pictures,
            image_tokens: u64::from(pictures) * per_picture,
            latency_ms: call.and_then(|c| c.output.time).map_or(0, |t| (t * 1e3).round() as u64),
            attempts: 1,
            after_resolution: false,
            ideal_belief: Some(ideal_belief),
            belief: None,
            belief_error: None,
            forecast: None,
            forecast_error: None,
        });
    }
    if !episode.is_done() {
        let why = match &sample.error {
            Some(e) => {
                format!("the sample ended in an error: {}", e.get("message").and_then(Value::as_str).unwrap_or("?"))
            }
            None => "the sample ended before the episode did (an Inspect limit)".to_string(),
        };
        return Ok(Replayed::Unfinished { turn: episode.observation().turn, why });
    }
    let graded = episode.finish();
    if let Some((outcome, reward)) = sample.scored() {
        let ours = serde_json::to_value(graded.outcome).expect("an outcome serialises");
        let ours = ours.as_str().unwrap_or_default();
        if outcome != ours || (reward - graded.grades.reward).abs() > 1e-9 {
            return Err(format!(
                "replayed, the episode ends {ours} with reward {:.6}, but the log scored {outcome} with {reward:.6}",
                graded.grades.reward
            ));
        }
    }
    let from = Provenance {
        model: config.model.clone(),
        config_hash: config.hash(),
        retries: sample.error_retries.len() as u32,
        cost_usd: None,
        wall_ms: sample.total_time.map_or(0, |t| (t * 1e3).round() as u64),
        finished_at: sample.completed_at.clone().unwrap_or_default(),
    };
    Ok(Replayed::Finished(Box::new(RolloutRecord::assemble(key, graded, turns, Default::default(), from))))
}

/// Whether the user message the log shows is the one this build sends for
/// `obs` (its text is `ours`) when the scene is shown as `observation`:
/// its line or text, and its picture's bytes when the log kept them.
/// Returns whether the message carries a picture.
fn check_scene(
    sample: &LogSample,
    scene: &Scene,
    obs: &crate::observation::Observation,
    ours: &str,
    observation: ObservationMode,
    key: EpisodeKey,
) -> Result<bool, String> {
    let turn = obs.turn;
    let sent = match observation {
        ObservationMode::Image => crate::picture::user_line(obs),
        ObservationMode::Text | ObservationMode::Both => ours.to_string(),
    };
    if scene.text != sent {
        return Err(format!(
            "the scene at turn {turn} is not the one this negotiator renders for {key} (a log of another version, or of another scenario file)"
        ));
    }
    match (&scene.image, observation) {
        (None, ObservationMode::Text) => Ok(false),
        (Some(_), ObservationMode::Text) => {
            Err(format!("a picture at turn {turn}, but the system prompt is a text run's"))
        }
        (None, _) => Err(format!("no picture at turn {turn}, but the system prompt says one is shown")),
        (Some(image), _) => {
            // A log written with --no-log-images keeps no bytes to check.
            if let Some(bytes) = sample.picture_bytes(&image.image)? {
                let drawn = crate::picture::png(obs).map_err(|e| e.to_string())?;
                if bytes != drawn {
                    return Err(format!(
                        "the picture at turn {turn} is not the one this negotiator draws for {key} (a log of another version?)"
                    ));
                }
            }
            Ok(true)
        }
    }
}

/// Inspect's stop reasons in the words `eval` records (`finish_reason`).
fn finish_reason(stop: &str) -> String {
    match stop {
        "max_tokens" | "model_length" => "length".to_string(),
        other => other.to_string(),
    }
}

/// The episodes the task selected, from its arguments (as `eval` reads
/// `--scenario`, `--tier`, `-n` and `--seed`), or else from the samples.
fn selection(args: &Map<String, Value>, config: &Map<String, Value>, keys: &[EpisodeKey]) -> Selection {
    let text = |v: &Value| match v {
        Value::String(s) => s.clone(),
        Value::Array(a) => a.iter().map(|x| x.to_string().trim_matches('"').to_string()).collect::<Vec<_>>().join(","),
        other => other.to_string(),
    };
    let names = |field: &str| args.get(field).map(text).filter(|s| !s.trim().is_empty());
    let scenarios = names("scenario")
        .and_then(|s| list_of(&s, &ScenarioKind::ALL))
        .unwrap_or_else(|| unique(keys.iter().map(|k| k.scenario)));
    let tiers =
        names("tier").and_then(|s| list_of(&s, &Tier::ALL)).unwrap_or_else(|| unique(keys.iter().map(|k| k.tier)));
    let first = keys.iter().map(|k| k.seed).min().unwrap_or(0);
    let last = keys.iter().map(|k| k.seed).max().unwrap_or(0);
    let base_seed = args.get("seed").and_then(Value::as_u64).unwrap_or(first);
    let seeds = args.get("seeds").and_then(Value::as_u64).unwrap_or(last.saturating_sub(first) + 1);
    let epochs = config.get("epochs").and_then(Value::as_u64).map(|e| e as u32);
    let rollouts = epochs.unwrap_or_else(|| keys.iter().map(|k| k.rollout + 1).max().unwrap_or(1));
    Selection { base_seed, rollouts, scenarios, seeds, shard: Shard::WHOLE, tiers }
}

/// `all`, or a comma-separated list of names (`None` if one is unknown).
fn list_of<T: Copy + std::str::FromStr>(value: &str, all: &[T]) -> Option<Vec<T>> {
    if value.trim() == "all" {
        return Some(all.to_vec());
    }
    value.split(',').map(|v| v.trim().parse().ok()).collect()
}

fn unique<T: Ord + Copy>(items: impl Iterator<Item = T>) -> Vec<T> {
    let set: std::collections::BTreeSet<T> = items.collect();
    set.into_iter().collect()
}

/// The log's header and samples, from a `.eval` zip or a `.json` log.
fn load(path: &Path) -> Result<(LogHeader, Vec<LogSample>), InspectLogError> {
    let shown = path.display().to_string();
    let bad = |message: String| InspectLogError::Format { path: shown.clone(), message };
    let file = std::fs::File::open(path).map_err(|source| InspectLogError::Io { path: shown.clone(), source })?;
    if path.extension().is_some_and(|e| e == "json") {
        let mut log: LogHeader =
            serde_json::from_reader(std::io::BufReader::new(file)).map_err(|e| bad(e.to_string()))?;
        let samples = log.samples.take().unwrap_or_default();
        return Ok((log, samples));
    }
    let mut zip = zip::ZipArchive::new(file).map_err(|e| bad(e.to_string()))?;
    let mut read_entry = |name: &str| -> Result<Vec<u8>, InspectLogError> {
        let mut entry = zip.by_name(name).map_err(|e| bad(format!("{name}: {e}")))?;
        let mut bytes = Vec::new();
        entry.read_to_end(&mut bytes).map_err(|e| bad(format!("{name}: {e}")))?;
        Ok(bytes)
    };
    let header: LogHeader =
        serde_json::from_slice(&read_entry("header.json")?).map_err(|e| bad(format!("header.json: {e}")))?;
    let mut names: Vec<String> = zip
        .file_names()
        .filter_map(|n| n.ok().map(|n| n.into_owned()))
        .filter(|n| n.starts_with("samples/") && n.ends_with(".json"))
        .collect();
    names.sort();
    let mut samples = Vec::with_capacity(names.len());
    for name in names {
        let mut entry = zip.by_name(&name).map_err(|e| bad(format!("{name}: {e}")))?;
        let mut bytes = Vec::new();
        entry.read_to_end(&mut bytes).map_err(|e| bad(format!("{name}: {e}")))?;
        samples.push(serde_json::from_slice(&bytes).map_err(|e| bad(format!("{name}: {e}")))?);
    }
    Ok((header, samples))
}

// The parts of Inspect's log format read here (`inspect_ai.log.EvalLog`);
// every other field is ignored.

#[derive(Debug, Deserialize)]
struct LogHeader {
    eval: EvalSpec,
    #[serde(default)]
    stats: Option<EvalStats>,
    #[serde(default)]
    samples: Option<Vec<LogSample>>,
}

#[derive(Debug, Deserialize)]
struct EvalSpec {
    #[serde(default)]
    eval_id: String,
    #[serde(default)]
    run_id: String,
    #[serde(default)]
    created: String,
    task: String,
    #[serde(default)]
    task_args: Map<String, Value>,
    model: String,
    #[serde(default)]
    model_base_url: Option<String>,
    #[serde(default)]
    model_generate_config: Map<String, Value>,
    #[serde(default)]
    packages: Map<String, Value>,
    #[serde(default)]
    config: Map<String, Value>,
}

#[derive(Debug, Default, Deserialize)]
struct EvalStats {
    #[serde(default)]
    started_at: Option<String>,
    #[serde(default)]
    completed_at: Option<String>,
}

#[derive(Debug, Deserialize)]
struct LogSample {
    id: Value,
    #[serde(default = "first_epoch")]
    epoch: u32,
    #[serde(default)]
    metadata: Map<String, Value>,
    #[serde(default)]
    messages: Vec<Message>,
    #[serde(default)]
    events: Vec<Value>,
    #[serde(default)]
    scores: Option<Map<String, Value>>,
    #[serde(default)]
    error: Option<Map<String, Value>>,
    #[serde(default)]
    error_retries: Vec<Value>,
    #[serde(default)]
    total_time: Option<f64>,
    #[serde(default)]
    completed_at: Option<String>,
    /// Content Inspect moved out of the messages (`attachment://<hash>`):
    /// the pictures among them.
    #[serde(default)]
    attachments: Map<String, Value>,
}

fn first_epoch() -> u32 {
    1
}

#[derive(Debug, Deserialize)]
struct Message {
    role: String,
    #[serde(default)]
    content: Content,
}

#[derive(Debug, Deserialize)]
#[serde(untagged)]
enum Content {
    Text(String),
    Parts(Vec<Value>),
}

impl Default for Content {
    fn default() -> Self {
        Content::Text(String::new())
    }
}

impl Content {
    /// The message's picture (its first image part), if it has one.
    fn image(&self) -> Option<ImagePart> {
        match self {
            Content::Text(_) => None,
            Content::Parts(parts) => parts
                .iter()
                .find(|p| p.get("type").and_then(Value::as_str) == Some("image"))
                .and_then(|p| serde_json::from_value(p.clone()).ok()),
        }
    }

    /// The parts of one type (`text`, `reasoning`), joined by newlines as
    /// Inspect's `ChatMessage.text` joins them; `None` if there are none.
    fn parts(&self, kind: &str) -> Option<String> {
        match self {
            Content::Text(t) => (kind == "text").then(|| t.clone()),
            Content::Parts(parts) => {
                let found: Vec<&str> = parts
                    .iter()
                    .filter(|p| p.get("type").and_then(Value::as_str) == Some(kind))
                    .filter_map(|p| p.get(kind).and_then(Value::as_str))
                    .collect();
                (!found.is_empty()).then(|| found.join("\n"))
            }
        }
    }
}

/// One decision's user message: its text, and its picture if it has one.
struct Scene {
    text: String,
    image: Option<ImagePart>,
}

/// Inspect's `ContentImage`.
#[derive(Debug, Deserialize)]
struct ImagePart {
    image: String,
    #[serde(default)]
    detail: Option<String>,
}

/// How a sample showed the scene: its system prompt's observation, and
/// the detail its pictures were sent at.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Shown {
    observation: ObservationMode,
    detail: ImageDetail,
}

/// What Inspect writes in place of a picture it was told not to log.
const PICTURE_NOT_LOGGED: &str = "<base64-data-removed>";

/// One decision as the messages show it: the scene sent and the reply.
struct Exchange {
    text: Option<String>,
    reasoning: Option<String>,
}

#[derive(Debug, Deserialize)]
struct ModelCall {
    output: ModelOutput,
}

#[derive(Debug, Deserialize)]
struct ModelOutput {
    #[serde(default)]
    completion: Option<String>,
    #[serde(default)]
    usage: Option<InspectUsage>,
    #[serde(default)]
    time: Option<f64>,
    #[serde(default)]
    choices: Vec<Value>,
}

impl ModelOutput {
    fn stop_reason(&self) -> Option<&str> {
        self.choices.first().and_then(|c| c.get("stop_reason")).and_then(Value::as_str)
    }
}

/// Inspect's `ModelUsage`: its input tokens leave out the cached ones.
#[derive(Debug, Deserialize)]
struct InspectUsage {
    #[serde(default)]
    input_tokens: u64,
    #[serde(default)]
    output_tokens: u64,
    #[serde(default)]
    total_tokens: Option<u64>,
    #[serde(default)]
    input_tokens_cache_read: Option<u64>,
    #[serde(default)]
    input_tokens_cache_write: Option<u64>,
    #[serde(default)]
    reasoning_tokens: Option<u64>,
}

impl InspectUsage {
    /// The usage as an OpenAI-compatible endpoint reports it, which is
    /// what `eval` records.
    fn to_usage(&self) -> Usage {
        let cached = self.input_tokens_cache_read.unwrap_or(0);
        let prompt = self.input_tokens + cached + self.input_tokens_cache_write.unwrap_or(0);
        Usage {
            prompt_tokens: Some(prompt),
            completion_tokens: Some(self.output_tokens),
            total_tokens: Some(self.total_tokens.unwrap_or(prompt + self.output_tokens)),
            prompt_tokens_details: self.input_tokens_cache_read.map(|c| PromptTokensDetails { cached_tokens: Some(c) }),
            completion_tokens_details: self
                .reasoning_tokens
                .map(|r| CompletionTokensDetails { reasoning_tokens: Some(r) }),
            ..Usage::default()
        }
    }
}

impl LogSample {
    /// (scenario, tier, seed) from the sample's metadata, the rollout from
    /// its epoch.
    fn key(&self) -> Result<EpisodeKey, String> {
        let field = |name: &str| self.metadata.get(name).ok_or_else(|| format!("no `{name}` in its metadata"));
        let scenario: ScenarioKind = field("scenario")?
            .as_str()
            .ok_or("`scenario` is not a name")?
            .parse()
            .map_err(|e: crate::scenario::UnknownScenario| e.to_string())?;
        let tier: Tier = match field("tier")? {
            Value::Number(n) => n.to_string(),
            Value::String(s) => s.clone(),
            _ => return Err("`tier` is not 1, 2 or 3".into()),
        }
        .parse()
        .map_err(|e: crate::scenario::UnknownTier| e.to_string())?;
        let seed = field("seed")?.as_u64().ok_or("`seed` is not a whole number")?;
        Ok(EpisodeKey { scenario, tier, seed, rollout: self.epoch.saturating_sub(1) })
    }

    fn system_prompt(&self) -> Option<&str> {
        self.messages.iter().find(|m| m.role == "system").and_then(|m| match &m.content {
            Content::Text(t) => Some(t.as_str()),
            Content::Parts(_) => None,
        })
    }

    /// How the sample showed the scene: the observation whose system
    /// prompt (this build's, for the sample's scenario) it sent, and the
    /// detail of its first picture.
    fn shown(&self, kind: ScenarioKind) -> Result<Shown, String> {
        let prompt = self.system_prompt().ok_or("no system message")?;
        let observation = [ObservationMode::Text, ObservationMode::Image, ObservationMode::Both]
            .into_iter()
            .find(|&o| system_prompt(Probe::NONE, kind, o) == prompt)
            .ok_or_else(|| {
                if prompt.starts_with(SYSTEM_PROMPT) && prompt.len() > SYSTEM_PROMPT.len() {
                    "its system prompt asks for a probe or shows pictures in a way this negotiator does not import"
                } else {
                    "its system prompt is not this negotiator's (another version?)"
                }
            })?;
        let detail = match self.exchanges().iter().find_map(|(scene, _)| scene.image.as_ref()) {
            None => ImageDetail::Auto,
            Some(image) => match image.detail.as_deref().unwrap_or("auto") {
                "low" => ImageDetail::Low,
                "high" => ImageDetail::High,
                "auto" => ImageDetail::Auto,
                other => return Err(format!("its pictures were sent at detail '{other}', which eval does not send")),
            },
        };
        Ok(Shown { observation, detail })
    }

    /// The PNG bytes of a picture as the log keeps them: inline, or as one
    /// of the sample's attachments; `None` when the log left them out.
    fn picture_bytes(&self, image: &str) -> Result<Option<Vec<u8>>, String> {
        use base64::Engine as _;
        let data = match image.strip_prefix("attachment://") {
            Some(hash) => self
                .attachments
                .get(hash)
                .and_then(Value::as_str)
                .ok_or_else(|| format!("a picture's attachment {hash} is not in the sample"))?,
            None => image,
        };
        if data == PICTURE_NOT_LOGGED {
            return Ok(None);
        }
        let encoded = data.strip_prefix("data:image/png;base64,").ok_or("a picture that is not a PNG data URL")?;
        base64::engine::general_purpose::STANDARD
            .decode(encoded)
            .map(Some)
            .map_err(|e| format!("a picture's base64 does not decode ({e})"))
    }

    /// Each user message (a scene) with the assistant's reply after it.
    fn exchanges(&self) -> Vec<(Scene, Exchange)> {
        let mut out = Vec::new();
        let mut scene: Option<Scene> = None;
        for m in &self.messages {
            match m.role.as_str() {
                "user" => {
                    scene = m.content.parts("text").map(|text| Scene { text, image: m.content.image() });
                }
                "assistant" => {
                    if let Some(s) = scene.take() {
                        out.push((
                            s,
                            Exchange { text: m.content.parts("text"), reasoning: m.content.parts("reasoning") },
                        ));
                    }
                }
                _ => {}
            }
        }
        out
    }

    /// The outcome and reward the log's scorer recorded, if any.
    fn scored(&self) -> Option<(String, f64)> {
        let score = self.scores.as_ref()?.values().next()?;
        let md = score.get("metadata")?;
        Some((md.get("outcome")?.as_str()?.to_string(), md.get("reward")?.as_f64()?))
    }
}
