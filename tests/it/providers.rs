//! One mock per request profile of `configs/endpoints.toml`. Each mock
//! enforces the request rules its provider documents (the profile's comment
//! cites the page), answering a broken rule with a 400 worded as that
//! provider words it, and reports usage in that provider's shape. `eval`
//! with the shipped profile must finish against each with zero 400s; the
//! wrong profile must be refused with the setting that fixes it.
//!
//! Where a provider's exact wording is not documented (OpenRouter's
//! both-effort-and-budget refusal, Anthropic's thinking constraints through
//! the compatibility layer), the mock words it after the rule the docs state.

use crate::support::{negotiator, scratch};
use negotiator::policy::PolicyKind;
use serde_json::{Value, json};
use std::path::Path;
use std::process::Output;
use std::sync::{Arc, Mutex};

/// A provider's verdict on a request body: `Err((status, error body))`.
type Rules = fn(&Value) -> Result<(), (u16, Value)>;

/// What one provider returns for a reply: (usage, extra message fields),
/// given the prompt size, the reply size and the thinking spent.
type Shape = fn(u64, u64, u64) -> (Value, Value);

struct Provider {
    /// Endpoint name in the built-in endpoints file (its profile is used).
    endpoint: &'static str,
    model: &'static str,
    key_var: Option<&'static str>,
    rules: Rules,
    shape: Shape,
    /// Reasoning tokens spent per turn (0: the model does not think).
    thinking: u64,
}

/// Everything a mock saw.
#[derive(Default)]
pub struct Seen {
    pub bodies: Vec<Vec<u8>>,
    pub rejected: Vec<String>,
}

/// The expert's answer to the last user message, as JSON content.
pub fn expert_reply(body: &Value) -> String {
    let scene = body["messages"].as_array().and_then(|m| m.last()).and_then(|m| m["content"].as_str()).unwrap_or("");
    let action = match negotiator::observation::parse_scene(scene) {
        Ok(obs) => {
            let mut p = PolicyKind::Expert.build();
            p.reset(0);
            p.act(&obs)
        }
        Err(_) => return "{\"maneuver\": \"stop\"}".into(),
    };
    json!({"reasoning": "mock", "acceleration": action.acceleration, "steering": 0.0,
           "maneuver": action.maneuver.name()})
    .to_string()
}

/// The completion-token limit of a body, in either spelling.
pub fn limit_of(body: &Value) -> Option<u64> {
    body.get("max_completion_tokens").or(body.get("max_tokens")).and_then(Value::as_u64)
}

/// A rough token count of the request, as a server would tokenise it.
fn prompt_tokens(body: &Value) -> u64 {
    (body["messages"].to_string().len() / 4) as u64
}

pub type Handler = Arc<dyn Fn(&Value) -> (u16, Value) + Send + Sync>;

/// An axum server on a background thread answering every POST to
/// `/v1/chat/completions` with `handler(body)`; returns its base URL and
/// what it saw.
pub fn start_mock(handler: Handler) -> (String, Arc<Mutex<Seen>>) {
    start_mock_on("127.0.0.1", handler)
}

/// [`start_mock`] on another loopback address (127.0.0.2 is this machine
/// too, but not a host the prices file knows).
pub fn start_mock_on(host: &'static str, handler: Handler) -> (String, Arc<Mutex<Seen>>) {
    use axum::routing::post;
    let seen = Arc::new(Mutex::new(Seen::default()));
    let (tx, rx) = std::sync::mpsc::channel();
    let log = seen.clone();
    std::thread::spawn(move || {
        let rt = tokio::runtime::Builder::new_current_thread().enable_all().build().unwrap();
        rt.block_on(async move {
            let listener = tokio::net::TcpListener::bind((host, 0)).await.unwrap();
            tx.send(listener.local_addr().unwrap().port()).unwrap();
            let app = axum::Router::new().route(
                "/v1/chat/completions",
                post(move |bytes: axum::body::Bytes| {
                    let (handler, log) = (handler.clone(), log.clone());
                    async move {
                        use axum::response::IntoResponse;
                        let body: Value = serde_json::from_slice(&bytes).unwrap_or(Value::Null);
                        let (status, reply) = handler(&body);
                        let mut seen = log.lock().unwrap();
                        seen.bodies.push(bytes.to_vec());
                        if status == 400 {
                            seen.rejected.push(reply.to_string());
                        }
                        (axum::http::StatusCode::from_u16(status).unwrap(), axum::Json(reply)).into_response()
                    }
                }),
            );
            axum::serve(listener, app).await.unwrap();
        });
    });
    (format!("http://{host}:{}/v1", rx.recv().unwrap()), seen)
}

/// A mock for one provider: its rules, then a reply in its shape.
fn provider_mock(p: &'static Provider) -> (String, Arc<Mutex<Seen>>) {
    start_mock(Arc::new(move |body: &Value| {
        if let Err(refusal) = (p.rules)(body) {
            return refusal;
        }
        let content = expert_reply(body);
        let completion = (content.len() / 4) as u64;
        let (usage, extra) = (p.shape)(prompt_tokens(body), completion, p.thinking);
        let mut message = json!({"role": "assistant", "content": content});
        if let (Some(m), Some(e)) = (message.as_object_mut(), extra.as_object()) {
            m.extend(e.clone());
        }
        (
            200,
            json!({"id": "x", "object": "chat.completion", "model": p.model,
                     "choices": [{"index": 0, "message": message, "finish_reason": "stop"}], "usage": usage}),
        )
    }))
}

fn openai_error(message: String, param: &str, code: &str) -> (u16, Value) {
    (400, json!({"error": {"message": message, "type": "invalid_request_error", "param": param, "code": code}}))
}

/// OpenAI rejects arguments it does not know.
fn openai_known(body: &Value, known: &[&str]) -> Result<(), (u16, Value)> {
    for k in body.as_object().into_iter().flat_map(|o| o.keys()) {
        if !known.contains(&k.as_str()) {
            return Err(openai_error(format!("Unrecognized request argument supplied: {k}"), k, "unknown_parameter"));
        }
    }
    Ok(())
}

const OPENAI_FIELDS: &[&str] = &[
    "model",
    "messages",
    "max_tokens",
    "max_completion_tokens",
    "temperature",
    "top_p",
    "seed",
    "presence_penalty",
    "frequency_penalty",
    "logprobs",
    "top_logprobs",
    "logit_bias",
    "response_format",
    "reasoning_effort",
    "stop",
    "n",
    "stream",
];

fn openai_chat_rules(body: &Value) -> Result<(), (u16, Value)> {
    openai_known(body, OPENAI_FIELDS)?;
    if body.get("reasoning_effort").is_some() {
        return Err(openai_error(
            "Unsupported parameter: 'reasoning_effort' is not supported with this model.".into(),
            "reasoning_effort",
            "unsupported_parameter",
        ));
    }
    Ok(())
}

fn openai_reasoning_rules(body: &Value) -> Result<(), (u16, Value)> {
    openai_known(body, OPENAI_FIELDS)?;
    if body.get("max_tokens").is_some() {
        return Err(openai_error(
            "Unsupported parameter: 'max_tokens' is not supported with this model. Use 'max_completion_tokens' instead."
                .into(),
            "max_tokens",
            "unsupported_parameter",
        ));
    }
    for p in ["temperature", "top_p"] {
        if let Some(v) = body.get(p).filter(|v| v.as_f64() != Some(1.0)) {
            return Err(openai_error(
                format!(
                    "Unsupported value: '{p}' does not support {v} with this model. Only the default (1) value is supported."
                ),
                p,
                "unsupported_value",
            ));
        }
    }
    if let Some(e) = body.get("reasoning_effort").and_then(Value::as_str)
        && !["minimal", "low", "medium", "high"].contains(&e)
    {
        return Err(openai_error(
            format!(
                "Unsupported value: 'reasoning_effort' does not support '{e}' with this model. Supported values are: 'minimal', 'low', 'medium', and 'high'."
            ),
            "reasoning_effort",
            "unsupported_value",
        ));
    }
    Ok(())
}

/// OpenAI's usage: cached prompt tokens and reasoning tokens in details;
/// reasoning is part of completion_tokens.
fn openai_shape(prompt: u64, completion: u64, thinking: u64) -> (Value, Value) {
    let cached = prompt / 2;
    (
        json!({"prompt_tokens": prompt, "completion_tokens": completion + thinking,
               "total_tokens": prompt + completion + thinking,
               "prompt_tokens_details": {"cached_tokens": cached, "audio_tokens": 0},
               "completion_tokens_details": {"reasoning_tokens": thinking, "audio_tokens": 0}}),
        json!({"refusal": null, "annotations": []}),
    )
}

fn openrouter_rules(body: &Value) -> Result<(), (u16, Value)> {
    if let Some(r) = body.get("reasoning") {
        if r.get("effort").is_some() && r.get("max_tokens").is_some() {
            return Err((
                400,
                json!({"error": {"code": 400, "message": "Only one of \"reasoning.effort\" and \"reasoning.max_tokens\" may be specified"}}),
            ));
        }
        if let Some(e) = r.get("effort").and_then(Value::as_str)
            && !["minimal", "low", "medium", "high"].contains(&e)
        {
            return Err((400, json!({"error": {"code": 400, "message": format!("Invalid reasoning.effort '{e}'")}})));
        }
    }
    if body.get("max_completion_tokens").is_some() && body.get("max_tokens").is_some() {
        return Err((
            400,
            json!({"error": {"code": 400, "message": "Give either 'max_tokens' or 'max_completion_tokens'"}}),
        ));
    }
    Ok(())
}

/// OpenRouter: OpenAI's details, a cost, the thinking in `reasoning`.
fn openrouter_shape(prompt: u64, completion: u64, thinking: u64) -> (Value, Value) {
    let (mut usage, _) = openai_shape(prompt, completion, thinking);
    usage["cost"] = json!(0.0001);
    usage["is_byok"] = json!(false);
    (usage, json!({"reasoning": if thinking > 0 { json!("weighing the other car") } else { Value::Null }}))
}

fn anthropic_error(message: &str) -> (u16, Value) {
    (400, json!({"type": "error", "error": {"type": "invalid_request_error", "message": message}}))
}

fn anthropic_rules(body: &Value) -> Result<(), (u16, Value)> {
    if body.get("n").is_some_and(|n| n.as_u64() != Some(1)) {
        return Err(anthropic_error("n: only n = 1 is supported"));
    }
    let limit = limit_of(body);
    if let Some(t) = body.get("thinking") {
        let budget = t["budget_tokens"].as_u64().unwrap_or(0);
        if budget < 1024 {
            return Err(anthropic_error(
                "thinking.enabled.budget_tokens: Input should be greater than or equal to 1024",
            ));
        }
        if limit.is_none_or(|l| l <= budget) {
            return Err(anthropic_error("`max_tokens` must be greater than `thinking.budget_tokens`"));
        }
        for p in ["temperature", "top_k"] {
            if body.get(p).is_some_and(|v| v.as_f64() != Some(1.0)) {
                return Err(anthropic_error(&format!("`{p}` may only be set to 1 when thinking is enabled")));
            }
        }
    }
    Ok(())
}

/// Anthropic's compatibility layer: the three OpenAI counts only.
fn plain_shape(prompt: u64, completion: u64, thinking: u64) -> (Value, Value) {
    (
        json!({"prompt_tokens": prompt, "completion_tokens": completion + thinking,
               "total_tokens": prompt + completion + thinking}),
        json!({}),
    )
}

const GEMINI_FIELDS: &[&str] = &[
    "model",
    "messages",
    "max_tokens",
    "temperature",
    "top_p",
    "n",
    "stop",
    "seed",
    "presence_penalty",
    "frequency_penalty",
    "reasoning_effort",
    "response_format",
    "stream",
    "extra_body",
];

fn gemini_rules(body: &Value) -> Result<(), (u16, Value)> {
    for k in body.as_object().into_iter().flat_map(|o| o.keys()) {
        if !GEMINI_FIELDS.contains(&k.as_str()) {
            return Err((
                400,
                json!([{"error": {"code": 400,
                    "message": format!("Invalid JSON payload received. Unknown name \"{k}\": Cannot find field."),
                    "status": "INVALID_ARGUMENT"}}]),
            ));
        }
    }
    Ok(())
}

/// Gemini: the thinking is in total_tokens only.
fn gemini_shape(prompt: u64, completion: u64, thinking: u64) -> (Value, Value) {
    (
        json!({"prompt_tokens": prompt, "completion_tokens": completion, "total_tokens": prompt + completion + thinking}),
        json!({}),
    )
}

fn deepseek_rules(body: &Value) -> Result<(), (u16, Value)> {
    for p in ["logprobs", "top_logprobs"] {
        if body.get(p).is_some() {
            return Err(openai_error(format!("{p} is not supported by deepseek-reasoner"), p, "invalid_request_error"));
        }
    }
    let sent_back = body["messages"].as_array().is_some_and(|m| m.iter().any(|m| m.get("reasoning_content").is_some()));
    if sent_back {
        return Err(openai_error(
            "The reasoning_content is an intermediate result for display only and must not be passed back as input"
                .into(),
            "messages",
            "invalid_request_error",
        ));
    }
    if limit_of(body).is_some_and(|l| l > 65_536) {
        return Err(openai_error("max_tokens must be at most 65536".into(), "max_tokens", "invalid_request_error"));
    }
    Ok(())
}

/// DeepSeek: cache hits and misses at the top level, reasoning in details,
/// the thinking in `reasoning_content`.
fn deepseek_shape(prompt: u64, completion: u64, thinking: u64) -> (Value, Value) {
    let hit = prompt / 2;
    (
        json!({"prompt_tokens": prompt, "completion_tokens": completion + thinking,
               "total_tokens": prompt + completion + thinking,
               "prompt_cache_hit_tokens": hit, "prompt_cache_miss_tokens": prompt - hit,
               "completion_tokens_details": {"reasoning_tokens": thinking}}),
        json!({"reasoning_content": "the car keeps its speed"}),
    )
}

/// Together serves with a context window; the limit counts inside it.
fn together_rules(body: &Value) -> Result<(), (u16, Value)> {
    let (inputs, max_new) = (prompt_tokens(body), limit_of(body).unwrap_or(0));
    if inputs + max_new > 32_769 {
        return Err((
            400,
            json!({"error": {"message": format!("Input validation error: `inputs` tokens + `max_new_tokens` must be <= 32769. Given: {inputs} `inputs` tokens and {max_new} `max_new_tokens`"),
                             "type": "invalid_request_error", "param": null, "code": null}}),
        ));
    }
    Ok(())
}

/// vLLM rejects a request whose prompt plus completion limit exceeds the
/// served context (`--max-model-len`; Qwen3-8B's own default is 40,960).
/// Modelled as a deployment that caps it at 16,384: a full-history episode
/// of the longest scenario (24 turns) fits with the 1,024-token limit.
fn vllm_rules(body: &Value) -> Result<(), (u16, Value)> {
    let (inputs, completion) = (prompt_tokens(body), limit_of(body).unwrap_or(0));
    if inputs + completion > 16_384 {
        return Err((
            400,
            json!({"object": "error", "type": "BadRequestError", "param": null, "code": 400,
                   "message": format!("This model's maximum context length is 16384 tokens. However, you requested {} tokens ({inputs} in the messages, {completion} in the completion). Please reduce the length of the messages or completion.", inputs + completion)}),
        ));
    }
    Ok(())
}

/// vLLM with --enable-prompt-tokens-details and a reasoning parser.
fn vllm_shape(prompt: u64, completion: u64, thinking: u64) -> (Value, Value) {
    (
        json!({"prompt_tokens": prompt, "completion_tokens": completion + thinking,
               "total_tokens": prompt + completion + thinking, "prompt_tokens_details": {"cached_tokens": prompt / 2}}),
        json!({"reasoning_content": null, "tool_calls": []}),
    )
}

fn ollama_rules(body: &Value) -> Result<(), (u16, Value)> {
    if let Some(e) = body.get("reasoning_effort").and_then(Value::as_str)
        && !["high", "medium", "low", "none"].contains(&e)
    {
        return Err((
            400,
            json!({"error": {"message": format!("invalid reasoning value: '{e}' (must be \"high\", \"medium\", \"low\", or \"none\")"),
                             "type": "invalid_request_error", "param": null, "code": null}}),
        ));
    }
    Ok(())
}

static PROVIDERS: &[Provider] = &[
    Provider {
        endpoint: "openai",
        model: "gpt-4o",
        key_var: Some("OPENAI_API_KEY"),
        rules: openai_chat_rules,
        shape: openai_shape,
        thinking: 0,
    },
    Provider {
        endpoint: "openai",
        model: "gpt-5",
        key_var: Some("OPENAI_API_KEY"),
        rules: openai_reasoning_rules,
        shape: openai_shape,
        thinking: 300,
    },
    Provider {
        endpoint: "openrouter",
        model: "openai/gpt-5",
        key_var: Some("OPENROUTER_API_KEY"),
        rules: openrouter_rules,
        shape: openrouter_shape,
        thinking: 300,
    },
    Provider {
        endpoint: "openrouter",
        model: "meta-llama/llama-3.3-70b-instruct",
        key_var: Some("OPENROUTER_API_KEY"),
        rules: openrouter_rules,
        shape: openrouter_shape,
        thinking: 0,
    },
    Provider {
        endpoint: "anthropic",
        model: "claude-sonnet-4-5",
        key_var: Some("ANTHROPIC_API_KEY"),
        rules: anthropic_rules,
        shape: plain_shape,
        thinking: 0,
    },
    Provider {
        endpoint: "gemini",
        model: "gemini-2.5-pro",
        key_var: Some("GEMINI_API_KEY"),
        rules: gemini_rules,
        shape: gemini_shape,
        thinking: 500,
    },
    Provider {
        endpoint: "deepseek",
        model: "deepseek-reasoner",
        key_var: Some("DEEPSEEK_API_KEY"),
        rules: deepseek_rules,
        shape: deepseek_shape,
        thinking: 400,
    },
    Provider {
        endpoint: "together",
        model: "deepseek-ai/DeepSeek-R1",
        key_var: Some("TOGETHER_API_KEY"),
        rules: together_rules,
        shape: plain_shape,
        thinking: 400,
    },
    Provider {
        endpoint: "vllm",
        model: "Qwen/Qwen3-8B",
        key_var: None,
        rules: vllm_rules,
        shape: vllm_shape,
        thinking: 0,
    },
    Provider {
        endpoint: "ollama",
        model: "qwen3:8b",
        key_var: None,
        rules: ollama_rules,
        shape: plain_shape,
        thinking: 0,
    },
];

pub fn eval_against(
    endpoint: &str,
    base_url: &str,
    model: &str,
    key_var: Option<&str>,
    out: &Path,
    extra: &[&str],
) -> Output {
    let mut c = negotiator();
    c.args(["eval", "--endpoint", endpoint, "--base-url", base_url, "--model", model, "--output"])
        .arg(out)
        .args(["--run-name", "run", "--scenario", "all", "-n", "2", "-c", "3", "--max-retries", "0"])
        .args(extra);
    if let Some(var) = key_var {
        c.env(var, "sk-test-not-a-real-key");
    }
    let out = c.output().unwrap();
    assert!(!String::from_utf8_lossy(&out.stderr).contains("panicked"), "{}", String::from_utf8_lossy(&out.stderr));
    out
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn every_shipped_profile_passes_its_providers_rules() {
    for p in PROVIDERS {
        let (url, seen) = provider_mock(p);
        let out = scratch(&format!("provider-{}-{}", p.endpoint, p.model.replace(['/', ':', '.'], "_")));
        let effort =
            if p.model == "gpt-5" || p.endpoint == "openrouter" { vec!["--reasoning-effort", "low"] } else { vec![] };
        let o = eval_against(p.endpoint, &url, p.model, p.key_var, &out, &effort);
        let seen = seen.lock().unwrap();
        assert!(seen.rejected.is_empty(), "{} {}: 400s {:?}", p.endpoint, p.model, seen.rejected);
        assert!(o.status.success(), "{} {}: exit {:?}: {}", p.endpoint, p.model, o.status.code(), stderr(&o));
        let lines = std::fs::read_to_string(out.join("run/rollouts.jsonl")).unwrap();
        assert_eq!(lines.lines().count(), 6, "{} {}", p.endpoint, p.model);
        // The stored usage keeps the provider's own fields.
        let first: Value = serde_json::from_str(lines.lines().next().unwrap()).unwrap();
        let usage = &first["turns"][0]["usage"];
        assert!(usage["prompt_tokens"].as_u64().unwrap() > 0, "{usage}");
        if p.endpoint == "deepseek" {
            assert!(usage["prompt_cache_hit_tokens"].as_u64().is_some(), "{usage}");
        }
    }
}

#[test]
fn the_wrong_profile_is_refused_with_the_setting_that_fixes_it() {
    let gpt5 = &PROVIDERS[1];
    let (url, seen) = provider_mock(gpt5);
    let out = scratch("provider-wrong-profile");
    // The chat profile sends temperature 0.7 and max_completion_tokens.
    let o = eval_against("openai", &url, "gpt-5", gpt5.key_var, &out, &["--profile", "openai-chat"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let err = stderr(&o);
    let last = err.lines().last().unwrap();
    assert!(last.contains("Unsupported value: 'temperature' does not support 0.7"), "{err}");
    assert!(last.contains("the endpoint rejects 'temperature'"), "{err}");
    assert!(last.contains("--sampling-args '{\"temperature\": null}'"), "{err}");
    assert!(!seen.lock().unwrap().rejected.is_empty());

    // The null the hint names removes the key; the generic profile then
    // sends the flag's max_tokens as is, which this model refuses in turn.
    let out = scratch("provider-wrong-profile-2");
    let o = eval_against(
        "openai",
        &url,
        "gpt-5",
        gpt5.key_var,
        &out,
        &["--profile", "generic", "--sampling-args", "{\"temperature\": null}", "--max-tokens", "500"],
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("Unsupported parameter: 'max_tokens'"), "{err}");
    assert!(err.contains("the endpoint rejects 'max_tokens'"), "{err}");
    assert!(err.contains("token_limit"), "{err}");
}

#[test]
fn a_bad_effort_for_the_profile_is_a_usage_error_before_any_request() {
    let (url, seen) = provider_mock(&PROVIDERS[6]);
    let out = scratch("provider-deepseek-effort");
    let o = eval_against(
        "deepseek",
        &url,
        "deepseek-reasoner",
        Some("DEEPSEEK_API_KEY"),
        &out,
        &["--reasoning-effort", "high"],
    );
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(
        stderr(&o).trim(),
        "Error: --reasoning-effort: profile 'deepseek-reasoner' has no reasoning effort setting (its models take none)"
    );
    assert!(seen.lock().unwrap().bodies.is_empty());
}

/// A reasoning model that spends `THINKING` tokens before its JSON answer,
/// inside the completion limit (as OpenAI's reasoning models do): with a
/// smaller limit it is cut off with `finish_reason: "length"` and no
/// content, all of its completion spent on reasoning.
const THINKING: u64 = 2000;

fn thinking_mock() -> (String, Arc<Mutex<Seen>>) {
    start_mock(Arc::new(|body: &Value| {
        if let Err(refusal) = openai_reasoning_rules(body) {
            return refusal;
        }
        let limit = limit_of(body).unwrap_or(u64::MAX);
        let prompt = prompt_tokens(body);
        let usage = |completion: u64, reasoning: u64| {
            json!({"prompt_tokens": prompt, "completion_tokens": completion, "total_tokens": prompt + completion,
                   "prompt_tokens_details": {"cached_tokens": 0},
                   "completion_tokens_details": {"reasoning_tokens": reasoning}})
        };
        let content = expert_reply(body);
        let answer = (content.len() / 4) as u64;
        if limit < THINKING + answer {
            return (
                200,
                json!({"choices": [{"index": 0, "finish_reason": "length",
                "message": {"role": "assistant", "content": ""}}], "usage": usage(limit, limit)}),
            );
        }
        (
            200,
            json!({"choices": [{"index": 0, "finish_reason": "stop",
            "message": {"role": "assistant", "content": content}}], "usage": usage(THINKING + answer, THINKING)}),
        )
    }))
}

fn summary_of(out: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(out.join("run/summary.json")).unwrap()).unwrap()
}

#[test]
fn a_thinking_model_below_its_limit_is_flagged_truncated_and_the_run_stops_with_the_remedy() {
    let (url, _) = thinking_mock();
    let out = scratch("provider-thinking-cut");
    let o =
        eval_against("openai", &url, "gpt-5", Some("OPENAI_API_KEY"), &out, &["--max-tokens", "800", "--tier", "all"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let err = stderr(&o);
    let last = err.lines().last().unwrap();
    assert!(last.contains("were cut off by the completion-token limit (max_completion_tokens = 800)"), "{err}");
    assert!(last.contains("--max-tokens N") && last.contains("--allow-truncation"), "{err}");
    // The fleet was paused long before the 18 selected episodes.
    let lines: Vec<Value> = std::fs::read_to_string(out.join("run/rollouts.jsonl"))
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert!(!lines.is_empty() && lines.len() < 10, "{} episodes", lines.len());
    for l in &lines {
        assert_eq!(l["truncated_turns"], l["turns_taken"], "every turn was cut off");
        assert_eq!(l["parse_error_turns"], 0, "cut-off turns are not counted as parse errors");
        assert_eq!(l["turns"][0]["truncated"], true);
        assert_eq!(l["turns"][0]["reasoning_tokens"], 800);
    }
    // Resuming the same command stops again before playing anything.
    let o =
        eval_against("openai", &url, "gpt-5", Some("OPENAI_API_KEY"), &out, &["--max-tokens", "800", "--tier", "all"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let after = std::fs::read_to_string(out.join("run/rollouts.jsonl")).unwrap().lines().count();
    assert_eq!(after, lines.len());
}

#[test]
fn the_shipped_reasoning_limit_does_not_truncate_and_allow_truncation_scores_cut_turns() {
    let (url, seen) = thinking_mock();
    let out = scratch("provider-thinking-ok");
    let o = eval_against("openai", &url, "gpt-5", Some("OPENAI_API_KEY"), &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(seen.lock().unwrap().rejected.is_empty());
    let s = summary_of(&out);
    assert!(s["cells"].as_array().unwrap().iter().all(|c| c["truncated_rate"] == 0.0), "{s}");
    let turns: u64 = s["cells"].as_array().unwrap().iter().map(|c| c["episodes"].as_u64().unwrap()).sum();
    assert!(turns > 0);
    assert_eq!(s["reasoning_tokens"].as_u64().unwrap() % THINKING, 0, "{s}");
    assert!(s["reasoning_tokens"].as_u64().unwrap() >= 6 * THINKING, "{s}");

    let out = scratch("provider-thinking-allowed");
    let o = eval_against(
        "openai",
        &url,
        "gpt-5",
        Some("OPENAI_API_KEY"),
        &out,
        &["--max-tokens", "800", "--allow-truncation"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let s = summary_of(&out);
    for c in s["cells"].as_array().unwrap() {
        assert_eq!(c["truncated_rate"], 1.0, "{c}");
        assert_eq!(c["parse_error_rate"], 0.0, "{c}");
    }
}

/// Provider prompt caches match on a byte prefix: with the full history,
/// each request of an episode must start with the previous one's bytes up to
/// its last message, and end with the same parameters (no timestamp, no
/// reordered key).
#[test]
fn each_request_extends_the_previous_one_byte_for_byte() {
    let p = &PROVIDERS[0];
    let (url, seen) = provider_mock(p);
    let out = scratch("provider-prefix");
    let o = eval_against(p.endpoint, &url, p.model, p.key_var, &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    // Requests of one episode share their first scene; episodes interleave.
    let mut episodes: std::collections::BTreeMap<String, Vec<String>> = Default::default();
    for b in &seen.lock().unwrap().bodies {
        let v: Value = serde_json::from_slice(b).unwrap();
        let first_scene = v["messages"][1]["content"].as_str().unwrap().to_string();
        episodes.entry(first_scene).or_default().push(String::from_utf8(b.clone()).unwrap());
    }
    assert_eq!(episodes.len(), 6);
    let mut compared = 0;
    for bodies in episodes.values_mut() {
        bodies.sort_by_key(String::len);
        for pair in bodies.windows(2) {
            let (a, b) = (&pair[0], &pair[1]);
            let end = a.rfind("}]").expect("a messages array") + 1;
            assert!(b.starts_with(&a[..end]), "prefix changed:\n{a}\n{b}");
            assert_eq!(&a[end + 1..], &b[b.rfind("}]").unwrap() + 2..], "parameters changed");
            compared += 1;
        }
    }
    assert!(compared >= 10, "{compared} consecutive turns compared");
}
