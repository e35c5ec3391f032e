//! The HTTP client: one POST per attempt, retries with capped exponential
//! backoff and jitter, `Retry-After` honoured, failures classified.

use super::types::{ChatRequest, ChatResponse, Usage, split_think};
use crate::hash::{GOLDEN_GAMMA, splitmix64, unit_f64};
use reqwest::header::{AUTHORIZATION, CONTENT_TYPE, HeaderMap, HeaderValue};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant, SystemTime};

/// How a failed attempt is treated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FailureClass {
    /// Worth retrying: the service may recover (connect/read errors,
    /// timeouts, 408, 429, 5xx, a 200 carrying an error or no choices).
    Transient,
    /// The endpoint refuses this run as configured (401, 403, 404): every
    /// further request would fail the same way, so the run stops at once.
    Refused,
    /// Any other client error (400, 413, 422, ...): a bug or a request the
    /// endpoint will never accept. Also stops the run.
    Permanent,
}

/// Classify an HTTP status that is not a success.
pub fn classify_status(status: u16) -> FailureClass {
    match status {
        408 | 429 | 500..=599 => FailureClass::Transient,
        401 | 403 | 404 => FailureClass::Refused,
        _ => FailureClass::Permanent,
    }
}

#[derive(Debug, Clone, thiserror::Error)]
pub enum LlmError {
    #[error("the endpoint refused the request (HTTP {status}): {message}")]
    Refused { status: u16, message: String },
    #[error("the endpoint rejected the request (HTTP {status}): {message}")]
    Permanent { status: u16, message: String },
    /// A 400/413 saying the conversation no longer fits the model's context.
    #[error("the conversation outgrew the model's context window (HTTP {status}): {message}")]
    ContextOverflow { status: u16, message: String },
    /// The preflight request could not reach the endpoint at all.
    #[error("the endpoint is unreachable: {message}")]
    Unreachable { message: String },
    /// A server-sent event stream that was not asked for.
    #[error(
        "the endpoint answered with a server-sent event stream (Content-Type: {content_type}) although the request \
         did not ask for streaming; this client reads whole JSON replies: point --base-url at the OpenAI-compatible \
         /v1 API of the server (not a streaming proxy)"
    )]
    UnrequestedStream { content_type: String },
    #[error("gave up after {attempts} attempts; last error: {last}")]
    Exhausted { attempts: u32, last: String },
}

/// Whether an error body (of a 400, 413 or 422) says the prompt is longer
/// than the model's context window. Providers word it differently: OpenAI's
/// `context_length_exceeded` code, vLLM's "maximum context length",
/// Anthropic-style "prompt is too long", llama.cpp's "context size".
pub fn is_context_overflow(status: u16, body: &str) -> bool {
    if !matches!(status, 400 | 413 | 422) {
        return false;
    }
    let b = body.to_ascii_lowercase();
    [
        "context_length_exceeded",
        "context length",
        "maximum context",
        "context window",
        "context size",
        "prompt is too long",
        "too many tokens",
        "reduce the length of the messages",
    ]
    .iter()
    .any(|needle| b.contains(needle))
}

/// Default cap on a stored (and resent) reply, `--max-reply-bytes`.
pub const DEFAULT_MAX_REPLY_BYTES: usize = 64 * 1024;

/// The most bytes of one HTTP body read, for a given reply cap: room for a
/// capped reply, its reasoning and the JSON around them. Reading stops
/// there, so a runaway endpoint cannot exhaust memory.
pub fn body_limit(max_reply_bytes: usize) -> usize {
    max_reply_bytes.saturating_mul(16).saturating_add(64 * 1024)
}

/// Retry schedule.
#[derive(Debug, Clone, Copy)]
pub struct RetryPolicy {
    /// Retries after the first attempt.
    pub max_retries: u32,
    /// First backoff; doubled each retry.
    pub base: Duration,
    /// Cap on the exponential backoff.
    pub max_backoff: Duration,
    /// Cap on an honoured `Retry-After` (a server asking for an hour is
    /// effectively down; waiting longer than this helps nobody).
    pub max_retry_after: Duration,
}

impl Default for RetryPolicy {
    fn default() -> Self {
        RetryPolicy {
            max_retries: 10,
            base: Duration::from_millis(500),
            max_backoff: Duration::from_secs(60),
            max_retry_after: Duration::from_secs(600),
        }
    }
}

impl RetryPolicy {
    /// Delay before retry number `attempt` (0 for the first retry), given a
    /// uniform `u` in [0, 1) and the server's `Retry-After` if any.
    ///
    /// Exponential part: `min(cap, base * 2^attempt)`, with "equal jitter"
    /// (a uniform draw in its upper half) so concurrent episodes that failed
    /// together do not retry in lockstep. A `Retry-After` is a floor: we
    /// never come back earlier than asked, plus up to 10% jitter.
    pub fn delay(&self, attempt: u32, retry_after: Option<Duration>, u: f64) -> Duration {
        let exp = self.base.saturating_mul(1u32.checked_shl(attempt.min(31)).unwrap_or(u32::MAX)).min(self.max_backoff);
        let jittered = exp.mul_f64(0.5 + 0.5 * u);
        match retry_after {
            Some(ra) => jittered.max(ra.min(self.max_retry_after).mul_f64(1.0 + 0.1 * u)),
            None => jittered,
        }
    }
}

/// Parse a `Retry-After` value: delay-seconds (integral, or fractional as
/// some servers send) or an HTTP-date (a date in the past means now).
pub fn parse_retry_after(value: &str, now: SystemTime) -> Option<Duration> {
    let v = value.trim();
    if let Ok(secs) = v.parse::<f64>() {
        return (secs.is_finite() && secs >= 0.0).then(|| Duration::from_secs_f64(secs.min(1e9)));
    }
    let when = httpdate::parse_http_date(v).ok()?;
    Some(when.duration_since(now).unwrap_or(Duration::ZERO))
}

fn retry_after_of(headers: &HeaderMap) -> Option<Duration> {
    // OpenAI also sends a millisecond variant; prefer it when present.
    if let Some(ms) =
        headers.get("retry-after-ms").and_then(|v| v.to_str().ok()).and_then(|v| v.trim().parse::<f64>().ok())
        && ms.is_finite()
        && ms >= 0.0
    {
        return Some(Duration::from_secs_f64(ms / 1000.0));
    }
    headers
        .get(reqwest::header::RETRY_AFTER)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| parse_retry_after(v, SystemTime::now()))
}

/// Endpoint settings. The API key lives only here and in the request
/// headers; it is never logged or stored.
#[derive(Clone)]
pub struct ClientConfig {
    pub base_url: String,
    pub api_key: Option<String>,
    pub headers: HeaderMap,
    pub request_timeout: Duration,
    pub retry: RetryPolicy,
    /// Replies (and reasoning) longer than this are cut to it, flagged, and
    /// scored as a parse error.
    pub max_reply_bytes: usize,
}

impl std::fmt::Debug for ClientConfig {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ClientConfig")
            .field("base_url", &self.base_url)
            .field("api_key", &self.api_key.as_ref().map(|_| "<redacted>"))
            .field("headers", &self.headers.keys().collect::<Vec<_>>())
            .field("request_timeout", &self.request_timeout)
            .field("retry", &self.retry)
            .field("max_reply_bytes", &self.max_reply_bytes)
            .finish()
    }
}

/// One successful completion, with what it cost to get it.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Completion {
    /// The raw reply text (`None` when the provider sent null content).
    pub content: Option<String>,
    /// Provider reasoning (`reasoning_content` / `reasoning`) and any
    /// `<think>` blocks in the content. Stored, never scored, never sent back.
    pub reasoning: Option<String>,
    /// The content with `<think>` blocks removed: what goes back into the
    /// history.
    pub answer: String,
    pub finish_reason: Option<String>,
    pub usage: Option<Usage>,
    /// Attempts made (1 = no retry).
    pub attempts: u32,
    /// Wall time of the successful attempt.
    pub latency: Duration,
    /// The reply (or the HTTP body) was longer than the cap and was cut.
    pub capped: bool,
    /// The body was not valid UTF-8 and was decoded lossily.
    pub invalid_utf8: bool,
}

/// Why one attempt failed.
#[derive(Debug)]
enum AttemptError {
    /// `connect`: the request never reached a server (refused, DNS, TLS,
    /// connect timeout).
    Transient {
        message: String,
        retry_after: Option<Duration>,
        connect: bool,
    },
    Fatal(LlmError),
}

/// The exact bytes POSTed for a request (`eval --dry-run` prints and
/// measures these too).
pub fn request_body(request: &ChatRequest<'_>) -> Vec<u8> {
    let mut body = Vec::with_capacity(request.json_len_hint());
    serde_json::to_writer(&mut body, request).expect("a chat request always serialises");
    body
}

pub struct Client {
    http: reqwest::Client,
    url: String,
    config: ClientConfig,
    jitter: AtomicU64,
}

impl Client {
    pub fn new(config: ClientConfig) -> Result<Client, reqwest::Error> {
        let mut headers = config.headers.clone();
        headers.insert(CONTENT_TYPE, HeaderValue::from_static("application/json"));
        if let Some(key) = &config.api_key
            && let Ok(mut v) = HeaderValue::from_str(&format!("Bearer {key}"))
        {
            v.set_sensitive(true);
            headers.insert(AUTHORIZATION, v);
        }
        let http = reqwest::Client::builder()
            .default_headers(headers)
            .connect_timeout(Duration::from_secs(10).min(config.request_timeout))
            .pool_idle_timeout(Duration::from_secs(30))
            .user_agent(concat!("negotiator/", env!("CARGO_PKG_VERSION")))
            .build()?;
        let url = format!("{}/chat/completions", config.base_url.trim_end_matches('/'));
        let seed = SystemTime::now().duration_since(SystemTime::UNIX_EPOCH).map(|d| d.as_nanos() as u64).unwrap_or(1);
        Ok(Client { http, url, config, jitter: AtomicU64::new(seed) })
    }

    pub fn url(&self) -> &str {
        &self.url
    }

    /// A uniform draw in [0, 1) for jitter. Not reproducible on purpose:
    /// retry timing never influences an episode.
    fn unit(&self) -> f64 {
        let state = self.jitter.fetch_add(GOLDEN_GAMMA, Ordering::Relaxed);
        unit_f64(splitmix64(state))
    }

    /// Send one chat request, retrying transient failures. `on_retry` is
    /// called with the failure's message before each backoff sleep (for
    /// progress counters and the progress line).
    pub async fn chat(&self, request: &ChatRequest<'_>, on_retry: impl Fn(&str)) -> Result<Completion, LlmError> {
        self.send(request, on_retry, false).await
    }

    /// The request sent before any episode starts. Like [`Client::chat`],
    /// except that a request that never reaches a server (connection
    /// refused, DNS failure, TLS error, connect timeout) is not retried: it
    /// ends at once as [`LlmError::Unreachable`] with a one-line diagnosis,
    /// instead of minutes of backoff per episode.
    pub async fn preflight(&self, request: &ChatRequest<'_>, on_retry: impl Fn(&str)) -> Result<Completion, LlmError> {
        self.send(request, on_retry, true).await
    }

    async fn send(
        &self,
        request: &ChatRequest<'_>,
        on_retry: impl Fn(&str),
        fail_fast_on_connect: bool,
    ) -> Result<Completion, LlmError> {
        // Serialise once; every attempt sends the same bytes, shared (a
        // conversation of pictures is megabytes; a retry copies none).
        let body = bytes::Bytes::from(request_body(request));
        let mut last = String::new();
        let attempts_allowed = self.config.retry.max_retries.saturating_add(1);
        for attempt in 0..attempts_allowed {
            let t0 = Instant::now();
            match self.attempt(&body).await {
                Ok(mut c) => {
                    c.attempts = attempt + 1;
                    c.latency = t0.elapsed();
                    return Ok(c);
                }
                Err(AttemptError::Fatal(e)) => return Err(e),
                Err(AttemptError::Transient { message, connect: true, .. }) if fail_fast_on_connect => {
                    return Err(LlmError::Unreachable { message: format!("{message} ({})", self.url) });
                }
                Err(AttemptError::Transient { message, retry_after, .. }) => {
                    last = message;
                    if attempt + 1 < attempts_allowed {
                        on_retry(&last);
                        tokio::time::sleep(self.config.retry.delay(attempt, retry_after, self.unit())).await;
                    }
                }
            }
        }
        Err(LlmError::Exhausted { attempts: attempts_allowed, last })
    }

    /// One POST: its completion, or why it failed and whether that is
    /// worth retrying. The body is read up to a hard limit; an unrequested
    /// event stream and a context overflow are recognised here.
    async fn attempt(&self, body: &bytes::Bytes) -> Result<Completion, AttemptError> {
        let transient = |message: String| AttemptError::Transient { message, retry_after: None, connect: false };
        let response =
            self.http.post(&self.url).timeout(self.config.request_timeout).body(body.clone()).send().await.map_err(
                |e| AttemptError::Transient {
                    message: describe_reqwest(&e),
                    retry_after: None,
                    connect: e.is_connect(),
                },
            )?;
        let status = response.status();
        let retry_after = retry_after_of(response.headers());
        let content_type =
            response.headers().get(CONTENT_TYPE).and_then(|v| v.to_str().ok()).unwrap_or("").to_ascii_lowercase();
        let limit = body_limit(self.config.max_reply_bytes);
        let (bytes, cut) = read_bounded(response, limit)
            .await
            .map_err(|e| transient(format!("reading the reply: {}", describe_reqwest(&e))))?;
        if !status.is_success() {
            let message = format!("{status}: {}", error_message(&bytes));
            if is_context_overflow(status.as_u16(), &String::from_utf8_lossy(&bytes)) {
                return Err(AttemptError::Fatal(LlmError::ContextOverflow { status: status.as_u16(), message }));
            }
            return Err(match classify_status(status.as_u16()) {
                FailureClass::Transient => AttemptError::Transient { message, retry_after, connect: false },
                FailureClass::Refused => AttemptError::Fatal(LlmError::Refused { status: status.as_u16(), message }),
                FailureClass::Permanent => {
                    AttemptError::Fatal(LlmError::Permanent { status: status.as_u16(), message })
                }
            });
        }
        if content_type.starts_with("text/event-stream") || bytes.trim_ascii_start().starts_with(b"data:") {
            let content_type =
                if content_type.is_empty() { "none; the body starts with 'data:'".to_string() } else { content_type };
            return Err(AttemptError::Fatal(LlmError::UnrequestedStream { content_type }));
        }
        if cut {
            // The body itself is over the hard limit: no JSON to read. The
            // model's runaway output is kept up to the cap as a capped
            // reply: a parse error, never an infrastructure error.
            let cap = self.config.max_reply_bytes;
            let text = String::from_utf8_lossy(&bytes[..bytes.len().min(cap)]).into_owned();
            let text = clip_bytes(&text, cap).to_string();
            return Ok(Completion { content: Some(text), capped: true, ..Completion::default() });
        }
        interpret_capped(&bytes, self.config.max_reply_bytes).map_err(|message| AttemptError::Transient {
            message,
            retry_after,
            connect: false,
        })
    }
}

/// Read a response body, stopping after `limit` bytes (the rest is never
/// read: the connection is dropped). Returns the bytes and whether the body
/// was cut.
async fn read_bounded(mut response: reqwest::Response, limit: usize) -> Result<(Vec<u8>, bool), reqwest::Error> {
    let mut buf: Vec<u8> = Vec::new();
    while let Some(chunk) = response.chunk().await? {
        if buf.len() + chunk.len() > limit {
            buf.extend_from_slice(&chunk[..limit - buf.len()]);
            return Ok((buf, true));
        }
        buf.extend_from_slice(&chunk);
    }
    Ok((buf, false))
}

/// The longest prefix of `s` of at most `max` bytes that ends on a
/// character boundary.
fn clip_bytes(s: &str, max: usize) -> &str {
    if s.len() <= max {
        return s;
    }
    let mut end = max;
    while !s.is_char_boundary(end) {
        end -= 1;
    }
    &s[..end]
}

/// [`interpret`], then the reply cap: content and reasoning longer than
/// `max_reply_bytes` are cut and the completion flagged. A body that is not
/// UTF-8 is decoded lossily (the model's bad output, not an outage) and
/// flagged.
pub fn interpret_capped(bytes: &[u8], max_reply_bytes: usize) -> Result<Completion, String> {
    let mut c = match interpret(bytes) {
        Ok(c) => c,
        Err(e) if std::str::from_utf8(bytes).is_err() => {
            let mut c = interpret(String::from_utf8_lossy(bytes).as_bytes()).map_err(|_| e)?;
            c.invalid_utf8 = true;
            c
        }
        Err(e) => return Err(e),
    };
    if c.content.as_ref().is_some_and(|t| t.len() > max_reply_bytes) {
        let content = clip_bytes(c.content.as_deref().unwrap_or(""), max_reply_bytes).to_string();
        c.answer = split_think(&content).0;
        c.content = Some(content);
        c.capped = true;
    }
    if let Some(r) = c.reasoning.as_mut()
        && r.len() > max_reply_bytes
    {
        *r = clip_bytes(r, max_reply_bytes).to_string();
        c.capped = true;
    }
    Ok(c)
}

/// Turn a successful HTTP body into a completion, or a transient failure
/// message (unreadable body, error object, no choices).
pub fn interpret(bytes: &[u8]) -> Result<Completion, String> {
    let parsed: ChatResponse = serde_json::from_slice(bytes)
        .map_err(|e| format!("unreadable response body ({e}): {}", clip(&String::from_utf8_lossy(bytes), 200)))?;
    if let Some(err) = parsed.error.as_ref().filter(|e| !e.is_null()) {
        return Err(format!("HTTP 200 carrying an error: {}", clip(&error_text(err), 300)));
    }
    let choice =
        parsed.choices.as_ref().and_then(|c| c.first()).ok_or_else(|| "HTTP 200 with no choices".to_string())?;
    let message = choice.message.clone().unwrap_or_default();
    let content = message.text();
    let (answer, think) = split_think(content.as_deref().unwrap_or(""));
    let provider = message.reasoning_content.clone().or(message.reasoning.clone()).filter(|r| !r.trim().is_empty());
    let reasoning = match (provider, think) {
        (Some(p), Some(t)) => Some(format!("{p}\n\n{t}")),
        (p, t) => p.or(t),
    };
    Ok(Completion {
        content,
        reasoning,
        answer,
        finish_reason: choice.finish_reason.clone(),
        usage: parsed.usage,
        ..Completion::default()
    })
}

/// The most useful line of an error body: OpenAI-style `error.message`,
/// else the body itself, clipped.
fn error_message(bytes: &[u8]) -> String {
    match serde_json::from_slice::<serde_json::Value>(bytes) {
        // Google's OpenAI-compatible endpoint wraps its error in an array.
        Ok(serde_json::Value::Array(items)) if !items.is_empty() => {
            clip(&error_text(items[0].get("error").unwrap_or(&items[0])), 300)
        }
        Ok(v) => clip(&error_text(v.get("error").unwrap_or(&v)), 300),
        Err(_) => clip(String::from_utf8_lossy(bytes).trim(), 300),
    }
}

fn error_text(err: &serde_json::Value) -> String {
    match err {
        serde_json::Value::String(s) => s.clone(),
        v => v.get("message").and_then(|m| m.as_str()).map(str::to_string).unwrap_or_else(|| v.to_string()),
    }
}

fn describe_reqwest(e: &reqwest::Error) -> String {
    let chain = {
        let mut parts = Vec::new();
        let mut source = std::error::Error::source(e);
        while let Some(s) = source {
            parts.push(s.to_string().to_ascii_lowercase());
            source = s.source();
        }
        parts.join(": ")
    };
    // The causes a user can act on, named plainly.
    if e.is_connect() {
        if chain.contains("connection refused") {
            return "connection refused (nothing is listening there: is the server running, is the port right?)".into();
        }
        if chain.contains("dns") || chain.contains("lookup") || chain.contains("name or service not known") {
            return "DNS lookup failed (check the host name in the base URL)".into();
        }
        if ["certificate", "tls", "handshake", "ssl", "corrupt message", "invalidcontenttype"]
            .iter()
            .any(|w| chain.contains(w))
        {
            let detail = chain.rsplit(": ").next().unwrap_or("");
            return format!("TLS handshake failed ({detail}); check https vs http and the server's certificate");
        }
    }
    let kind = if e.is_timeout() {
        "timed out"
    } else if e.is_connect() {
        "connection failed"
    } else if e.is_body() || e.is_decode() {
        "connection broke while reading the body"
    } else {
        "request failed"
    };
    // The source chain says why (refused, reset, ...); the URL is ours.
    let mut detail = String::new();
    let mut source = std::error::Error::source(e);
    while let Some(s) = source {
        detail = s.to_string();
        source = s.source();
    }
    if detail.is_empty() { kind.to_string() } else { format!("{kind}: {detail}") }
}

pub fn clip(s: &str, max: usize) -> String {
    if s.len() <= max {
        return s.to_string();
    }
    let mut end = max;
    while !s.is_char_boundary(end) {
        end -= 1;
    }
    format!("{}...", &s[..end])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn status_classification_table() {
        use FailureClass::*;
        let table = [
            (400, Permanent),
            (401, Refused),
            (403, Refused),
            (404, Refused),
            (408, Transient),
            (409, Permanent),
            (413, Permanent),
            (422, Permanent),
            (429, Transient),
            (500, Transient),
            (502, Transient),
            (503, Transient),
            (504, Transient),
            (529, Transient),
        ];
        for (status, class) in table {
            assert_eq!(classify_status(status), class, "HTTP {status}");
        }
    }

    #[test]
    fn retry_after_seconds_and_http_date() {
        let now = SystemTime::UNIX_EPOCH + Duration::from_secs(1_700_000_000);
        assert_eq!(parse_retry_after("3", now), Some(Duration::from_secs(3)));
        assert_eq!(parse_retry_after(" 0 ", now), Some(Duration::ZERO));
        assert_eq!(parse_retry_after("1.5", now), Some(Duration::from_millis(1500)));
        let later = httpdate::fmt_http_date(now + Duration::from_secs(7));
        assert_eq!(parse_retry_after(&later, now), Some(Duration::from_secs(7)));
        let earlier = httpdate::fmt_http_date(now - Duration::from_secs(7));
        assert_eq!(parse_retry_after(&earlier, now), Some(Duration::ZERO));
        assert_eq!(parse_retry_after("soon", now), None);
        assert_eq!(parse_retry_after("-1", now), None);
    }

    #[test]
    fn retry_after_ms_header_wins() {
        let mut h = HeaderMap::new();
        h.insert("retry-after", HeaderValue::from_static("5"));
        assert_eq!(retry_after_of(&h), Some(Duration::from_secs(5)));
        h.insert("retry-after-ms", HeaderValue::from_static("250"));
        assert_eq!(retry_after_of(&h), Some(Duration::from_millis(250)));
    }

    #[test]
    fn backoff_grows_caps_and_jitters() {
        let p = RetryPolicy {
            max_retries: 5,
            base: Duration::from_millis(100),
            max_backoff: Duration::from_secs(1),
            max_retry_after: Duration::from_secs(30),
        };
        assert_eq!(p.delay(0, None, 0.0), Duration::from_millis(50));
        assert_eq!(p.delay(0, None, 0.999_999).as_millis(), 99);
        assert_eq!(p.delay(3, None, 0.0), Duration::from_millis(400));
        // Capped, however many retries.
        assert_eq!(p.delay(10, None, 0.0), Duration::from_millis(500));
        assert_eq!(p.delay(1000, None, 0.0), Duration::from_millis(500));
        // Retry-After is a floor, itself capped.
        assert_eq!(p.delay(0, Some(Duration::from_secs(2)), 0.0), Duration::from_secs(2));
        assert_eq!(p.delay(0, Some(Duration::from_secs(2)), 0.5), Duration::from_millis(2100));
        assert_eq!(p.delay(0, Some(Duration::from_secs(3600)), 0.0), Duration::from_secs(30));
        // A short Retry-After does not undercut the exponential backoff.
        assert_eq!(p.delay(3, Some(Duration::ZERO), 0.0), Duration::from_millis(400));
    }

    #[test]
    fn interpret_handles_odd_successes() {
        let c = interpret(br#"{"choices":[{"message":{"content":null,"reasoning_content":"r"},"finish_reason":""}]}"#)
            .unwrap();
        assert_eq!(c.content, None);
        assert_eq!(c.answer, "");
        assert_eq!(c.reasoning.as_deref(), Some("r"));
        assert_eq!(c.finish_reason.as_deref(), Some(""));
        assert_eq!(c.usage, None);
        let c = interpret(
            br#"{"choices":[{"message":{"content":"<think>t</think>{\"a\":1}"},"finish_reason":"length"}],"x":1}"#,
        )
        .unwrap();
        assert_eq!(c.answer, "{\"a\":1}");
        assert_eq!(c.reasoning.as_deref(), Some("t"));
        assert!(interpret(br#"{"error":{"message":"overloaded"}}"#).unwrap_err().contains("overloaded"));
        assert!(interpret(br#"{"choices":[]}"#).unwrap_err().contains("no choices"));
        assert!(interpret(b"<html>bad gateway</html>").unwrap_err().contains("unreadable"));
        // An explicit null error is no error.
        assert!(interpret(br#"{"error":null,"choices":[{"message":{"content":"x"}}]}"#).is_ok());
    }

    #[test]
    fn context_overflow_is_recognised_in_providers_wordings() {
        for body in [
            r#"{"error":{"message":"This model's maximum context length is 8192 tokens.","code":"context_length_exceeded"}}"#,
            r#"{"error":"prompt is too long: 210000 tokens > 200000 maximum"}"#,
            "the request exceeds the available context size, try increasing it",
        ] {
            assert!(is_context_overflow(400, body), "{body}");
        }
        assert!(!is_context_overflow(400, r#"{"error":"unknown parameter top_q"}"#));
        assert!(!is_context_overflow(500, "maximum context length"), "a 5xx is an outage, retried");
    }

    #[test]
    fn replies_over_the_cap_are_cut_and_flagged() {
        let long = "x".repeat(100);
        let body = serde_json::json!({"choices": [{"message": {"content": format!("{{}}{long}"), "reasoning": long}}]});
        let c = interpret_capped(body.to_string().as_bytes(), 10).unwrap();
        assert_eq!(c.content.as_deref(), Some("{}xxxxxxxx"));
        assert_eq!(c.reasoning.as_deref().map(str::len), Some(10));
        assert!(c.capped);
        let c = interpret_capped(body.to_string().as_bytes(), 1000).unwrap();
        assert!(!c.capped);
        // A multi-byte character is never split.
        let body = serde_json::json!({"choices": [{"message": {"content": "ééééé"}}]});
        assert_eq!(interpret_capped(body.to_string().as_bytes(), 5).unwrap().content.as_deref(), Some("éé"));
    }

    #[test]
    fn invalid_utf8_is_decoded_lossily_and_flagged() {
        let mut body = br#"{"choices":[{"message":{"content":"{\"maneuver\":\"stop\"} "#.to_vec();
        body.extend_from_slice(&[0xff, 0xfe]);
        body.extend_from_slice(br#""}}]}"#);
        let c = interpret_capped(&body, 1000).unwrap();
        assert!(c.invalid_utf8);
        assert!(c.content.unwrap().contains('\u{fffd}'));
        assert!(interpret_capped(b"\xff not json", 1000).is_err());
    }

    #[test]
    fn debug_never_shows_the_key() {
        let c = ClientConfig {
            base_url: "http://x".into(),
            api_key: Some("sk-secret".into()),
            headers: HeaderMap::new(),
            request_timeout: Duration::from_secs(1),
            retry: RetryPolicy::default(),
            max_reply_bytes: DEFAULT_MAX_REPLY_BYTES,
        };
        assert!(!format!("{c:?}").contains("sk-secret"));
    }
}
