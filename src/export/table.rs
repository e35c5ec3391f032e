use super::{Exporter, HEADERS, with_ci};
use crate::baselines::CellSummary;
use std::io::Write;

pub struct TableExporter;

impl Exporter for TableExporter {
    fn write(&self, cells: &[CellSummary], out: &mut dyn Write) -> anyhow::Result<()> {
        let mut rows: Vec<Vec<String>> = vec![HEADERS.iter().map(|h| h.to_string()).collect()];
        rows[0].push("correctness".into());
        for c in cells {
            rows.push(vec![
                c.cell.scenario.to_string(),
                c.cell.tier.to_string(),
                c.cell.policy.to_string(),
                c.n.to_string(),
                with_ci(&c.success),
                with_ci(&c.collision),
                with_ci(&c.timeout),
                with_ci(&c.reward),
                with_ci(&c.decision_correctness),
            ]);
        }
        let widths: Vec<usize> =
            (0..rows[0].len()).map(|i| rows.iter().map(|r| r[i].len()).max().unwrap_or(0)).collect();
        for r in rows {
            let line: Vec<String> = r.iter().zip(&widths).map(|(v, w)| format!("{v:<w$}")).collect();
            writeln!(out, "{}", line.join("  ").trim_end())?;
        }
        Ok(())
    }
}
