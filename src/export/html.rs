//! An HTML table with the title as its caption and the notes after it;
//! every text escaped.

use super::{Exporter, Table};
use std::fmt::Write;

pub(crate) struct HtmlExporter;

impl Exporter for HtmlExporter {
    fn render(&self, table: &Table) -> String {
        let mut s = String::new();
        let _ = write!(
            s,
            "<table class=\"t\" data-table=\"{}\"><caption>{}</caption><thead><tr>",
            esc(&table.name),
            esc(&table.title)
        );
        // Numeric columns (every cell a number or empty) are right-aligned.
        let numeric: Vec<bool> =
            table.shown().map(|(i, _)| table.rows.iter().all(|r| r[i].is_numeric_or_empty())).collect();
        let class = |k: usize| if numeric[k] { " class=\"num\"" } else { "" };
        for (k, (_, h)) in table.shown().enumerate() {
            let _ = write!(s, "<th{}>{}</th>", class(k), esc(h));
        }
        s.push_str("</tr></thead><tbody>");
        for r in table.display_rows() {
            s.push_str("<tr>");
            for (k, v) in r.iter().enumerate() {
                let _ = write!(s, "<td{}>{}</td>", class(k), esc(v));
            }
            s.push_str("</tr>");
        }
        s.push_str("</tbody></table>");
        for n in &table.notes {
            let _ = write!(s, "<p class=\"note\">{}</p>", esc(n));
        }
        s
    }
}

/// Escape text for HTML and SVG (element content and quoted attributes).
pub(crate) fn esc(s: &str) -> String {
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
