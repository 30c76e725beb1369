//! The significance test: a vector of filter outputs against its covariance (the Scheffé z over
//! all linear combinations at once), and the normal and χ² tails it needs.

/// z written where the standard error is 0 but the quantity is not (a noiseless field).
pub const Z_CAP: f64 = 1e3;

/// erfc(x) for x ≥ 0 (Numerical Recipes' Chebyshev fit, relative error < 1.2e-7).
fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let r = t
        * (-z * z - 1.26551223
            + t * (1.00002368
                + t * (0.37409196
                    + t * (0.09678418
                        + t * (-0.18628806
                            + t * (0.27886807
                                + t * (-1.13520398
                                    + t * (1.48851587 + t * (-0.82215223 + t * 0.17087277)))))))))
            .exp();
    if x >= 0.0 { r } else { 2.0 - r }
}

/// Two-sided tail of the standard normal: P(|N| ≥ z).
pub fn normal_two_sided_tail(z: f64) -> f64 {
    erfc(z.abs() / std::f64::consts::SQRT_2)
}

/// P(χ²_k ≥ x) for k = 1, 2, 3, 4, 6.
fn chi2_tail(k: usize, x: f64) -> f64 {
    let x = x.max(0.0);
    let h = x / 2.0;
    match k {
        1 => erfc(h.sqrt()),
        2 => (-h).exp(),
        3 => erfc(h.sqrt()) + (2.0 * x / std::f64::consts::PI).sqrt() * (-h).exp(),
        4 => (-h).exp() * (1.0 + h),
        6 => (-h).exp() * (1.0 + h + h * h / 2.0),
        _ => unreachable!("χ² tail of {k} degrees of freedom"),
    }
}

/// The z ≥ 0 with P(|N| ≥ z) = p (bisection on the tail; exact to 1e-9 of z).
fn z_of_two_sided_tail(p: f64) -> f64 {
    if p >= 1.0 {
        return 0.0;
    }
    if p <= 1e-290 {
        return f64::NAN; // the caller substitutes
    }
    let (mut lo, mut hi) = (0.0f64, 40.0f64);
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        if normal_two_sided_tail(mid) > p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The normal deviate with the two-sided tail of d² under χ²_k (the Scheffé z; see the module
/// docs). Capped at [`Z_CAP`]; never NaN.
pub fn scheffe_z(k: usize, d2: f64) -> f64 {
    if !d2.is_finite() {
        return if d2 > 0.0 { Z_CAP } else { 0.0 };
    }
    if d2 <= 0.0 {
        return 0.0;
    }
    if k == 1 {
        return d2.sqrt().min(Z_CAP);
    }
    let z = z_of_two_sided_tail(chi2_tail(k, d2));
    if z.is_finite() {
        z.min(Z_CAP)
    } else {
        // Beyond the tail's f64 range: the square root is a lower bound of the same order.
        (d2 - (k as f64 - 1.0) * d2.ln())
            .max(0.0)
            .sqrt()
            .clamp(37.0, Z_CAP)
    }
}

/// hᵀ Σ⁻¹ h for a symmetric positive semi-definite Σ (upper triangle row by row), by Cholesky with
/// a tiny ridge; `None` when Σ is zero (noiseless cells).
fn mahalanobis2(h: &[f64], cov_upper: &[f64]) -> Option<f64> {
    let k = h.len();
    let mut a = vec![0.0; k * k];
    let mut t = 0;
    for i in 0..k {
        for j in i..k {
            a[i * k + j] = cov_upper[t];
            a[j * k + i] = cov_upper[t];
            t += 1;
        }
    }
    let trace: f64 = (0..k).map(|i| a[i * k + i]).sum();
    if !(trace > 0.0) {
        return None;
    }
    for i in 0..k {
        a[i * k + i] += 1e-12 * trace;
    }
    // Cholesky: a = L Lᵀ, in place (lower triangle).
    for j in 0..k {
        let mut d = a[j * k + j];
        for m in 0..j {
            d -= a[j * k + m] * a[j * k + m];
        }
        if !(d > 0.0) {
            return None;
        }
        let d = d.sqrt();
        a[j * k + j] = d;
        for i in j + 1..k {
            let mut s = a[i * k + j];
            for m in 0..j {
                s -= a[i * k + m] * a[j * k + m];
            }
            a[i * k + j] = s / d;
        }
    }
    // Solve L y = h; d² = |y|².
    let mut y = vec![0.0; k];
    for i in 0..k {
        let mut s = h[i];
        for m in 0..i {
            s -= a[i * k + m] * y[m];
        }
        y[i] = s / a[i * k + i];
    }
    let d2: f64 = y.iter().map(|v| v * v).sum();
    d2.is_finite().then_some(d2)
}

/// The Scheffé z of each cell's component vector.
pub(super) fn z_map(vals: &[Vec<f64>], cov: &[Vec<f64>], defined: &[bool]) -> Vec<f64> {
    let k = vals.len();
    (0..defined.len())
        .map(|i| {
            if !defined[i] {
                return 0.0;
            }
            let h: Vec<f64> = vals.iter().map(|v| v[i]).collect();
            let c: Vec<f64> = cov.iter().map(|v| v[i]).collect();
            if h.iter().all(|x| *x == 0.0) {
                return 0.0;
            }
            match mahalanobis2(&h, &c) {
                Some(d2) => scheffe_z(k, d2),
                None => Z_CAP,
            }
        })
        .collect()
}
