use super::Exporter;
use crate::baselines::CellSummary;
use std::io::Write;

pub struct CsvExporter;

impl Exporter for CsvExporter {
    fn write(&self, cells: &[CellSummary], out: &mut dyn Write) -> anyhow::Result<()> {
        let mut w = csv::Writer::from_writer(out);
        let mut header = vec!["scenario".to_string(), "tier".into(), "policy".into(), "n".into()];
        for m in ["success", "collision", "timeout", "reward", "decision_correctness"] {
            header.extend([m.to_string(), format!("{m}_lo"), format!("{m}_hi")]);
        }
        w.write_record(&header)?;
        for c in cells {
            let mut row =
                vec![c.cell.scenario.to_string(), c.cell.tier.to_string(), c.cell.policy.to_string(), c.n.to_string()];
            for i in [&c.success, &c.collision, &c.timeout, &c.reward, &c.decision_correctness] {
                row.extend([format!("{:.4}", i.estimate), format!("{:.4}", i.lo), format!("{:.4}", i.hi)]);
            }
            w.write_record(&row)?;
        }
        w.flush()?;
        Ok(())
    }
}
