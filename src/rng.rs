//! Deterministic random streams. Every sample stream is keyed by (seed, pass, cell) so that a result
//! does not depend on the thread count or the tile order, and merged runs never reuse numbers.

use rand_core::Rng;
use rand_pcg::Pcg64Mcg;

/// SplitMix64 finaliser: a bijective 64-bit mixer used to turn stream keys into PCG states.
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A number in [0, 1) that is a fixed function of `words` (SplitMix64 over them): for decisions
/// that must be random across rays but the same wherever the same ray is traced, on any thread
/// (stochastic cut-outs, keyed by the ray's bits and the triangle).
#[inline]
pub fn hash_unit(words: &[u32]) -> f64 {
    let h = words
        .iter()
        .fold(0x2545_F491_4F6C_DD1D_u64, |h, &w| mix64(h ^ w as u64));
    (h >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// A uniform random number source for one sample stream.
pub struct Sampler {
    rng: Pcg64Mcg,
}

impl Sampler {
    /// The stream of `cell` in pass `pass` of a run seeded with `seed`.
    pub fn new(seed: u64, pass: u64, cell: u64) -> Self {
        let hi = mix64(seed ^ mix64(pass.wrapping_mul(0xD6E8_FEB8_6659_FD93)));
        let lo = mix64(cell ^ mix64(hi));
        // MCG state must be odd; the generator forces that itself.
        Sampler {
            rng: Pcg64Mcg::new(((hi as u128) << 64) | lo as u128),
        }
    }

    /// Uniform in [0, 1), 53 random bits.
    #[inline]
    pub fn next_f64(&mut self) -> f64 {
        (self.rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    #[inline]
    pub fn next_2d(&mut self) -> (f64, f64) {
        (self.next_f64(), self.next_f64())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let a: Vec<f64> = (0..4)
            .map(|_| 0.0)
            .scan(Sampler::new(1, 0, 7), |s, _| Some(s.next_f64()))
            .collect();
        let b: Vec<f64> = (0..4)
            .map(|_| 0.0)
            .scan(Sampler::new(1, 0, 7), |s, _| Some(s.next_f64()))
            .collect();
        let c: Vec<f64> = (0..4)
            .map(|_| 0.0)
            .scan(Sampler::new(1, 1, 7), |s, _| Some(s.next_f64()))
            .collect();
        let d: Vec<f64> = (0..4)
            .map(|_| 0.0)
            .scan(Sampler::new(2, 0, 7), |s, _| Some(s.next_f64()))
            .collect();
        assert_eq!(a, b);
        assert_ne!(a, c);
        assert_ne!(a, d);
        assert!(a.iter().all(|x| (0.0..1.0).contains(x)));
    }

    #[test]
    fn uniform_mean_and_variance() {
        let mut s = Sampler::new(42, 0, 0);
        let n = 200_000;
        let (mut m, mut m2) = (0.0, 0.0);
        for _ in 0..n {
            let x = s.next_f64();
            m += x;
            m2 += x * x;
        }
        m /= n as f64;
        m2 /= n as f64;
        // mean 1/2 with standard error sqrt(1/12/n); allow 4 standard errors.
        let se = (1.0f64 / 12.0 / n as f64).sqrt();
        assert!((m - 0.5).abs() < 4.0 * se, "mean {m}");
        assert!((m2 - m * m - 1.0 / 12.0).abs() < 0.002);
    }
}
