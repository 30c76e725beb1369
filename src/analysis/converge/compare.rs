//! One field against a reference: the error measures of a convergence level.

use crate::field::Field;

/// A run against a reference over the cells valid in both.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Comparison {
    pub cells: usize,
    /// Root mean square of σ − σ_ref.
    pub rmse: f64,
    /// Mean of |σ − σ_ref| / σ_ref over the cells with σ_ref > 0.
    pub mean_rel: f64,
    /// Mean of the reference's own estimated variance (stderr²): its share of rmse².
    pub ref_var: f64,
}

impl Comparison {
    /// The RMSE with the reference's own noise taken out: sqrt(max(0, rmse² − ref_var)).
    pub fn net_rmse(&self) -> f64 {
        (self.rmse * self.rmse - self.ref_var).max(0.0).sqrt()
    }
}

/// Compares `field` with `reference` over the cells valid in both.
pub fn compare(field: &Field, reference: &Field) -> Comparison {
    let (a, b) = (field.values(), reference.values());
    let (mut n, mut sq, mut var) = (0usize, 0.0f64, 0.0f64);
    let (mut nr, mut rel) = (0usize, 0.0f64);
    for (x, r) in a.iter().zip(&b) {
        if x.valid && r.valid {
            n += 1;
            sq += (x.sigma - r.sigma).powi(2);
            var += r.stderr * r.stderr;
            if r.sigma > 0.0 {
                nr += 1;
                rel += (x.sigma - r.sigma).abs() / r.sigma;
            }
        }
    }
    let nf = n.max(1) as f64;
    Comparison {
        cells: n,
        rmse: (sq / nf).sqrt(),
        mean_rel: if nr > 0 { rel / nr as f64 } else { 0.0 },
        ref_var: var / nf,
    }
}

/// Mean estimated standard error of σ over the valid cells.
pub fn mean_stderr(field: &Field) -> f64 {
    let (n, s) = field
        .values()
        .iter()
        .filter(|v| v.valid)
        .fold((0usize, 0.0), |(n, s), v| (n + 1, s + v.stderr));
    if n > 0 { s / n as f64 } else { 0.0 }
}
