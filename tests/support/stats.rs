//! The statistics Monte Carlo tests judge by, written here independently of the code under test.
//!
//! The rule every Monte Carlo test follows: a random quantity is compared with its reference within
//! k standard errors that the test computes from its own samples (their variance, or the spread of
//! independent batches or seeds), never within a constant; k is chosen for a false-failure
//! probability the test states, over the choice of its seeds. [`z_limit`] gives k for m
//! quantities judged together at [`ALPHA`] (Bonferroni); [`assert_consistent`] judges many z-scores
//! at once by their largest and by how many pass 3; [`chi2_test`] compares sampled counts with a
//! density.

use std::f64::consts::TAU;
use std::sync::OnceLock;

/// The false-failure probability a test allows itself for everything it judges at once, where it
/// takes its tolerance from [`z_limit`] (and the significance of each [`chi2_test`]).
pub const ALPHA: f64 = 1e-4;

// ------------------------------------------------------------------------------------------------
// Means and their standard errors

/// Running mean and variance of a sample (Welford).
#[derive(Clone, Copy, Debug, Default)]
pub struct Mean {
    n: f64,
    mean: f64,
    m2: f64,
}

impl Mean {
    /// The mean of `n` draws of `f`.
    pub fn of(n: usize, mut f: impl FnMut() -> f64) -> Mean {
        let mut m = Mean::default();
        for _ in 0..n {
            m.add(f());
        }
        m
    }

    pub fn add(&mut self, v: f64) {
        self.n += 1.0;
        let d = v - self.mean;
        self.mean += d / self.n;
        self.m2 += d * (v - self.mean);
    }

    pub fn mean(&self) -> f64 {
        self.mean
    }

    /// Standard error of the mean, from the sample variance (0 with fewer than two samples).
    pub fn stderr(&self) -> f64 {
        if self.n < 2.0 {
            return 0.0;
        }
        (self.m2 / (self.n - 1.0) / self.n).sqrt()
    }

    /// (mean, standard error).
    pub fn estimate(&self) -> (f64, f64) {
        (self.mean, self.stderr())
    }
}

/// Mean and standard error of the mean of `n` samples from their sum and sum of squares.
pub fn mean_and_se(sum: f64, sum2: f64, n: usize) -> (f64, f64) {
    let n = n as f64;
    let mean = sum / n;
    let var = ((sum2 / n - mean * mean) * n / (n - 1.0)).max(0.0);
    (mean, (var / n).sqrt())
}

/// Mean of `values` (independent batches or seeds) and its standard error from their spread.
pub fn mean_and_se_of(values: &[f64]) -> (f64, f64) {
    let mut m = Mean::default();
    values.iter().for_each(|v| m.add(*v));
    m.estimate()
}

// ------------------------------------------------------------------------------------------------
// How many standard errors

/// The number of standard errors k within which each of `m` estimates judged together must lie of
/// its expectation, so that a correct code fails with probability at most [`ALPHA`] whatever the
/// seeds (Bonferroni over the m two-sided normal tests: P(any |z| > k) ≤ m · 2Q(k) = ALPHA).
/// 3.89 for one quantity, 4.26 for 4, 4.42 for 10, 4.56 for 20.
pub fn z_limit(m: usize) -> f64 {
    normal_quantile(1.0 - ALPHA / (2.0 * m.max(1) as f64))
}

/// [`z_limit`] for standard errors taken from the spread of few independent batches: the z-score
/// is then Student's t with `dof` degrees of freedom (batches − 1; for a difference of two such
/// estimates of equal size, Welch's 2 (batches − 1) is close), whose tails are heavier.
pub fn t_limit(m: usize, dof: f64) -> f64 {
    let p = ALPHA / (2.0 * m.max(1) as f64);
    let (mut lo, mut hi) = (0.0f64, 1e3f64);
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        if student_t_upper_tail(mid, dof) > p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// P(T ≥ t) for Student's t with `dof` degrees of freedom, t ≥ 0: with t = √ν tan θ the density in
/// θ is ∝ cos^(ν−1) θ on (−π/2, π/2), so the tail is a ratio of two smooth integrals (composite
/// Simpson, 2000 panels: error far below the 1e-6 relative the tests need).
pub fn student_t_upper_tail(t: f64, dof: f64) -> f64 {
    let simpson = |a: f64, b: f64| {
        let n = 2000;
        let h = (b - a) / n as f64;
        let f = |x: f64| x.cos().max(0.0).powf(dof - 1.0);
        let mut s = f(a) + f(b);
        for i in 1..n {
            s += f(a + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
        }
        s * h / 3.0
    };
    let half = std::f64::consts::FRAC_PI_2;
    let theta = (t.max(0.0) / dof.sqrt()).atan();
    simpson(theta, half) / (2.0 * simpson(0.0, half))
}

/// Asserts that the estimate `(est, se)` lies within `k` standard errors of `reference`, that its
/// standard error is known (> 0) and, with `max_rel_se`, small enough against the reference for
/// the comparison to mean something; prints the numbers.
pub fn assert_within(what: &str, (est, se): (f64, f64), reference: f64, k: f64, max_rel_se: f64) {
    let z = (est - reference) / se;
    eprintln!("{what}: {est:.6} ± {se:.2e} vs reference {reference:.6} ({z:+.2} se, limit {k:.2})");
    assert!(
        se > 0.0 && se <= max_rel_se * reference.abs(),
        "{what}: standard error {se:.3e} too large for a meaningful test of {reference}"
    );
    assert!(
        (est - reference).abs() <= k * se,
        "{what}: {est} ± {se} differs from {reference} by {z:.2} standard errors (limit {k:.2})"
    );
}

// ------------------------------------------------------------------------------------------------
// Tails and quantiles

/// Upper tail of the standard normal, Q(z) = ∫_z^∞ φ(t) dt, by composite Simpson on [z, z + 12]
/// (the rest is < φ(12) < 1e-31). With h = 0.0025 the rule's error is at most
/// h⁴/180 · 12 · max|φ⁗| < 1e-11 (max|φ⁗| = 3/√(2π)).
pub fn normal_upper_tail(z: f64) -> f64 {
    let n = 4800;
    let h = 12.0 / n as f64;
    let phi = |t: f64| (-0.5 * t * t).exp() / TAU.sqrt();
    let mut s = phi(z) + phi(z + 12.0);
    for i in 1..n {
        s += phi(z + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
    }
    s * h / 3.0
}

/// Standard normal quantile Φ⁻¹(p), by bisection on [`normal_upper_tail`].
pub fn normal_quantile(p: f64) -> f64 {
    assert!(p > 0.0 && p < 1.0);
    let (mut lo, mut hi) = (-12.0f64, 12.0f64);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if normal_upper_tail(mid) > 1.0 - p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// (1 − α) quantile of χ²(dof), Wilson–Hilferty: (X/k)^(1/3) ≈ N(1 − 2/(9k), 2/(9k)).
pub fn chi2_quantile(dof: f64, alpha: f64) -> f64 {
    let z = if alpha == ALPHA {
        static Z: OnceLock<f64> = OnceLock::new();
        *Z.get_or_init(|| normal_quantile(1.0 - ALPHA))
    } else {
        normal_quantile(1.0 - alpha)
    };
    let c = 2.0 / (9.0 * dof);
    dof * (1.0 - c + z * c.sqrt()).powi(3)
}

/// P(X ≥ k) for X ~ Poisson(λ).
pub fn poisson_upper_tail(lambda: f64, k: u64) -> f64 {
    if k == 0 {
        return 1.0;
    }
    let mut term = (-lambda).exp();
    let mut cdf = term;
    for i in 1..k {
        term *= lambda / i as f64;
        cdf += term;
    }
    (1.0 - cdf).max(0.0)
}

/// ln n!: summed below 20, Stirling's series above (error under 1e-15 relative there).
fn ln_factorial(n: u64) -> f64 {
    if n < 20 {
        return (2..=n).map(|i| (i as f64).ln()).sum();
    }
    let x = n as f64;
    x * x.ln() - x + 0.5 * (TAU * x).ln() + 1.0 / (12.0 * x) - 1.0 / (360.0 * x.powi(3))
        + 1.0 / (1260.0 * x.powi(5))
}

/// P(X = j) for X ~ Binomial(n, p).
fn binomial_pmf(n: u64, p: f64, j: u64) -> f64 {
    if p <= 0.0 {
        return if j == 0 { 1.0 } else { 0.0 };
    }
    let ln_choose = ln_factorial(n) - ln_factorial(j) - ln_factorial(n - j);
    (ln_choose + j as f64 * p.ln() + (n - j) as f64 * (-p).ln_1p()).exp()
}

/// P(X ≥ k) for X ~ Binomial(n, p), summed term by term from k until the terms vanish.
pub fn binomial_upper_tail(n: u64, p: f64, k: u64) -> f64 {
    if k == 0 {
        return 1.0;
    }
    let mut sum = 0.0;
    for j in k..=n {
        let t = binomial_pmf(n, p, j);
        sum += t;
        if j as f64 > n as f64 * p && t < 1e-18 * sum {
            break;
        }
    }
    sum.min(1.0)
}

/// P(X ≤ k) for X ~ Binomial(n, p).
pub fn binomial_lower_tail(n: u64, p: f64, k: u64) -> f64 {
    (0..=k.min(n))
        .map(|j| binomial_pmf(n, p, j))
        .sum::<f64>()
        .min(1.0)
}

// ------------------------------------------------------------------------------------------------
// Judging many estimates at once

/// Pearson's chi-square test of `observed` against `expected` counts at significance [`ALPHA`];
/// `expected_err` bounds the quadrature error of each expected count.
pub fn chi2_test(label: &str, observed: &[f64], expected: &[f64], expected_err: &[f64]) {
    let total_o: f64 = observed.iter().sum();
    let total_e: f64 = expected.iter().sum();
    assert!(
        (total_o - total_e).abs() <= 1e-4 * total_o,
        "{label}: expected counts sum to {total_e}, observed to {total_o}"
    );
    // (bin, observed, expected, expected error)
    let mut cats: Vec<(usize, f64, f64, f64)> = Vec::new();
    let (mut pool_o, mut pool_e, mut pool_err) = (0.0, 0.0, 0.0);
    for (i, ((&o, &e), &de)) in observed.iter().zip(expected).zip(expected_err).enumerate() {
        if e < 5.0 {
            pool_o += o;
            pool_e += e.max(0.0);
            pool_err += de;
        } else {
            cats.push((i, o, e, de));
        }
    }
    // Rare bins together: an exact one-sided Poisson test (catches samples where the density is 0).
    if pool_o > pool_e {
        let p = poisson_upper_tail(pool_e + pool_err, pool_o as u64);
        assert!(
            p >= ALPHA,
            "{label}: {pool_o} samples fell in bins expecting {pool_e:.3} in total (P = {p:.2e})"
        );
    }
    if pool_e >= 5.0 {
        cats.push((usize::MAX, pool_o, pool_e, pool_err));
    } else if let Some(c) = cats.iter_mut().min_by(|a, b| a.2.total_cmp(&b.2)) {
        c.1 += pool_o;
        c.2 += pool_e;
        c.3 += pool_err;
    }
    if cats.len() < 2 {
        return; // a single category carries no information beyond the total
    }
    let stat: f64 = cats.iter().map(|c| (c.1 - c.2).powi(2) / c.2).sum();
    // With weights 1/E held fixed, sqrt(stat) is a weighted ℓ2 norm of (O − E): by the triangle
    // inequality, errors δ in E move it by at most sqrt(Σ δ²/E). Require that to be small against
    // the gap between the threshold and the statistic's typical value.
    let shift: f64 = cats.iter().map(|c| c.3 * c.3 / c.2).sum::<f64>().sqrt();
    let dof = (cats.len() - 1) as f64;
    let limit = chi2_quantile(dof, ALPHA);
    assert!(
        shift <= 0.05 * (limit.sqrt() - dof.sqrt()),
        "{label}: quadrature too coarse for the chi-square test (shift {shift:.3})"
    );
    if stat > limit {
        cats.sort_by(|a, b| {
            let ca = (a.1 - a.2).powi(2) / a.2;
            let cb = (b.1 - b.2).powi(2) / b.2;
            cb.total_cmp(&ca)
        });
        let worst: Vec<String> = cats
            .iter()
            .take(6)
            .map(|c| format!("bin {}: observed {} expected {:.1}", c.0 as isize, c.1, c.2))
            .collect();
        panic!(
            "{label}: chi-square {stat:.1} > {limit:.1} (dof {dof}, α {ALPHA}); worst: {}",
            worst.join("; ")
        );
    }
}

/// Checks a set of z-scores from independent estimates of equal expectations, judged together so
/// that a correct code fails with probability at most [`ALPHA`] whatever the seeds: none beyond
/// `z_limit(2m)` (Bonferroni over the m scores at ALPHA/2: 4.6 for 10 scores, 5.0 for 100), and
/// no more beyond 3 than a binomial tail at ALPHA/2 allows (each is beyond 3 with probability
/// 0.27 %: at most 2 of 10, 3 of 64, 4 of 100). The first catches one estimate far off, the second many
/// a little off.
pub fn assert_consistent(what: &str, zs: &[(String, f64)]) {
    let m = zs.len() as u64;
    let p3 = 2.0 * normal_upper_tail(3.0);
    let allowed = (0..=m)
        .find(|&c| binomial_upper_tail(m, p3, c + 1) <= ALPHA / 2.0)
        .unwrap_or(m);
    let limit = z_limit(2 * zs.len());
    let beyond3: Vec<_> = zs.iter().filter(|(_, z)| z.abs() > 3.0).collect();
    let mean_sq = zs.iter().map(|(_, z)| z * z).sum::<f64>() / zs.len() as f64;
    eprintln!(
        "{what}: {m} comparisons, mean z² {mean_sq:.2}, beyond 3: {beyond3:?} (at most \
         {allowed}), none beyond {limit:.2}"
    );
    for (name, z) in zs {
        assert!(
            z.abs() <= limit,
            "{what}: {name}: z = {z:.2} (limit {limit:.2})"
        );
    }
    assert!(
        beyond3.len() as u64 <= allowed,
        "{what}: {} of {m} beyond 3 standard errors (at most {allowed})",
        beyond3.len(),
    );
}
