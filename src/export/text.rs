//! Aligned columns for the terminal: the title, the headers, a rule, the
//! rows, then the notes. Widths count characters, not bytes.

use super::{Exporter, Table};

pub(crate) struct TextExporter;

impl Exporter for TextExporter {
    fn render(&self, table: &Table) -> String {
        let width = |s: &str| s.chars().count();
        let headers: Vec<String> = table.shown().map(|(_, h)| h.to_string()).collect();
        let rows = table.display_rows();
        let mut widths: Vec<usize> = headers.iter().map(|h| width(h)).collect();
        for r in &rows {
            for (w, v) in widths.iter_mut().zip(r) {
                *w = (*w).max(width(v));
            }
        }
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
