//! Request profiles: how one provider (or one family of models behind it)
//! wants the request body spelled.
//!
//! Providers agree on the OpenAI chat-completions shape but not on its
//! fields: OpenAI's reasoning models refuse `max_tokens` and any
//! `temperature` but the default, OpenRouter asks for effort in a
//! `reasoning` object, Anthropic's compatibility layer takes a `thinking`
//! object, Gemini's takes `reasoning_effort`. A [`RequestProfile`] names,
//! for one such family: the token-limit field, the sampling fields it
//! accepts, how to ask for a reasoning effort, and the fields to omit.
//! [`build_params`] turns the run's parameters (config defaults, then
//! flags) into the body fields that profile accepts.
//!
//! The shipped profiles live in `configs/endpoints.toml`, each with the
//! provider documentation it follows.

use serde::{Deserialize, Serialize};
use serde_json::{Map, Value, json};
use std::collections::BTreeMap;

/// Sampling fields the builder knows. A profile lists which of these its
/// models accept; the others are left out of the body when they come from
/// the configuration (a flag always wins, see [`build_params`]). Fields
/// outside this list are not sampling and pass through untouched unless the
/// profile omits them.
pub const SAMPLING_FIELDS: &[&str] = &[
    "temperature",
    "top_p",
    "top_k",
    "min_p",
    "seed",
    "presence_penalty",
    "frequency_penalty",
    "repetition_penalty",
    "logprobs",
    "top_logprobs",
    "logit_bias",
];

/// The two spellings of the completion-token limit.
pub const TOKEN_LIMIT_FIELDS: &[&str] = &["max_tokens", "max_completion_tokens"];

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TokenLimitField {
    #[default]
    MaxTokens,
    MaxCompletionTokens,
}

impl TokenLimitField {
    pub fn name(self) -> &'static str {
        match self {
            TokenLimitField::MaxTokens => "max_tokens",
            TokenLimitField::MaxCompletionTokens => "max_completion_tokens",
        }
    }
}

/// How `--reasoning-effort E` is spelled in the body.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ReasoningStyle {
    /// The models take no effort setting: `--reasoning-effort` is refused.
    #[default]
    None,
    /// `"reasoning_effort": "E"` (OpenAI, Gemini's and Ollama's
    /// OpenAI-compatible endpoints, vLLM, Together).
    ReasoningEffort,
    /// `"reasoning": {"effort": "E"}` (OpenRouter).
    ReasoningObject,
    /// `"thinking": {"type": "enabled", "budget_tokens": B}` with B from
    /// the profile's `thinking_budgets` (Anthropic).
    ThinkingBudget,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RequestProfile {
    #[serde(default)]
    pub description: Option<String>,
    /// Which field carries the completion-token limit.
    #[serde(default)]
    pub token_limit: TokenLimitField,
    /// The completion-token limit sent when no flag or endpoint sets one
    /// (none: the server's default). For models that think inside the limit
    /// it must leave room for the thinking, or every turn is cut off before
    /// the JSON answer.
    #[serde(default)]
    pub max_tokens: Option<u64>,
    /// The sampling fields of [`SAMPLING_FIELDS`] these models accept.
    #[serde(default)]
    pub sampling: Vec<String>,
    #[serde(default)]
    pub reasoning: ReasoningStyle,
    /// Accepted `--reasoning-effort` values (empty: any).
    #[serde(default)]
    pub efforts: Vec<String>,
    /// `thinking_budget` style: effort -> budget_tokens.
    #[serde(default)]
    pub thinking_budgets: BTreeMap<String, u64>,
    /// Other fields never to send from the configuration.
    #[serde(default)]
    pub omit: Vec<String>,
    /// Fields never to send from the configuration when a reasoning effort
    /// is asked for (Anthropic refuses a temperature with thinking on).
    #[serde(default)]
    pub omit_when_reasoning: Vec<String>,
    /// The models think before answering by default, inside the limit.
    #[serde(default)]
    pub thinks: bool,
    /// Reasoning tokens per turn assumed by `eval --dry-run` (an estimate to
    /// size a budget, not a measurement; 0 for models that do not think).
    #[serde(default)]
    pub expected_reasoning_tokens: u64,
}

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ProfileError {
    #[error("--reasoning-effort: profile '{profile}' has no reasoning effort setting (its models take none)")]
    NoReasoning { profile: String },
    #[error("--reasoning-effort: '{effort}' is not accepted by profile '{profile}' (accepted: {accepted})")]
    BadEffort { profile: String, effort: String, accepted: String },
    #[error(
        "--max-tokens: {limit} must be larger than the thinking budget {budget} that --reasoning-effort {effort} asks for (profile '{profile}')"
    )]
    BudgetOverLimit { profile: String, effort: String, budget: u64, limit: u64 },
    #[error("--max-tokens: the token limit must be a whole number of at least 1, got {0}")]
    BadLimit(String),
}

/// What [`build_params`] did, for the note printed before a run.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BuiltParams {
    /// The body fields besides `model` and `messages`.
    pub params: Map<String, Value>,
    /// Configuration fields left out because the profile does not take them.
    pub dropped: Vec<String>,
    /// Flag fields sent although the profile does not list them.
    pub forced: Vec<String>,
}

impl RequestProfile {
    /// The permissive profile used when an endpoint names none: every
    /// field is sent as configured, the limit as `max_tokens`.
    pub fn generic() -> RequestProfile {
        RequestProfile {
            description: Some("any OpenAI-compatible server: everything is sent as configured".into()),
            token_limit: TokenLimitField::MaxTokens,
            max_tokens: None,
            sampling: SAMPLING_FIELDS.iter().map(|s| s.to_string()).collect(),
            reasoning: ReasoningStyle::ReasoningEffort,
            ..RequestProfile::default()
        }
    }

    fn accepts_sampling(&self, field: &str) -> bool {
        self.sampling.iter().any(|s| s == field)
    }
}

/// The completion-token limit a request carries, decided here alone: a
/// flag's spelling wins over the configuration's; a null in either removes
/// the limit altogether; nothing set means the profile's figure. A thinking
/// budget is spent inside the limit: when nothing set the limit, the
/// profile's figure is room for the answer on top of the budget, and with
/// no figure the budget gets 1024 tokens of answer.
fn token_limit(
    profile: &RequestProfile,
    configured: &Map<String, Value>,
    flags: &Map<String, Value>,
    effort: Option<&str>,
) -> Result<Option<u64>, ProfileError> {
    fn pick(m: &Map<String, Value>) -> Option<&Value> {
        TOKEN_LIMIT_FIELDS.iter().find_map(|f| m.get(*f).filter(|v| !v.is_null()))
    }
    let removed =
        [flags, configured].iter().any(|m| TOKEN_LIMIT_FIELDS.iter().any(|f| m.get(*f).is_some_and(Value::is_null)));
    let set = pick(flags).or_else(|| pick(configured));
    let mut limit = match set {
        _ if removed && pick(flags).is_none() => None,
        Some(v) => Some(v.as_u64().filter(|n| *n > 0).ok_or_else(|| ProfileError::BadLimit(v.to_string()))?),
        None => profile.max_tokens,
    };
    let budget = effort
        .filter(|_| profile.reasoning == ReasoningStyle::ThinkingBudget)
        .and_then(|e| profile.thinking_budgets.get(e));
    if let Some(b) = budget {
        match limit.as_mut() {
            Some(l) if set.is_none() => *l += b,
            Some(_) => {}
            None => limit = Some(b + 1024),
        }
    }
    Ok(limit)
}

/// Build the body parameters.
///
/// `configured`: endpoint and alias defaults, merged. `flags`: what the
/// command line set (`--sampling-args`, `--temperature`, `--max-tokens`,
/// `--response-format`), applied over them; a `null` value removes the key
/// (`--sampling-args '{"temperature": null}'`). Then:
/// - the token limit (either spelling, else the profile's figure) goes out
///   under the profile's field; a `null` for either spelling sends none;
/// - sampling fields the profile does not accept, and `omit` fields, are
///   dropped when they come from the configuration and sent with a note
///   when a flag set them (the user may know a model better than the file);
/// - `effort` is spelled the profile's way.
pub fn build_params(
    name: &str,
    profile: &RequestProfile,
    configured: &Map<String, Value>,
    flags: &Map<String, Value>,
    effort: Option<&str>,
) -> Result<BuiltParams, ProfileError> {
    let mut merged: Map<String, Value> = configured.clone();
    let mut from_flags: Vec<&str> = Vec::new();
    for (k, v) in flags {
        if v.is_null() {
            merged.remove(k);
        } else {
            merged.insert(k.clone(), v.clone());
        }
        from_flags.push(k.as_str());
    }
    let flagged = |k: &str| from_flags.contains(&k);
    let mut out = BuiltParams::default();

    for f in TOKEN_LIMIT_FIELDS {
        merged.remove(*f);
    }
    let limit = token_limit(profile, configured, flags, effort)?;

    for (k, v) in merged {
        let unwanted = (SAMPLING_FIELDS.contains(&k.as_str()) && !profile.accepts_sampling(&k))
            || profile.omit.contains(&k)
            || (effort.is_some() && profile.omit_when_reasoning.contains(&k));
        if !unwanted {
            out.params.insert(k, v);
        } else if flagged(&k) {
            out.forced.push(k.clone());
            out.params.insert(k, v);
        } else {
            out.dropped.push(k);
        }
    }
    if let Some(limit) = limit {
        out.params.insert(profile.token_limit.name().to_string(), Value::from(limit));
    }

    if let Some(effort) = effort {
        if profile.reasoning == ReasoningStyle::None {
            return Err(ProfileError::NoReasoning { profile: name.to_string() });
        }
        let accepted: Vec<&String> = match profile.reasoning {
            ReasoningStyle::ThinkingBudget => profile.thinking_budgets.keys().collect(),
            _ => profile.efforts.iter().collect(),
        };
        if !accepted.is_empty() && !accepted.iter().any(|a| a.as_str() == effort) {
            return Err(ProfileError::BadEffort {
                profile: name.to_string(),
                effort: effort.to_string(),
                accepted: accepted.iter().map(|s| s.as_str()).collect::<Vec<_>>().join(", "),
            });
        }
        match profile.reasoning {
            ReasoningStyle::None => unreachable!("refused above"),
            ReasoningStyle::ReasoningEffort => {
                out.params.insert("reasoning_effort".into(), Value::from(effort));
            }
            ReasoningStyle::ReasoningObject => {
                out.params.insert("reasoning".into(), json!({ "effort": effort }));
            }
            ReasoningStyle::ThinkingBudget => {
                let budget = profile.thinking_budgets[effort];
                // Anthropic: budget_tokens must be below max_tokens.
                if let Some(limit) = limit.filter(|l| *l <= budget) {
                    return Err(ProfileError::BudgetOverLimit {
                        profile: name.to_string(),
                        effort: effort.to_string(),
                        budget,
                        limit,
                    });
                }
                out.params.insert("thinking".into(), json!({ "type": "enabled", "budget_tokens": budget }));
            }
        }
    }
    out.dropped.sort();
    out.forced.sort();
    Ok(out)
}

/// `*` matches any run of characters; everything else matches itself.
pub fn glob_match(pattern: &str, text: &str) -> bool {
    let parts: Vec<&str> = pattern.split('*').collect();
    if parts.len() == 1 {
        return pattern == text;
    }
    let (first, last) = (parts[0], parts[parts.len() - 1]);
    if !text.starts_with(first) || text.len() < first.len() + last.len() || !text.ends_with(last) {
        return false;
    }
    let mut rest = &text[first.len()..text.len() - last.len()];
    for mid in &parts[1..parts.len() - 1] {
        match rest.find(mid) {
            Some(i) => rest = &rest[i + mid.len()..],
            None => return false,
        }
    }
    true
}

/// Which setting a rejected parameter is changed with: the hint of the one
/// line that stops a run on a 400 naming a parameter.
pub fn remedy_for(param: &str, profile: &str) -> String {
    match param {
        "max_tokens" | "max_completion_tokens" => format!(
            "the endpoint wants the other token-limit field: set `token_limit` of profile '{profile}' in the endpoints file, or pick another --profile"
        ),
        "reasoning_effort" | "reasoning" | "thinking" => format!(
            "drop --reasoning-effort, or set `reasoning` of profile '{profile}' to the way this endpoint takes it"
        ),
        "temperature" => format!(
            "drop --temperature, or remove it with --sampling-args '{{\"temperature\": null}}' (profile '{profile}' lists the sampling fields it sends)"
        ),
        p => format!(
            "remove it with --sampling-args '{{\"{p}\": null}}', or add it to `omit` of profile '{profile}' in the endpoints file"
        ),
    }
}

/// The request parameter a provider's 400 message names, if any: the
/// wordings of OpenAI ("Unsupported parameter: 'max_tokens' ...",
/// "Unsupported value: 'temperature' ..."), Google ("Unknown name
/// \"seed\""), and a parameter of `sent` quoted anywhere in the message.
pub fn rejected_parameter(message: &str, sent: &Map<String, Value>) -> Option<String> {
    for lead in
        ["Unsupported parameter: ", "Unsupported value: ", "Unknown name ", "Unrecognized request argument supplied: "]
    {
        if let Some(i) = message.find(lead) {
            let rest = message[i + lead.len()..].trim_start_matches(['\'', '"', '`']);
            let name: String =
                rest.chars().take_while(|c| c.is_ascii_alphanumeric() || *c == '_' || *c == '.').collect();
            if !name.is_empty() {
                return Some(name.split('.').next().unwrap_or(&name).to_string());
            }
        }
    }
    // Longest names first, so `top_logprobs` is not read as `logprobs`.
    let mut names: Vec<&String> = sent.keys().collect();
    names.sort_by_key(|k| std::cmp::Reverse(k.len()));
    names.into_iter().find(|k| ["'", "\"", "`"].iter().any(|q| message.contains(&format!("{q}{k}{q}")))).cloned()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map(v: Value) -> Map<String, Value> {
        v.as_object().unwrap().clone()
    }

    fn reasoning_profile() -> RequestProfile {
        RequestProfile {
            token_limit: TokenLimitField::MaxCompletionTokens,
            max_tokens: Some(25_000),
            sampling: vec!["seed".into()],
            reasoning: ReasoningStyle::ReasoningEffort,
            efforts: vec!["low".into(), "medium".into(), "high".into()],
            ..RequestProfile::default()
        }
    }

    #[test]
    fn reasoning_profile_renames_the_limit_and_drops_configured_temperature() {
        let configured = map(json!({"temperature": 0.7, "max_tokens": 1024, "seed": 3}));
        let b = build_params("r", &reasoning_profile(), &configured, &Map::new(), Some("high")).unwrap();
        assert_eq!(
            Value::Object(b.params),
            json!({"max_completion_tokens": 1024, "seed": 3, "reasoning_effort": "high"})
        );
        assert_eq!(b.dropped, vec!["temperature"]);
        assert!(b.forced.is_empty());
    }

    #[test]
    fn the_profile_limit_applies_when_nothing_sets_one_and_null_removes_it() {
        let p = reasoning_profile();
        let b = build_params("r", &p, &Map::new(), &Map::new(), None).unwrap();
        assert_eq!(b.params.get("max_completion_tokens"), Some(&json!(25_000)));
        let b =
            build_params("r", &p, &map(json!({"max_tokens": 99})), &map(json!({"max_tokens": null})), None).unwrap();
        assert!(b.params.is_empty(), "{:?}", b.params);
        let b = build_params("r", &p, &Map::new(), &map(json!({"max_completion_tokens": 7})), None).unwrap();
        assert_eq!(Value::Object(b.params), json!({"max_completion_tokens": 7}));
        assert!(build_params("r", &p, &map(json!({"max_tokens": "lots"})), &Map::new(), None).is_err());
    }

    #[test]
    fn a_flag_wins_over_the_profile_and_is_reported() {
        let flags = map(json!({"temperature": 0.2}));
        let b = build_params("r", &reasoning_profile(), &Map::new(), &flags, None).unwrap();
        assert_eq!(b.params.get("temperature"), Some(&json!(0.2)));
        assert_eq!(b.forced, vec!["temperature"]);
        // A null flag removes a configured key outright.
        let g = RequestProfile::generic();
        let b =
            build_params("g", &g, &map(json!({"temperature": 0.7})), &map(json!({"temperature": null})), None).unwrap();
        assert!(b.params.is_empty(), "the generic profile sends no limit of its own: {:?}", b.params);
    }

    #[test]
    fn effort_styles() {
        let mut p = RequestProfile { max_tokens: Some(100), ..RequestProfile::default() };
        assert!(matches!(
            build_params("n", &p, &Map::new(), &Map::new(), Some("low")),
            Err(ProfileError::NoReasoning { .. })
        ));
        p.reasoning = ReasoningStyle::ReasoningObject;
        let b = build_params("o", &p, &Map::new(), &Map::new(), Some("low")).unwrap();
        assert_eq!(b.params.get("reasoning"), Some(&json!({"effort": "low"})));
        p.reasoning = ReasoningStyle::ThinkingBudget;
        p.thinking_budgets = [("low".to_string(), 1024u64), ("high".to_string(), 16_000)].into();
        p.max_tokens = Some(20_000);
        p.sampling = vec!["temperature".into()];
        p.omit_when_reasoning = vec!["temperature".into()];
        let b = build_params("a", &p, &map(json!({"temperature": 0.7})), &Map::new(), Some("high")).unwrap();
        assert_eq!(b.params.get("thinking"), Some(&json!({"type": "enabled", "budget_tokens": 16_000})));
        assert_eq!(b.params.get("max_tokens"), Some(&json!(36_000)), "the budget comes on top of the profile's limit");
        assert!(!b.params.contains_key("temperature"), "Anthropic refuses a temperature with thinking");
        let low_limit = map(json!({"max_tokens": 8000}));
        let e = build_params("a", &p, &Map::new(), &low_limit, Some("high")).unwrap_err();
        assert!(e.to_string().starts_with("--max-tokens: 8000"), "{e}");
        let e = build_params("a", &p, &Map::new(), &Map::new(), Some("extreme")).unwrap_err();
        assert_eq!(e.to_string(), "--reasoning-effort: 'extreme' is not accepted by profile 'a' (accepted: high, low)");
    }

    #[test]
    fn omitted_fields_leave_only_when_configured() {
        let p =
            RequestProfile { max_tokens: Some(5), omit: vec!["response_format".into()], ..RequestProfile::generic() };
        let rf = json!({"response_format": {"type": "json_object"}});
        let b = build_params("p", &p, &map(rf.clone()), &Map::new(), None).unwrap();
        assert_eq!(b.dropped, vec!["response_format"]);
        let b = build_params("p", &p, &Map::new(), &map(rf), None).unwrap();
        assert_eq!(b.forced, vec!["response_format"]);
    }

    #[test]
    fn globs() {
        assert!(glob_match("gpt-5*", "gpt-5-mini"));
        assert!(glob_match("o*", "o3"));
        assert!(glob_match("*/o4-*", "openai/o4-mini"));
        assert!(glob_match("*thinking*", "qwen3-thinking-2507"));
        assert!(!glob_match("gpt-5*", "gpt-4o"));
        assert!(glob_match("exact", "exact"));
        assert!(!glob_match("a*b", "ab_"));
        assert!(!glob_match("ab*ba", "aba"));
    }

    #[test]
    fn rejected_parameters_are_read_from_provider_wordings() {
        let sent = map(json!({"max_tokens": 1, "temperature": 0.7, "top_logprobs": 2, "logprobs": true}));
        let cases = [
            (
                "Unsupported parameter: 'max_tokens' is not supported with this model. Use 'max_completion_tokens' instead.",
                "max_tokens",
            ),
            (
                "Unsupported value: 'temperature' does not support 0.7 with this model. Only the default (1) value is supported.",
                "temperature",
            ),
            ("Invalid JSON payload received. Unknown name \"seed\": Cannot find field.", "seed"),
            ("`top_logprobs` is not supported by this model", "top_logprobs"),
        ];
        for (msg, want) in cases {
            assert_eq!(rejected_parameter(msg, &sent).as_deref(), Some(want), "{msg}");
        }
        assert_eq!(rejected_parameter("Invalid API key", &sent), None);
        assert!(remedy_for("max_tokens", "p").contains("token_limit"));
        assert!(remedy_for("temperature", "p").contains("{\"temperature\": null}"));
        assert!(remedy_for("logprobs", "p").contains("{\"logprobs\": null}"));
    }
}
