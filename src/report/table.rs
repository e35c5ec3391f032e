//! One table, four renderings: aligned text (terminal), Markdown, CSV and
//! HTML. The report's tables build a display form (intervals as
//! "0.53 [0.46, 0.60]") and a CSV form (one numeric column per figure).

use serde::Serialize;
use std::fmt::Write;

#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Table {
    /// File stem of the CSV (`leaderboard` -> `leaderboard.csv`).
    pub name: String,
    pub title: String,
    pub headers: Vec<String>,
    pub rows: Vec<Vec<String>>,
    /// Lines printed under the table.
    pub notes: Vec<String>,
}

impl Table {
    pub fn new(name: &str, title: impl Into<String>, headers: &[&str]) -> Table {
        Table {
            name: name.to_string(),
            title: title.into(),
            headers: headers.iter().map(|h| h.to_string()).collect(),
            ..Table::default()
        }
    }

    pub fn push(&mut self, row: Vec<String>) {
        self.rows.push(row);
    }

    pub fn note(&mut self, note: impl Into<String>) {
        self.notes.push(note.into());
    }

    /// Aligned columns with the title above, for the terminal.
    pub fn text(&self) -> String {
        let width = |s: &str| s.chars().count();
        let mut widths: Vec<usize> = self.headers.iter().map(|h| width(h)).collect();
        for r in &self.rows {
            for (i, v) in r.iter().enumerate() {
                if i < widths.len() {
                    widths[i] = widths[i].max(width(v));
                }
            }
        }
        let mut s = String::new();
        let _ = writeln!(s, "{}", self.title);
        let line = |cells: &[String]| {
            let padded: Vec<String> = cells
                .iter()
                .zip(&widths)
                .map(|(v, w)| format!("{v}{}", " ".repeat(w.saturating_sub(width(v)))))
                .collect();
            padded.join("  ").trim_end().to_string()
        };
        let _ = writeln!(s, "{}", line(&self.headers));
        let _ = writeln!(s, "{}", widths.iter().map(|w| "-".repeat(*w)).collect::<Vec<_>>().join("  "));
        for r in &self.rows {
            let _ = writeln!(s, "{}", line(r));
        }
        for n in &self.notes {
            let _ = writeln!(s, "{n}");
        }
        s
    }

    /// GitHub-flavoured Markdown, with the title as a heading.
    pub fn markdown(&self, level: usize) -> String {
        let cell = |v: &str| v.replace('|', "\\|").replace('\n', " ");
        let mut s = String::new();
        let _ = writeln!(s, "{} {}\n", "#".repeat(level), self.title);
        let _ = writeln!(s, "| {} |", self.headers.iter().map(|h| cell(h)).collect::<Vec<_>>().join(" | "));
        let _ = writeln!(s, "|{}", "---|".repeat(self.headers.len()));
        for r in &self.rows {
            let _ = writeln!(s, "| {} |", r.iter().map(|v| cell(v)).collect::<Vec<_>>().join(" | "));
        }
        if !self.notes.is_empty() {
            let _ = writeln!(s);
            for n in &self.notes {
                let _ = writeln!(s, "{n}  ");
            }
        }
        s
    }

    /// RFC 4180 CSV with a header line (no title, no notes).
    pub fn csv(&self) -> String {
        let mut w = csv::WriterBuilder::new().from_writer(Vec::new());
        // Writing to a Vec cannot fail; a row of another length is padded.
        let _ = w.write_record(&self.headers);
        for r in &self.rows {
            let mut r = r.clone();
            r.resize(self.headers.len(), String::new());
            let _ = w.write_record(&r);
        }
        String::from_utf8(w.into_inner().unwrap_or_default()).unwrap_or_default()
    }

    /// An HTML table with the title as a caption; every cell escaped.
    pub fn html(&self) -> String {
        let mut s = String::new();
        let _ = write!(
            s,
            "<table class=\"t\" data-table=\"{}\"><caption>{}</caption><thead><tr>",
            esc(&self.name),
            esc(&self.title)
        );
        for h in &self.headers {
            let _ = write!(s, "<th>{}</th>", esc(h));
        }
        s.push_str("</tr></thead><tbody>");
        for r in &self.rows {
            s.push_str("<tr>");
            for v in r {
                let _ = write!(s, "<td>{}</td>", esc(v));
            }
            s.push_str("</tr>");
        }
        s.push_str("</tbody></table>");
        for n in &self.notes {
            let _ = write!(s, "<p class=\"note\">{}</p>", esc(n));
        }
        s
    }
}

/// Escape text for HTML and SVG (element content and quoted attributes).
pub fn esc(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// Two decimals, or "-" when undefined.
pub fn f2(x: f64) -> String {
    if x.is_finite() { format!("{x:.2}") } else { "-".to_string() }
}

/// Four decimals for CSV, or empty when undefined.
pub fn f4(x: f64) -> String {
    if x.is_finite() { format!("{x:.4}") } else { String::new() }
}

/// "0.53 [0.46, 0.60]"; the estimate alone when the bounds are undefined.
pub fn with_ci(i: &crate::stats::Interval) -> String {
    if i.lo.is_finite() && i.hi.is_finite() {
        format!("{} [{}, {}]", f2(i.estimate), f2(i.lo), f2(i.hi))
    } else {
        f2(i.estimate)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn renderings() {
        let mut t = Table::new("x", "Title", &["model", "value"]);
        t.push(vec!["a|b".into(), "0.50".into()]);
        t.push(vec!["<c>".into(), "1.00".into()]);
        t.note("note");
        assert_eq!(
            t.markdown(3),
            "### Title\n\n| model | value |\n|---|---|\n| a\\|b | 0.50 |\n| <c> | 1.00 |\n\nnote  \n"
        );
        assert_eq!(t.csv(), "model,value\na|b,0.50\n<c>,1.00\n");
        assert_eq!(t.text(), "Title\nmodel  value\n-----  -----\na|b    0.50\n<c>    1.00\nnote\n");
        assert!(t.html().contains("<td>&lt;c&gt;</td>"));
        assert_eq!(esc("a&'\""), "a&amp;&#39;&quot;");
        assert_eq!((f2(f64::NAN), f4(0.5)), ("-".to_string(), "0.5000".to_string()));
    }
}
