//! The report's bootstraps: seeds, and the clustered interval for an
//! average over scenarios. Per-cell and paired intervals are those of
//! [`crate::stats`].
//!
//! Every interval is a percentile bootstrap 95% interval: the type-7
//! quantiles (`crate::stats::quantile`) at 0.025 and 0.975 of the sorted
//! replicate statistics. Each statistic has its own fixed seed derived from
//! what it is (so adding a model never changes another model's interval),
//! and a per-(scenario, tier) cell's interval is `eval`'s summary's, one
//! function (`stats::cell_success_ci`).

use crate::stats::{IndexSampler, Interval, StatsError, paired_bootstrap_diff_ci, quantile, wilson_ci};
pub use crate::stats::{cell_seed, seed_for};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// [`paired_bootstrap_diff_ci`], skipping the resampling when every
/// difference is the same.
pub(crate) fn paired_ci(a: &[f64], b: &[f64], resamples: usize, seed: u64) -> Result<Interval, StatsError> {
    if a.len() == b.len() && resamples > 0 {
        let d: Vec<f64> = a.iter().zip(b).map(|(x, y)| x - y).collect();
        if let Some(v) = crate::stats::constant(&d) {
            return Ok(Interval { estimate: v, lo: v, hi: v });
        }
    }
    paired_bootstrap_diff_ci(a, b, resamples, seed)
}

/// Clustered percentile-bootstrap 95% interval for the mean over groups of
/// the group means (the leaderboard's average over scenarios).
///
/// `clusters[c]` holds cluster `c`'s values as `(group, value)` pairs (a
/// cluster is a seed; its values are that seed's per-scenario, per-tier
/// successes; a group is a scenario). Estimate: `(1/G') Σ_g mean_g` over the
/// `G'` groups with values, `mean_g` pooling all values of group `g`. Each
/// replicate draws as many clusters as there are, with replacement, and
/// recomputes the same statistic from the drawn clusters' values (counted
/// with multiplicity; a group no drawn cluster has is left out of that
/// replicate's average). Bounds: type-7 quantiles at 0.025 and 0.975,
/// clamped to the range of the values; when every value is 0, or every
/// value is 1, the Wilson interval over the clusters instead. Clusters are
/// drawn with [`crate::stats::IndexSampler`] from `ChaCha8Rng::seed_from_u64(seed)`,
/// `k` per replicate, as [`crate::stats::bootstrap_mean_ci`] draws values:
/// when every cluster has one value per group, the interval is that of the
/// cluster means' bootstrap with the same seed.
pub(crate) fn clustered_mean_of_means_ci(
    clusters: &[Vec<(usize, f64)>],
    groups: usize,
    resamples: usize,
    seed: u64,
) -> Interval {
    let nan = Interval { estimate: f64::NAN, lo: f64::NAN, hi: f64::NAN };
    let clusters: Vec<&Vec<(usize, f64)>> = clusters.iter().filter(|c| !c.is_empty()).collect();
    if clusters.is_empty() || groups == 0 {
        return nan;
    }
    // Per cluster, per group: (sum, count).
    let mut sums = vec![0.0; clusters.len() * groups];
    let mut counts = vec![0.0; clusters.len() * groups];
    let (mut min, mut max) = (f64::INFINITY, f64::NEG_INFINITY);
    for (c, values) in clusters.iter().enumerate() {
        for &(g, v) in values.iter() {
            if g >= groups || !v.is_finite() {
                return nan;
            }
            sums[c * groups + g] += v;
            counts[c * groups + g] += 1.0;
            min = min.min(v);
            max = max.max(v);
        }
    }
    let stat = |s: &[f64], n: &[f64]| {
        let (mut total, mut k) = (0.0, 0usize);
        for g in 0..groups {
            if n[g] > 0.0 {
                total += s[g] / n[g];
                k += 1;
            }
        }
        total / k as f64
    };
    let mut s = vec![0.0; groups];
    let mut n = vec![0.0; groups];
    for c in 0..clusters.len() {
        for g in 0..groups {
            s[g] += sums[c * groups + g];
            n[g] += counts[c * groups + g];
        }
    }
    let estimate = stat(&s, &n).clamp(min, max);
    if resamples == 0 {
        return Interval { estimate, lo: f64::NAN, hi: f64::NAN };
    }
    if min == max {
        // Every value 0 (or 1): the Wilson interval over the seeds, as for a cell.
        if estimate == 0.0 || estimate == 1.0 {
            return wilson_ci(estimate * clusters.len() as f64, clusters.len() as f64);
        }
        return Interval { estimate, lo: estimate, hi: estimate };
    }
    let k = clusters.len();
    let sampler = IndexSampler::new(k as u64);
    let mut drawn = vec![0usize; k];
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut stats = Vec::with_capacity(resamples);
    for _ in 0..resamples {
        s.iter_mut().for_each(|x| *x = 0.0);
        n.iter_mut().for_each(|x| *x = 0.0);
        sampler.fill(&mut rng, &mut drawn);
        for &c in &drawn {
            for g in 0..groups {
                s[g] += sums[c * groups + g];
                n[g] += counts[c * groups + g];
            }
        }
        stats.push(stat(&s, &n));
    }
    stats.sort_unstable_by(f64::total_cmp);
    let lo = quantile(&stats, 0.025).clamp(min, max);
    let hi = quantile(&stats, 0.975).clamp(min, max);
    Interval { estimate, lo, hi }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::bootstrap_mean_ci;

    #[test]
    fn constant_samples_skip_resampling_with_the_same_answer() {
        let xs = [0.1; 40];
        assert_eq!(crate::stats::success_ci(&xs, 1000, 3), bootstrap_mean_ci(&xs, 1000, 3));
        assert_eq!(crate::stats::success_ci(&[1.0; 5], 1000, 3), wilson_ci(5.0, 5.0));
        let a = [1.0, 0.0, 1.0];
        assert_eq!(paired_ci(&a, &a, 1000, 1).unwrap(), Interval { estimate: 0.0, lo: 0.0, hi: 0.0 });
        assert!(paired_ci(&a, &a[..2], 1000, 1).is_err());
    }

    #[test]
    fn balanced_clusters_are_the_bootstrap_of_the_cluster_means() {
        // 120 seeds x 3 scenarios, deterministic pattern with per-seed
        // correlation. With one value per group in every cluster, the mean
        // of the group means is the mean of the cluster means, and the same
        // seed draws the same clusters: the two intervals agree (up to the
        // order of floating-point sums).
        let clusters: Vec<Vec<(usize, f64)>> = (0..120)
            .map(|s| (0..3).map(|g| (g, f64::from(u8::from((s * 7 + g * 3) % 5 < 2 + (s % 2))))).collect())
            .collect();
        let cluster_means: Vec<f64> = clusters.iter().map(|c| c.iter().map(|&(_, v)| v).sum::<f64>() / 3.0).collect();
        let ours = clustered_mean_of_means_ci(&clusters, 3, 10_000, 5);
        let means = bootstrap_mean_ci(&cluster_means, 10_000, 5);
        for (a, b) in [(ours.estimate, means.estimate), (ours.lo, means.lo), (ours.hi, means.hi)] {
            assert!((a - b).abs() < 1e-9, "{ours:?} {means:?}");
        }
        assert!(ours.lo < ours.estimate && ours.estimate < ours.hi);
        assert_eq!(ours, clustered_mean_of_means_ci(&clusters, 3, 10_000, 5));
    }

    #[test]
    fn seeded_and_wider_for_correlated_clusters() {
        let xs: Vec<f64> = (0..100).map(|i| ((i * 37) % 101) as f64 / 100.0).collect();
        let clusters: Vec<Vec<(usize, f64)>> = xs.chunks(10).map(|c| c.iter().map(|&v| (0, v)).collect()).collect();
        let at = |seed| clustered_mean_of_means_ci(&clusters, 1, 2000, seed);
        assert_eq!(at(3), at(3));
        assert_ne!(at(3), at(4));
        // Every seed's value repeated 10 times: the clustered interval is
        // about sqrt(10) wider than the naive one over all the values.
        let seeds: Vec<f64> = (0..40).map(|i| f64::from(u8::from((i * 7) % 12 < 5))).collect();
        let repeated: Vec<Vec<(usize, f64)>> = seeds.iter().map(|&v| vec![(0, v); 10]).collect();
        let flat: Vec<f64> = seeds.iter().flat_map(|&v| [v; 10]).collect();
        let clustered = clustered_mean_of_means_ci(&repeated, 1, 2000, 2);
        let naive = bootstrap_mean_ci(&flat, 2000, 2);
        let ratio = (clustered.hi - clustered.lo) / (naive.hi - naive.lo);
        assert!(ratio > 2.5 && ratio < 3.8, "ratio {ratio}");
    }

    proptest::proptest! {
        #[test]
        fn bounds_stay_within_the_values(
            clusters in proptest::collection::vec(proptest::collection::vec((0usize..3, 0.0f64..=1.0), 1..6), 1..20),
            seed in proptest::prelude::any::<u64>(),
        ) {
            // All values equal: a point, or the Wilson interval at 0 or 1.
            proptest::prop_assume!(crate::stats::constant(&clusters.iter().flatten().map(|&(_, v)| v).collect::<Vec<_>>()).is_none());
            let iv = clustered_mean_of_means_ci(&clusters, 3, 300, seed);
            let (min, max) = clusters.iter().flatten().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &(_, v)| (lo.min(v), hi.max(v)));
            proptest::prop_assert!(iv.lo <= iv.estimate && iv.estimate <= iv.hi, "{:?}", iv);
            proptest::prop_assert!(min <= iv.lo && iv.hi <= max, "{:?}", iv);
        }
    }

    #[test]
    fn unbalanced_groups_average_the_group_means() {
        // Group 0: values 1, 1 (mean 1); group 1: 0, 0, 0, 1 (mean 0.25).
        let clusters = vec![vec![(0, 1.0), (1, 0.0)], vec![(0, 1.0), (1, 0.0)], vec![(1, 0.0)], vec![(1, 1.0)]];
        let iv = clustered_mean_of_means_ci(&clusters, 2, 2000, 1);
        assert_eq!(iv.estimate, 0.625);
        assert!(iv.lo <= iv.estimate && iv.estimate <= iv.hi);
        let flat = clustered_mean_of_means_ci(&[vec![(0, 1.0)], vec![(0, 1.0)]], 1, 100, 1);
        assert_eq!(flat, wilson_ci(2.0, 2.0), "all ones: Wilson over the 2 seeds, not [1, 1]");
        let half = clustered_mean_of_means_ci(&[vec![(0, 0.5)], vec![(0, 0.5)]], 1, 100, 1);
        assert_eq!((half.lo, half.hi), (0.5, 0.5));
        assert!(clustered_mean_of_means_ci(&[], 3, 100, 1).estimate.is_nan());
        assert!(clustered_mean_of_means_ci(&[vec![(0, 0.5)], vec![(0, 1.0)]], 1, 0, 1).lo.is_nan());
    }
}
