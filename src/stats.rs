//! Statistics for benchmark reports: confidence intervals (normal
//! approximation, percentile bootstrap, clustered and paired
//! bootstrap), the exact McNemar test and the unbiased pass^k estimator.
//!
//! Everything is deterministic: resampling uses a `ChaCha8Rng` seeded with
//! the caller's seed, and index draws use Lemire's unbiased
//! multiply-shift method on `next_u64`, so results do not depend on the
//! sampling algorithms of a particular `rand` version.
//!
//! Conventions: all intervals are two-sided 95% intervals. Functions never
//! panic on empty or degenerate input; where a quantity is undefined they
//! return NaN, as documented on each function.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use statrs::function::factorial::ln_binomial;

/// Two-sided 97.5% standard-normal quantile, Φ⁻¹(0.975), used for 95% intervals.
pub(crate) const Z_95: f64 = 1.959963984540054;

/// Lower and upper tail probabilities of the 95% percentile interval.
const LO_Q: f64 = 0.025;
const HI_Q: f64 = 0.975;

/// A point estimate with a confidence interval `[lo, hi]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Interval {
    pub estimate: f64,
    pub lo: f64,
    pub hi: f64,
}

impl Interval {
    const NAN: Interval = Interval { estimate: f64::NAN, lo: f64::NAN, hi: f64::NAN };
}

/// Errors from the statistics functions.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum StatsError {
    /// Paired samples must have the same length.
    #[error("paired samples differ in length: {a} vs {b}")]
    LengthMismatch { a: usize, b: usize },
}

/// Arithmetic mean `Σxᵢ / n`; NaN for an empty slice.
pub(crate) fn mean(xs: &[f64]) -> f64 {
    if xs.is_empty() {
        return f64::NAN;
    }
    xs.iter().sum::<f64>() / xs.len() as f64
}

/// Wald (normal-approximation) 95% interval for a proportion.
///
/// `p̂ = successes / n`, bounds `p̂ ± Z_95 · √(p̂(1 − p̂)/n)` clamped to
/// `[0, 1]`. The estimate is `p̂`. Returns all-NaN when `n = 0` or
/// `successes > n` (undefined proportion).
pub(crate) fn normal_ci_proportion(successes: usize, n: usize) -> Interval {
    if n == 0 || successes > n {
        return Interval::NAN;
    }
    let nf = n as f64;
    let p = successes as f64 / nf;
    let half = Z_95 * (p * (1.0 - p) / nf).sqrt();
    Interval { estimate: p, lo: (p - half).clamp(0.0, 1.0), hi: (p + half).clamp(0.0, 1.0) }
}

/// Normal-approximation 95% interval for a mean.
///
/// `x̄ ± Z_95 · s/√n`, where `s` is the sample standard deviation with the
/// `n − 1` denominator. For `n = 1` the spread is undefined and the result
/// is `lo = hi = x̄`; for `n = 0` everything is NaN.
pub(crate) fn normal_ci_mean(xs: &[f64]) -> Interval {
    let n = xs.len();
    let m = mean(xs);
    if n < 2 {
        return Interval { estimate: m, lo: m, hi: m };
    }
    let ss: f64 = xs.iter().map(|x| (x - m) * (x - m)).sum();
    let s = (ss / (n - 1) as f64).sqrt();
    let half = Z_95 * s / (n as f64).sqrt();
    Interval { estimate: m, lo: m - half, hi: m + half }
}

/// Sample quantile of an ascending-sorted slice, Hyndman–Fan type 7 (the
/// default of R and numpy): with `h = (n − 1)·q`, `j = ⌊h⌋`,
/// `Q(q) = x[j] + (h − j)·(x[j+1] − x[j])` (0-based; `x[j]` when `j = n − 1`).
///
/// Returns NaN for an empty slice or `q` outside `[0, 1]` (or NaN). The
/// caller guarantees the slice is sorted ascending.
pub(crate) fn quantile(sorted: &[f64], q: f64) -> f64 {
    let n = sorted.len();
    if n == 0 || !(0.0..=1.0).contains(&q) {
        return f64::NAN;
    }
    let h = (n - 1) as f64 * q;
    let j = (h.floor() as usize).min(n - 1);
    let frac = h - j as f64;
    if j + 1 >= n || frac == 0.0 {
        return sorted[j];
    }
    sorted[j] + frac * (sorted[j + 1] - sorted[j])
}

/// Uniform indices in `[0, n)`, `n ≥ 1`, by Lemire's multiply-shift method
/// with rejection ("Fast random integer generation in an interval", 2019),
/// exactly unbiased: a uniform `L`-bit word `w` gives `m = w·n`; it is
/// rejected iff `m mod 2^L < (2^L − n) mod n`, else the index is `⌊m / 2^L⌋`.
///
/// Words are cut from `next_u64` outputs, low bits first, `L = 16` bits at a
/// time when `n ≤ 2¹²` (rejection probability < 1/16), 32 when `n ≤ 2³²`,
/// else 64; bits left in the last word of a [`IndexSampler::fill`] are
/// discarded.
/// The one index sampler of the crate's bootstraps (the report's clustered
/// interval draws its clusters with it too).
#[derive(Debug, Clone, Copy)]
pub(crate) struct IndexSampler {
    n: u64,
    bits: u32,
    threshold: u64,
}

const fn low_mask(bits: u32) -> u64 {
    if bits >= 64 { u64::MAX } else { (1 << bits) - 1 }
}

impl IndexSampler {
    pub(crate) fn new(n: u64) -> Self {
        debug_assert!(n >= 1);
        let bits = match n {
            0..=0x1000 => 16,
            0x1001..=0x1_0000_0000 => 32,
            _ => 64,
        };
        // (2^L − n) mod n, computed in L-bit wrapping arithmetic.
        let threshold = (n.wrapping_neg() & low_mask(bits)) % n;
        IndexSampler { n, bits, threshold }
    }

    /// Maps the low `BITS` bits of `w` to an index, or `None` if rejected.
    #[inline(always)]
    fn map<const BITS: u32>(&self, w: u64) -> Option<u64> {
        let w = w & low_mask(BITS);
        let (low, index) = if BITS <= 32 {
            let m = w * self.n; // < 2^32 · 2^32: no overflow
            (m & low_mask(BITS), m >> BITS)
        } else {
            let m = u128::from(w) * u128::from(self.n);
            (m as u64, (m >> 64) as u64)
        };
        (low >= self.threshold).then_some(index)
    }

    /// Fills `out` with independent uniform indices.
    pub(crate) fn fill<R: Rng + ?Sized>(&self, rng: &mut R, out: &mut [usize]) {
        match self.bits {
            16 => self.fill_with::<16, R>(rng, out),
            32 => self.fill_with::<32, R>(rng, out),
            _ => self.fill_with::<64, R>(rng, out),
        }
    }

    fn fill_with<const BITS: u32, R: Rng + ?Sized>(&self, rng: &mut R, out: &mut [usize]) {
        let mut k = 0;
        while k < out.len() {
            let mut w = rng.next_u64();
            for _ in 0..64 / BITS {
                if let Some(i) = self.map::<BITS>(w) {
                    out[k] = i as usize;
                    k += 1;
                    if k == out.len() {
                        return;
                    }
                }
                w = w.checked_shr(BITS).unwrap_or(0);
            }
        }
    }
}

/// `Σ_j xs[idx[j]]`, with four interleaved partial sums (fixed order, so
/// deterministic) to avoid one long floating-point dependency chain.
fn sum_indexed(xs: &[f64], idx: &[usize]) -> f64 {
    let mut acc = [0.0; 4];
    let chunks = idx.chunks_exact(4);
    let rest = chunks.remainder();
    for c in chunks {
        for (a, &i) in acc.iter_mut().zip(c) {
            *a += xs[i];
        }
    }
    for (a, &i) in acc.iter_mut().zip(rest) {
        *a += xs[i];
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3])
}

/// Sorts the replicate statistics and returns their type-7 quantiles at
/// 0.025 and 0.975, clamped to `[min, max]` (the range any statistic of the
/// resample can take; clamping only removes floating-point rounding).
fn percentile_bounds(mut stats: Vec<f64>, min: f64, max: f64) -> (f64, f64) {
    stats.sort_unstable_by(f64::total_cmp);
    let lo = quantile(&stats, LO_Q).clamp(min, max);
    let hi = quantile(&stats, HI_Q).clamp(min, max);
    (lo, hi)
}

fn min_max<'a>(xs: impl IntoIterator<Item = &'a f64>) -> (f64, f64) {
    xs.into_iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| (lo.min(x), hi.max(x)))
}

/// Percentile-bootstrap 95% interval for the mean.
///
/// Estimate: the sample mean `x̄`. Draw `resamples` resamples of size `n`
/// with replacement (indices uniform, `ChaCha8Rng::seed_from_u64(seed)`),
/// compute each resample's mean, sort, and take the type-7 [`quantile`]s at
/// 0.025 and 0.975. Estimate and bounds are clamped to `[min xᵢ, max xᵢ]`,
/// which only removes floating-point rounding.
///
/// NaN semantics: `n = 0` gives all-NaN; `resamples = 0` gives NaN bounds;
/// if any value is non-finite the bounds are NaN (and the estimate is the
/// plain mean). The percentile interval need not contain `x̄` in general,
/// though it does for any non-degenerate sample in practice.
pub(crate) fn bootstrap_mean_ci(xs: &[f64], resamples: usize, seed: u64) -> Interval {
    let n = xs.len();
    if n == 0 {
        return Interval::NAN;
    }
    let m = mean(xs);
    if xs.iter().any(|x| !x.is_finite()) {
        return Interval { estimate: m, lo: f64::NAN, hi: f64::NAN };
    }
    let (min, max) = min_max(xs);
    let estimate = m.clamp(min, max);
    if resamples == 0 {
        return Interval { estimate, lo: f64::NAN, hi: f64::NAN };
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let sampler = IndexSampler::new(n as u64);
    let mut idx = vec![0usize; n];
    let nf = n as f64;
    let stats: Vec<f64> = (0..resamples)
        .map(|_| {
            sampler.fill(&mut rng, &mut idx);
            sum_indexed(xs, &idx) / nf
        })
        .collect();
    let (lo, hi) = percentile_bounds(stats, min, max);
    Interval { estimate, lo, hi }
}

/// Paired percentile-bootstrap 95% interval for `mean(a − b)`.
///
/// Forms the differences `dᵢ = aᵢ − bᵢ` and returns
/// [`bootstrap_mean_ci`]`(d, resamples, seed)`, i.e. resamples pairs, so
/// the between-pair variation shared by `a` and `b` cancels. Returns
/// [`StatsError::LengthMismatch`] if the lengths differ; NaN semantics
/// otherwise as [`bootstrap_mean_ci`].
pub(crate) fn paired_bootstrap_diff_ci(
    a: &[f64],
    b: &[f64],
    resamples: usize,
    seed: u64,
) -> Result<Interval, StatsError> {
    if a.len() != b.len() {
        return Err(StatsError::LengthMismatch { a: a.len(), b: b.len() });
    }
    let d: Vec<f64> = a.iter().zip(b).map(|(x, y)| x - y).collect();
    Ok(bootstrap_mean_ci(&d, resamples, seed))
}

/// Exact two-sided McNemar test p-value from the discordant counts
/// `b` (first system succeeded, second failed) and `c` (the reverse).
///
/// `p = min(1, 2·P(X ≤ min(b, c)))` with `X ~ Binomial(b + c, 1/2)`;
/// `p = 1` when `b + c = 0`. The tail sum is computed relative to its
/// largest term `C(n, m)/2ⁿ` (the terms increase up to `m = min(b,c) ≤ n/2`),
/// whose logarithm comes from log-factorials, so large `n` neither
/// overflows nor loses relative precision; p-values below ~1e-308
/// underflow to 0.
pub fn mcnemar_exact(b: usize, c: usize) -> f64 {
    let n = b as u64 + c as u64;
    if n == 0 {
        return 1.0;
    }
    let m = b.min(c) as u64;
    // Σ_{k ≤ m} C(n,k) / C(n,m), accumulated downward from k = m using
    // C(n,k−1)/C(n,k) = k/(n−k+1).
    let mut ratio = 1.0;
    let mut sum = 1.0;
    let mut k = m;
    while k > 0 {
        ratio *= k as f64 / (n - k + 1) as f64;
        sum += ratio;
        if ratio < sum * f64::EPSILON * 1e-3 {
            break;
        }
        k -= 1;
    }
    let log_p = std::f64::consts::LN_2 + ln_binomial(n, m) - n as f64 * std::f64::consts::LN_2 + sum.ln();
    log_p.exp().min(1.0)
}

/// Wilson score 95% interval for a proportion of `successes` in `n`
/// (Wilson 1927): centre `(p̂ + z²/2n) / (1 + z²/n)`, half-width
/// `z √(p̂(1 − p̂)/n + z²/4n²) / (1 + z²/n)`, `z` = [`Z_95`]. Unlike the
/// percentile bootstrap it does not collapse at 0 or 1: at `successes = n`
/// it is `[n / (n + z²), 1]`. All-NaN when `n = 0` or `successes > n`.
pub(crate) fn wilson_ci(successes: f64, n: f64) -> Interval {
    if n <= 0.0 || !(0.0..=n).contains(&successes) {
        return Interval::NAN;
    }
    let p = successes / n;
    let z2 = Z_95 * Z_95;
    let denom = 1.0 + z2 / n;
    let centre = (p + z2 / (2.0 * n)) / denom;
    let half = Z_95 * (p * (1.0 - p) / n + z2 / (4.0 * n * n)).sqrt() / denom;
    Interval { estimate: p, lo: (centre - half).max(0.0), hi: (centre + half).min(1.0) }
}

/// The success interval of a set of units (a unit is a seed; its value is
/// its success rate over its rollouts, in `[0, 1]`): the percentile
/// bootstrap over the units ([`bootstrap_mean_ci`]), except when every unit
/// has the same value 0 or 1, where the bootstrap collapses to a point
/// ("1.00 [1.00, 1.00]" from two seeds reads as certainty): then the
/// Wilson score interval ([`wilson_ci`]) of `k·n` successes in `n` units,
/// `n` the number of seeds (rollouts of a seed are not independent, so
/// they do not add to `n`). [`collapsed`] tells which rule applied.
///
/// When every unit has the same other value the resampling is skipped: the
/// bootstrap gives that value three times anyway (its bounds are clamped
/// to the values' range).
pub(crate) fn success_ci(units: &[f64], resamples: usize, seed: u64) -> Interval {
    match collapsed(units) {
        Some(k) if resamples > 0 => wilson_ci(k * units.len() as f64, units.len() as f64),
        _ => match constant(units) {
            Some(v) if resamples > 0 => Interval { estimate: v, lo: v, hi: v },
            _ => bootstrap_mean_ci(units, resamples, seed),
        },
    }
}

/// The value every element of `xs` has, when they all have the same finite
/// one (a bootstrap of them is that value three times).
pub(crate) fn constant(xs: &[f64]) -> Option<f64> {
    let first = *xs.first()?;
    (first.is_finite() && xs.iter().all(|&x| x == first)).then_some(first)
}

/// The success interval of one (scenario, tier) cell: [`success_ci`] over
/// its seeds' success rates (in seed order) with the cell's own seed,
/// [`cell_seed`]. The one implementation `eval`'s summary (base 0) and
/// `report`'s tables (base `--seed`) both use, so they agree digit for
/// digit.
pub(crate) fn cell_success_ci(seed_rates: &[f64], resamples: usize, base: u64, scenario: &str, tier: u8) -> Interval {
    success_ci(seed_rates, resamples, cell_seed(base, scenario, tier))
}

/// `Some(0.0)` or `Some(1.0)` when every unit is 0, or every unit is 1 (the
/// bootstrap would collapse there), else `None`.
pub(crate) fn collapsed(units: &[f64]) -> Option<f64> {
    let first = *units.first()?;
    ((first == 0.0 || first == 1.0) && units.iter().all(|&x| x == first)).then_some(first)
}

/// Discordant pairs per shared key that a paired comparison needs, in
/// shared keys, for 80% power at two-sided level 0.05 with the exact
/// McNemar test, by Connor's (1987) normal approximation:
///
/// `n = (z_{α/2} √ψ + z_β √(ψ − δ²))² / δ²`, with `ψ = p₁₀ + p₀₁` the
/// discordant share, `δ = p₁₀ − p₀₁` the difference (here the observed
/// shares `a_only / keys` and `b_only / keys`), `z_{α/2} = 1.959964`,
/// `z_β = 0.841621` (β = 0.2). Rounded up. `None` when the observed
/// difference is 0 (no finite sample separates it) or there are no keys.
pub(crate) fn mcnemar_keys_for_power(a_only: usize, b_only: usize, keys: usize) -> Option<u64> {
    if keys == 0 || a_only == b_only {
        return None;
    }
    const Z_BETA_80: f64 = 0.8416212335729143;
    let (p10, p01) = (a_only as f64 / keys as f64, b_only as f64 / keys as f64);
    let psi = p10 + p01;
    let delta = p10 - p01;
    let root = Z_95 * psi.sqrt() + Z_BETA_80 * (psi - delta * delta).max(0.0).sqrt();
    Some((root * root / (delta * delta)).ceil() as u64)
}

/// Unbiased pass^k estimator for one seed with `c` successes among `r`
/// rollouts: `C(c, k) / C(r, k)`, the probability that `k` rollouts drawn
/// without replacement all succeed.
///
/// Computed as the product `Π_{i<k} (c − i)/(r − i)` (no overflow).
/// `c < k` gives 0, `k = 0` gives 1; `k > r` or `c > r` gives NaN.
pub(crate) fn pass_hat_k(c: usize, r: usize, k: usize) -> f64 {
    if k > r || c > r {
        return f64::NAN;
    }
    if c < k {
        return 0.0;
    }
    (0..k).map(|i| (c - i) as f64 / (r - i) as f64).product()
}

/// Mean of [`pass_hat_k`] over seeds, each given as `(successes, rollouts)`:
/// `(1/S) Σ_s C(c_s, k)/C(r_s, k)`. NaN if `per_seed` is empty or any seed
/// has `k > r_s` or `c_s > r_s`.
pub(crate) fn mean_pass_hat_k(per_seed: &[(usize, usize)], k: usize) -> f64 {
    if per_seed.is_empty() {
        return f64::NAN;
    }
    per_seed.iter().map(|&(c, r)| pass_hat_k(c, r, k)).sum::<f64>() / per_seed.len() as f64
}

/// Seed of the statistic named `label`, shifted by the user's `--seed`
/// (`base`): each statistic has its own fixed seed, so adding a model never
/// changes another model's interval.
pub fn seed_for(base: u64, label: &str) -> u64 {
    crate::hash::fnv1a64(label) ^ base.wrapping_mul(crate::hash::GOLDEN_GAMMA)
}

/// Seed of a (scenario, tier) cell's success interval: `eval`'s summary
/// (base 0) and `report` use this one seed, so they agree digit for digit.
/// `scenario` is the scenario's name and `tier` its number (statistics know
/// no scenario types).
pub fn cell_seed(base: u64, scenario: &str, tier: u8) -> u64 {
    seed_for(base, &format!("{scenario}/{tier}"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const B: usize = 10_000;

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    /// `n` Bernoulli values with exactly `ones` ones, interleaved
    /// deterministically (Bresenham spacing).
    fn bernoulli(ones: usize, n: usize) -> Vec<f64> {
        (0..n).map(|i| if (i + 1) * ones / n > i * ones / n { 1.0 } else { 0.0 }).collect()
    }

    #[test]
    fn normal_proportion_half() {
        let iv = normal_ci_proportion(50, 100);
        assert_eq!(iv.estimate, 0.5);
        // 1.959963984540054 * sqrt(0.25 / 100) = 0.0979981992270027
        assert!(close(iv.lo, 0.5 - 0.0979981992270027, 1e-12), "{iv:?}");
        assert!(close(iv.hi, 0.5 + 0.0979981992270027, 1e-12), "{iv:?}");
        assert!(close(iv.hi - 0.5, 0.098, 1e-4));
    }

    #[test]
    fn normal_proportion_degenerate_and_clamped() {
        let iv = normal_ci_proportion(10, 10);
        assert_eq!((iv.estimate, iv.lo, iv.hi), (1.0, 1.0, 1.0));
        let iv = normal_ci_proportion(0, 10);
        assert_eq!((iv.estimate, iv.lo, iv.hi), (0.0, 0.0, 0.0));
        let iv = normal_ci_proportion(1, 10);
        assert_eq!(iv.lo, 0.0); // 0.1 - 0.186 clamped
        let iv = normal_ci_proportion(0, 0);
        assert!(iv.estimate.is_nan() && iv.lo.is_nan() && iv.hi.is_nan());
        assert!(normal_ci_proportion(3, 2).estimate.is_nan());
    }

    #[test]
    fn normal_mean_known_values() {
        // mean 3, s = sqrt(2.5), half = z * sqrt(2.5 / 5) = z * sqrt(0.5)
        let iv = normal_ci_mean(&[1.0, 2.0, 3.0, 4.0, 5.0]);
        let half = 1.959963984540054 * 0.5f64.sqrt();
        assert_eq!(iv.estimate, 3.0);
        assert!(close(iv.lo, 3.0 - half, 1e-12) && close(iv.hi, 3.0 + half, 1e-12));
        let one = normal_ci_mean(&[0.7]);
        assert_eq!((one.estimate, one.lo, one.hi), (0.7, 0.7, 0.7));
        let empty = normal_ci_mean(&[]);
        assert!(empty.estimate.is_nan() && empty.lo.is_nan() && empty.hi.is_nan());
    }

    #[test]
    fn quantile_type7_hand_computed() {
        let x = [1.0, 2.0, 3.0, 4.0];
        assert_eq!(quantile(&x, 0.25), 1.75); // h = 0.75
        assert_eq!(quantile(&x, 0.5), 2.5); // h = 1.5
        assert_eq!(quantile(&x, 0.75), 3.25); // h = 2.25
        assert_eq!(quantile(&x, 0.0), 1.0);
        assert_eq!(quantile(&x, 1.0), 4.0);
        // numpy.quantile([10, 20, 30, 40, 50], 0.025) = 11.0, 0.975 -> 49.0
        let y = [10.0, 20.0, 30.0, 40.0, 50.0];
        assert!(close(quantile(&y, 0.025), 11.0, 1e-12));
        assert!(close(quantile(&y, 0.975), 49.0, 1e-12));
        assert_eq!(quantile(&[7.0], 0.3), 7.0);
        assert!(quantile(&[], 0.5).is_nan());
        assert!(quantile(&x, 1.5).is_nan());
        assert!(quantile(&x, f64::NAN).is_nan());
    }

    #[test]
    fn bootstrap_degenerate_samples() {
        let iv = bootstrap_mean_ci(&[1.0; 50], B, 1);
        assert_eq!((iv.estimate, iv.lo, iv.hi), (1.0, 1.0, 1.0));
        let iv = bootstrap_mean_ci(&[0.0; 50], B, 1);
        assert_eq!((iv.estimate, iv.lo, iv.hi), (0.0, 0.0, 0.0));
        // Rounding of 0.1 sums is clamped away.
        let iv = bootstrap_mean_ci(&[0.1; 30], 100, 1);
        assert_eq!((iv.estimate, iv.lo, iv.hi), (0.1, 0.1, 0.1));
        let iv = bootstrap_mean_ci(&[], B, 1);
        assert!(iv.estimate.is_nan() && iv.lo.is_nan() && iv.hi.is_nan());
        let iv = bootstrap_mean_ci(&[0.0, 1.0], 0, 1);
        assert_eq!(iv.estimate, 0.5);
        assert!(iv.lo.is_nan() && iv.hi.is_nan());
        let iv = bootstrap_mean_ci(&[0.0, f64::NAN], B, 1);
        assert!(iv.lo.is_nan() && iv.hi.is_nan());
    }

    #[test]
    fn bootstrap_symmetric_sample() {
        let xs: Vec<f64> = (0..101).map(|i| i as f64 / 100.0).collect();
        let iv = bootstrap_mean_ci(&xs, B, 7);
        assert!(close(iv.estimate, 0.5, 1e-12));
        assert!(iv.lo < 0.5 && iv.hi > 0.5);
        let asym = (iv.hi - 0.5) - (0.5 - iv.lo);
        assert!(asym.abs() < 0.005, "{iv:?}");
    }

    #[test]
    fn bootstrap_agrees_with_normal_on_large_sample() {
        let xs = bernoulli(600, 2000);
        assert_eq!(xs.iter().sum::<f64>(), 600.0);
        let boot = bootstrap_mean_ci(&xs, 2000, 42);
        let norm = normal_ci_proportion(600, 2000);
        assert!(close(boot.estimate, 0.3, 1e-12));
        assert!(close(boot.lo, norm.lo, 0.01), "{boot:?} vs {norm:?}");
        assert!(close(boot.hi, norm.hi, 0.01), "{boot:?} vs {norm:?}");
        let nm = normal_ci_mean(&xs);
        assert!(close(boot.lo, nm.lo, 0.01) && close(boot.hi, nm.hi, 0.01));
    }

    #[test]
    fn bootstrap_seed_determinism() {
        // Continuous values so the replicate means are not on a coarse grid.
        let xs: Vec<f64> = (0..100).map(|i| ((i * 37) % 101) as f64 / 100.0).collect();
        let a = bootstrap_mean_ci(&xs, 2000, 9);
        let b = bootstrap_mean_ci(&xs, 2000, 9);
        let c = bootstrap_mean_ci(&xs, 2000, 10);
        assert_eq!(a, b);
        assert_ne!(a, c);
        assert_eq!(a.estimate, c.estimate);
        assert!(close(a.lo, c.lo, 0.03) && close(a.hi, c.hi, 0.03));
    }

    #[test]
    fn bootstrap_is_fast() {
        let xs = bernoulli(60, 200);
        let t = std::time::Instant::now();
        let iv = bootstrap_mean_ci(&xs, B, 5);
        let dt = t.elapsed();
        assert!(iv.lo < 0.3 && iv.hi > 0.3);
        // Generous bound so debug builds pass; release is a few ms.
        assert!(dt.as_secs_f64() < 2.0, "{dt:?}");
    }

    #[test]
    fn lemire_is_exactly_unbiased() {
        // Exhaustive over all 16-bit words: every index is hit equally often.
        for n in [1u64, 2, 3, 7, 200, 1000, 4096] {
            let sampler = IndexSampler::new(n);
            assert_eq!(sampler.bits, 16);
            let mut counts = vec![0u32; n as usize];
            for w in 0..=0xFFFFu64 {
                if let Some(i) = sampler.map::<16>(w) {
                    counts[i as usize] += 1;
                }
            }
            let expected = (1u32 << 16) / n as u32;
            assert!(counts.iter().all(|&c| c == expected), "n = {n}");
        }
        assert_eq!(IndexSampler::new(5000).bits, 32);
        assert_eq!(IndexSampler::new(1 << 32).bits, 32);
        assert_eq!(IndexSampler::new((1 << 32) + 1).bits, 64);
    }

    #[test]
    fn index_sampler_is_uniform() {
        let mut rng = ChaCha8Rng::seed_from_u64(0);
        // 16-, 32- and 64-bit paths; n = 3·s split into thirds by i / s.
        for s in [1usize, 2000, 1 << 40] {
            let n = 3 * s;
            let sampler = IndexSampler::new(n as u64);
            let mut idx = vec![0usize; 30_001]; // odd length: partial last word
            sampler.fill(&mut rng, &mut idx);
            let mut counts = [0usize; 3];
            for &i in &idx {
                assert!(i < n);
                counts[i / s] += 1;
            }
            for c in counts {
                assert!(close(c as f64, 10_000.0, 400.0), "{n}: {counts:?}");
            }
        }
        let mut one = [7usize; 5];
        IndexSampler::new(1).fill(&mut rng, &mut one);
        assert_eq!(one, [0; 5]);
    }

    #[test]
    fn sum_indexed_matches_plain_sum() {
        let xs = [1.0, 2.0, 4.0, 8.0, 16.0];
        assert_eq!(sum_indexed(&xs, &[]), 0.0);
        assert_eq!(sum_indexed(&xs, &[4]), 16.0);
        assert_eq!(sum_indexed(&xs, &[0, 1, 2, 3, 4, 4, 0]), 48.0);
    }

    #[test]
    fn paired_difference() {
        // Large between-pair spread, constant difference: pairing removes it.
        let b: Vec<f64> = (0..50).map(|i| ((i * 37) % 100) as f64).collect();
        let a: Vec<f64> = b.iter().map(|x| x + 1.0).collect();
        let iv = paired_bootstrap_diff_ci(&a, &b, B, 3).unwrap();
        assert_eq!((iv.estimate, iv.lo, iv.hi), (1.0, 1.0, 1.0));
        let iv = paired_bootstrap_diff_ci(&b, &b, B, 3).unwrap();
        assert_eq!((iv.estimate, iv.lo, iv.hi), (0.0, 0.0, 0.0));
        assert_eq!(paired_bootstrap_diff_ci(&a, &b[..49], B, 3), Err(StatsError::LengthMismatch { a: 50, b: 49 }));
        let iv = paired_bootstrap_diff_ci(&[], &[], B, 3).unwrap();
        assert!(iv.estimate.is_nan());
    }

    #[test]
    fn mcnemar_textbook_values() {
        // 2 * P(X <= 2), X ~ Bin(12, 1/2) = 2 * 79 / 4096
        assert!(close(mcnemar_exact(10, 2), 0.03857421875, 1e-14));
        assert!(close(mcnemar_exact(2, 10), 0.03857421875, 1e-14));
        assert_eq!(mcnemar_exact(5, 5), 1.0);
        assert_eq!(mcnemar_exact(0, 0), 1.0);
        // 2 * (1/2)^6
        assert!(close(mcnemar_exact(0, 6), 0.03125, 1e-15));
        assert!(close(mcnemar_exact(0, 1), 1.0, 1e-15));
    }

    #[test]
    fn mcnemar_large_counts() {
        use statrs::distribution::{Binomial, DiscreteCDF};
        let p = mcnemar_exact(3000, 2900);
        assert!(p.is_finite() && p > 0.0 && p <= 1.0);
        let reference = 2.0 * Binomial::new(0.5, 5900).unwrap().cdf(2900);
        assert!(close(p, reference, 1e-9), "{p} vs {reference}");
        // Normal approximation with continuity correction: z = 49.5/sqrt(1475).
        assert!(close(p, 0.1976, 0.01), "{p}");
        let tiny = mcnemar_exact(100, 400);
        assert!(tiny > 0.0 && tiny < 1e-40);
        assert_eq!(mcnemar_exact(1_000_000, 1_000_000), 1.0);
    }

    #[test]
    fn wilson_textbook_values() {
        // 0 of 10: [0, 0.2775]; 10 of 10: [0.7225, 1]; 5 of 10: [0.2366, 0.7634] (Newcombe 1998, table I style).
        let close = |a: f64, b: f64| (a - b).abs() < 5e-5;
        let w = wilson_ci(0.0, 10.0);
        assert!(close(w.lo, 0.0) && close(w.hi, 0.2775), "{w:?}");
        let w = wilson_ci(10.0, 10.0);
        assert!(close(w.lo, 0.7225) && close(w.hi, 1.0) && w.estimate == 1.0, "{w:?}");
        let w = wilson_ci(5.0, 10.0);
        assert!(close(w.lo, 0.2366) && close(w.hi, 0.7634), "{w:?}");
        assert!(wilson_ci(1.0, 0.0).lo.is_nan());
    }

    #[test]
    fn success_interval_falls_back_to_wilson_only_when_the_bootstrap_collapses() {
        // Two seeds, both successes: not [1, 1] but Wilson [2/(2+z²), 1] = [0.3424, 1].
        let iv = success_ci(&[1.0, 1.0], 10_000, 7);
        assert_eq!(iv.estimate, 1.0);
        assert!((iv.lo - 2.0 / (2.0 + Z_95 * Z_95)).abs() < 1e-12 && iv.hi == 1.0, "{iv:?}");
        let iv = success_ci(&[0.0; 20], 10_000, 7);
        assert!(iv.lo == 0.0 && (iv.hi - Z_95 * Z_95 / (20.0 + Z_95 * Z_95)).abs() < 1e-12, "{iv:?}");
        // Anything else is the bootstrap, unchanged; a constant 0.5 (rollout rates) too.
        let xs = [1.0, 0.0, 1.0, 1.0, 0.5];
        assert_eq!(success_ci(&xs, 2000, 3), bootstrap_mean_ci(&xs, 2000, 3));
        assert_eq!(success_ci(&[0.5, 0.5], 2000, 3), bootstrap_mean_ci(&[0.5, 0.5], 2000, 3));
        assert_eq!((collapsed(&[1.0, 1.0]), collapsed(&[0.5, 0.5]), collapsed(&[])), (Some(1.0), None, None));
    }

    #[test]
    fn power_by_connors_formula() {
        // p10 = 0.15, p01 = 0.05: psi 0.2, delta 0.1:
        // (1.959964 * sqrt(0.2) + 0.841621 * sqrt(0.19))^2 / 0.01 = 154.6 -> 155 keys.
        assert_eq!(mcnemar_keys_for_power(30, 10, 200), Some(155));
        // The same shares at another sample size need the same keys.
        assert_eq!(mcnemar_keys_for_power(15, 5, 100), Some(155));
        // Symmetric in direction; no difference -> no finite answer.
        assert_eq!(mcnemar_keys_for_power(10, 30, 200), Some(155));
        assert_eq!(mcnemar_keys_for_power(7, 7, 100), None);
        assert_eq!(mcnemar_keys_for_power(0, 0, 0), None);
        // A smaller difference needs more keys: p10 0.06, p01 0.04.
        let n = mcnemar_keys_for_power(6, 4, 100).unwrap();
        let expect = ((1.959964 * 0.1f64.sqrt() + 0.841621 * (0.1f64 - 0.0004).sqrt()).powi(2) / 0.0004).ceil();
        assert_eq!(n as f64, expect);
    }

    #[test]
    fn pass_hat_k_values() {
        assert_eq!(pass_hat_k(5, 5, 3), 1.0);
        assert_eq!(pass_hat_k(1, 5, 2), 0.0);
        assert!(close(pass_hat_k(3, 5, 2), 0.3, 1e-15)); // C(3,2)/C(5,2) = 3/10
        assert!(close(pass_hat_k(3, 5, 1), 0.6, 1e-15));
        assert_eq!(pass_hat_k(2, 5, 0), 1.0);
        assert!(pass_hat_k(2, 3, 4).is_nan());
        assert!(pass_hat_k(4, 3, 1).is_nan());
        // Large r without overflow: C(900,3)/C(1000,3).
        let exact = (900.0 * 899.0 * 898.0) / (1000.0 * 999.0 * 998.0);
        assert!(close(pass_hat_k(900, 1000, 3), exact, 1e-14));
        assert!(close(mean_pass_hat_k(&[(3, 5), (5, 5), (0, 5)], 2), 1.3 / 3.0, 1e-15));
        assert!(mean_pass_hat_k(&[], 2).is_nan());
    }

    #[test]
    fn interval_serde_roundtrip() {
        let iv = Interval { estimate: 0.5, lo: 0.25, hi: 0.75 };
        let s = serde_json::to_string(&iv).unwrap();
        assert_eq!(s, r#"{"estimate":0.5,"lo":0.25,"hi":0.75}"#);
        assert_eq!(serde_json::from_str::<Interval>(&s).unwrap(), iv);
    }

    proptest! {
        #[test]
        fn bootstrap_bounds_contain_estimate_within_range(
            xs in prop::collection::vec(0.0f64..=1.0, 1..60),
            seed in any::<u64>(),
        ) {
            let iv = bootstrap_mean_ci(&xs, 500, seed);
            let (min, max) = min_max(&xs);
            prop_assert!(iv.lo <= iv.estimate && iv.estimate <= iv.hi, "{:?}", iv);
            prop_assert!(min <= iv.lo && iv.hi <= max, "{:?} {} {}", iv, min, max);
        }

        #[test]
        fn mcnemar_in_unit_interval_and_symmetric(b in 0usize..400, c in 0usize..400) {
            let p = mcnemar_exact(b, c);
            prop_assert!(p > 0.0 && p <= 1.0);
            prop_assert_eq!(p, mcnemar_exact(c, b));
        }
    }
}
