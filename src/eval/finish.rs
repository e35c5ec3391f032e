//! Finishing a run: totals and status in run.json, the summary files, the
//! last event.

use super::events::{Event, Reporter, StopReason};
use super::fleet::{Drove, fatal_error};
use super::prepare::Prepared;
use super::{EvalError, RunOutcome, now_rfc3339, summary};
use crate::rundir;
use crate::rundir::record::{EpisodeKey, EpisodeScalars};
use crate::rundir::{RunStatus, Totals};
use crate::scenario::{ScenarioKind, Tier};
use std::collections::HashMap;
use std::sync::atomic::Ordering::Relaxed;
/// Close the writer, record the invocation's totals and status in
/// run.json, report the end, then either return the error that stopped the
/// run or write the summary of every finished episode of the selection.
pub(super) fn finalize(run: Prepared, drove: Drove, reporter: &mut dyn Reporter) -> Result<RunOutcome, EvalError> {
    let Prepared {
        started,
        dir,
        selection,
        finished,
        mut info,
        mut invocation,
        prev_totals,
        ctx,
        writer,
        lock: _lock,
        ..
    } = run;
    let write_result = writer.finish();
    invocation.retries = ctx.counters.retries.load(Relaxed);
    invocation.turns = ctx.counters.turns.load(Relaxed);
    invocation.wall_s = started.elapsed().as_secs_f64();
    invocation.ended_at = Some(now_rfc3339());

    let mut summary = summarize_selection(&ctx.options.config.model, &selection, &finished);
    summary.prices_as_of = ctx.options.pricing.as_ref().map(|p| p.as_of.clone());
    let missing = summary.missing;
    invocation.status = match drove.stop {
        Some(StopReason::Refused) => RunStatus::Refused,
        Some(StopReason::Failed) => RunStatus::Failed,
        _ if write_result.is_err() => RunStatus::Failed,
        Some(StopReason::Interrupted) => RunStatus::Interrupted,
        _ if missing == 0 => RunStatus::Finished,
        _ => RunStatus::Incomplete,
    };
    let status = invocation.status;
    info.totals = Totals {
        episodes: finished.len() as u64,
        infra_errors: prev_totals.infra_errors + invocation.infra_errors,
        missing: missing as u64,
        retries: prev_totals.retries + invocation.retries,
        tokens: finished.values().map(|s| s.tokens).sum(),
        cost_usd: finished.values().map(|s| s.cost_usd).sum(),
        wall_s: prev_totals.wall_s + invocation.wall_s,
    };
    info.ended_at = invocation.ended_at.clone();
    let inv = &invocation;
    let end = Event::Finished {
        status,
        stop: drove.stop,
        episodes: inv.episodes,
        infra_errors: inv.infra_errors,
        turns: inv.turns,
        retries: inv.retries,
        tokens: inv.tokens,
        cost_usd: inv.cost_usd,
        wall_s: inv.wall_s,
        missing,
    };
    info.last_invocation = invocation;
    rundir::write_run_info(&dir, &info)?;
    reporter.event(&end);
    write_result?;
    if let Some(f) = drove.failure {
        return Err(f);
    }
    if let Some(e) = drove.fatal {
        return Err(fatal_error(e, &ctx, &dir));
    }
    let json = serde_json::to_vec_pretty(&summary).expect("summary serialises");
    rundir::write_atomic(&dir.join(rundir::SUMMARY_JSON), &json)?;
    rundir::write_atomic(&dir.join(rundir::SUMMARY_MD), summary::render(&summary).as_bytes())?;
    Ok(RunOutcome { summary, run_dir: dir, missing, status, stop: drove.stop })
}

/// The summary over every finished episode of the selection, in key order
/// (the missing ones counted per cell).
pub(super) fn summarize_selection(
    model: &str,
    selection: &[EpisodeKey],
    finished: &HashMap<EpisodeKey, EpisodeScalars>,
) -> summary::Summary {
    let mut by_cell: Vec<(ScenarioKind, Tier, Vec<EpisodeScalars>, usize)> = Vec::new();
    let mut index: HashMap<(ScenarioKind, Tier), usize> = HashMap::new();
    for key in selection {
        let i = *index.entry((key.scenario, key.tier)).or_insert_with(|| {
            by_cell.push((key.scenario, key.tier, Vec::new(), 0));
            by_cell.len() - 1
        });
        match finished.get(key) {
            Some(s) => by_cell[i].2.push(*s),
            None => by_cell[i].3 += 1,
        }
    }
    summary::summarize(model, &by_cell)
}
