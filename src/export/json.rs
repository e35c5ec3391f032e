//! JSON: an array with one object per row, keyed by the data columns in
//! column order; an interval is `{"estimate", "lo", "hi"}`, anything
//! undefined is `null`. Several tables make one object keyed by each
//! table's name (its CSV file stem).

use super::{Exporter, Table};

pub(crate) struct JsonExporter;

impl Exporter for JsonExporter {
    fn render(&self, table: &Table) -> String {
        let rows: Vec<_> = table.data_rows().collect();
        // Serialising strings and numbers into a String cannot fail.
        serde_json::to_string_pretty(&rows).unwrap_or_default() + "\n"
    }

    fn render_all(&self, tables: &[Table]) -> String {
        let all: serde_json::Map<String, serde_json::Value> = tables
            .iter()
            .map(|t| (t.name.clone(), serde_json::to_value(t.data_rows().collect::<Vec<_>>()).unwrap_or_default()))
            .collect();
        serde_json::to_string_pretty(&all).unwrap_or_default() + "\n"
    }
}
