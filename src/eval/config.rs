//! Named endpoints (`configs/endpoints.toml`) and the run configuration
//! that identifies a run directory.

use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};
use std::collections::BTreeMap;

/// The endpoints file shipped with the binary (a copy of
/// `configs/endpoints.toml`), so a fresh install knows the same names.
pub const BUILTIN_ENDPOINTS: &str = include_str!("../../configs/endpoints.toml");

#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    #[error("{path}: {message}")]
    Parse { path: String, message: String },
    #[error("unknown endpoint '{name}' (known: {known})")]
    UnknownEndpoint { name: String, known: String },
    #[error("model alias '{alias}' names endpoint '{endpoint}', which is not defined")]
    DanglingAlias { alias: String, endpoint: String },
}

#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EndpointsFile {
    #[serde(default)]
    pub endpoints: BTreeMap<String, Endpoint>,
    /// Model aliases: `--model ALIAS` picks the endpoint and model id.
    #[serde(default)]
    pub models: BTreeMap<String, ModelAlias>,
}

#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Endpoint {
    pub base_url: String,
    /// Environment variable holding the API key; none for local servers.
    #[serde(default)]
    pub api_key_env: Option<String>,
    /// Default request parameters (temperature, max_tokens, ...), merged
    /// into every request; flags override them.
    #[serde(default)]
    pub sampling: Map<String, Value>,
    /// Extra headers sent with every request (values may not hold secrets:
    /// use `api_key_env` for those).
    #[serde(default)]
    pub headers: BTreeMap<String, String>,
    #[serde(default)]
    pub description: Option<String>,
}

#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelAlias {
    pub endpoint: String,
    pub id: String,
    #[serde(default)]
    pub sampling: Map<String, Value>,
    #[serde(default)]
    pub description: Option<String>,
}

impl EndpointsFile {
    pub fn parse(path: &str, text: &str) -> Result<EndpointsFile, ConfigError> {
        let file: EndpointsFile =
            toml::from_str(text).map_err(|e| ConfigError::Parse { path: path.to_string(), message: e.to_string() })?;
        for (alias, m) in &file.models {
            if !file.endpoints.contains_key(&m.endpoint) {
                return Err(ConfigError::DanglingAlias { alias: alias.clone(), endpoint: m.endpoint.clone() });
            }
        }
        Ok(file)
    }

    pub fn builtin() -> EndpointsFile {
        EndpointsFile::parse("configs/endpoints.toml (built in)", BUILTIN_ENDPOINTS)
            .expect("the built-in endpoints file parses")
    }

    pub fn endpoint(&self, name: &str) -> Result<&Endpoint, ConfigError> {
        self.endpoints.get(name).ok_or_else(|| ConfigError::UnknownEndpoint {
            name: name.to_string(),
            known: self.endpoints.keys().cloned().collect::<Vec<_>>().join(", "),
        })
    }
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

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// What makes two invocations the same experiment, so that they may share a
/// run directory: everything that can change how an episode plays out.
/// Deliberately left out (recorded in run.json, free to change on resume):
/// the selection of episodes (scenarios, tiers, n, r, base seed, shard;
/// episodes are keyed, so a resume may extend or merge), the base URL and
/// headers (transport: a mirror of the same model may finish a run), and
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

/// A directory-safe rendering of a model id: `openai/gpt-4o` -> `openai_gpt-4o`.
pub fn sanitize_name(model: &str) -> String {
    let s: String = model
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() || matches!(c, '-' | '.' | '_') { c } else { '_' })
        .collect();
    let s = s.trim_matches(|c| c == '.' || c == '_').to_string();
    if s.is_empty() { "model".to_string() } else { s.chars().take(80).collect() }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config() -> RunConfig {
        let mut params = Map::new();
        params.insert("temperature".into(), Value::from(0.0));
        RunConfig {
            model: "m".into(),
            request_params: params,
            history: HistoryWindow::Full,
            prompt_hash: "p".into(),
            scenarios_hash: "s".into(),
        }
    }

    #[test]
    fn builtin_endpoints_parse_and_list_the_paper_models() {
        let f = EndpointsFile::builtin();
        for name in ["openai", "openrouter", "vllm", "ollama", "local"] {
            assert!(f.endpoints.contains_key(name), "{name}");
        }
        assert!(f.models.len() >= 6);
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
        let d = a.diff(&b);
        assert_eq!(d.len(), 3, "{d:?}");
        assert!(d.iter().any(|l| l.starts_with("request_params.temperature: 0.0 -> 0.7")), "{d:?}");
        assert!(d.iter().any(|l| l.starts_with("request_params.top_p: (unset) -> 0.9")), "{d:?}");
        assert!(d.iter().any(|l| l.starts_with("history:")), "{d:?}");
        assert_ne!(a.hash(), b.hash());
    }

    #[test]
    fn names_are_directory_safe() {
        assert_eq!(sanitize_name("openai/gpt-4o"), "openai_gpt-4o");
        assert_eq!(sanitize_name("../.."), "model");
        assert_eq!(sanitize_name("qwen3:30b"), "qwen3_30b");
    }
}
