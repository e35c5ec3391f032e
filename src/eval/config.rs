//! Named endpoints (`configs/endpoints.toml`). The run configuration that
//! identifies a run directory is [`crate::rundir::RunConfig`].

use serde::Deserialize;
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

    #[test]
    fn builtin_endpoints_parse_and_list_the_paper_models() {
        let f = EndpointsFile::builtin();
        for name in ["openai", "openrouter", "vllm", "ollama", "local"] {
            assert!(f.endpoints.contains_key(name), "{name}");
        }
        assert!(f.models.len() >= 6);
    }

    #[test]
    fn names_are_directory_safe() {
        assert_eq!(sanitize_name("openai/gpt-4o"), "openai_gpt-4o");
        assert_eq!(sanitize_name("../.."), "model");
        assert_eq!(sanitize_name("qwen3:30b"), "qwen3_30b");
    }
}
