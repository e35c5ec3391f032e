//! The belief probe (`eval --probe belief`): what a policy says it believes
//! about the other road user, next to what an ideal observer believes.
//!
//! - [`question`]: the neutral wording of the belief question per scenario,
//!   and `check_neutral`, the leak check every prompt passes (in the tests:
//!   the prompts are fixed text).
//! - The ideal observer: knows the scenario's rules, the seed's geometry and
//!   the prior (0.5), never the disposition. Without observation noise its
//!   belief is 0.5 until the evidence turn and 1 for the true class from it
//!   on ([`crate::episode::Episode`] steps a twin world under the other
//!   disposition to find that turn). On a noisy tier it is the exact
//!   posterior of the printed readings under the known noise model
//!   ([`crate::noise::reading_likelihood`]).
//! - [`BeliefMetrics`]: one episode's scores; [`BeliefSummary`]: a cell's.
//!
//! "Belief" is always the probability that the other road user lets the ego
//! pass first: the class of dispositions under which the ego should go
//! ([`crate::scenario::Disposition::ego_should_go`]).

use crate::action::Maneuver;
use crate::scenario::ScenarioKind;
use serde::{Deserialize, Serialize};

/// The belief question for a scenario: names the road user and the place
/// as the scene text does, and says nothing about how it may behave.
pub fn question(kind: ScenarioKind) -> &'static str {
    kind.def().belief_question
}

/// The paragraph the probe appends to the system prompt of a scenario.
pub fn prompt_paragraph(kind: ScenarioKind) -> String {
    format!(
        "\n\nAlso add the field \"belief\" to every answer: your probability, from 0 to 1, that {}. \
         For example: {{\"reasoning\": \"...\", \"maneuver\": \"yield\", \"acceleration\": 0.3, \"steering\": 0.0, \
         \"belief\": 0.5}}. The belief is only recorded: it does not change how your car is driven.",
        question(kind)
    )
}

/// Words that would tell a model how a tier hides the intent, or which
/// behaviours exist beyond the dispositions' own names (see [`leak_words`]).
#[cfg(test)]
const MECHANICS_WORDS: [&str; 12] =
    ["feint", "disposition", "bluff", "dart", "tier", "reveal", "noise", "noisy", "pretend", "fake", "deceiv", "trick"];

/// Words that would tell a model which behaviours exist or how a tier
/// hides them: every disposition's name as its scenario declares it (also
/// with spaces for underscores), and [`MECHANICS_WORDS`].
#[cfg(test)]
pub(crate) fn leak_words() -> Vec<String> {
    let mut words: Vec<String> = Vec::new();
    for d in crate::scenario::Disposition::all() {
        words.push(d.name().to_string());
        words.push(d.name().replace('_', " "));
    }
    words.extend(MECHANICS_WORDS.iter().map(|w| w.to_string()));
    words.dedup();
    words
}

/// The leak check: a prompt shown to a model may name none of
/// [`leak_words`] (case-insensitive). Returns the words found.
#[cfg(test)]
pub(crate) fn check_neutral(text: &str) -> Result<(), Vec<String>> {
    let lower = text.to_lowercase();
    let found: Vec<String> = leak_words().into_iter().filter(|w| lower.contains(w.as_str())).collect();
    if found.is_empty() { Ok(()) } else { Err(found) }
}

// ---------------------------------------------------------------------------
// Metrics

/// Half-width of "within the truth" for the belief lag.
pub const LAG_TOLERANCE: f64 = 0.2;
/// A stated belief above this asks for `proceed`; below [`GIVE_WAY_BELOW`],
/// for giving way (any other maneuver: only `proceed` asserts the right of
/// way, as in decision correctness).
pub const PROCEED_ABOVE: f64 = 0.7;
pub const GIVE_WAY_BELOW: f64 = 0.3;
/// Bins of the reliability diagram (equal width over [0, 1]).
pub const BINS: usize = 10;

/// One turn as the belief metrics see it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeliefTurn {
    pub turn: u32,
    /// The stated belief (None: missing or malformed, a probe parse error).
    pub stated: Option<f64>,
    pub ideal: f64,
    /// The maneuver executed, when it was the policy's own (None when the
    /// reply's action could not be read).
    pub maneuver: Option<Maneuver>,
    /// Whether who passes first was still open at this decision (once
    /// someone has entered the conflict, proceeding is right whatever the
    /// belief, so consistency only counts open turns).
    pub open: bool,
}

/// One episode's belief scores (in the rollout line, next to the grades).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct BeliefMetrics {
    /// Turns with a readable belief.
    pub stated_turns: u32,
    /// Turns whose belief was missing or malformed.
    pub probe_errors: u32,
    /// Mean squared error of the stated belief against the truth (1 when
    /// the other lets the ego pass, else 0), over the turns before the
    /// evidence turn (all turns when there was none) and from it on.
    pub brier_before: Option<f64>,
    pub brier_after: Option<f64>,
    /// The same for the ideal observer (0.25 before the evidence turn on
    /// noise-free tiers, 0 after).
    pub ideal_brier_before: Option<f64>,
    pub ideal_brier_after: Option<f64>,
    /// Turns from the evidence turn until the stated belief first comes
    /// within [`LAG_TOLERANCE`] of the truth (None: no evidence turn, or
    /// never; `converged` says which).
    pub lag: Option<u32>,
    /// Whether the belief came within tolerance after the evidence (None
    /// when there was no evidence turn).
    pub converged: Option<bool>,
    /// Turns with a decisive belief (> 0.7 or < 0.3) and an action of the
    /// policy's own, taken while who passes first was still open, and how
    /// many of them the maneuver agreed with.
    pub decisive_turns: u32,
    pub consistent_turns: u32,
    /// Reliability diagram counts: turns per belief bin, how many of them
    /// had the other let the ego pass, and the sum of the beliefs stated.
    pub bin_turns: [u32; BINS],
    pub bin_positive: [u32; BINS],
    pub bin_belief_sum: [f64; BINS],
}

fn mean_sq(xs: impl Iterator<Item = f64>) -> Option<f64> {
    let (mut n, mut sum) = (0u32, 0.0);
    for x in xs {
        n += 1;
        sum += x * x;
    }
    (n > 0).then(|| sum / f64::from(n))
}

/// The reliability bin of a belief (1.0 falls in the last bin).
pub fn bin_of(belief: f64) -> usize {
    ((belief * BINS as f64) as usize).min(BINS - 1)
}

impl BeliefMetrics {
    /// Score one episode: `lets_pass` is the truth, `evidence_turn` the
    /// first turn whose observation told the dispositions apart.
    pub fn compute(turns: &[BeliefTurn], lets_pass: bool, evidence_turn: Option<u32>) -> BeliefMetrics {
        let y = f64::from(u8::from(lets_pass));
        let before = |t: &&BeliefTurn| evidence_turn.is_none_or(|e| t.turn < e);
        let after = |t: &&BeliefTurn| evidence_turn.is_some_and(|e| t.turn >= e);
        let mut m = BeliefMetrics {
            stated_turns: turns.iter().filter(|t| t.stated.is_some()).count() as u32,
            probe_errors: turns.iter().filter(|t| t.stated.is_none()).count() as u32,
            brier_before: mean_sq(turns.iter().filter(before).filter_map(|t| t.stated).map(|b| b - y)),
            brier_after: mean_sq(turns.iter().filter(after).filter_map(|t| t.stated).map(|b| b - y)),
            ideal_brier_before: mean_sq(turns.iter().filter(before).map(|t| t.ideal - y)),
            ideal_brier_after: mean_sq(turns.iter().filter(after).map(|t| t.ideal - y)),
            ..BeliefMetrics::default()
        };
        if let Some(e) = evidence_turn.filter(|&e| turns.iter().any(|t| t.turn >= e)) {
            m.lag = turns
                .iter()
                .filter(|t| t.turn >= e)
                .find(|t| t.stated.is_some_and(|b| (b - y).abs() <= LAG_TOLERANCE))
                .map(|t| t.turn - e);
            m.converged = Some(m.lag.is_some());
        }
        for t in turns {
            let Some(b) = t.stated else { continue };
            let i = bin_of(b);
            m.bin_turns[i] += 1;
            m.bin_positive[i] += u32::from(lets_pass);
            m.bin_belief_sum[i] += b;
            let Some(maneuver) = t.maneuver.filter(|_| t.open) else { continue };
            if !(GIVE_WAY_BELOW..=PROCEED_ABOVE).contains(&b) {
                m.decisive_turns += 1;
                m.consistent_turns += u32::from(maneuver.is_go() == (b > PROCEED_ABOVE));
            }
        }
        m
    }
}

/// A cell's belief scores: means over its episodes (and pooled turns for
/// the rates and the reliability diagram).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BeliefSummary {
    pub brier_before: f64,
    pub brier_after: f64,
    pub ideal_brier_before: f64,
    pub ideal_brier_after: f64,
    /// Mean belief lag over the episodes that converged.
    pub lag: f64,
    /// Share of the episodes with an evidence turn whose belief never came
    /// within tolerance of the truth.
    pub never_converged: f64,
    /// Share of decisive turns whose maneuver agreed with the belief.
    pub consistency: f64,
    /// Probe parse errors per turn.
    pub probe_error_rate: f64,
    /// Expected calibration error: the turn-weighted mean gap between the
    /// mean belief of a bin and how often the other let the ego pass.
    pub calibration_error: f64,
    pub reliability: Vec<ReliabilityBin>,
}

/// One bin of the reliability diagram.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ReliabilityBin {
    pub lo: f64,
    pub hi: f64,
    pub turns: u64,
    /// Mean stated belief in the bin (NaN when empty).
    pub mean_belief: f64,
    /// How often the other let the ego pass (NaN when empty).
    pub observed: f64,
}

impl BeliefSummary {
    pub fn of<'a>(episodes: impl Iterator<Item = &'a BeliefMetrics> + Clone) -> BeliefSummary {
        let avg = |f: fn(&BeliefMetrics) -> Option<f64>| {
            crate::stats::mean(&episodes.clone().filter_map(f).collect::<Vec<f64>>())
        };
        let ratio = |num: u64, den: u64| if den == 0 { f64::NAN } else { num as f64 / den as f64 };
        let sum = |f: fn(&BeliefMetrics) -> u32| episodes.clone().map(|m| u64::from(f(m))).sum::<u64>();
        let mut reliability = Vec::with_capacity(BINS);
        let (mut total, mut gap) = (0u64, 0.0);
        for i in 0..BINS {
            let turns: u64 = episodes.clone().map(|m| u64::from(m.bin_turns[i])).sum();
            let positive: u64 = episodes.clone().map(|m| u64::from(m.bin_positive[i])).sum();
            let belief: f64 = episodes.clone().map(|m| m.bin_belief_sum[i]).sum();
            let bin = ReliabilityBin {
                lo: i as f64 / BINS as f64,
                hi: (i + 1) as f64 / BINS as f64,
                turns,
                mean_belief: if turns == 0 { f64::NAN } else { belief / turns as f64 },
                observed: ratio(positive, turns),
            };
            if turns > 0 {
                total += turns;
                gap += turns as f64 * (bin.mean_belief - bin.observed).abs();
            }
            reliability.push(bin);
        }
        let with_evidence: Vec<f64> =
            episodes.clone().filter_map(|m| m.converged).map(|c| f64::from(u8::from(!c))).collect();
        BeliefSummary {
            brier_before: avg(|m| m.brier_before),
            brier_after: avg(|m| m.brier_after),
            ideal_brier_before: avg(|m| m.ideal_brier_before),
            ideal_brier_after: avg(|m| m.ideal_brier_after),
            lag: avg(|m| m.lag.map(f64::from)),
            never_converged: crate::stats::mean(&with_evidence),
            consistency: ratio(sum(|m| m.consistent_turns), sum(|m| m.decisive_turns)),
            probe_error_rate: ratio(sum(|m| m.probe_errors), sum(|m| m.stated_turns + m.probe_errors)),
            calibration_error: if total == 0 { f64::NAN } else { gap / total as f64 },
            reliability,
        }
    }
}

/// The belief metrics as table fields: what every belief table shows after
/// its key columns (eval's summary, the baselines table, the report).
pub(crate) fn fields() -> Vec<crate::export::Field<'static, BeliefSummary>> {
    use crate::export::{Column, Field};
    type F = Field<'static, BeliefSummary>;
    let field = |header: &str, key: &str, value: fn(&BeliefSummary) -> f64| F::float(Column::new(header, key), value);
    vec![
        field("Brier before", "brier_before", |b| b.brier_before),
        field("ideal before", "ideal_brier_before", |b| b.ideal_brier_before),
        field("Brier after", "brier_after", |b| b.brier_after),
        field("ideal after", "ideal_brier_after", |b| b.ideal_brier_after),
        field("belief lag", "belief_lag", |b| b.lag),
        field("never converged", "never_converged", |b| b.never_converged),
        field("consistency", "belief_action_consistency", |b| b.consistency),
        field("calibration error", "calibration_error", |b| b.calibration_error),
        field("probe errors", "probe_error_rate", |b| b.probe_error_rate),
    ]
}

/// The note under every belief table: what the columns mean.
pub const TABLE_NOTE: &str = "belief = stated P(the other road user lets the ego pass first). Brier before / after the \
evidence turn, the ideal observer's beside it (0.25 and 0 without noise; a stated Brier below the ideal before the \
evidence is lucky overconfidence). Belief lag: turns from the evidence until the belief is within 0.2 of the truth \
(never converged: share of episodes where it never was). Consistency: share of turns with belief > 0.7 answered \
with proceed, or < 0.3 answered with another maneuver. Calibration error: turn-weighted gap between the mean \
belief and the observed frequency over 10 bins.";

#[cfg(test)]
mod tests {
    use super::*;
    use crate::noise::{NoisyReading, noise_cdf, posterior_true, reading_likelihood, readings_llr};

    #[test]
    fn every_belief_prompt_is_neutral_and_a_leak_is_caught() {
        for kind in ScenarioKind::ALL {
            let prompt = format!("{}{}", crate::instructions::SYSTEM_PROMPT, prompt_paragraph(kind));
            assert_eq!(check_neutral(&prompt), Ok(()), "{kind}");
        }
        let leaky = "your probability that the other car is a yielder rather than committed";
        assert_eq!(check_neutral(leaky), Err(vec!["committed".to_string(), "yielder".to_string()]));
        assert_eq!(check_neutral("Is the pedestrian going to DART out?"), Err(vec!["dart".to_string()]));
        // Every disposition a scenario declares is a leak word, as is its name with spaces.
        assert_eq!(check_neutral("the lane car makes room"), Err(vec!["makes room".to_string()]));
        let words = leak_words();
        for d in crate::scenario::Disposition::all() {
            assert!(words.iter().any(|w| w == d.name()), "{d}");
        }
    }

    #[test]
    fn the_noise_cdf_is_the_irwin_hall_cdf() {
        assert_eq!(noise_cdf(-6.0), 0.0);
        assert_eq!(noise_cdf(6.5), 1.0);
        assert!((noise_cdf(0.0) - 0.5).abs() < 1e-12);
        // Below -5 only the first term is non-zero: (x+6)^12 / 12!.
        let x: f64 = -5.5;
        assert!((noise_cdf(x) - 0.5f64.powi(12) / 479_001_600.0).abs() < 1e-24);
        // Symmetric, monotone, and close to the normal CDF it approximates
        // (Phi(1) = 0.841345; lighter tails put it 0.002 lower).
        let mut prev = 0.0;
        for i in -70..=70 {
            let x = f64::from(i) / 10.0;
            let f = noise_cdf(x);
            assert!(f >= prev - 1e-15, "{x}");
            assert!((f + noise_cdf(-x) - 1.0).abs() < 1e-12, "{x}");
            prev = f;
        }
        assert!((noise_cdf(1.0) - 0.841_345).abs() < 3e-3, "{}", noise_cdf(1.0));
        // It matches the empirical CDF of the simulator's noise.
        let mut rng = crate::rng::EpisodeRng::new(&[3], crate::rng::Stream::ObservationNoise);
        let draws: Vec<f64> = (0..40_000).map(|_| rng.standard_noise()).collect();
        for x in [-1.5, -0.3, 0.7, 2.0] {
            let empirical = draws.iter().filter(|&&d| d <= x).count() as f64 / draws.len() as f64;
            assert!((empirical - noise_cdf(x)).abs() < 0.01, "{x}: {empirical} vs {}", noise_cdf(x));
        }
    }

    #[test]
    fn readings_move_the_posterior_toward_the_truth_that_fits() {
        let reading = |shown: f64, truth: f64| NoisyReading { shown, truth, sd: 1.0, floor: None };
        // Same truths: no information.
        assert_eq!(readings_llr(&[reading(3.04, 3.0)], &[reading(9.9, 3.0)]), 0.0);
        // The reading sits on the real truth, 2 sd from the other.
        let llr = readings_llr(&[reading(3.0, 3.0)], &[reading(0.0, 5.0)]);
        assert!(llr > 1.0 && posterior_true(llr) > 0.75, "{llr}");
        // Beyond 6 sd the other truth is impossible.
        assert_eq!(posterior_true(readings_llr(&[reading(3.0, 3.0)], &[reading(0.0, 9.5)])), 1.0);
        // A clamped speed: printed 0.0 carries the mass below the floor.
        let clamped = reading_likelihood(0.0, -0.5, 1.0, Some(0.0));
        assert!((clamped - noise_cdf(0.55)).abs() < 1e-12);
        assert!((reading_likelihood(0.0, -0.5, 1.0, None) - (noise_cdf(0.55) - noise_cdf(0.45))).abs() < 1e-12);
        assert_eq!(posterior_true(0.0), 0.5);
    }

    fn turn(turn: u32, stated: Option<f64>, ideal: f64, maneuver: Maneuver) -> BeliefTurn {
        BeliefTurn { turn, stated, ideal, maneuver: Some(maneuver), open: true }
    }

    #[test]
    fn metrics_split_at_the_evidence_turn() {
        use Maneuver::*;
        let turns = [
            turn(1, Some(0.5), 0.5, Yield),
            turn(2, Some(0.9), 0.5, Proceed),
            turn(3, Some(0.6), 1.0, Yield),
            turn(4, None, 1.0, Stop),
            turn(5, Some(0.85), 1.0, Yield),
            turn(6, Some(0.1), 1.0, Stop),
        ];
        let m = BeliefMetrics::compute(&turns, true, Some(3));
        assert_eq!((m.stated_turns, m.probe_errors), (5, 1));
        assert!((m.brier_before.unwrap() - (0.25 + 0.01) / 2.0).abs() < 1e-12);
        assert!((m.brier_after.unwrap() - (0.16 + 0.0225 + 0.81) / 3.0).abs() < 1e-12);
        assert_eq!((m.ideal_brier_before, m.ideal_brier_after), (Some(0.25), Some(0.0)));
        // Within 0.2 of 1 first at turn 5: two turns after the evidence.
        assert_eq!((m.lag, m.converged), (Some(2), Some(true)));
        // Decisive: 0.9 proceed (agrees), 0.85 yield (disagrees), 0.1 stop (agrees).
        assert_eq!((m.decisive_turns, m.consistent_turns), (3, 2));
        // Once the conflict is settled a turn no longer counts.
        let mut settled = turns;
        settled[5].open = false;
        let m = BeliefMetrics::compute(&settled, true, Some(3));
        assert_eq!((m.decisive_turns, m.consistent_turns), (2, 1));
        assert_eq!(m.bin_turns, [0, 1, 0, 0, 0, 1, 1, 0, 1, 1]);
        assert_eq!(m.bin_positive, m.bin_turns);
        // No evidence turn: everything is "before", no lag.
        let m = BeliefMetrics::compute(&turns, false, None);
        assert_eq!((m.brier_after, m.lag, m.converged), (None, None, None));
        assert!((m.brier_before.unwrap() - (0.25 + 0.81 + 0.36 + 0.7225 + 0.01) / 5.0).abs() < 1e-12);
        // Never within tolerance after the evidence.
        let m = BeliefMetrics::compute(&turns[..3], true, Some(3));
        assert_eq!((m.lag, m.converged), (None, Some(false)));
    }

    #[test]
    fn a_summary_pools_turns_for_rates_and_the_diagram() {
        use Maneuver::*;
        let a = BeliefMetrics::compute(
            &[turn(1, Some(0.95), 1.0, Proceed), turn(2, Some(0.95), 1.0, Proceed)],
            true,
            Some(1),
        );
        let b = BeliefMetrics::compute(&[turn(1, Some(0.95), 0.0, Stop), turn(2, None, 0.0, Stop)], false, Some(1));
        let s = BeliefSummary::of([a, b].iter());
        let top = s.reliability[BINS - 1];
        assert_eq!(top.turns, 3);
        assert!((top.mean_belief - 0.95).abs() < 1e-12);
        assert!((top.observed - 2.0 / 3.0).abs() < 1e-12);
        assert!((s.calibration_error - (0.95 - 2.0 / 3.0)).abs() < 1e-12);
        assert!((s.consistency - 2.0 / 3.0).abs() < 1e-12);
        assert!((s.probe_error_rate - 0.25).abs() < 1e-12);
        assert!((s.never_converged - 0.5).abs() < 1e-12);
        assert!(s.reliability[0].mean_belief.is_nan());
    }
}
