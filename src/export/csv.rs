//! RFC 4180 CSV of the data columns: a header line, then one line per row
//! (an interval column takes three fields). No title, no notes.

use super::{Exporter, Table};

pub(crate) struct CsvExporter;

impl Exporter for CsvExporter {
    fn render(&self, table: &Table) -> String {
        let mut w = csv::Writer::from_writer(Vec::new());
        // Writing into a Vec cannot fail.
        let headers: Vec<String> = table.columns.iter().flat_map(|c| c.csv_headers()).collect();
        let _ = w.write_record(&headers);
        for row in table.data_rows() {
            let fields: Vec<String> = row.fields().flat_map(|(c, cell)| cell.csv_fields(c.style)).collect();
            let _ = w.write_record(&fields);
        }
        String::from_utf8(w.into_inner().unwrap_or_default()).unwrap_or_default()
    }
}
