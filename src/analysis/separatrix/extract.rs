//! The extraction itself: thresholds, filter responses, per-cell measures (the Hessian's dominant
//! eigenvalue and direction, the jump across the gradient), marking, then the lines (2D).

use super::filters::{Bank, THIRD_ORDERS, gradient_orders, hessian_orders};
use super::grid::{Grid, defined_cells};
use super::lines::trace_lines;
use super::scale::{default_scale, median};
use super::significance::z_map;
use super::{SepParams, Separatrices};
use anyhow::bail;

/// Extracts separatrices from `grid` with `params` (checked by [`SepParams::check`]).
pub fn extract(grid: &Grid, params: &SepParams) -> anyhow::Result<Separatrices> {
    params.check()?;
    let n = grid.len();
    if n == 0 || grid.sigma.len() != n || grid.stderr.len() != n || grid.valid.len() != n {
        bail!("separatrices: an empty or inconsistent grid");
    }
    let ndim = grid.ndim();
    let sigmas: Vec<f64> = grid
        .sigma
        .iter()
        .zip(&grid.valid)
        .filter(|(s, ok)| **ok && **s > 0.0)
        .map(|(s, _)| *s)
        .collect();
    let tau = params.tau.unwrap_or(0.1 * median(sigmas));
    let scale = params
        .scale
        .unwrap_or_else(|| default_scale(grid, tau, params.z));
    let bank = Bank::new(grid.dims, ndim, scale);
    let var: Vec<f64> = grid.stderr.iter().map(|s| s * s).collect();
    let defined = defined_cells(grid, bank.r);

    let h_orders = hessian_orders(ndim);
    let (hv, hc) = bank.components(grid, &var, &h_orders);
    let gv: Vec<Vec<f64>> = gradient_orders(ndim)
        .into_iter()
        .map(|o| bank.apply(&grid.sigma, o))
        .collect();
    let z = z_map(&hv, &hc, &defined);
    // Jumps (2D): the third derivative across the line, tested over all directions at once.
    let (tv, jump_z) = if ndim == 2 {
        let (tv, tc) = bank.components(grid, &var, &THIRD_ORDERS);
        let jz = z_map(&tv, &tc, &defined);
        (tv, jz)
    } else {
        (Vec::new(), vec![0.0; n])
    };

    let h = grid.cell;
    let h_geo = h[..ndim].iter().product::<f64>().powf(1.0 / ndim as f64);
    let norm2 = (scale * h_geo).powi(2);
    let mut strength = vec![0.0; n];
    let mut dir = vec![[0.0; 3]; n];
    let mut jump = vec![0.0; n];
    // Where σ_nn = 0 along n, from the cell centre, in cells (2D jump lines are drawn through it).
    let mut jump_offset = vec![[0.0; 2]; n];
    for i in 0..n {
        if !defined[i] {
            continue;
        }
        // Physical Hessian: cell-unit derivatives divided by the cell sizes.
        let mut m = [[0.0; 3]; 3];
        for (c, o) in h_orders.iter().enumerate() {
            let axes: Vec<usize> = (0..3).flat_map(|a| std::iter::repeat_n(a, o[a])).collect();
            let (a, b) = (axes[0], axes[1]);
            let v = hv[c][i] / (h[a] * h[b]);
            m[a][b] = v;
            m[b][a] = v;
        }
        let (lambda, d) = dominant_eigen(m, ndim);
        strength[i] = (lambda.abs() * norm2).min(f64::MAX);
        // The eigenvector is in physical axes; report it so (unit length).
        dir[i] = d;
        if ndim == 2 {
            let (gx, gy) = (gv[0][i] / h[0], gv[1][i] / h[1]);
            let g = gx.hypot(gy);
            if g > 0.0 {
                let (nx, ny) = (gx / g, gy / g);
                let d3 = |c: usize, a: i32| tv[c][i] / (h[0].powi(3 - a) * h[1].powi(a));
                let nnn = nx.powi(3) * d3(0, 0)
                    + 3.0 * nx * nx * ny * d3(1, 1)
                    + 3.0 * nx * ny * ny * d3(2, 2)
                    + ny.powi(3) * d3(3, 3);
                // A blurred step D Phi(x/s) has the third derivative -D/(s^3 sqrt(2 pi)) at its
                // centre.
                jump[i] =
                    (-nnn).max(0.0) * (scale * h_geo).powi(3) * (2.0 * std::f64::consts::PI).sqrt();
                // One Newton step to the zero of σ_nn (the step's centre): −σ_nn / σ_nnn.
                let nn = nx * nx * m[0][0] + 2.0 * nx * ny * m[0][1] + ny * ny * m[1][1];
                if nnn < 0.0 {
                    let d = -nn / nnn;
                    let (dx, dy) = (d * nx / h[0], d * ny / h[1]);
                    if dx.is_finite() && dy.is_finite() && dx.hypot(dy) <= 1.0 {
                        jump_offset[i] = [dx, dy];
                    }
                }
            }
        }
    }
    let clean = |v: &mut Vec<f64>| {
        for x in v.iter_mut() {
            if !x.is_finite() {
                *x = 0.0;
            }
        }
    };
    clean(&mut strength);
    clean(&mut jump);
    let marked: Vec<bool> = (0..n)
        .map(|i| defined[i] && strength[i] >= tau && strength[i] > 0.0 && z[i] >= params.z)
        .collect();

    let mut sep = Separatrices {
        dims: grid.dims,
        scale,
        tau,
        z_threshold: params.z,
        strength,
        z,
        dir,
        jump,
        jump_z,
        defined,
        marked,
        line: vec![0; n],
        lines: Vec::new(),
    };
    if ndim == 2 {
        let grads: Vec<[f64; 2]> = (0..n).map(|i| [gv[0][i] / h[0], gv[1][i] / h[1]]).collect();
        trace_lines(&mut sep, &grads, &jump_offset);
    }
    Ok(sep)
}

/// Eigenvalue of largest magnitude of a symmetric 3×3 (or 2×2 in the upper-left corner, with the
/// rest zero) and its unit eigenvector (cyclic Jacobi).
fn dominant_eigen(mut m: [[f64; 3]; 3], ndim: usize) -> (f64, [f64; 3]) {
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _ in 0..30 {
        let off: f64 = (0..ndim)
            .flat_map(|p| (p + 1..ndim).map(move |q| (p, q)))
            .map(|(p, q)| m[p][q] * m[p][q])
            .sum();
        if off < 1e-30 * (1.0 + (0..ndim).map(|i| m[i][i] * m[i][i]).sum::<f64>()) {
            break;
        }
        for p in 0..ndim {
            for q in p + 1..ndim {
                if m[p][q] == 0.0 {
                    continue;
                }
                let theta = (m[q][q] - m[p][p]) / (2.0 * m[p][q]);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for row in m.iter_mut().take(ndim) {
                    let (mrp, mrq) = (row[p], row[q]);
                    row[p] = c * mrp - s * mrq;
                    row[q] = s * mrp + c * mrq;
                }
                let (mut row_p, mut row_q) = (m[p], m[q]);
                for (a, b) in row_p.iter_mut().zip(row_q.iter_mut()).take(ndim) {
                    let (mpr, mqr) = (*a, *b);
                    *a = c * mpr - s * mqr;
                    *b = s * mpr + c * mqr;
                }
                (m[p], m[q]) = (row_p, row_q);
                for row in v.iter_mut().take(ndim) {
                    let (vp, vq) = (row[p], row[q]);
                    row[p] = c * vp - s * vq;
                    row[q] = s * vp + c * vq;
                }
            }
        }
    }
    let best = (0..ndim)
        .max_by(|&a, &b| m[a][a].abs().total_cmp(&m[b][b].abs()))
        .unwrap_or(0);
    let mut dir = [v[0][best], v[1][best], v[2][best]];
    // A canonical sign: the first non-zero component positive.
    if let Some(&c) = dir.iter().find(|c| c.abs() > 1e-12)
        && c < 0.0
    {
        dir = dir.map(|c| -c);
    }
    (m[best][best], dir)
}
