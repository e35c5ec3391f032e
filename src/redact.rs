//! The one choke point for secrets: every string that leaves the process
//! (terminal lines, `errors.jsonl`, `rollouts.jsonl`, `run.json`, summaries,
//! report files) goes through [`scrub`] first.
//!
//! What is removed, replaced by `[REDACTED]`:
//! - every registered secret value (the API key, header values, URL
//!   userinfo), wherever it appears;
//! - partial echoes of a registered secret of at least 12 characters: any
//!   token (a run of characters that are not whitespace, quotes, commas or
//!   backslashes) starting with the secret's first 8 characters. Providers
//!   print keys as `sk-proj-****abcd` or `sk-proj-...abcd`; such a token
//!   starts with the key's prefix. Over-redacting another key of the same
//!   provider is the safe side;
//! - any `Bearer <token>` (case-insensitive), registered or not;
//! - URL userinfo: `scheme://user:password@host` becomes
//!   `scheme://[REDACTED]@host`.
//!
//! Secrets are registered process-wide (the CLI registers them once, before
//! anything is sent or written), so that deep code paths (a writer thread,
//! an error built from an endpoint's body) need no handle to scrub.

use std::borrow::Cow;
use std::sync::RwLock;

pub const MASK: &str = "[REDACTED]";

/// Shortest secret scrubbed by value: shorter strings (a one-letter user
/// name) would mangle unrelated text without protecting anything.
const MIN_SECRET: usize = 4;
/// Secrets at least this long also have their prefix echoes scrubbed.
const MIN_PREFIX_SECRET: usize = 12;
const PREFIX: usize = 8;

static SECRETS: RwLock<Vec<String>> = RwLock::new(Vec::new());

/// Register a secret value to be scrubbed from everything written from now
/// on. Blank and very short values are ignored.
pub fn register_secret(value: &str) {
    let v = value.trim();
    if v.len() < MIN_SECRET {
        return;
    }
    let mut s = SECRETS.write().unwrap_or_else(|e| e.into_inner());
    if !s.iter().any(|x| x == v) {
        s.push(v.to_string());
        // Longest first, so a secret containing another is removed whole.
        s.sort_by_key(|x| std::cmp::Reverse(x.len()));
    }
}

/// Register the userinfo (user name and password) of a URL, if any.
pub fn register_url_userinfo(url: &str) {
    if let Ok(u) = reqwest::Url::parse(url) {
        register_secret(u.username());
        if let Some(p) = u.password() {
            register_secret(p);
        }
    }
}

/// `text` with every secret removed (see the module documentation).
pub fn scrub(text: &str) -> Cow<'_, str> {
    let secrets = SECRETS.read().unwrap_or_else(|e| e.into_inner());
    scrub_with(text, &secrets)
}

/// [`scrub`] for bytes. Bytes that are not UTF-8 are left untouched unless
/// their lossy decoding holds a secret, in which case the scrubbed lossy
/// text is returned.
pub fn scrub_bytes(bytes: &[u8]) -> Cow<'_, [u8]> {
    match std::str::from_utf8(bytes) {
        Ok(s) => match scrub(s) {
            Cow::Borrowed(_) => Cow::Borrowed(bytes),
            Cow::Owned(o) => Cow::Owned(o.into_bytes()),
        },
        Err(_) => match scrub(&String::from_utf8_lossy(bytes)) {
            Cow::Owned(o) => Cow::Owned(o.into_bytes()),
            Cow::Borrowed(_) => Cow::Borrowed(bytes),
        },
    }
}

/// The URL with its userinfo removed (for run.json and the config hash).
pub fn url_without_userinfo(url: &str) -> String {
    match reqwest::Url::parse(url) {
        Ok(mut u) => {
            let _ = u.set_username("");
            let _ = u.set_password(None);
            u.as_str().trim_end_matches('/').to_string()
        }
        Err(_) => strip_userinfo(url).into_owned(),
    }
}

fn is_token_char(c: char) -> bool {
    !(c.is_whitespace() || matches!(c, '"' | '\'' | ',' | '\\' | '<' | '>' | '`'))
}

/// Scrub against an explicit secret list (the global one in production).
pub fn scrub_with<'a>(text: &'a str, secrets: &[String]) -> Cow<'a, str> {
    let mut out: Cow<'a, str> = Cow::Borrowed(text);
    for s in secrets {
        if s.len() >= MIN_SECRET && out.contains(s.as_str()) {
            out = Cow::Owned(out.replace(s.as_str(), MASK));
        }
        if s.len() >= MIN_PREFIX_SECRET {
            let prefix = &s[..s.char_indices().nth(PREFIX).map_or(s.len(), |(i, _)| i)];
            if out.contains(prefix) {
                out = Cow::Owned(mask_tokens_starting_with(&out, prefix));
            }
        }
    }
    if contains_ignore_case(&out, "bearer ") {
        out = Cow::Owned(mask_bearer(&out));
    }
    if out.contains("://")
        && out.contains('@')
        && let Cow::Owned(o) = strip_userinfo(&out)
    {
        out = Cow::Owned(o);
    }
    out
}

fn contains_ignore_case(text: &str, needle: &str) -> bool {
    text.as_bytes().windows(needle.len()).any(|w| w.eq_ignore_ascii_case(needle.as_bytes()))
}

/// Replace each token that starts with `prefix` by the mask.
fn mask_tokens_starting_with(text: &str, prefix: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(i) = rest.find(prefix) {
        // Extend back to the token's start and forward to its end.
        let start = rest[..i].char_indices().rev().take_while(|(_, c)| is_token_char(*c)).last().map_or(i, |(j, _)| j);
        let end = i + rest[i..].char_indices().find(|(_, c)| !is_token_char(*c)).map_or(rest.len() - i, |(j, _)| j);
        out.push_str(&rest[..start]);
        out.push_str(MASK);
        rest = &rest[end..];
    }
    out.push_str(rest);
    out
}

/// `Bearer <token>` -> `Bearer [REDACTED]`, whatever the case of "Bearer".
fn mask_bearer(text: &str) -> String {
    let lower = text.to_ascii_lowercase();
    let mut out = String::with_capacity(text.len());
    let mut at = 0;
    while let Some(i) = lower[at..].find("bearer ") {
        let word_start = at + i;
        let mut token_start = word_start + "bearer ".len();
        while text[token_start..].starts_with(' ') {
            token_start += 1;
        }
        let token_len = text[token_start..]
            .char_indices()
            .find(|(_, c)| !is_token_char(*c))
            .map_or(text.len() - token_start, |(j, _)| j);
        out.push_str(&text[at..token_start]);
        if token_len > 0 {
            out.push_str(MASK);
        }
        at = token_start + token_len;
    }
    out.push_str(&text[at..]);
    out
}

/// `scheme://user:pass@host` -> `scheme://[REDACTED]@host`, for every URL in
/// the text.
fn strip_userinfo(text: &str) -> Cow<'_, str> {
    let mut out = String::new();
    let mut at = 0;
    let mut changed = false;
    while let Some(i) = text[at..].find("://") {
        let auth_start = at + i + 3;
        // The authority ends at the first '/', '?', '#' or non-token char.
        let auth_len = text[auth_start..]
            .char_indices()
            .find(|(_, c)| !is_token_char(*c) || matches!(c, '/' | '?' | '#'))
            .map_or(text.len() - auth_start, |(j, _)| j);
        let authority = &text[auth_start..auth_start + auth_len];
        out.push_str(&text[at..auth_start]);
        match authority.rfind('@') {
            Some(k) if !authority[..k].is_empty() && authority[..k] != *MASK => {
                out.push_str(MASK);
                out.push_str(&authority[k..]);
                changed = true;
            }
            _ => out.push_str(authority),
        }
        at = auth_start + auth_len;
    }
    if !changed {
        return Cow::Borrowed(text);
    }
    out.push_str(&text[at..]);
    Cow::Owned(out)
}

/// `eprintln!` through [`term::err_line`]: scrubbed, and silent on a
/// closed stderr.
macro_rules! eline {
    ($($arg:tt)*) => { $crate::redact::term::err_line(&format!($($arg)*)) };
}
pub(crate) use eline;

/// Terminal output that never panics and never leaks: each line is
/// scrubbed, and a closed stream (`eval ... 2>&1 | head -3`) is ignored
/// instead of aborting the run with a panic, so run.json is still
/// finalized.
pub mod term {
    use std::io::Write;

    /// One line on stderr.
    pub fn err_line(line: &str) {
        let mut e = std::io::stderr().lock();
        let _ = writeln!(e, "{}", super::scrub(line));
    }

    /// Text on stdout (already line-terminated by the caller).
    pub fn out(text: &str) {
        let _ = write_out(text);
    }

    /// Text on stdout, scrubbed, with the write's error returned: for a
    /// command whose output is its result (`baselines`, `validate`,
    /// `report`), so that a closed pipe ends it quietly (see
    /// `cli::is_broken_pipe`) instead of computing on.
    pub fn write_out(text: &str) -> std::io::Result<()> {
        let mut o = std::io::stdout().lock();
        o.write_all(super::scrub(text).as_bytes())?;
        o.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn s(v: &[&str]) -> Vec<String> {
        v.iter().map(|x| x.to_string()).collect()
    }

    #[test]
    fn the_key_and_its_partial_echoes_are_removed() {
        let key = "sk-proj-abcdefghijklmnopqrstuvwxyz0123456789";
        let secrets = s(&[key]);
        let cases = [
            (format!("Incorrect API key provided: {key}."), "Incorrect API key provided: [REDACTED]."),
            (
                "Incorrect API key provided: sk-proj-********************6789. See".to_string(),
                "Incorrect API key provided: [REDACTED] See",
            ),
            ("key sk-proj-...6789 invalid".to_string(), "key [REDACTED] invalid"),
            (format!("{{\"error\":\"bad key {key}\"}}"), "{\"error\":\"bad key [REDACTED]\"}"),
            ("nothing secret here".to_string(), "nothing secret here"),
        ];
        for (input, want) in cases {
            assert_eq!(scrub_with(&input, &secrets), want, "{input}");
        }
    }

    #[test]
    fn bearer_tokens_and_userinfo_are_removed_without_registration() {
        assert_eq!(scrub_with("Authorization: Bearer abc.def-123", &[]), "Authorization: Bearer [REDACTED]");
        assert_eq!(scrub_with("\"authorization\":\"bearer xyz\"", &[]), "\"authorization\":\"bearer [REDACTED]\"");
        assert_eq!(
            scrub_with("POST http://user:pw@10.0.0.1:8000/v1/chat failed", &[]),
            "POST http://[REDACTED]@10.0.0.1:8000/v1/chat failed"
        );
        assert_eq!(
            scrub_with("mail me at a@b.c, see https://x.org/a@b", &[]),
            "mail me at a@b.c, see https://x.org/a@b"
        );
        assert_eq!(url_without_userinfo("http://u:p@h:1/v1/"), "http://h:1/v1");
        assert_eq!(url_without_userinfo("https://api.openai.com/v1"), "https://api.openai.com/v1");
    }

    #[test]
    fn short_secrets_are_only_removed_by_value() {
        assert_eq!(scrub_with("user bob and bobby", &s(&["bob"])), "user bob and bobby", "below the minimum");
        assert_eq!(scrub_with("pw hunter22 hunter", &s(&["hunter22"])), "pw [REDACTED] hunter");
    }

    proptest! {
        #[test]
        fn a_registered_key_never_survives(
            key in "[A-Za-z0-9_-]{12,60}",
            before in "[ -~]{0,40}",
            after in "[ -~]{0,40}",
        ) {
            let text = format!("{before}{key}{after}");
            let out = scrub_with(&text, std::slice::from_ref(&key)).into_owned();
            prop_assert!(!out.contains(&key), "{out}");
            prop_assert!(!out.contains(&key[..8]), "{out}");
        }

        #[test]
        fn text_without_secrets_is_unchanged(text in "[a-z ,.:]{0,80}") {
            prop_assert_eq!(scrub_with(&text, &s(&["sk-secret-value-1234"])), text.as_str());
        }
    }
}
