//! The observation noise of a noisy tier and the ideal observer's
//! likelihoods: what a world draws its noisy readings with and what the
//! episode weighs them by. A leaf module (it uses nothing above it), so the
//! worlds, the episode and the belief probe all use it without a loop.

/// A reading as the scene text prints it: `observation::round_to` at one
/// digit, repeated here so the noise model needs nothing above it (a test
/// holds the two equal).
fn printed(x: f64) -> f64 {
    let scale = 10f64.powi(PRINTED_DIGITS);
    let r = (x * scale).round() / scale;
    if r == 0.0 { 0.0 } else { r }
}

/// Digits the scene text prints every reading with.
const PRINTED_DIGITS: i32 = 1;

/// One reading shown through observation noise: the value drawn (before
/// printing), the truth behind it, and the noise model that drew it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoisyReading {
    pub shown: f64,
    pub truth: f64,
    /// Standard deviation of the additive noise (the standardised
    /// Irwin-Hall noise of [`crate::rng::EpisodeRng::standard_noise`]).
    pub sd: f64,
    /// Shown values are clamped at this floor (speeds at 0), if any.
    pub floor: Option<f64>,
}

/// CDF of the standardised Irwin-Hall noise (the sum of 12 uniforms minus
/// 6), exact: F(x) = 1/12! sum_k (-1)^k C(12,k) (x+6-k)^12 over k <= x+6.
/// The upper half uses the symmetry F(x) = 1 - F(-x), which keeps the
/// alternating sum short and free of cancellation.
pub fn noise_cdf(x: f64) -> f64 {
    const N: i32 = 12;
    if x.is_nan() {
        return f64::NAN;
    }
    if x > 0.0 {
        return 1.0 - noise_cdf(-x);
    }
    let s = x + 6.0;
    if s <= 0.0 {
        return 0.0;
    }
    let factorial: f64 = (1..=N).map(f64::from).product();
    let mut binom = 1.0;
    let mut sum = 0.0;
    for k in 0..=(s.floor() as i32).min(N) {
        if k > 0 {
            binom *= f64::from(N - k + 1) / f64::from(k);
        }
        let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
        sum += sign * binom * (s - f64::from(k)).powi(N);
    }
    (sum / factorial).clamp(0.0, 1.0)
}

/// Probability of the *printed* reading given a truth: the noise mass over
/// the printed value's rounding bin (plus the clamped mass when the
/// printed value is the floor). Exact for the simulator's noise; the only
/// approximation is floating point.
pub fn reading_likelihood(printed: f64, truth: f64, sd: f64, floor: Option<f64>) -> f64 {
    let half = 0.5 * 10f64.powi(-PRINTED_DIGITS);
    let (lo, hi) = (printed - half, printed + half);
    if sd <= 0.0 {
        return f64::from(u8::from((lo..hi).contains(&truth)));
    }
    let cdf = |v: f64| noise_cdf((v - truth) / sd);
    match floor {
        Some(f) if printed <= f + half => cdf(hi),
        _ => cdf(hi) - cdf(lo),
    }
}

/// The log-likelihood ratio one turn's readings add for the true
/// disposition against the other: `shown` and `truth` from the real world,
/// `other_truth` from the twin. +infinity when the other disposition could
/// not have produced what was printed.
pub fn readings_llr(real: &[NoisyReading], twin: &[NoisyReading]) -> f64 {
    let mut llr = 0.0;
    for (r, t) in real.iter().zip(twin) {
        let printed = printed(r.shown);
        let l_true = reading_likelihood(printed, r.truth, r.sd, r.floor);
        let l_other = reading_likelihood(printed, t.truth, r.sd, r.floor);
        if l_other <= 0.0 {
            return f64::INFINITY;
        }
        if l_true > 0.0 {
            llr += (l_true / l_other).ln();
        }
    }
    llr
}

/// Posterior probability of the true disposition from a log-likelihood
/// ratio and the 0.5 prior.
pub fn posterior_true(llr: f64) -> f64 {
    if llr == f64::INFINITY { 1.0 } else { 1.0 / (1.0 + (-llr).exp()) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn printed_is_the_scene_texts_rounding(x in -1.0e6f64..1.0e6) {
            prop_assert_eq!(printed(x).to_bits(), crate::observation::round_to(x, PRINTED_DIGITS).to_bits());
        }
    }
}
