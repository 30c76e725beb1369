//! Per-cell accumulators. Everything is a sum, so fields from separate runs (other seeds, other
//! tiles, resumed runs) merge by addition, exactly.
//!
//! The weighted sums ΣP, ΣPΔ, ΣPΔ² are compensated (Neumaier's variant of Kahan summation): each
//! keeps the rounding error of its additions in a second f64, so that their value `s + comp` has
//! the error of one rounding however many samples a cell takes. Plain f64 sums drift by about
//! n·2⁻⁵³ relative, and σ's second term sqrt(m2 − m1²) magnifies that where Δ barely varies: over
//! 10⁸ samples it changed σ's 6th significant digit (the test
//! `stability_moments_over_1e8_samples_keep_six_digits`). Merging adds the sums with the same
//! compensated addition and adds the compensations too.

use crate::math::{Rgb, safe_sqrt};

/// Weighted moments of the pairwise path deviation Δ at one cell (paper eq. 14's ΣP, ΣΔ, ΣΔ²), plus
/// independent-batch statistics of σ for the standard error.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Moments {
    /// Σ c (c = weight · βA · βB, luminance).
    pub s0: f64,
    /// Σ c Δ.
    pub s1: f64,
    /// Σ c Δ².
    pub s2: f64,
    /// Neumaier compensations of `s0`, `s1`, `s2`: the sums are `s + comp` (see [`Moments::sums`]).
    pub comp: [f64; 3],
    /// Number of samples taken (including those with c = 0).
    pub n: u64,
    /// Σ over samples of the direction weight (RGB), for fluence = Σ / n.
    pub fluence: Rgb,
    /// Number of batches with a defined σ, Σ σ_b and Σ σ_b² over them.
    pub batches: u64,
    pub batch_sigma: f64,
    pub batch_sigma2: f64,
}

/// Finalised values of one cell.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CellValue {
    /// FTPD σ (eq. 14); 0 when invalid.
    pub sigma: f64,
    /// Weighted mean of Δ (S1/S0).
    pub mean: f64,
    /// Weighted second moment of Δ (S2/S0).
    pub m2: f64,
    /// Standard error of σ from the spread of independent batches (0 with fewer than 2 batches).
    pub stderr: f64,
    /// Mean contribution weight S0/n.
    pub weight: f64,
    pub valid: bool,
}

/// FTPD from normalised moments: `sqrt(m2) + sqrt(max(0, m2 - m1²))` (eq. 14).
#[inline]
pub fn sigma_from(m1: f64, m2: f64) -> f64 {
    safe_sqrt(m2) + safe_sqrt(m2 - m1 * m1)
}

/// `sum + x` with Neumaier's compensation: the rounding error of the addition goes to `comp`.
#[inline]
fn add_compensated(sum: &mut f64, comp: &mut f64, x: f64) {
    let t = *sum + x;
    *comp += if sum.abs() >= x.abs() {
        (*sum - t) + x
    } else {
        (x - t) + *sum
    };
    *sum = t;
}

impl Moments {
    #[inline]
    pub fn add_sample(&mut self, c: f64, delta: f64, weight_rgb: Rgb) {
        let cd = c * delta;
        add_compensated(&mut self.s0, &mut self.comp[0], c);
        add_compensated(&mut self.s1, &mut self.comp[1], cd);
        add_compensated(&mut self.s2, &mut self.comp[2], cd * delta);
        self.n += 1;
        self.fluence += weight_rgb;
    }

    /// ΣP, ΣPΔ, ΣPΔ² with their compensations applied.
    #[inline]
    pub fn sums(&self) -> (f64, f64, f64) {
        (
            self.s0 + self.comp[0],
            self.s1 + self.comp[1],
            self.s2 + self.comp[2],
        )
    }

    /// σ of these sums alone, when defined (S0 > 0 and finite).
    pub fn sigma(&self) -> Option<f64> {
        let (s0, s1, s2) = self.sums();
        if s0 > 0.0 && s0.is_finite() {
            let (m1, m2) = (s1 / s0, s2 / s0);
            let s = sigma_from(m1, m2);
            s.is_finite().then_some(s)
        } else {
            None
        }
    }

    /// Adds the weighted sums of `o` (compensated, compensations included).
    fn add_sums(&mut self, o: &Moments) {
        add_compensated(&mut self.s0, &mut self.comp[0], o.s0);
        add_compensated(&mut self.s1, &mut self.comp[1], o.s1);
        add_compensated(&mut self.s2, &mut self.comp[2], o.s2);
        for k in 0..3 {
            self.comp[k] += o.comp[k];
        }
    }

    /// Folds the sums of one finished batch into `self`, recording the batch's σ.
    pub fn add_batch(&mut self, batch: &Moments) {
        if let Some(s) = batch.sigma() {
            self.batches += 1;
            self.batch_sigma += s;
            self.batch_sigma2 += s * s;
        }
        self.add_sums(batch);
        self.n += batch.n;
        self.fluence += batch.fluence;
    }

    /// Exact merge of two accumulators: every field is a sum (the weighted sums added with their
    /// compensations, see the module notes).
    pub fn merge(&mut self, o: &Moments) {
        self.add_sums(o);
        self.n += o.n;
        self.fluence += o.fluence;
        self.batches += o.batches;
        self.batch_sigma += o.batch_sigma;
        self.batch_sigma2 += o.batch_sigma2;
    }

    pub fn finalize(&self) -> CellValue {
        let Some(sigma) = self.sigma() else {
            return CellValue::default();
        };
        let (s0, s1, s2) = self.sums();
        let (mean, m2) = (s1 / s0, s2 / s0);
        let k = self.batches as f64;
        let stderr = if self.batches >= 2 {
            let var = (self.batch_sigma2 - self.batch_sigma * self.batch_sigma / k) / (k - 1.0);
            safe_sqrt(var / k)
        } else {
            0.0
        };
        CellValue {
            sigma,
            mean,
            m2,
            stderr: if stderr.is_finite() { stderr } else { 0.0 },
            weight: if self.n > 0 { s0 / self.n as f64 } else { 0.0 },
            valid: true,
        }
    }

    /// Mean incident radiance integrated over the sphere (scalar irradiance).
    pub fn fluence(&self) -> Rgb {
        if self.n > 0 {
            self.fluence / self.n as f64
        } else {
            Rgb::ZERO
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_cell_is_invalid_not_nan() {
        let v = Moments::default().finalize();
        assert!(!v.valid);
        assert_eq!(v.sigma, 0.0);
        let mut m = Moments::default();
        m.add_sample(0.0, 5.0, Rgb::ZERO);
        assert!(!m.finalize().valid);
        assert_eq!(m.finalize().sigma, 0.0);
    }

    #[test]
    fn sigma_matches_eq14_on_a_known_sequence() {
        // Unit weights, Δ in {1, 3}: mean 2, second moment 5, variance 1 → σ = sqrt(5) + 1.
        let mut m = Moments::default();
        for d in [1.0, 3.0, 1.0, 3.0] {
            m.add_sample(1.0, d, Rgb::ZERO);
        }
        let v = m.finalize();
        assert!((v.sigma - (5f64.sqrt() + 1.0)).abs() < 1e-15);
        assert_eq!(v.mean, 2.0);
        assert_eq!(v.m2, 5.0);
    }

    #[test]
    fn compensated_sums_survive_merging() {
        // 0.1 is not a binary fraction: 10⁶ plain additions drift, compensated ones do not, and
        // merging two compensated halves keeps that (the compensations are added too).
        let (mut a, mut b) = (Moments::default(), Moments::default());
        for _ in 0..500_000 {
            a.add_sample(0.1, 1.0, Rgb::ZERO);
            b.add_sample(0.1, 1.0, Rgb::ZERO);
        }
        let mut plain = 0.0;
        for _ in 0..1_000_000 {
            plain += 0.1;
        }
        assert!((plain - 100_000.0f64).abs() > 1e-7);
        a.merge(&b);
        assert!((a.sums().0 - 100_000.0).abs() <= 1e-10, "{:?}", a.sums());
        let mut batches = Moments::default();
        batches.add_batch(&b);
        batches.add_batch(&b);
        assert_eq!(batches.sums(), a.sums());
    }

    #[test]
    fn merge_is_exact_addition() {
        let mut a = Moments::default();
        let mut b = Moments::default();
        a.add_sample(0.5, 0.25, Rgb::ONE);
        b.add_sample(0.75, -1.5, Rgb::X);
        let mut ab = a;
        ab.merge(&b);
        let mut direct = Moments::default();
        direct.add_sample(0.5, 0.25, Rgb::ONE);
        direct.add_sample(0.75, -1.5, Rgb::X);
        assert_eq!(ab, direct);
    }
}
