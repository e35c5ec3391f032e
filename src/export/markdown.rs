//! GitHub-flavoured Markdown: the title as a heading, the table, the notes
//! as lines ending in a hard break.

use super::{Exporter, Style, Table};

pub(crate) struct MarkdownExporter {
    /// Level of the title's heading (2: `##`).
    pub(crate) heading_level: usize,
}

impl Exporter for MarkdownExporter {
    fn render(&self, table: &Table) -> String {
        let escape = |v: &str| v.replace('|', "\\|").replace('\n', " ");
        let mut s = String::new();
        if !table.title.is_empty() {
            s.push_str(&format!("{} {}\n\n", "#".repeat(self.heading_level), table.title));
        }
        let headers: Vec<String> = table.shown().map(|(_, h)| escape(h)).collect();
        s.push_str(&format!("| {} |\n", headers.join(" | ")));
        s.push_str(&format!("|{}\n", "---|".repeat(headers.len())));
        let styles: Vec<Style> = table.shown().map(|(i, _)| table.columns[i].style).collect();
        for r in table.display_rows() {
            let cells: Vec<String> = r
                .iter()
                .zip(&styles)
                .map(|(v, style)| if *style == Style::Code { format!("`{}`", escape(v)) } else { escape(v) })
                .collect();
            s.push_str(&format!("| {} |\n", cells.join(" | ")));
        }
        if !table.notes.is_empty() {
            s.push('\n');
            for n in &table.notes {
                s.push_str(&format!("{n}  \n"));
            }
        }
        s
    }
}
