//! What a client sends, checked once for every transport. HTTP, WebSocket
//! and the session read a message the same way: a JSON object, whose field
//! names are checked against the ones its kind takes, then its parts
//! (a reset's fields, a step's action) by the session. An error is built
//! where the problem is found, relative to the part being read, and located
//! in the message by the transport that knows where that part sits
//! ([`located`]: `["body", ...]` over HTTP, `["data", ...]` over WebSocket).
//!
//! Errors are shaped like the validation errors OpenEnv's own server
//! returns (pydantic's), and bounded: a few listed, the rest counted, and
//! nothing echoed of the client's input longer than [`MAX_ECHO_BYTES`].

use serde::Serialize;
use serde_json::{Map, Value};

/// One problem with a message's fields: where, what, and a kind.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub(crate) struct FieldError {
    #[serde(rename = "type")]
    pub kind: &'static str,
    pub loc: Vec<String>,
    pub msg: String,
}

impl FieldError {
    /// A problem with `field` of the part being read.
    pub(crate) fn new(kind: &'static str, field: &str, msg: impl Into<String>) -> FieldError {
        FieldError { kind, loc: vec![clip(field).into_owned()], msg: clip(&msg.into()).into_owned() }
    }

    /// A problem with the part as a whole (not an object, too many errors).
    pub(crate) fn whole(kind: &'static str, msg: impl Into<String>) -> FieldError {
        FieldError { kind, loc: Vec::new(), msg: clip(&msg.into()).into_owned() }
    }

    /// A required field is absent.
    pub(crate) fn missing(field: &str) -> FieldError {
        FieldError::new("missing", field, "Field required")
    }

    /// A field the part does not take, with the ones it does.
    pub(crate) fn unknown(field: &str, expected: &[&str]) -> FieldError {
        FieldError::new("extra_forbidden", field, format!("unknown field (expected {})", expected.join(", ")))
    }
}

/// Errors found in a part that sits at `at` in its message (`["body"]`,
/// `["data"]`, `["body", "action"]`), located from the message's root.
pub(crate) fn located(errors: Vec<FieldError>, at: &[&str]) -> Vec<FieldError> {
    errors
        .into_iter()
        .map(|mut e| {
            e.loc.splice(0..0, at.iter().map(|s| s.to_string()));
            e
        })
        .collect()
}

/// At most this many field errors are listed in one reply; the rest are
/// counted. An error reply never grows with the request that caused it.
pub(crate) const MAX_LISTED_ERRORS: usize = 5;
/// A field name or message echoed in an error is cut to this many bytes.
pub(crate) const MAX_ECHO_BYTES: usize = 160;

/// `text` cut to [`MAX_ECHO_BYTES`] (at a character boundary, marked by
/// "..."): what an error may echo of a client's input.
pub(crate) fn clip(text: &str) -> std::borrow::Cow<'_, str> {
    if text.len() <= MAX_ECHO_BYTES {
        return text.into();
    }
    let mut end = MAX_ECHO_BYTES;
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    format!("{}...", &text[..end]).into()
}

/// The field errors of one request: the first [`MAX_LISTED_ERRORS`] listed,
/// the others only counted (so a body of 100,000 unknown keys costs a
/// counter, not a list), then one entry that says how many were left out.
#[derive(Debug, Default)]
pub(crate) struct FieldErrors {
    listed: Vec<FieldError>,
    omitted: usize,
}

impl FieldErrors {
    pub(crate) fn push(&mut self, error: impl FnOnce() -> FieldError) {
        if self.listed.len() < MAX_LISTED_ERRORS {
            self.listed.push(error());
        } else {
            self.omitted += 1;
        }
    }

    pub(crate) fn is_empty(&self) -> bool {
        self.listed.is_empty()
    }

    pub(crate) fn into_list(mut self) -> Vec<FieldError> {
        if self.omitted > 0 {
            self.listed.push(FieldError::whole("too_many_errors", format!("{} more errors not listed", self.omitted)));
        }
        self.listed
    }

    /// `Ok(value)` if nothing was found, else the list.
    pub(crate) fn or<T>(self, value: T) -> Result<T, Vec<FieldError>> {
        if self.is_empty() { Ok(value) } else { Err(self.into_list()) }
    }
}

/// A JSON value as the object a part must be; `expected` says what it holds.
pub(crate) fn object<'a>(value: &'a Value, expected: &str) -> Result<&'a Map<String, Value>, FieldError> {
    value.as_object().ok_or_else(|| not_an_object(expected))
}

/// [`object`], taking the value (a request body is read once, not copied).
pub(crate) fn into_object(value: Value, expected: &str) -> Result<Map<String, Value>, FieldError> {
    match value {
        Value::Object(map) => Ok(map),
        _ => Err(not_an_object(expected)),
    }
}

fn not_an_object(expected: &str) -> FieldError {
    FieldError::whole("dict_type", format!("expected {expected}"))
}

/// The field names of one kind of message or part: the ones it must carry,
/// and the ones it may.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Names {
    pub required: &'static [&'static str],
    pub optional: &'static [&'static str],
}

impl Names {
    /// Every required name present and none but these; the fields' values
    /// are the reader's to check.
    pub(crate) fn check(&self, fields: &Map<String, Value>) -> Result<(), Vec<FieldError>> {
        let mut errors = FieldErrors::default();
        for name in self.required.iter().filter(|n| !fields.contains_key(**n)) {
            errors.push(|| FieldError::missing(name));
        }
        let known = |k: &str| self.required.contains(&k) || self.optional.contains(&k);
        for key in fields.keys().filter(|k| !known(k)) {
            errors.push(|| FieldError::unknown(key, &[self.required, self.optional].concat()));
        }
        errors.or(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    const STEP: Names = Names { required: &["action", "episode_id"], optional: &["timeout_s"] };

    #[test]
    fn names_are_checked_in_one_wording() {
        let fields = |v: Value| v.as_object().unwrap().clone();
        assert_eq!(STEP.check(&fields(json!({"action": {}, "episode_id": "e", "timeout_s": 1}))), Ok(()));
        let errors = STEP.check(&fields(json!({"action": {}, "extra": 1}))).unwrap_err();
        assert_eq!(
            errors,
            [
                FieldError::missing("episode_id"),
                FieldError::new("extra_forbidden", "extra", "unknown field (expected action, episode_id, timeout_s)"),
            ]
        );
    }

    #[test]
    fn errors_are_located_where_their_part_sits() {
        let errors = vec![FieldError::missing("tier"), FieldError::whole("dict_type", "expected an object")];
        let at = located(errors, &["body", "action"]);
        assert_eq!(at[0].loc, ["body", "action", "tier"]);
        assert_eq!(at[1].loc, ["body", "action"]);
    }

    #[test]
    fn a_long_field_name_is_clipped_and_many_errors_are_counted() {
        let mut errors = FieldErrors::default();
        for i in 0..100 {
            errors.push(|| FieldError::unknown(&format!("{i}{}", "k".repeat(1000)), &["a"]));
        }
        let list = errors.into_list();
        assert_eq!(list.len(), MAX_LISTED_ERRORS + 1);
        assert!(list.iter().all(|e| e.loc.iter().all(|l| l.len() <= MAX_ECHO_BYTES + 3)));
        assert_eq!(list.last().unwrap().msg, "95 more errors not listed");
    }
}
