//! The default strength threshold τ and the default filter scale, chosen from the field's noise.

use super::filters::Bank;
use super::grid::Grid;

/// Candidate default scales, in cells.
const SCALES: &[f64] = &[1.0, 1.25, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0];

/// Smallest scale accepted: below it the sampled Gaussian is no longer smooth.
pub const MIN_SCALE: f64 = 0.7;

/// The default strength threshold τ: a tenth of the median σ of the valid cells with σ > 0 (see
/// the module docs).
pub(super) fn default_tau(grid: &Grid) -> f64 {
    let sigmas: Vec<f64> = grid
        .sigma
        .iter()
        .zip(&grid.valid)
        .filter(|(s, ok)| **ok && **s > 0.0)
        .map(|(s, _)| *s)
        .collect();
    0.1 * median(sigmas)
}

/// Median of the finite values (0 if none).
fn median(mut v: Vec<f64>) -> f64 {
    v.retain(|x| x.is_finite());
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The default scale: the smallest of [`SCALES`] at which the noise of the line measure (2D: the
/// jump's step height; 3D: the strength) in the median valid cell is at most τ, so that a step of
/// Z·τ is significant at Z (the largest that fits the grid otherwise).
pub(super) fn default_scale(grid: &Grid, tau: f64, z: f64) -> f64 {
    let ndim = grid.ndim();
    let min_dim = grid.dims[..ndim].iter().copied().min().unwrap_or(1);
    let fits: Vec<f64> = SCALES
        .iter()
        .copied()
        .filter(|&s| 2 * ((3.0 * s).ceil() as usize) < min_dim.max(3) || s == SCALES[0])
        .collect();
    if tau <= 0.0 || z <= 0.0 {
        return fits[0];
    }
    let var: Vec<f64> = grid.stderr.iter().map(|s| s * s).collect();
    for &s in &fits {
        let bank = Bank::new(grid.dims, ndim, s);
        // 2D: the jump's measure (third derivative, × s³√(2π)); 3D: the Hessian's (× s²).
        let (o, norm) = if ndim == 2 {
            ([3, 0, 0], s.powi(3) * (2.0 * std::f64::consts::PI).sqrt())
        } else {
            ([2, 0, 0], s * s)
        };
        let v = bank.covariance_of(grid, &var, o, o);
        let se: Vec<f64> = v
            .iter()
            .zip(&grid.valid)
            .filter(|(_, ok)| **ok)
            .map(|(v, _)| v.max(0.0).sqrt() * norm)
            .collect();
        if median(se) <= tau {
            return s;
        }
    }
    *fits.last().unwrap_or(&SCALES[0])
}
