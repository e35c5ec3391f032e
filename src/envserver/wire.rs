//! The bytes of the server's observations: serde_json's compact output,
//! byte for byte, written faster where a step's answer spends its time.
//!
//! A full observation is ~2 KB of JSON holding ~80 numbers and a ~1 KB
//! scene text, and the profile of `env-server` at 64 sessions put
//! serde_json's float formatting (zmij's shortest round trip) and its
//! string escaping (one table lookup per byte) near the top of the
//! server's own time. Two shortcuts, each falling back to serde_json:
//!
//! - **Numbers.** Every number an observation carries is rounded to the
//!   printed precision (one or two decimals) or is a whole number. For a
//!   double `v` equal to `k / 10^d` with `d <= 2` and `|v| < 10^9`, the
//!   shortest decimal that reads back as `v` is `k`'s digits with the point
//!   `d` places in (no shorter string lies within `v`'s rounding interval,
//!   which is far narrower than 0.01 there), so it is written from the
//!   integer `k`. Anything else (zero's sign, larger magnitudes, more
//!   decimals) takes serde_json's own formatter.
//! - **Text.** The scene and the instructions are escaped eight bytes at a
//!   time (a word holding no `"`, `\` or control byte is copied whole) into
//!   a [`RawValue`], which serde_json writes verbatim.
//!
//! Property tests hold both to serde_json's output on arbitrary input.

use crate::observation::fixed_point;
use serde::{Serialize, Serializer};
use serde_json::ser::{CompactFormatter, Formatter};
use serde_json::value::RawValue;
use std::io;

/// `value` as compact JSON, as `serde_json::to_string` writes it.
/// `capacity` is a guess at its length, so that the buffer is not grown
/// and copied several times per answer.
pub(crate) fn to_json<T: Serialize>(value: &T, capacity: usize) -> String {
    let mut out = Vec::with_capacity(capacity);
    let mut serializer = serde_json::Serializer::with_formatter(&mut out, Decimals);
    value.serialize(&mut serializer).expect("an answer serialises");
    String::from_utf8(out).expect("serde_json writes UTF-8")
}

/// serde_json's compact formatter, with numbers of at most two decimals
/// written from their integer (see the module doc).
struct Decimals;

impl Formatter for Decimals {
    fn write_f64<W: ?Sized + io::Write>(&mut self, writer: &mut W, value: f64) -> io::Result<()> {
        match short_decimal(value, &mut [0; 24]) {
            Some(text) => writer.write_all(text.as_bytes()),
            None => CompactFormatter.write_f64(writer, value),
        }
    }
}

/// `value`'s shortest round-trip decimal when it has at most two decimals
/// and `0 < |value| < 10^9` or `value` is +0; None otherwise.
fn short_decimal(value: f64, buffer: &mut [u8; 24]) -> Option<&str> {
    if value.is_nan() || value.abs() >= 1e9 || (value == 0.0 && value.is_sign_negative()) {
        return None;
    }
    // One decimal first: whole numbers pass it too (and are written
    // "k.0", as serde_json writes them), so most numbers take one division.
    let (k, decimals) = [(10.0, 1), (100.0, 2)].into_iter().find_map(|(scale, decimals)| {
        // The nearest whole number by truncation (`f64::round` is a libm
        // call here): any k passing the check below is the right one, and a
        // wrong guess only sends the value on to the next scale.
        let scaled = value * scale;
        let k = (scaled + 0.5f64.copysign(scaled)) as i64 as f64;
        (k / scale == value).then_some((k, decimals))
    })?;
    Some(fixed_point(k as i64, decimals, buffer))
}

/// `#[serde(serialize_with)]` for an optional long text: escaped a word at
/// a time and written verbatim (the JSON is the same string literal
/// serde_json writes).
pub(crate) fn text<S: Serializer>(value: &Option<String>, serializer: S) -> Result<S::Ok, S::Error> {
    match value {
        Some(text) => {
            let literal = RawValue::from_string(string_literal(text)).map_err(serde::ser::Error::custom)?;
            literal.serialize(serializer)
        }
        None => serializer.serialize_none(),
    }
}

/// The JSON string literal of `text`, quotes included, escaped as
/// serde_json escapes (`\"`, `\\`, `\b`, `\f`, `\n`, `\r`, `\t`, and
/// `\u00xx` for the other control bytes; nothing else).
fn string_literal(text: &str) -> String {
    const ONES: u64 = u64::MAX / 255;
    const HIGH: u64 = ONES * 0x80;
    // Whether any byte of `word` is below 0x20, a quote or a backslash:
    // Mycroft's test for a byte below n (exact for n <= 0x80), on the word
    // for 0x20 and on two xors of it for a zero byte, without branches.
    let below = |word: u64, n: u64| word.wrapping_sub(ONES * n) & !word;
    let special = |word: u64| {
        let quote = word ^ (ONES * u64::from(b'"'));
        let backslash = word ^ (ONES * u64::from(b'\\'));
        (below(word, 0x20) | below(quote, 1) | below(backslash, 1)) & HIGH != 0
    };
    let bytes = text.as_bytes();
    let mut out = String::with_capacity(bytes.len() + bytes.len() / 16 + 2);
    out.push('"');
    let mut run = 0; // start of the bytes not yet copied
    let mut at = 0;
    while at < bytes.len() {
        if let Some(word) = bytes.get(at..at + 8)
            && !special(u64::from_le_bytes(word.try_into().expect("eight bytes")))
        {
            at += 8;
            continue;
        }
        let end = (at + 8).min(bytes.len());
        for i in at..end {
            if let Some(escape) = escape(bytes[i]) {
                out.push_str(&text[run..i]);
                out.push_str(&escape);
                run = i + 1;
            }
        }
        at = end;
    }
    out.push_str(&text[run..]);
    out.push('"');
    out
}

/// serde_json's escape for one byte, if it has one.
fn escape(byte: u8) -> Option<std::borrow::Cow<'static, str>> {
    Some(match byte {
        b'"' => "\\\"".into(),
        b'\\' => "\\\\".into(),
        0x08 => "\\b".into(),
        0x0c => "\\f".into(),
        b'\n' => "\\n".into(),
        b'\r' => "\\r".into(),
        b'\t' => "\\t".into(),
        0x00..0x20 => format!("\\u{byte:04x}").into(),
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[derive(Serialize)]
    struct Texted {
        #[serde(serialize_with = "text")]
        text: Option<String>,
    }

    fn fast(value: f64) -> String {
        to_json(&value, 0)
    }

    #[test]
    fn numbers_are_written_as_serde_json_writes_them_at_the_edges() {
        let edges = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.1,
            -0.1,
            0.01,
            0.05,
            0.29,
            1.005,
            2.675,
            13.3,
            24.0,
            0.5,
            1e-5,
            1.5e-5,
            999_999_999.99,
            1e9,
            -1e9,
            1e15,
            1e16,
            1e17,
            1e300,
            5e-324,
            f64::MAX,
            f64::MIN_POSITIVE,
        ];
        for x in edges {
            assert_eq!(fast(x), serde_json::to_string(&x).unwrap(), "{x:e}");
        }
        assert_eq!(fast(f64::NAN), "null");
        assert_eq!(fast(f64::INFINITY), "null");
    }

    #[test]
    fn the_short_path_is_taken_for_rounded_numbers() {
        let mut buffer = [0; 24];
        for x in [0.0, 13.3, -4.25, 24.0, 123_456_789.12] {
            assert!(short_decimal(x, &mut buffer).is_some(), "{x}");
        }
        for x in [-0.0, 0.125, 1e9, 1e-5] {
            assert!(short_decimal(x, &mut buffer).is_none(), "{x}");
        }
    }

    #[test]
    fn texts_are_escaped_as_serde_json_escapes_them() {
        let all_bytes: String = (0u8..0x80).map(char::from).collect();
        for t in ["", "a", "\"", "\\", "12345678", "1234567\n", "\u{1f}\u{7f}é\u{2028}", &all_bytes] {
            let ours = serde_json::to_string(&Texted { text: Some(t.to_string()) }).unwrap();
            assert_eq!(ours, serde_json::json!({"text": t}).to_string(), "{t:?}");
        }
    }

    proptest! {
        #[test]
        fn rounded_numbers_are_written_as_serde_json_writes_them(k in -100_000_000_000i64..100_000_000_000, d in 0i32..=3) {
            let x = k as f64 / 10f64.powi(d);
            prop_assert_eq!(fast(x), serde_json::to_string(&x).unwrap());
        }

        #[test]
        fn any_double_is_written_as_serde_json_writes_it(bits in any::<u64>()) {
            let x = f64::from_bits(bits);
            prop_assert_eq!(fast(x), serde_json::to_string(&x).unwrap());
        }

        #[test]
        fn any_text_is_escaped_as_serde_json_escapes_it(t in "[\\x00-\\x7f\u{80}-\u{10ffff}]{0,80}") {
            let ours = serde_json::to_string(&Texted { text: Some(t.clone()) }).unwrap();
            prop_assert_eq!(ours, serde_json::json!({"text": t}).to_string());
        }

        #[test]
        fn any_text_with_specials_is_escaped_as_serde_json_escapes_it(t in "[a-z \"\\\\\n\t\x01\x1f]{0,40}") {
            let ours = serde_json::to_string(&Texted { text: Some(t.clone()) }).unwrap();
            prop_assert_eq!(ours, serde_json::json!({"text": t}).to_string());
        }
    }
}
