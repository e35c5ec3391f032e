//! Aligned columns for the terminal: the title, the headers, a rule, the
//! rows, then the notes. Widths count characters, not bytes.

use super::{Exporter, Table};

/// Terminal width the tables aim for.
pub(crate) const TERMINAL_COLUMNS: usize = 100;

/// Model names are shortened (in the middle, `…`) to no fewer characters
/// than this (the reference rows' "always_proceed floor" stays whole).
const MIN_NAME: usize = 20;

/// Shorten the model-name columns (keys `model`, `a`, `b`) in the middle
/// until the table fits [`TERMINAL_COLUMNS`] (or the names reach
/// [`MIN_NAME`] characters); a trailing incomplete mark is kept.
fn fit_names(table: &Table, rows: &mut [Vec<String>], widths: &mut [usize]) {
    let shown: Vec<usize> = table.shown().map(|(i, _)| i).collect();
    let names: Vec<usize> = (0..shown.len())
        .filter(|&k| matches!(table.columns[shown[k]].key.as_deref(), Some("model" | "a" | "b")))
        .collect();
    let total = |w: &[usize]| w.iter().sum::<usize>() + 2 * w.len().saturating_sub(1);
    let mut excess = total(widths).saturating_sub(TERMINAL_COLUMNS);
    for &k in &names {
        if excess == 0 {
            break;
        }
        let header = table.columns[shown[k]].header.as_deref().unwrap_or_default().chars().count();
        let target = widths[k].saturating_sub(excess).max(MIN_NAME).max(header);
        if target >= widths[k] {
            continue;
        }
        excess -= widths[k] - target;
        widths[k] = target;
        for r in rows.iter_mut() {
            r[k] = shorten_middle(&r[k], target);
        }
    }
}

/// `s` in at most `max` characters, cut in the middle with `…`; a trailing
/// " †" (incomplete mark) stays.
pub(crate) fn shorten_middle(s: &str, max: usize) -> String {
    let (body, mark) = match s.strip_suffix(&format!(" {}", super::INCOMPLETE_MARK)) {
        Some(b) => (b, format!(" {}", super::INCOMPLETE_MARK)),
        None => (s, String::new()),
    };
    let chars: Vec<char> = body.chars().collect();
    let room = max.saturating_sub(mark.chars().count());
    if chars.len() + mark.chars().count() <= max || room < 3 {
        return s.to_string();
    }
    let head = (room - 1).div_ceil(2);
    let tail = room - 1 - head;
    format!(
        "{}\u{2026}{}{mark}",
        chars[..head].iter().collect::<String>(),
        chars[chars.len() - tail..].iter().collect::<String>()
    )
}

pub(crate) struct TextExporter;

impl Exporter for TextExporter {
    fn render(&self, table: &Table) -> String {
        let width = |s: &str| s.chars().count();
        let headers: Vec<String> = table.shown().map(|(_, h)| h.to_string()).collect();
        let mut rows = table.display_rows();
        let mut widths: Vec<usize> = headers.iter().map(|h| width(h)).collect();
        for r in &rows {
            for (w, v) in widths.iter_mut().zip(r) {
                *w = (*w).max(width(v));
            }
        }
        fit_names(table, &mut rows, &mut widths);
        let line = |cells: &[String]| {
            let padded: Vec<String> = cells
                .iter()
                .zip(&widths)
                .map(|(v, w)| format!("{v}{}", " ".repeat(w.saturating_sub(width(v)))))
                .collect();
            padded.join("  ").trim_end().to_string() + "\n"
        };
        let mut s = String::new();
        if !table.title.is_empty() {
            s.push_str(&table.title);
            s.push('\n');
        }
        s.push_str(&line(&headers));
        s.push_str(&widths.iter().map(|w| "-".repeat(*w)).collect::<Vec<_>>().join("  "));
        s.push('\n');
        for r in &rows {
            s.push_str(&line(r));
        }
        for n in &table.notes {
            s.push_str(n);
            s.push('\n');
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::tables::{OutcomeRow, outcome_table};
    use crate::scenario::{ScenarioKind, Tier};

    fn outcomes(model: &str) -> Table {
        let row = |scenario| OutcomeRow {
            model: model.into(),
            scenario,
            episodes: 200,
            success_rate: 0.5,
            collision_rate: 0.25,
            timeout_rate: 0.25,
            decision_correctness: 0.75,
            mean_reward: 0.1,
        };
        outcome_table(&[row(ScenarioKind::YieldStandoff), row(ScenarioKind::ContestedMerge)], &[Tier::T1])
    }

    #[test]
    fn long_model_names_are_shortened_to_fit_100_columns() {
        let long = "accounts/fireworks/models/llama-v3p1-405b-instruct-long-context";
        let text = TextExporter.render(&outcomes(long));
        let table_lines: Vec<&str> = text.lines().skip(1).take(4).collect();
        assert!(table_lines.iter().all(|l| l.chars().count() <= TERMINAL_COLUMNS), "{text}");
        assert!(!text.contains(long) && text.contains("accounts/") && text.contains('\u{2026}'), "{text}");
        assert!(text.contains("accounts/f\u{2026}ng-context  yield_standoff"), "start and end kept: {text}");
        // Short names are left alone.
        let text = TextExporter.render(&outcomes("gpt-4o"));
        assert!(text.contains("gpt-4o  ") && !text.contains('\u{2026}'), "{text}");
    }

    #[test]
    fn shortening_keeps_the_incomplete_mark() {
        assert_eq!(shorten_middle("abcdefghijklmnop \u{2020}", 12), "abcde\u{2026}mnop \u{2020}");
        assert_eq!(shorten_middle("abcdefghijklmnop", 12), "abcdef\u{2026}lmnop");
        assert_eq!(shorten_middle("short", 12), "short");
    }
}
