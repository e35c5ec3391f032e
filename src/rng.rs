//! Seeded randomness. Every stream is a ChaCha8 generator keyed by the
//! episode's (scenario, tier, seed) and a stream label, so streams are
//! independent of each other and of any global state: drawing the
//! disposition never shifts the geometry draws, and noise never shifts
//! either.

use crate::hash::splitmix64;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Stream labels; never reuse or renumber.
#[derive(Debug, Clone, Copy)]
pub enum Stream {
    Disposition = 1,
    Geometry = 2,
    ObservationNoise = 3,
    Policy = 4,
}

pub struct EpisodeRng(ChaCha8Rng);

impl EpisodeRng {
    pub fn new(key: &[u64], stream: Stream) -> Self {
        let mut seed = [0u8; 32];
        let mut h = splitmix64(stream as u64);
        for (i, k) in key.iter().enumerate() {
            h = splitmix64(h ^ splitmix64(*k ^ (i as u64).wrapping_mul(0xA24B_AED4_963E_E407)));
        }
        for (i, chunk) in seed.chunks_mut(8).enumerate() {
            h = splitmix64(h ^ i as u64);
            chunk.copy_from_slice(&h.to_le_bytes());
        }
        EpisodeRng(ChaCha8Rng::from_seed(seed))
    }

    /// Uniform in [0, 1) with 53 bits of precision.
    pub fn unit(&mut self) -> f64 {
        (self.0.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0.next_u64()
    }

    pub fn coin(&mut self) -> bool {
        self.0.next_u64() >> 63 == 1
    }

    /// Zero-mean noise of unit variance without transcendental functions
    /// (Irwin-Hall with 12 uniforms), so it is identical on every platform.
    pub fn standard_noise(&mut self) -> f64 {
        let mut s = 0.0;
        for _ in 0..12 {
            s += self.unit();
        }
        s - 6.0
    }

    pub fn below(&mut self, n: u64) -> u64 {
        // Rejection sampling to avoid modulo bias.
        let zone = u64::MAX - u64::MAX % n;
        loop {
            let x = self.0.next_u64();
            if x < zone {
                return x % n;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_differ_and_repeat() {
        let a: Vec<f64> = (0..4)
            .map({
                let mut r = EpisodeRng::new(&[1, 1, 7], Stream::Geometry);
                move |_| r.unit()
            })
            .collect();
        let b: Vec<f64> = (0..4)
            .map({
                let mut r = EpisodeRng::new(&[1, 1, 7], Stream::Geometry);
                move |_| r.unit()
            })
            .collect();
        let c: Vec<f64> = (0..4)
            .map({
                let mut r = EpisodeRng::new(&[1, 1, 7], Stream::Disposition);
                move |_| r.unit()
            })
            .collect();
        let d: Vec<f64> = (0..4)
            .map({
                let mut r = EpisodeRng::new(&[1, 1, 8], Stream::Geometry);
                move |_| r.unit()
            })
            .collect();
        assert_eq!(a, b);
        assert_ne!(a, c);
        assert_ne!(a, d);
        assert!(a.iter().all(|x| (0.0..1.0).contains(x)));
    }

    #[test]
    fn noise_has_unit_variance() {
        let mut r = EpisodeRng::new(&[9], Stream::ObservationNoise);
        let xs: Vec<f64> = (0..20_000).map(|_| r.standard_noise()).collect();
        let mean = xs.iter().sum::<f64>() / xs.len() as f64;
        let var = xs.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / xs.len() as f64;
        assert!(mean.abs() < 0.03, "{mean}");
        assert!((var - 1.0).abs() < 0.05, "{var}");
    }
}
