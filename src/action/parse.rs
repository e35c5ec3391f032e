//! Protective parser for model replies.
//!
//! A reply should be one JSON object such as
//! `{"reasoning": "...", "acceleration": 0.5, "steering": 0.0, "maneuver": "proceed"}`,
//! but models wrap it in code fences, `<think>` blocks and prose, restate
//! it, or get cut off. [`parse_action`] finds the object and validates it;
//! anything it cannot trust turns the whole action into
//! [`Action::CONSERVATIVE`] and is recorded as an [`ActionParseError`].
//!
//! Rules:
//! - `<think>...</think>` blocks are ignored, including a block whose
//!   opening tag is missing (the reply starts inside it and the first tag
//!   is `</think>`). A reply that ends inside a `<think>` block has no
//!   answer.
//! - Candidates are top-level JSON objects anywhere in the remaining text.
//!   The last one with a `maneuver` key wins (models restate their answer);
//!   otherwise the last one. Objects nested inside another object are
//!   values, never answers.
//! - The JSON reader is strict except for a few common model slips: trailing
//!   commas, raw control characters inside strings, and the `NaN` /
//!   `Infinity` tokens (which then fail the range check).
//! - Keys are matched ignoring ASCII case; unknown keys are ignored; `null`
//!   counts as absent; duplicate keys: the last one wins.
//! - `maneuver` goes through [`Maneuver::from_loose`]; `acceleration` (required)
//!   and `steering` (optional, default 0) must be numbers, or strings holding
//!   only a number, in [-1, 1].
//! - Any error degrades the whole action to [`Action::CONSERVATIVE`]: one
//!   simple rule, and braking is the safe reading of an unclear answer.
//!
//! Scanning is linear-ish: every parse attempt starts at a `{` the previous
//! attempts did not already read as an object start, and the total work
//! spent on failed attempts is capped, so adversarial input (1 MB of `{`,
//! deep nesting, unterminated strings) stays fast. Nesting depth is capped,
//! and no indexing on input-derived positions can panic.

use super::json::{Fail, Reader, Val};
use super::{Action, Maneuver};
use serde::{Deserialize, Serialize};
use std::fmt;

/// The outcome of reading one reply: the action to execute, the model's
/// `reasoning` field if any, and every problem found. When `errors` is not
/// empty, `action` is [`Action::CONSERVATIVE`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ParsedAction {
    pub action: Action,
    pub reasoning: Option<String>,
    pub errors: Vec<ActionParseError>,
}

impl ParsedAction {
    /// True when the reply was read without any problem.
    pub fn is_clean(&self) -> bool {
        self.errors.is_empty()
    }

    fn degraded(reasoning: Option<String>, errors: Vec<ActionParseError>) -> ParsedAction {
        ParsedAction { action: Action::CONSERVATIVE, reasoning, errors }
    }
}

/// A numeric field of the action.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NumericField {
    Acceleration,
    Steering,
}

impl fmt::Display for NumericField {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            NumericField::Acceleration => "acceleration",
            NumericField::Steering => "steering",
        })
    }
}

/// Why a reply could not be trusted. Values quoted from the reply are
/// clipped to a few dozen characters so logs stay small.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, thiserror::Error)]
#[serde(tag = "kind", content = "detail", rename_all = "snake_case")]
pub enum ActionParseError {
    #[error("the reply is empty")]
    Empty,
    #[error("no JSON object found in the reply")]
    NoJson,
    #[error("the reply ends inside an unclosed <think> block")]
    UnclosedThink,
    #[error("the reply is a JSON {found}, not an object")]
    NotAnObject { found: String },
    #[error("the JSON object is cut off before its end")]
    Truncated,
    #[error("malformed JSON: {detail}")]
    Malformed { detail: String },
    #[error("no \"maneuver\" field")]
    MissingManeuver,
    #[error("unknown maneuver {value:?}")]
    UnknownManeuver { value: String },
    #[error("no \"acceleration\" field")]
    MissingAcceleration,
    #[error("{field} is not a number: {value:?}")]
    NotANumber { field: NumericField, value: String },
    #[error("{field} {value} is outside [-1, 1]")]
    OutOfRange { field: NumericField, value: String },
    /// The reply was longer than `--max-reply-bytes` and was cut there.
    #[error("the reply is longer than {limit} bytes (--max-reply-bytes) and was cut")]
    Oversized { limit: usize },
    /// The reply's bytes were not UTF-8 (decoded lossily).
    #[error("the reply is not valid UTF-8")]
    InvalidUtf8,
}

impl ActionParseError {
    /// Stable snake_case name of the variant (the serde `kind` tag), for
    /// counting failures by kind.
    pub fn kind(&self) -> &'static str {
        match self {
            ActionParseError::Empty => "empty",
            ActionParseError::NoJson => "no_json",
            ActionParseError::UnclosedThink => "unclosed_think",
            ActionParseError::NotAnObject { .. } => "not_an_object",
            ActionParseError::Truncated => "truncated",
            ActionParseError::Malformed { .. } => "malformed",
            ActionParseError::MissingManeuver => "missing_maneuver",
            ActionParseError::UnknownManeuver { .. } => "unknown_maneuver",
            ActionParseError::MissingAcceleration => "missing_acceleration",
            ActionParseError::NotANumber { .. } => "not_a_number",
            ActionParseError::OutOfRange { .. } => "out_of_range",
            ActionParseError::Oversized { .. } => "oversized",
            ActionParseError::InvalidUtf8 => "invalid_utf8",
        }
    }
}

/// Read one model reply. Never panics; see the module docs for the rules.
pub fn parse_action(text: &str) -> ParsedAction {
    if text.trim().is_empty() {
        return ParsedAction::degraded(None, vec![ActionParseError::Empty]);
    }
    let scan = scan(text);
    // A reply that is a whole JSON array or scalar answered the wrong shape,
    // even if an object hides inside it.
    if let Some(found) = scan.answer_region.and_then(non_object_kind) {
        return ParsedAction::degraded(None, vec![ActionParseError::NotAnObject { found: found.to_string() }]);
    }
    match scan.answer() {
        Some(fields) => evaluate(fields),
        None => ParsedAction::degraded(None, vec![scan.no_candidate_error()]),
    }
}

/// Why the belief probe's `"belief"` field could not be read. A belief
/// error never touches the action: it is counted apart, as a probe parse
/// error.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, thiserror::Error)]
#[serde(tag = "kind", content = "detail", rename_all = "snake_case")]
pub enum BeliefParseError {
    /// No JSON object to read the field from (the action parse says why).
    #[error("no JSON answer to read a belief from")]
    NoAnswer,
    #[error("no \"belief\" field")]
    Missing,
    #[error("belief is not a number: {value:?}")]
    NotANumber { value: String },
    #[error("belief {value} is outside [0, 1]")]
    OutOfRange { value: String },
}

/// Read the belief probe's `"belief"` field (a probability in [0, 1]) from
/// the same JSON object [`parse_action`] reads the action from. Never
/// panics; a number written as a string is accepted, as for the action.
pub fn parse_belief(text: &str) -> Result<f64, BeliefParseError> {
    let scan = scan(text);
    if scan.answer_region.and_then(non_object_kind).is_some() {
        return Err(BeliefParseError::NoAnswer);
    }
    let fields = scan.answer().ok_or(BeliefParseError::NoAnswer)?;
    let v = lookup(fields, "belief").ok_or(BeliefParseError::Missing)?;
    match v.number() {
        None => Err(BeliefParseError::NotANumber { value: clip(v.text()) }),
        Some(x) if x.is_finite() && (0.0..=1.0).contains(&x) => Ok(x),
        Some(_) => Err(BeliefParseError::OutOfRange { value: clip(v.text()) }),
    }
}

/// Why the forecast probe's `"forecast"` field could not be read. Like a
/// belief error it never touches the action: a probe parse error.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, thiserror::Error)]
#[serde(tag = "kind", content = "detail", rename_all = "snake_case")]
pub enum ForecastParseError {
    /// No JSON object to read the field from (the action parse says why).
    #[error("no JSON answer to read a forecast from")]
    NoAnswer,
    #[error("no \"forecast\" field")]
    Missing,
    /// Not an object with both intents' lists of [1 s, 2 s] pairs.
    #[error("forecast is not an object of two lists of [1 s, 2 s] pairs: {value:?}")]
    Malformed { value: String },
    #[error("forecast gives {got} road users under {intent:?}, expected {expected}")]
    WrongCount { intent: String, expected: usize, got: usize },
}

/// A forecast as read from an answer: per intent (lets the ego go first,
/// does not), per road user, the positions at 1 s and 2 s.
pub type StatedForecast = [Vec<[f64; 2]>; 2];

/// Read the forecast probe's `"forecast"` field from the same JSON object
/// [`parse_action`] reads the action from: an object whose keys
/// `lets_you_go_key` and `does_not_key` each hold `road_users` pairs of
/// finite numbers (numbers written as strings accepted; a single road
/// user's pair may come unwrapped). Never panics.
pub fn parse_forecast(
    text: &str,
    road_users: usize,
    lets_you_go_key: &str,
    does_not_key: &str,
) -> Result<StatedForecast, ForecastParseError> {
    let scan = scan(text);
    if scan.answer_region.and_then(non_object_kind).is_some() {
        return Err(ForecastParseError::NoAnswer);
    }
    let fields = scan.answer().ok_or(ForecastParseError::NoAnswer)?;
    let v = lookup(fields, "forecast").ok_or(ForecastParseError::Missing)?;
    let malformed = || ForecastParseError::Malformed { value: clip(v.text()) };
    let Val::Other(raw) = v else { return Err(malformed()) };
    let object: serde_json::Map<String, serde_json::Value> = serde_json::from_str(raw).map_err(|_| malformed())?;
    let number = |x: &serde_json::Value| {
        match x {
            serde_json::Value::Number(n) => n.as_f64(),
            serde_json::Value::String(s) => s.trim().parse::<f64>().ok(),
            _ => None,
        }
        .filter(|x| x.is_finite())
    };
    let pair = |x: &serde_json::Value| -> Option<[f64; 2]> {
        match x.as_array()?.as_slice() {
            [a, b] => Some([number(a)?, number(b)?]),
            _ => None,
        }
    };
    let intent = |key: &str| -> Result<Vec<[f64; 2]>, ForecastParseError> {
        let list = object.iter().find(|(k, _)| key_is(k, key)).map(|(_, v)| v).ok_or_else(malformed)?;
        let pairs: Vec<[f64; 2]> = match pair(list) {
            Some(p) if road_users == 1 => vec![p],
            _ => {
                list.as_array().ok_or_else(malformed)?.iter().map(pair).collect::<Option<_>>().ok_or_else(malformed)?
            }
        };
        if pairs.len() != road_users {
            return Err(ForecastParseError::WrongCount {
                intent: key.to_string(),
                expected: road_users,
                got: pairs.len(),
            });
        }
        Ok(pairs)
    };
    Ok([intent(lets_you_go_key)?, intent(does_not_key)?])
}

// ---------------------------------------------------------------------------
// Field validation

fn key_is(key: &str, name: &str) -> bool {
    key.trim().eq_ignore_ascii_case(name)
}

/// Last value under `name`; `null` counts as absent.
fn lookup<'f, 'a>(fields: &'f [(String, Val<'a>)], name: &str) -> Option<&'f Val<'a>> {
    fields.iter().rev().find(|(k, _)| key_is(k, name)).map(|(_, v)| v).filter(|v| !matches!(v, Val::Null))
}

fn evaluate(fields: &[(String, Val<'_>)]) -> ParsedAction {
    let reasoning = match lookup(fields, "reasoning") {
        Some(Val::Str(s)) => Some(s.clone()),
        _ => None,
    };
    let mut errors = Vec::new();

    let maneuver = match lookup(fields, "maneuver") {
        None => {
            errors.push(ActionParseError::MissingManeuver);
            None
        }
        Some(v) => {
            let m = match v {
                Val::Str(s) => Maneuver::from_loose(s),
                _ => None,
            };
            if m.is_none() {
                errors.push(ActionParseError::UnknownManeuver { value: clip(v.text()) });
            }
            m
        }
    };
    let acceleration = match lookup(fields, "acceleration") {
        None => {
            errors.push(ActionParseError::MissingAcceleration);
            None
        }
        Some(v) => unit_number(NumericField::Acceleration, v).map_err(|e| errors.push(e)).ok(),
    };
    let steering = match lookup(fields, "steering") {
        None => Some(0.0),
        Some(v) => unit_number(NumericField::Steering, v).map_err(|e| errors.push(e)).ok(),
    };

    match (maneuver, acceleration, steering) {
        (Some(maneuver), Some(acceleration), Some(steering)) if errors.is_empty() => {
            ParsedAction { action: Action { maneuver, acceleration, steering }, reasoning, errors }
        }
        _ => ParsedAction::degraded(reasoning, errors),
    }
}

/// A number in [-1, 1]. A string holding only a number is accepted (models
/// quote numbers); anything else in the string is prose.
fn unit_number(field: NumericField, v: &Val<'_>) -> Result<f64, ActionParseError> {
    match v.number() {
        None => Err(ActionParseError::NotANumber { field, value: clip(v.text()) }),
        Some(x) if x.is_finite() && (-1.0..=1.0).contains(&x) => Ok(x),
        Some(_) => Err(ActionParseError::OutOfRange { field, value: clip(v.text()) }),
    }
}

/// Keep quoted reply text short in error messages.
fn clip(s: &str) -> String {
    const MAX_CHARS: usize = 64;
    match s.char_indices().nth(MAX_CHARS) {
        Some((cut, _)) => format!("{}…", s.get(..cut).unwrap_or_default()),
        None => s.to_string(),
    }
}

// ---------------------------------------------------------------------------
// Scanning the reply for candidate objects

const THINK_OPEN: &[u8] = b"<think>";
const THINK_CLOSE: &[u8] = b"</think>";

/// Failed attempts may re-read text; cap their total work at this many
/// times the input length (plus a constant) to stay linear on adversarial
/// input. Real replies never come close.
const FAILED_WORK_FACTOR: usize = 8;
const FAILED_WORK_SLACK: usize = 1 << 16;

struct Scan<'a> {
    /// Top-level fields of every object that parsed, in reply order.
    candidates: Vec<Vec<(String, Val<'a>)>>,
    /// The failed attempt that read furthest, if any.
    best_failure: Option<Fail>,
    /// The reply ended inside a `<think>` block.
    unclosed_think: bool,
    /// Text after the last `</think>` (the whole reply if none), when the
    /// reply does not end inside a think block.
    answer_region: Option<&'a str>,
    /// Bytes read by all parse attempts: counted in tests only, which check
    /// that it stays linear (the cap above is `failed_work`'s).
    #[cfg(test)]
    work: usize,
}

impl<'a> Scan<'a> {
    /// The object that answers: the last one with a `maneuver` field, else
    /// the last one read (the action and the belief probe read the same).
    fn answer(&self) -> Option<&[(String, Val<'a>)]> {
        let has_maneuver = |fields: &&Vec<(String, Val<'a>)>| fields.iter().any(|(k, _)| key_is(k, "maneuver"));
        self.candidates.iter().rev().find(has_maneuver).or(self.candidates.last()).map(Vec::as_slice)
    }

    fn no_candidate_error(&self) -> ActionParseError {
        match &self.best_failure {
            Some(f) if f.eof => ActionParseError::Truncated,
            Some(f) => ActionParseError::Malformed { detail: format!("{} at byte {}", f.what, f.pos) },
            None if self.unclosed_think => ActionParseError::UnclosedThink,
            None => ActionParseError::NoJson,
        }
    }
}

/// Does `tag` (ASCII, case-insensitive) start at byte `i`?
fn tag_at(b: &[u8], i: usize, tag: &[u8]) -> bool {
    b.get(i..i + tag.len()).is_some_and(|w| w.eq_ignore_ascii_case(tag))
}

fn find_tag(b: &[u8], from: usize, tag: &[u8]) -> Option<usize> {
    (from..b.len()).find(|&i| b.get(i) == Some(&b'<') && tag_at(b, i, tag))
}

/// A model whose chat template opens the think block itself replies with
/// thinking, `</think>`, then the answer: the reply starts inside a block.
fn starts_in_think(b: &[u8]) -> bool {
    match find_tag(b, 0, THINK_CLOSE) {
        Some(close) => find_tag(b, 0, THINK_OPEN).is_none_or(|open| close < open),
        None => false,
    }
}

/// Bit set over byte positions, allocated on first use.
#[derive(Default)]
struct Bits(Vec<u64>);

impl Bits {
    fn insert(&mut self, i: usize) {
        let word = i / 64;
        if self.0.len() <= word {
            self.0.resize(word + 1, 0);
        }
        if let Some(w) = self.0.get_mut(word) {
            *w |= 1 << (i % 64);
        }
    }

    fn contains(&self, i: usize) -> bool {
        self.0.get(i / 64).is_some_and(|w| w & (1 << (i % 64)) != 0)
    }
}

fn scan(text: &str) -> Scan<'_> {
    let b = text.as_bytes();
    let mut candidates = Vec::new();
    let mut best_failure: Option<Fail> = None;
    // Object starts already read by a failed attempt: restarting there would
    // fail the same way (the reader's state at an object start is fixed).
    let mut dead_starts = Bits::default();
    let mut object_starts = Vec::new();
    // End of the furthest-reaching failed attempt: an object that closes
    // before it lies inside broken JSON (say, braces in the string of a
    // truncated reply) and is no answer.
    let mut failed_reach = 0;
    let mut failed_work = 0usize;
    #[cfg(test)]
    let mut work = 0usize;
    let work_budget = b.len().saturating_mul(FAILED_WORK_FACTOR).saturating_add(FAILED_WORK_SLACK);
    let mut in_think = starts_in_think(b);
    let mut unclosed_think = false;
    let mut after_think = 0;

    let mut i = 0;
    while i < b.len() {
        if in_think {
            match find_tag(b, i, THINK_CLOSE) {
                Some(close) => {
                    i = close + THINK_CLOSE.len();
                    after_think = i;
                    in_think = false;
                }
                None => {
                    unclosed_think = true;
                    break;
                }
            }
            continue;
        }
        match b.get(i) {
            Some(b'<') if tag_at(b, i, THINK_OPEN) => {
                in_think = true;
                i += THINK_OPEN.len();
            }
            Some(b'{') if !dead_starts.contains(i) && failed_work <= work_budget => {
                object_starts.clear();
                let mut reader = Reader { s: text, b, pos: i, object_starts: &mut object_starts };
                let outcome = reader.top_object();
                #[cfg(test)]
                {
                    work = work.saturating_add(reader.pos.saturating_sub(i) + 1);
                }
                match outcome {
                    Ok(fields) => {
                        if reader.pos > failed_reach {
                            candidates.push(fields);
                        }
                        i = reader.pos;
                    }
                    Err(fail) => {
                        failed_work = failed_work.saturating_add(fail.pos.saturating_sub(i) + 1);
                        failed_reach = failed_reach.max(fail.pos);
                        for &start in object_starts.iter() {
                            dead_starts.insert(start);
                        }
                        let progress = fail.pos.saturating_sub(i);
                        if best_failure.as_ref().is_none_or(|best| progress >= best.pos.saturating_sub(best.start)) {
                            best_failure = Some(Fail { start: i, ..fail });
                        }
                        i += 1;
                    }
                }
            }
            _ => i += 1,
        }
    }

    let answer_region = if unclosed_think { None } else { text.get(after_think..) };
    Scan {
        candidates,
        best_failure,
        unclosed_think,
        answer_region,
        #[cfg(test)]
        work,
    }
}

/// If the answer (fences stripped) is one complete JSON value that is not
/// an object, name its type.
fn non_object_kind(region: &str) -> Option<&'static str> {
    let payload = strip_fence(region);
    let first = *payload.as_bytes().first()?;
    if first == b'{' {
        return None;
    }
    let mut object_starts = Vec::new();
    let mut reader = Reader { s: payload, b: payload.as_bytes(), pos: 0, object_starts: &mut object_starts };
    reader.value(0).ok()?;
    reader.ws();
    if reader.pos != payload.len() {
        return None;
    }
    Some(match first {
        b'[' => "array",
        b'"' => "string",
        b't' | b'f' => "boolean",
        b'n' => "null",
        _ => "number",
    })
}

/// Remove one surrounding Markdown code fence (with optional language tag).
fn strip_fence(s: &str) -> &str {
    let mut t = s.trim();
    if let Some(rest) = t.strip_prefix("```") {
        t = match rest.split_once('\n') {
            Some((tag, body)) if tag.trim().chars().all(|c| c.is_ascii_alphanumeric()) => body,
            _ => rest,
        };
        t = t.trim_end();
        t = t.strip_suffix("```").unwrap_or(t);
    }
    t.trim()
}

#[cfg(test)]
mod tests {
    use super::*;
    use ActionParseError as E;
    use proptest::prelude::*;

    const STOP: Action = Action::CONSERVATIVE;

    fn act(maneuver: Maneuver, acceleration: f64, steering: f64) -> Action {
        Action { maneuver, acceleration, steering }
    }

    /// A clean parse of exactly `want`.
    fn assert_clean(text: &str, want: Action) {
        let p = parse_action(text);
        assert!(p.is_clean(), "unexpected errors {:?} for {text:?}", p.errors);
        assert_eq!(p.action, want, "for {text:?}");
    }

    /// A degraded parse with exactly these errors.
    fn assert_degraded(text: &str, want: &[ActionParseError]) {
        let p = parse_action(text);
        assert_eq!(p.errors, want, "for {text:?}");
        assert_eq!(p.action, STOP, "for {text:?}");
    }

    /// A degraded parse whose single error has this kind.
    fn assert_kind(text: &str, kind: &str) {
        let p = parse_action(text);
        let kinds: Vec<_> = p.errors.iter().map(ActionParseError::kind).collect();
        assert_eq!(kinds, [kind], "for {text:?}");
        assert_eq!(p.action, STOP, "for {text:?}");
    }

    const GO: &str = r#"{"reasoning": "clear", "acceleration": 0.5, "steering": 0.25, "maneuver": "proceed"}"#;
    const GO_ACTION: Action = Action { maneuver: Maneuver::Proceed, acceleration: 0.5, steering: 0.25 };

    // --- accepted forms ---------------------------------------------------

    #[test]
    fn a_forecast_is_read_beside_the_action_and_its_faults_are_named() {
        let read = |text: &str, n| parse_forecast(text, n, "lets", "not");
        let answer =
            r#"{"maneuver": "yield", "acceleration": 0.2, "forecast": {"lets": [[3.0, "1.5"]], "Not": [[2.0, -1]]}}"#;
        assert_eq!(read(answer, 1), Ok([vec![[3.0, 1.5]], vec![[2.0, -1.0]]]));
        // One road user's pair may come unwrapped.
        assert_eq!(
            read(r#"{"forecast": {"lets": [1, 2], "not": [3, 4]}}"#, 1),
            Ok([vec![[1.0, 2.0]], vec![[3.0, 4.0]]])
        );
        assert_eq!(read(r#"{"maneuver": "stop"}"#, 1), Err(ForecastParseError::Missing));
        assert_eq!(read("no json here", 1), Err(ForecastParseError::NoAnswer));
        assert!(matches!(read(r#"{"forecast": 3}"#, 1), Err(ForecastParseError::Malformed { .. })));
        assert!(matches!(read(r#"{"forecast": {"lets": [[1, 2]]}}"#, 1), Err(ForecastParseError::Malformed { .. })));
        assert!(matches!(
            read(r#"{"forecast": {"lets": [[1, NaN]], "not": [[1, 2]]}}"#, 1),
            Err(ForecastParseError::Malformed { .. })
        ));
        assert_eq!(
            read(r#"{"forecast": {"lets": [[1, 2]], "not": [[1, 2]]}}"#, 2),
            Err(ForecastParseError::WrongCount { intent: "lets".into(), expected: 2, got: 1 })
        );
        // The action is read as without the probe.
        assert_eq!(parse_action(answer).action.maneuver, Maneuver::Yield);
    }

    #[test]
    fn plain_object() {
        let p = parse_action(GO);
        assert_eq!(p, ParsedAction { action: GO_ACTION, reasoning: Some("clear".into()), errors: vec![] });
        assert!(p.is_clean());
    }

    #[test]
    fn fenced_object() {
        assert_clean(&format!("```\n{GO}\n```"), GO_ACTION);
        assert_clean(&format!("```json\n{GO}\n```"), GO_ACTION);
        assert_clean(&format!("Here you go:\n```JSON\n{GO}\n```\nDrive safe."), GO_ACTION);
    }

    #[test]
    fn after_think_block_ignoring_json_inside_it() {
        let decoy = r#"{"maneuver": "stop", "acceleration": -1}"#;
        assert_clean(&format!("<think>maybe {decoy}? no.</think>\n{GO}"), GO_ACTION);
        assert_clean(&format!("<THINK>{decoy}</Think>```json\n{GO}\n```"), GO_ACTION);
        // The chat template opened the block: the reply starts inside it.
        assert_clean(&format!("the car {decoy} is far</think>\n\n{GO}"), GO_ACTION);
    }

    #[test]
    fn json_only_inside_think_is_no_answer() {
        assert_degraded(&format!("<think>{GO}</think> I will proceed."), &[E::NoJson]);
        assert_degraded(&format!("<think>{GO}"), &[E::UnclosedThink]);
        assert_degraded("<think>let me consider the gap, the truck is", &[E::UnclosedThink]);
        // Implicitly opened block (only the closing tag is in the reply).
        assert_degraded(&format!("maybe {GO}</think>The answer is above."), &[E::NoJson]);
        // A block after the answer does not override it.
        let decoy = r#"{"maneuver": "stop", "acceleration": -1}"#;
        assert_clean(&format!("{GO}\n<think>second thoughts: {decoy}</think>"), GO_ACTION);
    }

    #[test]
    fn prose_around_and_trailing_text() {
        assert_clean(&format!("Sure! My decision:\n{GO}"), GO_ACTION);
        assert_clean(&format!("{GO}\nI proceed because the gap is large }}."), GO_ACTION);
        assert_clean(&format!("Decision: {GO} -- \"done\" {{ :)"), GO_ACTION);
    }

    #[test]
    fn stray_braces_and_quotes_before_the_object() {
        assert_clean(&format!("Format is {{like this}}. {GO}"), GO_ACTION);
        assert_clean(&format!("I'll write {{\" then: {GO}"), GO_ACTION);
        assert_clean(&format!("unbalanced {{ {{ {{ {GO}"), GO_ACTION);
    }

    #[test]
    fn numeric_strings_are_numbers() {
        let text = r#"{"maneuver": "yield", "acceleration": "-0.75", "steering": " 0.1 "}"#;
        assert_clean(text, act(Maneuver::Yield, -0.75, 0.1));
    }

    #[test]
    fn maneuver_spellings() {
        let cases = [
            ("proceed", Maneuver::Proceed),
            ("PROCEED", Maneuver::Proceed),
            (" Proceed ", Maneuver::Proceed),
            ("yield", Maneuver::Yield),
            ("Yield", Maneuver::Yield),
            ("stop", Maneuver::Stop),
            ("STOP", Maneuver::Stop),
            ("nudge_forward", Maneuver::NudgeForward),
            ("Nudge-Forward", Maneuver::NudgeForward),
            ("nudge forward", Maneuver::NudgeForward),
            ("NUDGEFORWARD", Maneuver::NudgeForward),
        ];
        for (name, want) in cases {
            assert_clean(&format!(r#"{{"maneuver": "{name}", "acceleration": 0.2}}"#), act(want, 0.2, 0.0));
        }
    }

    #[test]
    fn restated_object_last_wins() {
        let first = r#"{"maneuver": "stop", "acceleration": -1}"#;
        assert_clean(&format!("Draft: {first}\nFinal answer: {GO}"), GO_ACTION);
        assert_clean(&format!("{GO}\nActually: {first}"), act(Maneuver::Stop, -1.0, 0.0));
        // A later object without a maneuver does not displace the answer.
        assert_clean(&format!("{GO}\nUnits: {{\"acceleration\": \"normalised\"}}"), GO_ACTION);
    }

    #[test]
    fn json_leniencies() {
        // Trailing commas, raw newlines in strings, escapes, nested values,
        // unknown keys, case-insensitive keys, null steering.
        let text = "{\"reasoning\": \"line 1\nline \\\"2\\\" {x} \\u00e9\\ud83d\\ude97\",\n \"extra\": {\"a\": [1, {\"b\": null},],},\n \"Maneuver\": \"nudge_forward\", \"ACCELERATION\": 1, \"steering\": null,\n}";
        let p = parse_action(text);
        assert_eq!(p.errors, []);
        assert_eq!(p.action, act(Maneuver::NudgeForward, 1.0, 0.0));
        assert_eq!(p.reasoning.as_deref(), Some("line 1\nline \"2\" {x} é🚗"));
    }

    #[test]
    fn boundaries_are_inclusive_and_duplicates_take_the_last() {
        assert_clean(r#"{"maneuver": "stop", "acceleration": -1.0, "steering": 1e0}"#, act(Maneuver::Stop, -1.0, 1.0));
        assert_clean(r#"{"maneuver": "stop", "maneuver": "yield", "acceleration": 0}"#, act(Maneuver::Yield, 0.0, 0.0));
    }

    #[test]
    fn reasoning_is_kept_even_when_degraded() {
        let p = parse_action(r#"{"reasoning": "why", "maneuver": "fly", "acceleration": 0}"#);
        assert_eq!(p.reasoning.as_deref(), Some("why"));
        assert_eq!(p.action, STOP);
        assert_eq!(parse_action(r#"{"maneuver": "stop", "acceleration": 0}"#).reasoning, None);
    }

    // --- failures -----------------------------------------------------------

    #[test]
    fn empty_reply() {
        assert_degraded("", &[E::Empty]);
        assert_degraded(" \n\t ", &[E::Empty]);
    }

    #[test]
    fn no_json() {
        assert_degraded("I would proceed carefully.", &[E::NoJson]);
        assert_degraded("maneuver: proceed, acceleration: 0.5", &[E::NoJson]);
    }

    #[test]
    fn malformed_json() {
        assert_kind(r#"{"maneuver": proceed, "acceleration": 0.5}"#, "malformed");
        assert_kind(r#"{'maneuver': 'stop', 'acceleration': 0}"#, "malformed");
        assert_kind(r#"{"maneuver": "stop" "acceleration": 0}"#, "malformed");
        let p = parse_action(r#"{"maneuver": "stop", "acceleration": 0.}"#);
        assert_eq!(p.errors, [E::Malformed { detail: "expected a digit at byte 39".into() }]);
    }

    #[test]
    fn truncated_at_a_token_limit() {
        for cut in [10, 30, GO.len() - 1] {
            assert_degraded(&GO[..cut], &[E::Truncated]);
        }
        assert_degraded(r#"{"maneuver": "stop", "acceleration": 0.5, "done": tr"#, &[E::Truncated]);
        // Braces inside the cut-off string are not an answer.
        assert_degraded(r#"{"reasoning": "gap {} ok", "maneuver": "proceed", "acceleration"#, &[E::Truncated]);
    }

    #[test]
    fn unknown_or_missing_maneuver() {
        assert_degraded(
            r#"{"maneuver": "accelerate", "acceleration": 0.5}"#,
            &[E::UnknownManeuver { value: "accelerate".into() }],
        );
        assert_degraded(r#"{"maneuver": 2, "acceleration": 0.5}"#, &[E::UnknownManeuver { value: "2".into() }]);
        assert_degraded(r#"{"acceleration": 0.5, "steering": 0}"#, &[E::MissingManeuver]);
        assert_degraded(r#"{"maneuver": null, "acceleration": 0.5}"#, &[E::MissingManeuver]);
    }

    #[test]
    fn missing_acceleration() {
        assert_degraded(r#"{"maneuver": "proceed"}"#, &[E::MissingAcceleration]);
    }

    #[test]
    fn prose_in_numeric_fields() {
        let acc = NumericField::Acceleration;
        assert_degraded(
            r#"{"maneuver": "proceed", "acceleration": "fast"}"#,
            &[E::NotANumber { field: acc, value: "fast".into() }],
        );
        assert_degraded(
            r#"{"maneuver": "proceed", "acceleration": "0.5 m/s^2"}"#,
            &[E::NotANumber { field: acc, value: "0.5 m/s^2".into() }],
        );
        assert_degraded(
            r#"{"maneuver": "proceed", "acceleration": [0.5]}"#,
            &[E::NotANumber { field: acc, value: "[0.5]".into() }],
        );
        assert_degraded(
            r#"{"maneuver": "proceed", "acceleration": 0.5, "steering": "left"}"#,
            &[E::NotANumber { field: NumericField::Steering, value: "left".into() }],
        );
    }

    #[test]
    fn out_of_range_numbers() {
        let out = |field, value: &str| E::OutOfRange { field, value: value.into() };
        let acc = NumericField::Acceleration;
        for (raw, quoted) in [
            ("3.0", "3.0"),
            ("-1.5", "-1.5"),
            ("1e309", "1e309"),
            ("\"NaN\"", "NaN"),
            ("NaN", "NaN"),
            ("-Infinity", "-Infinity"),
        ] {
            let text = format!(r#"{{"maneuver": "proceed", "acceleration": {raw}}}"#);
            assert_degraded(&text, &[out(acc, quoted)]);
        }
        assert_degraded(
            r#"{"maneuver": "proceed", "acceleration": 0.5, "steering": -2}"#,
            &[out(NumericField::Steering, "-2")],
        );
    }

    #[test]
    fn all_field_errors_are_reported() {
        assert_degraded(
            r#"{"maneuver": "warp", "steering": 9}"#,
            &[
                E::UnknownManeuver { value: "warp".into() },
                E::MissingAcceleration,
                E::OutOfRange { field: NumericField::Steering, value: "9".into() },
            ],
        );
    }

    #[test]
    fn not_an_object() {
        let kind = |k: &str| vec![E::NotAnObject { found: k.into() }];
        assert_degraded(r#"["proceed", 0.5]"#, &kind("array"));
        assert_degraded(r#"[{"maneuver": "proceed", "acceleration": 0.5}]"#, &kind("array"));
        assert_degraded("```json\n[1, 2]\n```", &kind("array"));
        assert_degraded("0.5", &kind("number"));
        assert_degraded(r#""proceed""#, &kind("string"));
        assert_degraded("<think>hmm</think> null", &kind("null"));
    }

    #[test]
    fn long_values_are_clipped_in_errors() {
        let long = "x".repeat(1000);
        let p = parse_action(&format!(r#"{{"maneuver": "{long}", "acceleration": 0}}"#));
        let [E::UnknownManeuver { value }] = p.errors.as_slice() else { panic!("{:?}", p.errors) };
        assert_eq!(value.chars().count(), 65);
    }

    #[test]
    fn deep_nesting_is_an_error_not_a_crash() {
        let deep =
            format!(r#"{{"maneuver": "stop", "acceleration": 0, "x": {}1{}}}"#, "[".repeat(200), "]".repeat(200));
        assert_kind(&deep, "malformed");
        let ok = format!(r#"{{"maneuver": "stop", "acceleration": 0, "x": {}1{}}}"#, "[".repeat(100), "]".repeat(100));
        assert_clean(&ok, act(Maneuver::Stop, 0.0, 0.0));
        let objects = "{\"a\":".repeat(100_000);
        assert_kind(&objects, "malformed");
    }

    #[test]
    fn errors_serialise_with_kind_tags_and_messages() {
        let p = parse_action(r#"{"maneuver": "stop", "acceleration": "lots"}"#);
        let json = serde_json::to_value(&p).unwrap();
        assert_eq!(
            json["errors"][0],
            serde_json::json!({"kind": "not_a_number", "detail": {"field": "acceleration", "value": "lots"}})
        );
        let back: ParsedAction = serde_json::from_value(json).unwrap();
        assert_eq!(back, p);
        assert_eq!(p.errors[0].to_string(), "acceleration is not a number: \"lots\"");
        assert_eq!(serde_json::to_value(E::Truncated).unwrap(), serde_json::json!({"kind": "truncated"}));
        assert_eq!(E::Truncated.to_string(), "the JSON object is cut off before its end");
    }

    #[test]
    fn megabyte_adversarial_inputs_are_fast() {
        const MB: usize = 1 << 20;
        let fill = |pat: &str| pat.repeat(MB / pat.len());
        let inputs = [
            fill("{"),
            // Nesting bombs: every `{` opens a deeper object.
            fill("{\"\":"),
            // Valid JSON prefix both as is and read from the `{` in its string.
            format!("{{\"\":\"{{\"{}", fill(",\":\":\",\"")),
            format!("{{\"reasoning\": \"{}", fill("{\\\"")),
            fill("</think>{"),
            fill("\"["),
            format!("{{\"maneuver\": \"stop\", \"acceleration\": 0.{}}}", "5".repeat(MB)),
        ];
        for text in &inputs {
            let p = parse_action(text);
            assert!(p.is_clean() || p.action == STOP);
            // Deterministic check of the linear bound (timing alone is noisy).
            let work = scan(text).work;
            assert!(work <= 12 * text.len() + FAILED_WORK_SLACK, "work {work} on {:?}…", &text[..8]);
        }
        let big = format!(r#"{{"reasoning": "{}", "maneuver": "yield", "acceleration": -0.3}}"#, fill("{x} "));
        assert_clean(&big, act(Maneuver::Yield, -0.3, 0.0));
    }

    // --- properties -----------------------------------------------------------

    /// Either a clean, in-range action, or CONSERVATIVE with a reason.
    fn check_invariant(p: &ParsedAction) -> Result<(), TestCaseError> {
        if p.is_clean() {
            for v in [p.action.acceleration, p.action.steering] {
                prop_assert!(v.is_finite() && (-1.0..=1.0).contains(&v), "clean action out of range: {:?}", p);
            }
        } else {
            prop_assert_eq!(p.action, STOP);
        }
        Ok(())
    }

    fn fragment() -> impl Strategy<Value = String> {
        prop_oneof![
            prop::sample::select(vec![
                "{",
                "}",
                "\"",
                "\\",
                "\\\"",
                "\\u",
                "<think>",
                "</think>",
                "```",
                "```json\n",
                ":",
                ",",
                "[",
                "]",
                "\"maneuver\"",
                "\"acceleration\"",
                "\"steering\"",
                "\"stop\"",
                "\"proceed\"",
                "0.5",
                "-1",
                "1e309",
                "NaN",
                "null",
                "true",
                " ",
                "\n",
            ])
            .prop_map(String::from),
            any::<String>(),
        ]
    }

    fn valid_object() -> impl Strategy<Value = (String, Action, Option<String>)> {
        (
            prop::sample::select(Maneuver::ALL.to_vec()),
            -1.0f64..=1.0,
            prop::option::of(-1.0f64..=1.0),
            prop::option::of(any::<String>()),
            any::<bool>(),
        )
            .prop_flat_map(|(m, a, s, r, pretty)| {
                let mut entries = vec![
                    format!("\"maneuver\": {}", serde_json::json!(m.name())),
                    format!("\"acceleration\": {}", serde_json::json!(a)),
                ];
                if let Some(s) = s {
                    entries.push(format!("\"steering\": {}", serde_json::json!(s)));
                }
                if let Some(r) = &r {
                    entries.push(format!("\"reasoning\": {}", serde_json::json!(r)));
                }
                let action = act(m, a, s.unwrap_or(0.0));
                Just(entries).prop_shuffle().prop_map(move |entries| {
                    let sep = if pretty { ",\n  " } else { ", " };
                    (format!("{{{}}}", entries.join(sep)), action, r.clone())
                })
            })
    }

    fn prose() -> impl Strategy<Value = String> {
        "[a-zA-Z0-9 .,;:!?'\"()*#}\n-]{0,40}"
    }

    proptest! {
        #[test]
        fn arbitrary_text_never_panics(text in any::<String>()) {
            check_invariant(&parse_action(&text))?;
        }

        #[test]
        fn json_ish_fragments_never_panic(parts in prop::collection::vec(fragment(), 0..40)) {
            check_invariant(&parse_action(&parts.concat()))?;
        }

        #[test]
        fn valid_action_in_any_wrapping_parses_back(
            (object, action, reasoning) in valid_object(),
            (decoy, _, _) in valid_object(),
            before in prose(),
            after in prose(),
            think in prose(),
            think_style in 0..3usize,
            fence in prop::sample::select(vec!["", "```\n", "```json\n"]),
            restated in any::<bool>(),
        ) {
            // Decoys inside think blocks or restated earlier must lose.
            let think = match think_style {
                0 => String::new(),
                1 => format!("<think>{think} {decoy}</think>\n"),
                _ => format!("{think} {decoy}</think>\n"),
            };
            let earlier = if restated { format!("draft: {decoy}\n") } else { String::new() };
            let close = if fence.is_empty() { "" } else { "\n```" };
            let text = format!("{think}{before}\n{earlier}{fence}{object}{close}\n{after}");
            let p = parse_action(&text);
            prop_assert_eq!(&p.errors, &vec![], "{}", text);
            prop_assert_eq!(p.action, action);
            prop_assert_eq!(p.action.acceleration.to_bits(), action.acceleration.to_bits());
            prop_assert_eq!(p.reasoning, reasoning);
        }

        #[test]
        fn one_character_mutation_never_panics(
            (object, _, _) in valid_object(),
            op in 0..3usize,
            at in any::<prop::sample::Index>(),
            c in any::<char>(),
        ) {
            let mut chars: Vec<char> = object.chars().collect();
            let i = at.index(chars.len());
            match op {
                0 => { chars.remove(i); }
                1 => chars.insert(i, c),
                _ => chars[i] = c,
            }
            let text: String = chars.into_iter().collect();
            check_invariant(&parse_action(&text))?;
        }

        #[test]
        fn belief_reads_back_and_never_changes_the_action(
            (object, action, _) in valid_object(),
            belief in 0.0f64..=1.0,
            quoted in any::<bool>(),
            before in prose(),
        ) {
            let value = if quoted { format!("\"{belief}\"") } else { serde_json::json!(belief).to_string() };
            let with_belief = format!("{before}\n{}, \"belief\": {value}}}", object.trim_end_matches('}'));
            prop_assert_eq!(parse_belief(&with_belief).map(f64::to_bits), Ok(belief.to_bits()), "{}", with_belief);
            let p = parse_action(&with_belief);
            prop_assert_eq!(p.action, action);
            prop_assert_eq!(&p.errors, &vec![]);
            prop_assert_eq!(parse_belief(&object), Err(BeliefParseError::Missing));
        }

        #[test]
        fn belief_parsing_never_panics(text in any::<String>(), parts in prop::collection::vec(fragment(), 0..30)) {
            let _ = parse_belief(&text);
            let _ = parse_belief(&parts.concat());
        }
    }

    #[test]
    fn malformed_beliefs_are_named() {
        let with = |b: &str| format!("{{\"maneuver\": \"stop\", \"acceleration\": 0.5, \"belief\": {b}}}");
        assert_eq!(parse_belief(&with("0.25")), Ok(0.25));
        assert_eq!(parse_belief(&with("\" 1 \"")), Ok(1.0));
        assert_eq!(parse_belief(&with("1.5")), Err(BeliefParseError::OutOfRange { value: "1.5".into() }));
        assert_eq!(parse_belief(&with("-0.1")), Err(BeliefParseError::OutOfRange { value: "-0.1".into() }));
        assert_eq!(parse_belief(&with("NaN")), Err(BeliefParseError::OutOfRange { value: "NaN".into() }));
        assert_eq!(parse_belief(&with("\"likely\"")), Err(BeliefParseError::NotANumber { value: "likely".into() }));
        assert_eq!(parse_belief(&with("null")), Err(BeliefParseError::Missing));
        assert_eq!(parse_belief("I think it will stop"), Err(BeliefParseError::NoAnswer));
        assert_eq!(parse_belief("[0.5]"), Err(BeliefParseError::NoAnswer));
        // The action's object is the one read: a belief in a think block or
        // an earlier draft does not count.
        let drafted = format!("<think>{}</think> {{\"maneuver\": \"stop\", \"acceleration\": 0}}", with("0.9"));
        assert_eq!(parse_belief(&drafted), Err(BeliefParseError::Missing));
    }
}
