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
    #[error("gave up after {attempts} attempts; last error: {last}")]
    Exhausted { attempts: u32, last: String },
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
}

impl std::fmt::Debug for ClientConfig {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ClientConfig")
            .field("base_url", &self.base_url)
            .field("api_key", &self.api_key.as_ref().map(|_| "<redacted>"))
            .field("headers", &self.headers.keys().collect::<Vec<_>>())
            .field("request_timeout", &self.request_timeout)
            .field("retry", &self.retry)
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
}

/// Why one attempt failed.
#[derive(Debug)]
enum AttemptError {
    Transient { message: String, retry_after: Option<Duration> },
    Fatal(LlmError),
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
    /// called before each backoff sleep (for progress counters).
    pub async fn chat(&self, request: &ChatRequest<'_>, on_retry: impl Fn()) -> Result<Completion, LlmError> {
        // Serialise once; every attempt sends the same bytes.
        let body = serde_json::to_vec(request).expect("a chat request always serialises");
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
                Err(AttemptError::Transient { message, retry_after }) => {
                    last = message;
                    if attempt + 1 < attempts_allowed {
                        on_retry();
                        tokio::time::sleep(self.config.retry.delay(attempt, retry_after, self.unit())).await;
                    }
                }
            }
        }
        Err(LlmError::Exhausted { attempts: attempts_allowed, last })
    }

    async fn attempt(&self, body: &[u8]) -> Result<Completion, AttemptError> {
        let transient = |message: String| AttemptError::Transient { message, retry_after: None };
        let response = self
            .http
            .post(&self.url)
            .timeout(self.config.request_timeout)
            .body(body.to_vec())
            .send()
            .await
            .map_err(|e| transient(describe_reqwest(&e)))?;
        let status = response.status();
        let retry_after = retry_after_of(response.headers());
        let bytes =
            response.bytes().await.map_err(|e| transient(format!("reading the reply: {}", describe_reqwest(&e))))?;
        if !status.is_success() {
            let message = format!("{}: {}", status, error_message(&bytes));
            return Err(match classify_status(status.as_u16()) {
                FailureClass::Transient => AttemptError::Transient { message, retry_after },
                FailureClass::Refused => AttemptError::Fatal(LlmError::Refused { status: status.as_u16(), message }),
                FailureClass::Permanent => {
                    AttemptError::Fatal(LlmError::Permanent { status: status.as_u16(), message })
                }
            });
        }
        interpret(&bytes).map_err(|message| AttemptError::Transient { message, retry_after })
    }
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
    fn debug_never_shows_the_key() {
        let c = ClientConfig {
            base_url: "http://x".into(),
            api_key: Some("sk-secret".into()),
            headers: HeaderMap::new(),
            request_timeout: Duration::from_secs(1),
            retry: RetryPolicy::default(),
        };
        assert!(!format!("{c:?}").contains("sk-secret"));
    }
}
