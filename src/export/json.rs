use super::Exporter;
use crate::baselines::CellSummary;
use std::io::Write;

pub struct JsonExporter;

impl Exporter for JsonExporter {
    fn write(&self, cells: &[CellSummary], out: &mut dyn Write) -> anyhow::Result<()> {
        serde_json::to_writer_pretty(&mut *out, cells)?;
        writeln!(out)?;
        Ok(())
    }
}
