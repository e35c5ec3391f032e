//! Named endpoints (`configs/endpoints.toml`). The run configuration that
//! identifies a run directory is [`crate::rundir::RunConfig`].

use crate::llm::profile::RequestProfile;
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
    #[error("{owner} names request profile '{profile}', which is not defined (known: {known})")]
    UnknownProfile { owner: String, profile: String, known: String },
}

#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EndpointsFile {
    #[serde(default)]
    pub endpoints: BTreeMap<String, Endpoint>,
    /// Model aliases: `--model ALIAS` picks the endpoint and model id.
    #[serde(default)]
    pub models: BTreeMap<String, ModelAlias>,
    /// Request profiles: how a provider wants the body spelled.
    #[serde(default)]
    pub profiles: BTreeMap<String, RequestProfile>,
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
    /// The request profile of this endpoint's models (none: send the
    /// configuration as is).
    #[serde(default)]
    pub profile: Option<String>,
    /// Model-id pattern (`*` = anything) -> profile, for the models of this
    /// endpoint that want another one; the longest matching pattern wins.
    #[serde(default)]
    pub model_profiles: BTreeMap<String, String>,
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
    /// A request profile for this model, over the endpoint's choice.
    #[serde(default)]
    pub profile: Option<String>,
}

impl EndpointsFile {
    pub fn parse(path: &str, text: &str) -> Result<EndpointsFile, ConfigError> {
        let file: EndpointsFile =
            toml::from_str(text).map_err(|e| ConfigError::Parse { path: path.to_string(), message: e.to_string() })?;
        for (alias, m) in &file.models {
            if !file.endpoints.contains_key(&m.endpoint) {
                return Err(ConfigError::DanglingAlias { alias: alias.clone(), endpoint: m.endpoint.clone() });
            }
            if let Some(p) = &m.profile {
                file.check_profile(&format!("model alias '{alias}'"), p)?;
            }
        }
        for (name, e) in &file.endpoints {
            for p in e.profile.iter().chain(e.model_profiles.values()) {
                file.check_profile(&format!("endpoint '{name}'"), p)?;
            }
        }
        Ok(file)
    }

    fn check_profile(&self, owner: &str, profile: &str) -> Result<(), ConfigError> {
        if self.profiles.contains_key(profile) {
            return Ok(());
        }
        Err(ConfigError::UnknownProfile {
            owner: owner.to_string(),
            profile: profile.to_string(),
            known: self.profiles.keys().cloned().collect::<Vec<_>>().join(", "),
        })
    }

    /// The request profile for a model: `--profile`, else the alias's, else
    /// the endpoint's longest matching `model_profiles` pattern, else the
    /// endpoint's `profile`, else the permissive generic one. Returns its
    /// name with it.
    pub fn profile_for(
        &self,
        flag: Option<&str>,
        alias: Option<&ModelAlias>,
        endpoint: Option<&Endpoint>,
        model: &str,
    ) -> Result<(String, RequestProfile), ConfigError> {
        let by_pattern = endpoint.and_then(|e| {
            e.model_profiles
                .iter()
                .filter(|(pattern, _)| crate::llm::profile::glob_match(pattern, model))
                .max_by_key(|(pattern, _)| pattern.len())
                .map(|(_, p)| p.as_str())
        });
        let chosen = flag
            .or(alias.and_then(|a| a.profile.as_deref()))
            .or(by_pattern)
            .or(endpoint.and_then(|e| e.profile.as_deref()));
        match chosen {
            None => Ok(("generic".to_string(), RequestProfile::generic())),
            Some(name) => {
                if flag.is_some() && name == "generic" && !self.profiles.contains_key("generic") {
                    return Ok(("generic".to_string(), RequestProfile::generic()));
                }
                self.check_profile("--profile", name)?;
                Ok((name.to_string(), self.profiles[name].clone()))
            }
        }
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
    fn models_get_their_provider_profile() {
        let f = EndpointsFile::builtin();
        let pick = |endpoint: &str, model: &str| {
            f.profile_for(None, None, Some(f.endpoint(endpoint).unwrap()), model).unwrap().0
        };
        assert_eq!(pick("openai", "gpt-4o"), "openai-chat");
        assert_eq!(pick("openai", "gpt-5"), "openai-reasoning");
        assert_eq!(pick("openai", "gpt-5-mini"), "openai-reasoning");
        assert_eq!(pick("openai", "gpt-5-chat-latest"), "openai-chat", "the longest pattern wins");
        assert_eq!(pick("openai", "o4-mini"), "openai-reasoning");
        assert_eq!(pick("openrouter", "openai/gpt-5"), "openrouter-reasoning");
        assert_eq!(pick("openrouter", "meta-llama/llama-3.3-70b-instruct"), "openrouter");
        assert_eq!(pick("deepseek", "deepseek-reasoner"), "deepseek-reasoner");
        assert_eq!(pick("deepseek", "deepseek-chat"), "deepseek-chat");
        assert_eq!(pick("anthropic", "claude-sonnet-4-5"), "anthropic");
        assert_eq!(pick("gemini", "gemini-2.5-flash"), "gemini");
        assert_eq!(f.profile_for(None, None, None, "x").unwrap().0, "generic");
        assert_eq!(f.profile_for(Some("vllm"), None, Some(f.endpoint("openai").unwrap()), "gpt-5").unwrap().0, "vllm");
        let e = f.profile_for(Some("nope"), None, None, "x").unwrap_err().to_string();
        assert!(
            e.starts_with("--profile names request profile 'nope', which is not defined (known: anthropic,"),
            "{e}"
        );
        // Every shipped reasoning profile leaves room to think.
        for (name, p) in &f.profiles {
            if p.thinks {
                assert!(p.max_tokens.is_some_and(|m| m >= 16_000), "{name}: {:?}", p.max_tokens);
            }
        }
    }

    #[test]
    fn an_endpoint_naming_a_missing_profile_is_refused() {
        let text = "[endpoints.x]\nbase_url = \"http://h/v1\"\nprofile = \"missing\"\n";
        let e = EndpointsFile::parse("f.toml", text).unwrap_err().to_string();
        assert_eq!(e, "endpoint 'x' names request profile 'missing', which is not defined (known: )");
    }
}
