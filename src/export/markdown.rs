use super::{Exporter, HEADERS, with_ci};
use crate::baselines::CellSummary;
use std::io::Write;

pub struct MarkdownExporter;

impl Exporter for MarkdownExporter {
    fn write(&self, cells: &[CellSummary], out: &mut dyn Write) -> anyhow::Result<()> {
        writeln!(out, "| {} | decision correctness |", HEADERS.join(" | "))?;
        writeln!(out, "|{}---|", "---|".repeat(HEADERS.len()))?;
        for c in cells {
            writeln!(
                out,
                "| `{}` | {} | `{}` | {} | {} | {} | {} | {} | {} |",
                c.cell.scenario,
                c.cell.tier,
                c.cell.policy,
                c.n,
                with_ci(&c.success),
                with_ci(&c.collision),
                with_ci(&c.timeout),
                with_ci(&c.reward),
                with_ci(&c.decision_correctness)
            )?;
        }
        Ok(())
    }
}
