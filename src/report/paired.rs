//! Paired comparison of every pair of models on the (scenario, tier, seed)
//! keys both have: the same scenario instances, so the difference in
//! success is estimated pair by pair.
//!
//! - Difference: mean over shared keys of (success A − success B), each
//!   key's success being its rate over rollouts; 95% paired percentile
//!   bootstrap CI resampling the keys (`crate::stats::paired_bootstrap_diff_ci`).
//! - Exact two-sided McNemar test on the discordant pairs: A succeeded and
//!   B failed (`a_only`) against the reverse (`b_only`). With several
//!   rollouts per seed the test uses each key's lowest rollout index that
//!   both models have, so its pairs stay independent.
//! - Verdict: a model is better only when the paired CI excludes 0 and the
//!   McNemar p is below 0.05, in the same direction; otherwise "no
//!   significant difference" (saying so when the two disagree). The
//!   verdict names the shared keys it rests on and flags fewer than
//!   `FEW_DISCORDANT` discordant pairs.
//! - Power: for a pair with no significant difference, the seeds per
//!   (scenario, tier) cell a paired McNemar test needs to detect the
//!   observed difference with 80% power (`mcnemar_keys_for_power`).

use super::boot::{paired_ci, seed_for};
use super::load::ModelData;
use super::tables::{Unit, tiers_label, units};
use crate::export::{Cell, Column, Field, Style, Table};
use crate::par::par_map;
use crate::scenario::Tier;
use crate::stats::{Interval, mcnemar_exact, mcnemar_keys_for_power};
use serde::Serialize;

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PairRow {
    pub a: String,
    pub b: String,
    /// Shared (scenario, tier, seed) keys.
    pub keys: usize,
    pub success_a: f64,
    pub success_b: f64,
    /// success A − success B.
    pub diff: Interval,
    /// Pairs where A succeeded and B failed.
    pub a_only: usize,
    /// Pairs where B succeeded and A failed.
    pub b_only: usize,
    pub mcnemar_p: f64,
    pub verdict: String,
    /// Whether the verdict names a better model (CI and McNemar agree).
    pub significant: bool,
    /// (scenario, tier) cells among the shared keys.
    pub cells: usize,
    /// Without a significant difference: seeds per cell for 80% power to
    /// detect the observed difference (`None`: no difference observed, or
    /// significant already).
    pub seeds_for_power: Option<u64>,
}

/// Significance level of the paired verdict (two-sided; the CIs are 95%).
pub(crate) const ALPHA: f64 = 0.05;

/// Fewer discordant pairs than this: the verdict says so (the exact test has
/// little power there).
pub(crate) const FEW_DISCORDANT: usize = 20;

/// The verdict on a pair: better only when the CI and the exact test agree.
pub(crate) fn verdict(a: &str, b: &str, diff: &Interval, p: f64, keys: usize, discordant: usize) -> (String, bool) {
    if keys == 0 {
        return ("no shared seeds".into(), false);
    }
    let ci_says = if diff.lo > 0.0 {
        Some(a)
    } else if diff.hi < 0.0 {
        Some(b)
    } else {
        None
    };
    let test_says = p < ALPHA;
    let (head, significant) = match (ci_says, test_says) {
        (Some(w), true) => (format!("{w} better"), true),
        (None, false) => ("no significant difference".to_string(), false),
        _ => ("no significant difference: CI and McNemar disagree".to_string(), false),
    };
    let few = if discordant < FEW_DISCORDANT { format!(", only {discordant} discordant") } else { String::new() };
    (format!("{head} ({keys} keys{few})"), significant)
}

/// Compare `a` and `b` on their shared keys within `tiers`.
pub(crate) fn compare(a: &ModelData, b: &ModelData, tiers: &[Tier], resamples: usize, base: u64) -> PairRow {
    let ua = units(&a.episodes, tiers);
    let ub = units(&b.episodes, tiers);
    let (mut va, mut vb) = (Vec::new(), Vec::new());
    let (mut a_only, mut b_only) = (0usize, 0usize);
    let mut cells = std::collections::BTreeSet::new();
    let (mut i, mut j) = (0, 0);
    while i < ua.len() && j < ub.len() {
        match ua[i].key().cmp(&ub[j].key()) {
            std::cmp::Ordering::Less => i += 1,
            std::cmp::Ordering::Greater => j += 1,
            std::cmp::Ordering::Equal => {
                cells.insert((ua[i].scenario, ua[i].tier));
                va.push(ua[i].value());
                vb.push(ub[j].value());
                if let Some((sa, sb)) = first_shared_rollout(a, &ua[i], b, &ub[j]) {
                    match (sa, sb) {
                        (true, false) => a_only += 1,
                        (false, true) => b_only += 1,
                        _ => {}
                    }
                }
                i += 1;
                j += 1;
            }
        }
    }
    let seed = seed_for(base, &format!("paired/{}/{}", a.label, b.label));
    let diff =
        paired_ci(&va, &vb, resamples, seed).unwrap_or(Interval { estimate: f64::NAN, lo: f64::NAN, hi: f64::NAN });
    let mcnemar_p = mcnemar_exact(a_only, b_only);
    let (verdict, significant) = verdict(&a.label, &b.label, &diff, mcnemar_p, va.len(), a_only + b_only);
    let seeds_for_power = (!significant)
        .then(|| mcnemar_keys_for_power(a_only, b_only, va.len()))
        .flatten()
        .map(|k| k.div_ceil(cells.len().max(1) as u64));
    let mean = |v: &[f64]| if v.is_empty() { f64::NAN } else { v.iter().sum::<f64>() / v.len() as f64 };
    PairRow {
        a: a.label.clone(),
        b: b.label.clone(),
        keys: va.len(),
        success_a: mean(&va),
        success_b: mean(&vb),
        diff,
        a_only,
        b_only,
        mcnemar_p,
        verdict,
        significant,
        cells: cells.len(),
        seeds_for_power,
    }
}

/// Success of both models on the lowest rollout index both have.
fn first_shared_rollout(a: &ModelData, ua: &Unit, b: &ModelData, ub: &Unit) -> Option<(bool, bool)> {
    let ea = &a.episodes[ua.start..ua.end];
    let eb = &b.episodes[ub.start..ub.end];
    let (mut i, mut j) = (0, 0);
    while i < ea.len() && j < eb.len() {
        match ea[i].rollout.cmp(&eb[j].rollout) {
            std::cmp::Ordering::Less => i += 1,
            std::cmp::Ordering::Greater => j += 1,
            std::cmp::Ordering::Equal => return Some((ea[i].success(), eb[j].success())),
        }
    }
    None
}

/// Every pair, in the order given (leaderboard order: A ranks above B).
pub(crate) fn all_pairs(models: &[&ModelData], tiers: &[Tier], resamples: usize, base: u64) -> Vec<PairRow> {
    let pairs: Vec<(usize, usize)> =
        (0..models.len()).flat_map(|i| (i + 1..models.len()).map(move |j| (i, j))).collect();
    par_map(&pairs, |&(i, j)| compare(models[i], models[j], tiers, resamples, base))
}

pub(crate) fn paired_table(rows: &[PairRow], tiers: &[Tier], resamples: usize) -> Table {
    type R = PairRow;
    let count = |header: &str, key: &str, value: fn(&R) -> usize| {
        Field::int(Column::new(header, key), move |r| value(r) as u64)
    };
    let fields: [Field<R>; 11] = [
        Field::new(Column::new("A", "a"), |r: &R| Cell::text(&r.a)),
        Field::new(Column::new("B", "b"), |r: &R| Cell::text(&r.b)),
        count("shared", "shared_keys", |r| r.keys),
        Field::new(Column::new("success A", "success_a"), |r: &R| Cell::Float(r.success_a)),
        Field::new(Column::new("success B", "success_b"), |r: &R| Cell::Float(r.success_b)),
        Field::new(Column::new("A − B [95% CI]", "diff").style(Style::SignedInterval), |r: &R| {
            Cell::Interval(r.diff)
        }),
        count("A only", "a_only", |r| r.a_only),
        count("B only", "b_only", |r| r.b_only),
        Field::new(Column::new("McNemar p", "mcnemar_p").style(Style::PValue), |r: &R| Cell::Float(r.mcnemar_p)),
        Field::new(Column::new("verdict", "verdict"), |r: &R| Cell::text(&r.verdict)),
        Field::new(Column::new("seeds for 80% power", "seeds_for_power"), |r: &R| match r.seeds_for_power {
            Some(n) => Cell::Int(n),
            None if r.significant => Cell::Blank,
            None => Cell::Missing,
        }),
    ];
    let mut t =
        Table::of("paired", format!("Paired comparisons on shared seeds ({})", tiers_label(tiers)), &fields, rows);
    t.note(format!(
        "shared: (scenario, tier, seed) keys both models have. CI: paired percentile bootstrap over the keys \
         ({resamples} resamples). A only / B only: discordant pairs (one succeeded, the other failed) for the exact \
         McNemar test. A model is better only when the CI excludes 0 and McNemar p < 0.05 agree; fewer than \
         {FEW_DISCORDANT} discordant pairs are flagged. Seeds for 80% power: for a pair without a significant \
         difference, the seeds per (scenario, tier) a paired McNemar test at 0.05 needs to detect the observed \
         difference 80% of the time (Connor 1987: n = (1.96 sqrt(psi) + 0.84 sqrt(psi - delta^2))^2 / delta^2 \
         keys, psi the discordant share, delta the difference, over the cells); '-': no difference observed. \
         eval extends a run in place (-n)."
    ));
    t
}
