//! What a person types, read into the reply a model would send.
//!
//! Rules (the same at the terminal and in line mode):
//! - a maneuver key: `p` proceed, `n` nudge forward, `y` yield, `s` stop;
//! - a strength digit `0`-`9`: the strength (|acceleration|) is the digit
//!   over 9, so `0` is 0 and `9` is 1 (arrow keys at the terminal step it
//!   by 0.1); a maneuver without a digit keeps the last strength;
//! - in line mode one line is a maneuver key or name followed by an
//!   optional digit or number in [0, 1] (`p9`, `y 3`, `proceed 0.8`);
//! - anything starting with `{` is a JSON action, sent as typed: the
//!   benchmark's protective parser reads it exactly as it reads a model's
//!   reply (a malformed one is a parse error and a firm stop).
//!
//! The reply is always the JSON a model would answer, so `eval`'s parser,
//! records and graders treat a person and a model alike.

use crate::action::{Action, Maneuver};

/// The answer being composed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Draft {
    pub maneuver: Maneuver,
    pub strength: f64,
}

impl Default for Draft {
    fn default() -> Draft {
        Draft { maneuver: Maneuver::Proceed, strength: 0.5 }
    }
}

impl Draft {
    /// The reply text: the action as the JSON object the model answers.
    pub fn reply(&self) -> String {
        let a = Action::new(self.maneuver, round2(self.strength));
        format!(r#"{{"maneuver": "{}", "acceleration": {}}}"#, a.maneuver.name(), a.acceleration)
    }

    pub fn adjust(&mut self, delta: f64) {
        self.strength = round2((self.strength + delta).clamp(0.0, 1.0));
    }
}

fn round2(x: f64) -> f64 {
    (x * 100.0).round() / 100.0
}

/// A maneuver key.
pub(crate) fn maneuver_key(c: char) -> Option<Maneuver> {
    match c.to_ascii_lowercase() {
        'p' => Some(Maneuver::Proceed),
        'n' => Some(Maneuver::NudgeForward),
        'y' => Some(Maneuver::Yield),
        's' => Some(Maneuver::Stop),
        _ => None,
    }
}

/// A strength digit.
pub(crate) fn strength_key(c: char) -> Option<f64> {
    c.to_digit(10).map(|d| round2(d as f64 / 9.0))
}

/// One line of line mode, read into the reply to send; `last` is the
/// draft so far (its strength is kept when the line gives none). `None`
/// for a line that is not an answer (the caller says so and asks again).
pub(crate) fn read_line(line: &str, last: &mut Draft) -> Option<String> {
    let line = line.trim();
    if line.starts_with('{') {
        return Some(line.to_string());
    }
    let (word, rest) = match line.find(|c: char| c.is_ascii_digit() || c.is_whitespace()) {
        Some(i) => (&line[..i], line[i..].trim()),
        None => (line, ""),
    };
    let maneuver =
        if word.chars().count() == 1 { maneuver_key(word.chars().next()?)? } else { Maneuver::from_loose(word)? };
    let strength = match rest {
        "" => last.strength,
        d if d.len() == 1 => strength_key(d.chars().next()?)?,
        x => x.parse::<f64>().ok().filter(|v| (0.0..=1.0).contains(v))?,
    };
    *last = Draft { maneuver, strength };
    Some(last.reply())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::action::parse_action;
    use proptest::prelude::*;

    #[test]
    fn keys_and_lines_read_as_the_model_would_answer() {
        let mut d = Draft::default();
        assert_eq!(read_line("p9", &mut d).as_deref(), Some(r#"{"maneuver": "proceed", "acceleration": 1}"#));
        assert_eq!(read_line("y 3", &mut d).map(|r| parse_action(&r).action), Some(Action::new(Maneuver::Yield, 0.33)));
        assert_eq!(read_line("stop", &mut d).map(|r| parse_action(&r).action), Some(Action::new(Maneuver::Stop, 0.33)));
        assert_eq!(
            read_line("nudge_forward 0.5", &mut d).map(|r| parse_action(&r).action),
            Some(Action::new(Maneuver::NudgeForward, 0.5))
        );
        assert_eq!(read_line(r#"{"maneuver": "fly"}"#, &mut d).as_deref(), Some(r#"{"maneuver": "fly"}"#));
        for bad in ["", "q", "x9", "p 1.5", "p nine", "proceed 12"] {
            assert_eq!(read_line(bad, &mut d), None, "{bad}");
        }
    }

    proptest! {
        /// Every draft's reply is read back, cleanly, as that very action.
        #[test]
        fn every_draft_parses_back_to_itself(m in 0usize..4, s in 0.0f64..=1.0) {
            let d = Draft { maneuver: Maneuver::ALL[m], strength: round2(s) };
            let parsed = parse_action(&d.reply());
            prop_assert!(parsed.is_clean());
            prop_assert_eq!(parsed.action, Action::new(d.maneuver, d.strength));
        }

        /// No line panics the reader.
        #[test]
        fn no_line_panics(line in ".{0,40}") {
            let _ = read_line(&line, &mut Draft::default());
        }
    }
}
