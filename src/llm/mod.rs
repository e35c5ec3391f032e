//! Client for OpenAI-compatible chat-completions endpoints (docs/eval.md):
//! tolerant wire types ([`types`]) and a retrying client ([`client`]).
//!
//! Failure policy: connect/read errors, timeouts, 408, 429, 5xx, and an
//! HTTP 200 carrying an error object or no choices are transient and
//! retried with capped exponential backoff and jitter, honouring
//! `Retry-After` (seconds or HTTP-date; `retry-after-ms` too). 401, 403 and
//! 404 mean the run is misconfigured (key, model name) and stop it; other
//! 4xx statuses stop it as well.

pub mod client;
pub mod profile;
pub mod types;

pub use client::{Client, ClientConfig, Completion, DEFAULT_MAX_REPLY_BYTES, LlmError, RetryPolicy};
pub use types::{ChatMessage, ChatRequest, ImageUrl, Role, Usage};
