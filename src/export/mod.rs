//! Exporters for the baseline table: one trait, one file per format.

mod csv;
mod json;
mod markdown;
mod table;

use crate::baselines::CellSummary;
use std::io::Write;

pub trait Exporter {
    fn write(&self, cells: &[CellSummary], out: &mut dyn Write) -> anyhow::Result<()>;
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// Aligned text for the terminal.
    Table,
    /// GitHub-flavoured Markdown.
    Md,
    Csv,
    Json,
}

impl Format {
    pub fn exporter(self) -> Box<dyn Exporter> {
        match self {
            Format::Table => Box::new(table::TableExporter),
            Format::Md => Box::new(markdown::MarkdownExporter),
            Format::Csv => Box::new(csv::CsvExporter),
            Format::Json => Box::new(json::JsonExporter),
        }
    }
}

/// "0.53 [0.46, 0.60]"
pub(crate) fn with_ci(i: &crate::stats::Interval) -> String {
    format!("{:.2} [{:.2}, {:.2}]", i.estimate, i.lo, i.hi)
}

pub(crate) const HEADERS: [&str; 8] = ["scenario", "tier", "policy", "n", "success", "collision", "timeout", "reward"];
