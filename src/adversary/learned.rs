//! The learned adversary: an optimiser that sees what a driver sees. The
//! blind search asks whether a policy that never looks can win; this asks
//! the other question, whether a policy that looks finds a way to collect
//! reward without reading the other road user right.
//!
//! The policy is linear over the feature vector (env-server's `features`
//! view, normalised by the mean and spread of a seeded batch of random
//! play), choosing the highest-scoring of the discrete actions. It is
//! trained by the cross-entropy method on the episode reward, on training
//! seeds that never overlap the held-out ones, with its own seeded
//! randomness: the same cell and seed give the same policy everywhere.
//!
//! Two measurements on held-out seeds are its findings: how often it
//! succeeds with the wrong choice (decision correctness 0, a hack), and
//! how well it does with the other road users' slots frozen at their first
//! reading (the masked view: a policy that wins by reading falls to the
//! blind level there).

use crate::episode::{Episode, Outcome};
use crate::features::{DISCRETE_ACTIONS, features, road_user_slots};
use crate::rng::{EpisodeRng, Stream};
use crate::scenario::{ScenarioConfig, Tier};

/// How hard the adversary trains on one cell.
#[derive(Debug, Clone, Copy)]
pub struct LearnSpec {
    pub generations: usize,
    pub population: usize,
    pub elite: usize,
    /// Training episodes per candidate per generation (fresh seeds every
    /// generation, so that no candidate is fitted to a few geometries).
    pub episodes: usize,
    /// Seed of the optimiser's own randomness.
    pub search_seed: u64,
}

/// A few seconds per cell on one core.
pub const DEFAULT_TRAINING: LearnSpec =
    LearnSpec { generations: 20, population: 40, elite: 8, episodes: 30, search_seed: 1 };

/// Training seeds start here (the blind search's start at 10^9; the
/// held-out ones at 0).
const TRAIN_SEED_BASE: u64 = 2_000_000_000;
/// Episodes of uniformly random play the normalisation is measured on.
const NORMALISE_EPISODES: u64 = 64;
/// The smallest spread a CEM coordinate keeps (exploration floor).
const MIN_SPREAD: f64 = 0.05;

/// A linear policy over the normalised feature vector.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearPolicy {
    mean: Vec<f64>,
    scale: Vec<f64>,
    /// One row of `features + 1` (the last is the bias) per action.
    weights: Vec<f64>,
}

impl LinearPolicy {
    fn inputs(&self) -> usize {
        self.mean.len() + 1
    }

    /// The index of the chosen action.
    pub fn act(&self, x: &[f64]) -> usize {
        let n = self.inputs();
        let z: Vec<f64> = x.iter().zip(&self.mean).zip(&self.scale).map(|((x, m), s)| (x - m) / s).collect();
        let scores =
            self.weights.chunks_exact(n).map(|row| z.iter().zip(row).map(|(z, w)| z * w).sum::<f64>() + row[n - 1]);
        // The highest score; a tie goes to the lower index.
        scores.enumerate().fold((0, f64::NEG_INFINITY), |best, (a, v)| if v > best.1 { (a, v) } else { best }).0
    }
}

/// What a policy scored on a set of seeds.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct LearnedScore {
    pub episodes: usize,
    pub success: f64,
    pub correctness: f64,
    pub reward: f64,
    /// Share of episodes won with the wrong choice (decision correctness 0).
    pub hack_rate: f64,
}

/// Play `seeds` with `choose` (features in, action index out); `masked`
/// freezes the road-user slots at the episode's first reading.
fn play(
    config: &ScenarioConfig,
    tier: Tier,
    seeds: &[u64],
    masked: bool,
    mut choose: impl FnMut(&[f64]) -> usize,
) -> LearnedScore {
    let slots = if masked { road_user_slots() } else { Vec::new() };
    let mut s = LearnedScore { episodes: seeds.len(), ..LearnedScore::default() };
    for &seed in seeds {
        let mut episode = Episode::new(config, tier, seed);
        // The first reading, kept only when the masked view needs it.
        let mut first: Option<Vec<f64>> = None;
        while !episode.is_done() {
            let mut x = features(&episode.observation().rounded(), tier);
            if masked {
                let first = first.get_or_insert_with(|| x.clone());
                for &i in &slots {
                    x[i] = first[i];
                }
            }
            episode.step(DISCRETE_ACTIONS[choose(&x)]);
        }
        let record = episode.finish();
        let won = record.outcome == Outcome::Success;
        s.success += won as u8 as f64;
        s.correctness += record.grades.decision_correctness;
        s.reward += record.grades.reward;
        s.hack_rate += (won && record.grades.decision_correctness == 0.0) as u8 as f64;
    }
    let n = seeds.len().max(1) as f64;
    s.success /= n;
    s.correctness /= n;
    s.reward /= n;
    s.hack_rate /= n;
    s
}

/// `policy` on `seeds`, with the full view or the masked one.
pub fn evaluate(
    config: &ScenarioConfig,
    tier: Tier,
    policy: &LinearPolicy,
    seeds: &[u64],
    masked: bool,
) -> LearnedScore {
    play(config, tier, seeds, masked, |x| policy.act(x))
}

/// The per-slot mean and spread of the features under uniformly random
/// play (a slot that never varies keeps spread 1).
fn normalisation(config: &ScenarioConfig, tier: Tier, rng: &mut EpisodeRng) -> (Vec<f64>, Vec<f64>) {
    let mut rows: Vec<Vec<f64>> = Vec::new();
    for seed in TRAIN_SEED_BASE - NORMALISE_EPISODES..TRAIN_SEED_BASE {
        let mut episode = Episode::new(config, tier, seed);
        while !episode.is_done() {
            rows.push(features(&episode.observation().rounded(), tier));
            episode.step(DISCRETE_ACTIONS[rng.below(DISCRETE_ACTIONS.len() as u64) as usize]);
        }
    }
    let n = rows.len().max(1) as f64;
    let width = rows.first().map_or(0, Vec::len);
    let mean: Vec<f64> = (0..width).map(|i| rows.iter().map(|r| r[i]).sum::<f64>() / n).collect();
    let scale = (0..width)
        .map(|i| {
            let var = rows.iter().map(|r| (r[i] - mean[i]).powi(2)).sum::<f64>() / n;
            if var > 1e-12 { var.sqrt() } else { 1.0 }
        })
        .collect();
    (mean, scale)
}

/// Train the adversary on one cell.
pub fn train(config: &ScenarioConfig, tier: Tier, spec: LearnSpec) -> LinearPolicy {
    train_on(config, tier, spec, false)
}

/// Train a blind learner on one cell: the same search, on the masked view
/// (the road users' slots frozen at their first reading). What it wins, it
/// wins without reading: outwaiting, racing, a schedule. It catches a
/// world that a reader can win too, where the reading learner need not
/// look for a shortcut.
pub fn train_blind(config: &ScenarioConfig, tier: Tier, spec: LearnSpec) -> LinearPolicy {
    train_on(config, tier, spec, true)
}

fn train_on(config: &ScenarioConfig, tier: Tier, spec: LearnSpec, masked: bool) -> LinearPolicy {
    let mut rng = EpisodeRng::new(&[spec.search_seed, tier.number() as u64, config.kind().rng_id()], Stream::Policy);
    let (mean, scale) = normalisation(config, tier, &mut rng);
    let dim = (mean.len() + 1) * DISCRETE_ACTIONS.len();
    let (mut centre, mut spread) = (vec![0.0; dim], vec![1.0; dim]);
    let mut best = (f64::NEG_INFINITY, centre.clone());
    let mut next_seed = TRAIN_SEED_BASE;
    for _ in 0..spec.generations {
        let seeds: Vec<u64> = (next_seed..next_seed + spec.episodes as u64).collect();
        next_seed += spec.episodes as u64;
        let mut scored: Vec<(f64, Vec<f64>)> = (0..spec.population)
            .map(|k| {
                // The first candidate is the centre itself, so the best
                // found never gets worse for lack of a lucky draw.
                let weights: Vec<f64> = if k == 0 {
                    centre.clone()
                } else {
                    centre.iter().zip(&spread).map(|(c, s)| c + s * rng.standard_noise()).collect()
                };
                let policy = LinearPolicy { mean: mean.clone(), scale: scale.clone(), weights };
                (evaluate(config, tier, &policy, &seeds, masked).reward, policy.weights)
            })
            .collect();
        scored.sort_by(|a, b| b.0.total_cmp(&a.0));
        let elite = &scored[..spec.elite.min(scored.len())];
        if elite[0].0 > best.0 {
            best = elite[0].clone();
        }
        let e = elite.len() as f64;
        for i in 0..dim {
            let m = elite.iter().map(|(_, w)| w[i]).sum::<f64>() / e;
            let v = elite.iter().map(|(_, w)| (w[i] - m).powi(2)).sum::<f64>() / e;
            centre[i] = m;
            spread[i] = v.sqrt().max(MIN_SPREAD);
        }
    }
    LinearPolicy { mean, scale, weights: best.1 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::{ScenarioKind, ScenarioSet};

    #[test]
    fn the_same_cell_and_seed_train_the_same_policy() {
        let set = ScenarioSet::default();
        let spec = LearnSpec { generations: 2, population: 6, elite: 2, episodes: 4, search_seed: 3 };
        let config = set.get(ScenarioKind::PedestrianFeint);
        assert_eq!(train(config, Tier::T1, spec), train(config, Tier::T1, spec));
    }

    #[test]
    fn a_policy_frozen_out_of_the_road_users_view_cannot_tell_them_apart() {
        // The masked view of a policy that proceeds while the pedestrian's
        // latest lateral velocity is low: frozen at the first reading, it
        // plays one schedule whatever the pedestrian does.
        let set = ScenarioSet::default();
        let config = set.get(ScenarioKind::PedestrianFeint);
        let names = crate::features::feature_names();
        let v = names.iter().position(|n| n == "road_user0.velocity_mps").unwrap();
        let seeds: Vec<u64> = (0..60).collect();
        let reads = play(config, Tier::T1, &seeds, false, |x| if x[v] > 0.3 { 7 } else { 2 });
        let masked = play(config, Tier::T1, &seeds, true, |x| if x[v] > 0.3 { 7 } else { 2 });
        assert_ne!(reads, masked);
    }
}
