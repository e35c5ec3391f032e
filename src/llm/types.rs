//! Wire types for OpenAI-compatible chat completions.
//!
//! Requests are small and strict. Responses are read as tolerantly as
//! possible: providers disagree on almost every field, so every field is
//! optional, a field with an unexpected type reads as absent instead of
//! failing the whole response, and unknown fields are kept in `extra` (so a
//! stored response loses nothing).

use serde::de::DeserializeOwned;
use serde::{Deserialize, Deserializer, Serialize};
use serde_json::{Map, Value};

/// One message of the conversation we send: its text, and for a scene
/// shown as a picture the picture, sent before the text as OpenAI content
/// parts (`[{"type": "image_url", ...}, {"type": "text", ...}]`); a message
/// without a picture is sent as a plain string, as before.
#[derive(Debug, Clone, PartialEq)]
pub struct ChatMessage {
    pub role: Role,
    pub content: String,
    /// The picture, shared (the history holds every turn's).
    pub image: Option<std::sync::Arc<ImageUrl>>,
}

/// An `image_url` content part's body, `{"url": ..., "detail": ...}`: the
/// picture as a data URL and the detail the provider should look at it
/// with. Written as JSON once: every later request of the episode carries
/// it again (tens of kilobytes) and copies it as it is, unscanned.
#[derive(Debug, Clone)]
pub struct ImageUrl(Box<serde_json::value::RawValue>);

impl PartialEq for ImageUrl {
    fn eq(&self, other: &ImageUrl) -> bool {
        self.0.get() == other.0.get()
    }
}

impl Serialize for ImageUrl {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.0.serialize(s)
    }
}

impl ImageUrl {
    /// `url` at `detail`.
    pub fn new(url: &str, detail: &'static str) -> ImageUrl {
        let json = serde_json::json!({ "url": url, "detail": detail }).to_string();
        ImageUrl(serde_json::value::RawValue::from_string(json).expect("an object is JSON"))
    }

    /// A PNG as a `data:image/png;base64,` URL, written straight into its
    /// JSON: base64 and the detail's name need no escaping, so the tens of
    /// kilobytes are neither copied again nor scanned.
    pub fn png(bytes: &[u8], detail: &'static str) -> ImageUrl {
        use base64::Engine;
        const HEAD: &str = r#"{"url":"data:image/png;base64,"#;
        let mut json = String::with_capacity(HEAD.len() + bytes.len().div_ceil(3) * 4 + detail.len() + 16);
        json.push_str(HEAD);
        base64::engine::general_purpose::STANDARD.encode_string(bytes, &mut json);
        json.push_str(r#"","detail":"#);
        json.push_str(&serde_json::to_string(detail).expect("a string is JSON"));
        json.push('}');
        ImageUrl(serde_json::value::RawValue::from_string(json).expect("base64 in a JSON string is JSON"))
    }

    /// The length of its JSON.
    pub fn json_len(&self) -> usize {
        self.0.get().len()
    }
}

impl Serialize for ChatMessage {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        #[derive(Serialize)]
        #[serde(tag = "type", rename_all = "snake_case")]
        enum Part<'a> {
            ImageUrl { image_url: &'a ImageUrl },
            Text { text: &'a str },
        }
        let mut m = s.serialize_struct("ChatMessage", 2)?;
        m.serialize_field("role", &self.role)?;
        match &self.image {
            None => m.serialize_field("content", &self.content)?,
            Some(image) => m.serialize_field(
                "content",
                &[Part::ImageUrl { image_url: image }, Part::Text { text: &self.content }],
            )?,
        }
        m.end()
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Role {
    System,
    User,
    Assistant,
}

impl ChatMessage {
    pub fn new(role: Role, content: impl Into<String>) -> ChatMessage {
        ChatMessage { role, content: content.into(), image: None }
    }

    /// The same message with a picture before its text.
    pub fn with_image(mut self, image: std::sync::Arc<ImageUrl>) -> ChatMessage {
        self.image = Some(image);
        self
    }
}

/// The request body: model, messages, and the run's sampling parameters
/// (temperature, max_tokens, response_format and any `--sampling-args`),
/// flattened into the top level as the API expects.
#[derive(Debug, Serialize)]
pub struct ChatRequest<'a> {
    pub model: &'a str,
    pub messages: &'a [&'a ChatMessage],
    #[serde(flatten)]
    pub params: &'a Map<String, Value>,
}

impl ChatRequest<'_> {
    /// About the length of its JSON, a little over unless much of its text
    /// needs escaping: the body is written into a buffer this size at once
    /// rather than grown by doubling, which for a conversation of pictures
    /// copies megabytes.
    pub fn json_len_hint(&self) -> usize {
        let messages: usize = self
            .messages
            .iter()
            .map(|m| m.content.len() + m.image.as_ref().map_or(0, |i| i.json_len() + 64) + 64)
            .sum();
        messages + self.model.len() + 1024
    }
}

/// Deserialize into `Option<T>`, turning a value of the wrong shape into
/// `None` instead of an error: one odd field must not cost a whole reply.
fn lenient<'de, D, T>(d: D) -> Result<Option<T>, D::Error>
where
    D: Deserializer<'de>,
    T: DeserializeOwned,
{
    let v = Value::deserialize(d)?;
    Ok(if v.is_null() { None } else { serde_json::from_value(v).ok() })
}

/// Like [`lenient`] for token counts, also accepting integral floats
/// (`12.0`) and numeric strings, which some proxies emit.
fn lenient_count<'de, D: Deserializer<'de>>(d: D) -> Result<Option<u64>, D::Error> {
    let v = Value::deserialize(d)?;
    Ok(match v {
        Value::Number(n) => {
            n.as_u64().or_else(|| n.as_f64().filter(|x| *x >= 0.0 && x.fract() == 0.0).map(|x| x as u64))
        }
        Value::String(s) => s.trim().parse().ok(),
        _ => None,
    })
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ChatResponse {
    #[serde(default, deserialize_with = "lenient", skip_serializing_if = "Option::is_none")]
    pub id: Option<String>,
    #[serde(default, deserialize_with = "lenient", skip_serializing_if = "Option::is_none")]
    pub object: Option<String>,
    #[serde(default, deserialize_with = "lenient", skip_serializing_if = "Option::is_none")]
    pub created: Option<i64>,
    #[serde(default, deserialize_with = "lenient", skip_serializing_if = "Option::is_none")]
    pub model: Option<String>,
    #[serde(default, deserialize_with = "lenient", skip_serializing_if = "Option::is_none")]
    pub choices: Option<Vec<Choice>>,
    #[serde(default, deserialize_with = "lenient", skip_serializing_if = "Option::is_none")]
    pub usage: Option<Usage>,
    /// Some providers answer HTTP 200 with an error object instead of
    /// choices (OpenRouter does when an upstream fails).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<Value>,
    #[serde(flatten)]
    pub extra: Map<String, Value>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Choice {
    #[serde(default, deserialize_with = "lenient", skip_serializing_if = "Option::is_none")]
    pub index: Option<u64>,
    #[serde(default, deserialize_with = "lenient", skip_serializing_if = "Option::is_none")]
    pub message: Option<ResponseMessage>,
    #[serde(default, deserialize_with = "lenient", skip_serializing_if = "Option::is_none")]
    pub finish_reason: Option<String>,
    #[serde(flatten)]
    pub extra: Map<String, Value>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ResponseMessage {
    #[serde(default, deserialize_with = "lenient", skip_serializing_if = "Option::is_none")]
    pub role: Option<String>,
    /// A string, `null`, or (some providers) an array of content parts.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub content: Option<Value>,
    /// DeepSeek, vLLM and others.
    #[serde(default, deserialize_with = "lenient", skip_serializing_if = "Option::is_none")]
    pub reasoning_content: Option<String>,
    /// OpenRouter and others.
    #[serde(default, deserialize_with = "lenient", skip_serializing_if = "Option::is_none")]
    pub reasoning: Option<String>,
    #[serde(flatten)]
    pub extra: Map<String, Value>,
}

/// Token usage as providers report it. Besides the three OpenAI counts:
/// - cached prompt tokens: `prompt_tokens_details.cached_tokens` (OpenAI,
///   OpenRouter, vLLM), `prompt_cache_hit_tokens` (DeepSeek), a top-level
///   `cached_tokens` (Together), `cache_read_input_tokens` (Anthropic's
///   native field, passed through by some proxies);
/// - reasoning tokens: `completion_tokens_details.reasoning_tokens`
///   (OpenAI, OpenRouter, DeepSeek), part of `completion_tokens`. Gemini's
///   OpenAI endpoint reports no such field and leaves its thinking out of
///   `completion_tokens` while counting it in `total_tokens`; [`Usage::reasoning`]
///   reads that gap as hidden reasoning.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Usage {
    #[serde(default, deserialize_with = "lenient_count", skip_serializing_if = "Option::is_none")]
    pub prompt_tokens: Option<u64>,
    #[serde(default, deserialize_with = "lenient_count", skip_serializing_if = "Option::is_none")]
    pub completion_tokens: Option<u64>,
    #[serde(default, deserialize_with = "lenient_count", skip_serializing_if = "Option::is_none")]
    pub total_tokens: Option<u64>,
    #[serde(default, deserialize_with = "lenient", skip_serializing_if = "Option::is_none")]
    pub prompt_tokens_details: Option<PromptTokensDetails>,
    #[serde(default, deserialize_with = "lenient", skip_serializing_if = "Option::is_none")]
    pub completion_tokens_details: Option<CompletionTokensDetails>,
    #[serde(default, deserialize_with = "lenient_count", skip_serializing_if = "Option::is_none")]
    pub prompt_cache_hit_tokens: Option<u64>,
    #[serde(default, deserialize_with = "lenient_count", skip_serializing_if = "Option::is_none")]
    pub prompt_cache_miss_tokens: Option<u64>,
    #[serde(default, deserialize_with = "lenient_count", skip_serializing_if = "Option::is_none")]
    pub cached_tokens: Option<u64>,
    #[serde(default, deserialize_with = "lenient_count", skip_serializing_if = "Option::is_none")]
    pub cache_read_input_tokens: Option<u64>,
}

#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct PromptTokensDetails {
    #[serde(default, deserialize_with = "lenient_count", skip_serializing_if = "Option::is_none")]
    pub cached_tokens: Option<u64>,
}

#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct CompletionTokensDetails {
    #[serde(default, deserialize_with = "lenient_count", skip_serializing_if = "Option::is_none")]
    pub reasoning_tokens: Option<u64>,
}

impl Usage {
    /// Total tokens: the reported total, else the sum of the parts.
    pub fn total(&self) -> Option<u64> {
        self.total_tokens.or(match (self.prompt_tokens, self.completion_tokens) {
            (None, None) => None,
            (p, c) => Some(p.unwrap_or(0) + c.unwrap_or(0)),
        })
    }

    /// Prompt tokens served from the provider's prompt cache, in whichever
    /// spelling the provider uses (0 when it reports none).
    pub fn cached(&self) -> u64 {
        self.prompt_tokens_details
            .and_then(|d| d.cached_tokens)
            .or(self.prompt_cache_hit_tokens)
            .or(self.cached_tokens)
            .or(self.cache_read_input_tokens)
            .unwrap_or(0)
    }

    /// Reasoning tokens: the reported count, else the part of the total
    /// that neither prompt nor completion accounts for (hidden thinking).
    pub fn reasoning(&self) -> u64 {
        if let Some(r) = self.completion_tokens_details.and_then(|d| d.reasoning_tokens) {
            return r;
        }
        self.hidden_reasoning()
    }

    /// Thinking counted in the total but not in `completion_tokens`.
    pub fn hidden_reasoning(&self) -> u64 {
        match (self.total_tokens, self.prompt_tokens, self.completion_tokens) {
            (Some(t), Some(p), Some(c)) => t.saturating_sub(p + c),
            _ => 0,
        }
    }

    /// Output tokens billed: completion tokens plus hidden thinking.
    pub fn billed_output(&self) -> u64 {
        self.completion_tokens.unwrap_or(0) + self.hidden_reasoning()
    }
}

impl ResponseMessage {
    /// The reply text: a string content as is, an array of parts joined
    /// (text parts only), anything else as absent.
    pub fn text(&self) -> Option<String> {
        match self.content.as_ref()? {
            Value::String(s) => Some(s.clone()),
            Value::Array(parts) => {
                let text: String =
                    parts.iter().filter_map(|p| p.as_str().or_else(|| p.get("text").and_then(Value::as_str))).collect();
                Some(text)
            }
            _ => None,
        }
    }
}

/// `<think>...</think>` handling: returns (the text with every think block
/// removed, the think blocks' contents joined). A reply whose first tag is a
/// closing `</think>` started inside the block (some servers strip the
/// opening tag); a reply that ends inside an open block has no answer.
pub fn split_think(text: &str) -> (String, Option<String>) {
    const OPEN: &str = "<think>";
    const CLOSE: &str = "</think>";
    let mut answer = String::new();
    let mut thoughts: Vec<&str> = Vec::new();
    let mut rest = text;
    // A leading orphan close tag: everything before it is thought.
    if let Some(close) = rest.find(CLOSE)
        && rest.find(OPEN).is_none_or(|open| close < open)
    {
        thoughts.push(&rest[..close]);
        rest = &rest[close + CLOSE.len()..];
    }
    while let Some(open) = rest.find(OPEN) {
        answer.push_str(&rest[..open]);
        let after = &rest[open + OPEN.len()..];
        match after.find(CLOSE) {
            Some(close) => {
                thoughts.push(&after[..close]);
                rest = &after[close + CLOSE.len()..];
            }
            None => {
                thoughts.push(after);
                rest = "";
            }
        }
    }
    answer.push_str(rest);
    let thoughts: Vec<&str> = thoughts.into_iter().map(str::trim).filter(|t| !t.is_empty()).collect();
    (answer, if thoughts.is_empty() { None } else { Some(thoughts.join("\n\n")) })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(s: &str) -> ChatResponse {
        serde_json::from_str(s).unwrap()
    }

    /// The picture's JSON, written by hand, is the JSON serde writes for
    /// the same URL and detail, and the request's size hint covers it.
    #[test]
    fn a_pictures_json_is_written_as_serde_writes_it() {
        use base64::Engine as _;
        let bytes: Vec<u8> = (0..=255u8).cycle().take(1000).collect();
        let url = format!("data:image/png;base64,{}", base64::engine::general_purpose::STANDARD.encode(&bytes));
        for detail in ["low", "high", "auto"] {
            let ours: Value = serde_json::from_str(ImageUrl::png(&bytes, detail).0.get()).unwrap();
            assert_eq!(ours, serde_json::json!({"url": url, "detail": detail}));
        }
        let image = std::sync::Arc::new(ImageUrl::png(&bytes, "auto"));
        let messages = [
            ChatMessage::new(Role::System, "rules \"quoted\""),
            ChatMessage::new(Role::User, "Turn 1 of 9").with_image(image),
        ];
        let refs: Vec<&ChatMessage> = messages.iter().collect();
        let params = Map::new();
        let request = ChatRequest { model: "m", messages: &refs, params: &params };
        assert!(serde_json::to_vec(&request).unwrap().len() <= request.json_len_hint());
    }

    #[test]
    fn null_content_and_missing_usage_are_tolerated() {
        let r = parse(r#"{"choices":[{"message":{"role":"assistant","content":null},"finish_reason":"stop"}]}"#);
        let c = &r.choices.as_ref().unwrap()[0];
        assert_eq!(c.message.as_ref().unwrap().text(), None);
        assert!(r.usage.is_none());
    }

    #[test]
    fn reasoning_fields_are_read() {
        let r = parse(
            r#"{"choices":[{"message":{"content":"{}","reasoning_content":"hmm","reasoning":"also"}}],
                "usage":{"prompt_tokens":10,"completion_tokens":"5"}}"#,
        );
        let m = r.choices.as_ref().unwrap()[0].message.clone().unwrap();
        assert_eq!(m.reasoning_content.as_deref(), Some("hmm"));
        assert_eq!(m.reasoning.as_deref(), Some("also"));
        assert_eq!(r.usage.unwrap().total(), Some(15));
    }

    #[test]
    fn extra_fields_and_odd_values_are_kept_or_ignored() {
        let r = parse(
            r#"{"id":42,"provider":"x","created":"yesterday","choices":[{"index":0,"finish_reason":"",
                "message":{"content":[{"type":"text","text":"a"},{"type":"text","text":"b"}],"refusal":null},
                "logprobs":{"x":1}}],"usage":{"total_tokens":7.0,"cost":0.1}}"#,
        );
        assert_eq!(r.id, None, "a numeric id reads as absent, not as an error");
        assert_eq!(r.extra.get("provider"), Some(&Value::from("x")));
        let c = &r.choices.as_ref().unwrap()[0];
        assert_eq!(c.finish_reason.as_deref(), Some(""));
        assert!(c.extra.contains_key("logprobs"));
        assert_eq!(c.message.as_ref().unwrap().text().as_deref(), Some("ab"));
        assert_eq!(r.usage.unwrap().total(), Some(7));
    }

    #[test]
    fn cached_and_reasoning_tokens_in_every_spelling() {
        let u = |s: &str| serde_json::from_str::<Usage>(s).unwrap();
        let openai = u(r#"{"prompt_tokens":100,"completion_tokens":50,"total_tokens":150,
            "prompt_tokens_details":{"cached_tokens":64,"audio_tokens":0},
            "completion_tokens_details":{"reasoning_tokens":40}}"#);
        assert_eq!((openai.cached(), openai.reasoning(), openai.billed_output()), (64, 40, 50));
        let deepseek = u(r#"{"prompt_tokens":100,"completion_tokens":50,"total_tokens":150,
            "prompt_cache_hit_tokens":80,"prompt_cache_miss_tokens":20,
            "completion_tokens_details":{"reasoning_tokens":30}}"#);
        assert_eq!((deepseek.cached(), deepseek.reasoning()), (80, 30));
        let together = u(r#"{"prompt_tokens":10,"completion_tokens":5,"total_tokens":15,"cached_tokens":8}"#);
        assert_eq!((together.cached(), together.reasoning()), (8, 0));
        // Gemini: the thinking only shows in the total.
        let gemini = u(r#"{"prompt_tokens":100,"completion_tokens":20,"total_tokens":620}"#);
        assert_eq!((gemini.cached(), gemini.reasoning(), gemini.billed_output()), (0, 500, 520));
        let odd = u(r#"{"prompt_tokens_details":"n/a","completion_tokens_details":{"reasoning_tokens":"7"}}"#);
        assert_eq!((odd.cached(), odd.reasoning()), (0, 7));
    }

    #[test]
    fn error_bodies_and_missing_choices_parse() {
        let r = parse(r#"{"error":{"message":"upstream failed","code":502}}"#);
        assert!(r.error.is_some());
        assert!(r.choices.is_none());
        let r = parse(r#"{"choices":"nope"}"#);
        assert!(r.choices.is_none());
    }

    #[test]
    fn think_blocks_are_split_off() {
        let (a, t) = split_think("<think>the car brakes</think>\n{\"maneuver\":\"proceed\"}");
        assert_eq!(a.trim(), "{\"maneuver\":\"proceed\"}");
        assert_eq!(t.as_deref(), Some("the car brakes"));
        let (a, t) = split_think("opening tag stripped</think>{}");
        assert_eq!((a.as_str(), t.as_deref()), ("{}", Some("opening tag stripped")));
        let (a, t) = split_think("{} <think>cut off");
        assert_eq!((a.as_str(), t.as_deref()), ("{} ", Some("cut off")));
        let (a, t) = split_think("plain");
        assert_eq!((a.as_str(), t), ("plain", None));
    }
}
