//! `negotiator serve`: an OpenAI-compatible chat endpoint whose "model" is a
//! scripted policy reading the scene text. For offline demos, tests and
//! fault injection.
//!
//! The model reads only the last user message, parses it back into an
//! observation with [`parse_scene`] and answers with the policy's action as
//! `{"reasoning": ..., "acceleration": ..., "steering": 0.0, "maneuver": ...}`.
//! A message that is not a scene gets the conservative stop, not an HTTP
//! error. `random` draws from a seed hashed from the scene text and the
//! server seed, so the same scene gets the same answer.
//!
//! A request with `"stream": true` is answered as OpenAI's API streams:
//! server-sent events, one `chat.completion.chunk` with the role, one with
//! the content, one with the finish reason, a last chunk with no choices
//! and the usage when `stream_options.include_usage` asks for it, then
//! `data: [DONE]`. A harness that wraps the scene in JSON (a user message
//! such as `{"observation": {...}, "action_schema": {...}}`, as an
//! environment client forwards it) is read too: the scene is the last
//! string inside it that holds one.
//!
//! A conversation that shows the scene as a picture (`eval --observation
//! image`: an `image_url` content part and one line) is answered from the
//! episode found behind it ([`pictured`]): the pictures are matched as
//! bytes against the simulator's own, never read.
//!
//! Token counts in `usage` are estimates: request body bytes / 4 for the
//! prompt (a picture's data URL left out, and the picture counted as
//! OpenAI counts it: 85 tokens at detail low, 255 otherwise), reply bytes
//! / 4 for the completion.
//!
//! Fault injection is decided per request, in arrival order: request i
//! (counting every chat request) draws from a stream seeded by (seed, i), so
//! a given request count meets the same faults on every run. The rate limit
//! is a token bucket (capacity one second's worth) and is time-based by
//! nature: a request finding it empty gets 429 with `Retry-After` in whole
//! seconds. Then, independently: `fail_rate` answers a 5xx (500 or 503 with
//! an error body) or an HTTP 200 carrying an error object and no choices;
//! `drop_rate` sends the headers and part of the body, then breaks the
//! connection; `garbage_rate` answers a well-formed completion whose content
//! is not a valid action (prose, cut-off JSON with `finish_reason: length`,
//! null content, an unknown maneuver, an out-of-range number, an unclosed
//! `<think>`): driving on a parse error, not an infrastructure failure.

mod pictured;

use crate::episode::Episode;
use crate::hash::{fnv1a64, splitmix64, unit_f64};
use crate::observation::{parse_scene, render_scene};
use crate::policy::PolicyKind;
use crate::policy::reply::{SceneRead, action_json, answer_with_belief};
use crate::scenario::{ScenarioKind, ScenarioSet, Tier};
use crate::shutdown::shutdown;
use axum::Router;
use axum::body::{Body, Bytes};
use axum::extract::State;
use axum::http::{HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use serde::Deserialize;
use serde_json::{Value, json};
use std::collections::HashMap;
use std::sync::Arc;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant, SystemTime};

/// The largest request body taken (OpenAI takes 50 MB of pictures per request).
const MAX_BODY_BYTES: usize = 64 << 20;

/// Server settings.
#[derive(Debug, Clone)]
pub(crate) struct ServeConfig {
    pub(crate) policy: PolicyKind,
    pub(crate) seed: u64,
    pub(crate) latency: Duration,
    pub(crate) fail_rate: f64,
    pub(crate) rate_limit: Option<f64>,
    pub(crate) drop_rate: f64,
    pub(crate) garbage_rate: f64,
    /// `--probe belief`: add the policy's belief to every answer; the
    /// expert's needs its episode found in this index.
    pub(crate) belief: Option<Arc<EpisodeIndex>>,
    /// `--probe forecast`: add this forecaster's forecast of the last
    /// scene to every answer (it reads only the scene text).
    pub(crate) forecast: Option<crate::forecast::ForecasterKind>,
    /// The seeds whose episodes a conversation may be found among (the
    /// belief probe's text index, and every conversation of pictures).
    pub(crate) probe_seeds: std::ops::Range<u64>,
}

/// Counts of what was served (for the shutdown line and tests).
#[derive(Debug, Default)]
pub(crate) struct ServeStats {
    pub(crate) requests: AtomicU64,
    pub(crate) ok: AtomicU64,
    pub(crate) failed: AtomicU64,
    pub(crate) rate_limited: AtomicU64,
    pub(crate) dropped: AtomicU64,
    pub(crate) garbage: AtomicU64,
    pub(crate) unparseable_scenes: AtomicU64,
    /// Belief probe: conversations whose episode the index could not find
    /// (the expert then states 0.5).
    pub(crate) unidentified_episodes: AtomicU64,
}

struct Bucket {
    tokens: f64,
    last: Instant,
}

pub(crate) struct ServeState {
    config: ServeConfig,
    pub(crate) stats: ServeStats,
    /// Finds the episode behind a conversation of pictures.
    pictures: pictured::PictureIndex,
    bucket: Option<Mutex<Bucket>>,
    created: u64,
}

impl ServeState {
    pub(crate) fn new(config: ServeConfig) -> ServeState {
        let bucket = config.rate_limit.map(|rps| Mutex::new(Bucket { tokens: rps.max(1.0), last: Instant::now() }));
        let created = SystemTime::now().duration_since(SystemTime::UNIX_EPOCH).map(|d| d.as_secs()).unwrap_or(0);
        let pictures = pictured::PictureIndex::new(config.probe_seeds.clone());
        ServeState { config, stats: ServeStats::default(), pictures, bucket, created }
    }

    /// Take a token, or say how long until one is available.
    fn rate_limit(&self) -> Result<(), Duration> {
        let (Some(bucket), Some(rps)) = (&self.bucket, self.config.rate_limit) else { return Ok(()) };
        let mut b = bucket.lock().unwrap_or_else(|e| e.into_inner());
        let now = Instant::now();
        let capacity = rps.max(1.0);
        b.tokens = (b.tokens + now.duration_since(b.last).as_secs_f64() * rps).min(capacity);
        b.last = now;
        if b.tokens >= 1.0 {
            b.tokens -= 1.0;
            Ok(())
        } else {
            Err(Duration::from_secs_f64((1.0 - b.tokens) / rps))
        }
    }
}

/// The routes: `POST /v1/chat/completions`, `GET /v1/models`.
pub(crate) fn router(state: Arc<ServeState>) -> Router {
    // A conversation of pictures is a few MB (axum's default limit is 2 MB).
    Router::new()
        .route("/v1/chat/completions", post(chat))
        .route("/v1/models", get(models))
        .layer(axum::extract::DefaultBodyLimit::max(MAX_BODY_BYTES))
        .with_state(state)
}

/// Independent uniform draws for request `i`: draw `k` of stream (seed, i).
fn draw(seed: u64, i: u64, k: u64) -> f64 {
    unit_f64(splitmix64(splitmix64(seed ^ splitmix64(i)) ^ k))
}

fn error_response(status: StatusCode, kind: &str, message: &str) -> Response {
    (status, axum::Json(json!({"error": {"message": message, "type": kind, "code": status.as_u16()}}))).into_response()
}

#[derive(Deserialize)]
struct ChatIn {
    #[serde(default)]
    model: Option<String>,
    #[serde(default)]
    messages: Vec<MessageIn>,
    #[serde(default)]
    stream: bool,
    #[serde(default)]
    stream_options: Option<StreamOptions>,
}

#[derive(Deserialize)]
struct StreamOptions {
    #[serde(default)]
    include_usage: bool,
}

#[derive(Deserialize)]
struct MessageIn {
    #[serde(default)]
    role: String,
    #[serde(default)]
    content: Value,
}

fn content_text(v: &Value) -> Option<String> {
    match v {
        Value::String(s) => Some(s.clone()),
        Value::Array(parts) => Some(parts.iter().filter_map(|p| p.get("text").and_then(Value::as_str)).collect()),
        _ => None,
    }
}

/// A message that is JSON rather than a scene (a harness forwarding an
/// environment's observation): the last string inside it that holds a scene,
/// from its last "Scene:" line on. None when the text is not JSON or holds
/// no scene.
fn scene_inside(text: &str) -> Option<String> {
    let trimmed = text.trim_start();
    if !(trimmed.starts_with('{') || trimmed.starts_with('[')) {
        return None;
    }
    let value: Value = serde_json::from_str(trimmed).ok()?;
    fn strings<'a>(v: &'a Value, out: &mut Vec<&'a str>) {
        match v {
            Value::String(s) => out.push(s),
            Value::Array(items) => items.iter().for_each(|i| strings(i, out)),
            Value::Object(map) => map.values().for_each(|i| strings(i, out)),
            _ => {}
        }
    }
    let mut all = Vec::new();
    strings(&value, &mut all);
    all.iter().rev().find_map(|s| {
        let start = if s.starts_with("Scene:") { Some(0) } else { s.rfind("\nScene:").map(|i| i + 1) }?;
        let scene = &s[start..];
        parse_scene(scene).is_ok().then(|| scene.to_string())
    })
}

/// A completion as OpenAI streams it: server-sent events of chunks, the
/// usage last when asked for, then `[DONE]`.
fn stream_events(reply: &Value, include_usage: bool) -> String {
    let choice = &reply["choices"][0];
    let chunk = |choices: Value, usage: Option<&Value>| {
        let mut c = json!({
            "id": reply["id"],
            "object": "chat.completion.chunk",
            "created": reply["created"],
            "model": reply["model"],
            "system_fingerprint": reply["system_fingerprint"],
            "choices": choices,
        });
        if include_usage {
            c["usage"] = usage.cloned().unwrap_or(Value::Null);
        }
        format!("data: {c}\n\n")
    };
    let delta = |d: Value, finish: Value| json!([{"index": 0, "delta": d, "logprobs": null, "finish_reason": finish}]);
    let mut out = chunk(delta(json!({"role": "assistant", "content": ""}), Value::Null), None);
    if let Some(content) = choice["message"]["content"].as_str() {
        out.push_str(&chunk(delta(json!({"content": content}), Value::Null), None));
    }
    out.push_str(&chunk(delta(json!({}), choice["finish_reason"].clone()), None));
    if include_usage {
        out.push_str(&chunk(json!([]), Some(&reply["usage"])));
    }
    out.push_str("data: [DONE]\n\n");
    out
}

/// Finds the episode behind a conversation, so that `serve` can state the
/// ideal observer's belief (privileged: it needs the seed) from the text
/// alone. The first scene of every (scenario, tier, seed) in a seed range,
/// with the built-in scenario parameters, is indexed by its hash; a
/// conversation's candidates are then replayed with the actions of its
/// earlier replies, and the one whose every scene renders identically is
/// the episode. Needs the full history (`eval --history full`, the
/// default).
pub(crate) struct EpisodeIndex {
    set: ScenarioSet,
    by_first_scene: HashMap<u64, Vec<(ScenarioKind, Tier, u64)>>,
}

impl std::fmt::Debug for EpisodeIndex {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "EpisodeIndex({} first scenes)", self.by_first_scene.len())
    }
}

impl EpisodeIndex {
    pub(crate) fn build(seeds: std::ops::Range<u64>) -> EpisodeIndex {
        let set = ScenarioSet::default();
        let mut by_first_scene: HashMap<u64, Vec<(ScenarioKind, Tier, u64)>> = HashMap::new();
        for kind in ScenarioKind::ALL {
            for tier in Tier::ALL {
                for seed in seeds.clone() {
                    let episode = Episode::new(set.get(kind), tier, seed);
                    let text = render_scene(episode.observation());
                    by_first_scene.entry(fnv1a64(&text)).or_default().push((kind, tier, seed));
                }
            }
        }
        EpisodeIndex { set, by_first_scene }
    }

    /// The ideal observer's belief at the last scene of a conversation:
    /// `scenes` are its user messages, `replies` the assistant messages
    /// between them.
    pub(crate) fn ideal_belief(&self, scenes: &[&str], replies: &[&str]) -> Option<f64> {
        let (first, last) = (scenes.first()?, scenes.len() - 1);
        if replies.len() < last {
            return None;
        }
        'candidates: for &(kind, tier, seed) in self.by_first_scene.get(&fnv1a64(first))? {
            let mut episode = Episode::new(self.set.get(kind), tier, seed);
            for (i, scene) in scenes.iter().enumerate() {
                if episode.is_done() || render_scene(episode.observation()) != *scene {
                    continue 'candidates;
                }
                if i == last {
                    return Some(episode.ideal_belief());
                }
                episode.step(crate::action::parse_action(replies[i]).action);
            }
        }
        None
    }
}

/// The pictures of a message's content parts, as (data URL, detail)
/// (OpenAI's `{"type": "image_url", "image_url": {"url": ..., "detail":
/// ...}}`, or the URL as a string, which some clients send).
fn content_pictures(v: &Value) -> impl Iterator<Item = (&str, Option<&str>)> {
    v.as_array().into_iter().flatten().filter_map(|p| {
        let url = p.get("image_url")?;
        let detail = url.get("detail").and_then(Value::as_str);
        url.get("url").and_then(Value::as_str).or_else(|| url.as_str()).map(|u| (u, detail))
    })
}

/// A message's last picture, as its data URL.
fn content_picture(v: &Value) -> Option<&str> {
    content_pictures(v).last().map(|(url, _)| url)
}

/// The answer to a whole conversation: the policy's action for the last
/// scene, with its belief added when probing.
fn reply_content(state: &ServeState, messages: &[MessageIn]) -> (String, SceneRead) {
    let cfg = &state.config;
    let text = |role: &str| -> Vec<String> {
        messages.iter().filter(|m| m.role == role).filter_map(|m| content_text(&m.content)).collect()
    };
    let users: Vec<&MessageIn> = messages.iter().filter(|m| m.role == "user").collect();
    let replies = text("assistant");
    let pictured = users.iter().any(|m| content_picture(&m.content).is_some());
    // Only user messages carry scenes; a scene wrapped in JSON is unwrapped.
    let mut scenes: Vec<String> = text("user").into_iter().map(|t| scene_inside(&t).unwrap_or(t)).collect();
    let mut found_belief = None;
    let mut found_keys = Vec::new();
    // A picture stands in for the scene (`--observation image`); under
    // `both` the text is there and is read as always.
    let by_picture = pictured && scenes.last().is_none_or(|s| parse_scene(s).is_err());
    if by_picture {
        // The scene is a picture: find its episode, and answer from the
        // texts its pictures were drawn from.
        let turns: Vec<pictured::UserTurn> = users
            .iter()
            .map(|m| pictured::UserTurn { picture: content_picture(&m.content).map(pictured::picture_hash) })
            .collect();
        // Several episodes match only while every picture shown has been
        // the same in each (so has every answer): each is remembered, the
        // first answers.
        let mut found = state.pictures.find(&turns, &replies.iter().map(String::as_str).collect::<Vec<_>>());
        found_keys = found.iter().map(|f| f.key).collect();
        match found.drain(..).next() {
            Some(first) => {
                scenes = first.scenes;
                found_belief = Some(first.ideal_belief);
            }
            None => {
                state.stats.unidentified_episodes.fetch_add(1, Ordering::Relaxed);
            }
        }
    }
    let scene = scenes.last().map_or("", String::as_str);
    let earlier: Vec<&str> = scenes[..scenes.len().saturating_sub(1)].iter().map(String::as_str).collect();
    let ideal = cfg.belief.as_ref().and_then(|index| {
        if by_picture {
            return found_belief;
        }
        let ideal = index.ideal_belief(
            &scenes.iter().map(String::as_str).collect::<Vec<_>>(),
            &replies.iter().map(String::as_str).collect::<Vec<_>>(),
        );
        if ideal.is_none() {
            state.stats.unidentified_episodes.fetch_add(1, Ordering::Relaxed);
        }
        ideal
    });
    let (answer, belief) = answer_with_belief(cfg.policy, cfg.seed, &earlier, scene, ideal);
    let mut content = action_json(&answer.action, &answer.reasoning);
    if cfg.belief.is_some() {
        content["belief"] = json!(belief);
    }
    if let Some(forecaster) = cfg.forecast
        && let Ok(obs) = crate::observation::parse_scene(scene)
    {
        use crate::forecast::{DOES_NOT_KEY, LETS_YOU_GO_KEY};
        let f = forecaster.build().forecast(&obs);
        content["forecast"] = json!({ LETS_YOU_GO_KEY: f.lets_you_go, DOES_NOT_KEY: f.does_not });
    }
    let content = content.to_string();
    if !found_keys.is_empty() {
        let mut answered: Vec<&str> = replies.iter().map(String::as_str).collect();
        answered.push(&content);
        for key in found_keys {
            state.pictures.expect_next(key, &answered);
        }
    }
    (content, answer.scene)
}

/// Malformed replies for `--garbage-rate`: each is a parse error for
/// [`crate::action::parse_action`]. Returns (content, finish_reason).
pub(crate) fn garbage(k: u64) -> (Option<String>, &'static str) {
    match k % 7 {
        0 => (Some("I would slow down a little and watch the other car carefully.".into()), "stop"),
        1 => (Some("{\"reasoning\": \"the other car is braking, so I will\", \"maneuver\": \"proc".into()), "length"),
        2 => (None, "stop"),
        3 => (Some("{\"reasoning\": \"go\", \"maneuver\": \"teleport\", \"acceleration\": 0.5}".into()), "stop"),
        4 => (Some("```json\n{\"maneuver\": \"proceed\", \"acceleration\": 7.5}\n```".into()), "stop"),
        5 => (Some("<think>The pedestrian is near the kerb and".into()), "length"),
        _ => (Some("\u{fffd}\u{0}\u{7f}{{{[[[ \"maneuver\" :: proceed ]".into()), "stop"),
    }
}

/// What a request's prompt tokens are estimated from: its bytes, less
/// its pictures' data URLs, and the pictures' own tokens.
#[derive(Clone, Copy)]
struct Usage {
    picture_tokens: u64,
    text_bytes: usize,
}

fn completion(state: &ServeState, id: u64, model: &str, content: Option<String>, finish: &str, prompt: Usage) -> Value {
    let completion_tokens = content.as_ref().map_or(0, |c| c.len().div_ceil(4)) as u64;
    let prompt_tokens = prompt.text_bytes.div_ceil(4) as u64 + prompt.picture_tokens;
    json!({
        "id": format!("chatcmpl-{id:016x}"),
        "object": "chat.completion",
        "created": state.created,
        "model": model,
        "system_fingerprint": concat!("negotiator-", env!("CARGO_PKG_VERSION")),
        "choices": [{
            "index": 0,
            "message": {"role": "assistant", "content": content},
            "finish_reason": finish,
        }],
        "usage": {
            "prompt_tokens": prompt_tokens,
            "completion_tokens": completion_tokens,
            "total_tokens": prompt_tokens + completion_tokens,
        },
    })
}

async fn chat(State(state): State<Arc<ServeState>>, body: Bytes) -> Response {
    let cfg = &state.config;
    let i = state.stats.requests.fetch_add(1, Ordering::Relaxed);
    if let Err(wait) = state.rate_limit() {
        state.stats.rate_limited.fetch_add(1, Ordering::Relaxed);
        let mut r =
            error_response(StatusCode::TOO_MANY_REQUESTS, "rate_limit_exceeded", "Rate limit reached; retry later");
        let secs = wait.as_secs_f64().ceil().max(1.0) as u64;
        r.headers_mut().insert(header::RETRY_AFTER, HeaderValue::from(secs));
        return r;
    }
    if !cfg.latency.is_zero() {
        tokio::time::sleep(cfg.latency).await;
    }
    let request: ChatIn = match serde_json::from_slice(&body) {
        Ok(r) => r,
        Err(e) => {
            return error_response(
                StatusCode::BAD_REQUEST,
                "invalid_request_error",
                &format!("invalid JSON body: {e}"),
            );
        }
    };
    let model = request.model.clone().unwrap_or_else(|| cfg.policy.name().to_string());
    if draw(cfg.seed, i, 1) < cfg.fail_rate {
        state.stats.failed.fetch_add(1, Ordering::Relaxed);
        return match (draw(cfg.seed, i, 2) * 3.0) as u32 {
            0 => error_response(StatusCode::INTERNAL_SERVER_ERROR, "server_error", "injected failure"),
            1 => error_response(StatusCode::SERVICE_UNAVAILABLE, "overloaded", "injected overload"),
            _ => (StatusCode::OK, axum::Json(json!({"error": {"message": "injected upstream error", "code": 502}})))
                .into_response(),
        };
    }
    let mut prompt = Usage { picture_tokens: 0, text_bytes: body.len() };
    let (content, finish) = if draw(cfg.seed, i, 4) < cfg.garbage_rate {
        state.stats.garbage.fetch_add(1, Ordering::Relaxed);
        garbage(splitmix64(cfg.seed ^ i))
    } else {
        // Finding a pictured conversation's episode may draw pictures:
        // off the async workers.
        let answering = Arc::clone(&state);
        let pictures: Vec<(&str, Option<&str>)> =
            request.messages.iter().flat_map(|m| content_pictures(&m.content)).collect();
        let (picture_tokens, picture_bytes) = pictured::picture_usage(&pictures);
        prompt = Usage { picture_tokens, text_bytes: body.len() - picture_bytes };
        let messages = request.messages;
        let Ok((content, scene)) = tokio::task::spawn_blocking(move || reply_content(&answering, &messages)).await
        else {
            return error_response(StatusCode::INTERNAL_SERVER_ERROR, "server_error", "the answer could not be made");
        };
        if scene == SceneRead::Unreadable {
            state.stats.unparseable_scenes.fetch_add(1, Ordering::Relaxed);
        }
        (Some(content), "stop")
    };
    let reply = completion(&state, i, &model, content, finish, prompt);
    let (reply, content_type) = if request.stream {
        let usage = request.stream_options.as_ref().is_some_and(|o| o.include_usage);
        (stream_events(&reply, usage), "text/event-stream")
    } else {
        (reply.to_string(), "application/json")
    };
    if draw(cfg.seed, i, 3) < cfg.drop_rate {
        state.stats.dropped.fetch_add(1, Ordering::Relaxed);
        // Headers and half the body, then a broken stream: hyper aborts the
        // connection, as a proxy dying mid-reply would.
        let half = reply.as_bytes()[..reply.len() / 2].to_vec();
        let chunks: Vec<Result<Vec<u8>, std::io::Error>> =
            vec![Ok(half), Err(std::io::Error::new(std::io::ErrorKind::ConnectionReset, "injected drop"))];
        let mut r = Response::new(Body::from_stream(futures_util::stream::iter(chunks)));
        r.headers_mut().insert(header::CONTENT_TYPE, HeaderValue::from_static(content_type));
        return r;
    }
    state.stats.ok.fetch_add(1, Ordering::Relaxed);
    ([(header::CONTENT_TYPE, content_type)], reply).into_response()
}

async fn models(State(state): State<Arc<ServeState>>) -> Response {
    axum::Json(json!({
        "object": "list",
        "data": [{
            "id": state.config.policy.name(),
            "object": "model",
            "created": state.created,
            "owned_by": "negotiator",
        }],
    }))
    .into_response()
}

/// Serve on `listener` until Ctrl-C (or SIGTERM). The command line prints
/// the address (`listening on http://HOST:PORT/v1`) before calling this.
pub(crate) async fn serve(listener: tokio::net::TcpListener, config: ServeConfig) -> std::io::Result<Arc<ServeState>> {
    let state = Arc::new(ServeState::new(config));
    axum::serve(listener, router(state.clone())).with_graceful_shutdown(shutdown()).await?;
    Ok(state)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn garbage_is_unreadable(k: u64) -> Vec<crate::action::ActionParseError> {
        crate::action::parse_action(garbage(k).0.as_deref().unwrap_or("")).errors
    }

    #[test]
    fn every_garbage_kind_is_a_parse_error() {
        for k in 0..7 {
            assert!(!garbage_is_unreadable(k).is_empty(), "garbage kind {k}: {:?}", garbage(k));
        }
    }

    #[test]
    fn faults_are_deterministic_per_request_index() {
        let a: Vec<f64> = (0..100).map(|i| draw(7, i, 1)).collect();
        let b: Vec<f64> = (0..100).map(|i| draw(7, i, 1)).collect();
        assert_eq!(a, b);
        assert_ne!(a, (0..100).map(|i| draw(8, i, 1)).collect::<Vec<_>>());
        let hits = (0..10_000).filter(|i| draw(1, *i, 1) < 0.2).count();
        assert!((1800..2200).contains(&hits), "{hits}");
    }

    #[test]
    fn rate_limit_bucket_empties_and_says_when() {
        let s = ServeState::new(ServeConfig {
            policy: PolicyKind::Expert,
            seed: 0,
            latency: Duration::ZERO,
            fail_rate: 0.0,
            rate_limit: Some(2.0),
            drop_rate: 0.0,
            garbage_rate: 0.0,
            belief: None,
            forecast: None,
            probe_seeds: 0..1,
        });
        assert!(s.rate_limit().is_ok());
        assert!(s.rate_limit().is_ok());
        let wait = s.rate_limit().unwrap_err();
        assert!(wait <= Duration::from_millis(500));
    }
}
