//! JSON: an array with one object per row, keyed by the data columns in
//! column order; an interval is `{"estimate", "lo", "hi"}`, anything
//! undefined is `null`.

use super::{Exporter, Table};

pub(crate) struct JsonExporter;

impl Exporter for JsonExporter {
    fn render(&self, table: &Table) -> String {
        let rows: Vec<_> = table.data_rows().collect();
        // Serialising strings and numbers into a String cannot fail.
        serde_json::to_string_pretty(&rows).unwrap_or_default() + "\n"
    }
}
