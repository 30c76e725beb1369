//! The extraction itself: thresholds, filter responses, per-cell measures (the Hessian's dominant
//! eigenvalue and direction, the jump across the gradient), marking, then the lines (2D).

use super::filters::{Bank, THIRD_ORDERS, gradient_orders, hessian_orders};
use super::grid::{Grid, defined_cells};
use super::lines::trace_lines;
use super::scale::{default_scale, default_tau};
use super::significance::z_map;
use super::{SepParams, Separatrices, SeparatrixError};

/// Extracts separatrices from `grid` with `params` (checked by [`SepParams::check`]).
pub fn extract(grid: &Grid, params: &SepParams) -> Result<Separatrices, SeparatrixError> {
    params.check()?;
    let n = grid.len();
    if n == 0 || grid.sigma.len() != n || grid.stderr.len() != n || grid.valid.len() != n {
        return Err(SeparatrixError::EmptyGrid);
    }
    let ndim = grid.ndim();
    let tau = match params.tau {
        Some(t) => t,
        None => default_tau(grid),
    };
    let scale = params
        .scale
        .unwrap_or_else(|| default_scale(grid, tau, params.z));
    let bank = Bank::new(grid.dims, ndim, scale);
    let defined = defined_cells(grid, bank.r);
    let responses = Responses::filter(grid, &bank, &defined);
    let Measures {
        strength,
        dir,
        jump,
        jump_offset,
    } = measure_cells(grid, scale, &responses, &defined);
    let marked: Vec<bool> = (0..n)
        .map(|i| {
            defined[i] && strength[i] >= tau && strength[i] > 0.0 && responses.z[i] >= params.z
        })
        .collect();
    let gradients = (ndim == 2).then(|| responses.gradients(grid));
    let mut sep = Separatrices {
        dims: grid.dims,
        scale,
        tau,
        z_threshold: params.z,
        strength,
        z: responses.z,
        dir,
        jump,
        jump_z: responses.jump_z,
        defined,
        marked,
        line: vec![0; n],
        lines: Vec::new(),
    };
    if let Some(grads) = gradients {
        trace_lines(&mut sep, &grads, &jump_offset);
    }
    Ok(sep)
}

/// σ filtered at one scale: the Hessian's components with their Scheffé z, the gradient, and in
/// 2D the third derivatives with the jump's Scheffé z (all in cell units).
struct Responses {
    hessian_orders: Vec<[usize; 3]>,
    hessian: Vec<Vec<f64>>,
    z: Vec<f64>,
    gradient: Vec<Vec<f64>>,
    /// Empty in 3D.
    third: Vec<Vec<f64>>,
    /// 0 in 3D.
    jump_z: Vec<f64>,
}

impl Responses {
    fn filter(grid: &Grid, bank: &Bank, defined: &[bool]) -> Responses {
        let ndim = grid.ndim();
        let var: Vec<f64> = grid.stderr.iter().map(|s| s * s).collect();
        let hessian_orders = hessian_orders(ndim);
        let (hv, hc) = bank.components(grid, &var, &hessian_orders);
        let gradient: Vec<Vec<f64>> = gradient_orders(ndim)
            .into_iter()
            .map(|o| bank.apply(&grid.sigma, o))
            .collect();
        let z = z_map(&hv, &hc, defined);
        // Jumps (2D): the third derivative across the line, tested over all directions at once.
        let (third, jump_z) = if ndim == 2 {
            let (tv, tc) = bank.components(grid, &var, &THIRD_ORDERS);
            let jz = z_map(&tv, &tc, defined);
            (tv, jz)
        } else {
            (Vec::new(), vec![0.0; grid.len()])
        };
        Responses {
            hessian_orders,
            hessian: hv,
            z,
            gradient,
            third,
            jump_z,
        }
    }

    /// The 2D gradient per cell in scene units.
    fn gradients(&self, grid: &Grid) -> Vec<[f64; 2]> {
        let (gv, h) = (&self.gradient, grid.cell);
        (0..grid.len())
            .map(|i| [gv[0][i] / h[0], gv[1][i] / h[1]])
            .collect()
    }
}

/// The per-cell measures (see the module docs), 0 where a cell is not defined or a value is not
/// finite.
struct Measures {
    strength: Vec<f64>,
    dir: Vec<[f64; 3]>,
    jump: Vec<f64>,
    /// Where σ_nn = 0 along n, from the cell centre, in cells (2D jump lines are drawn through it).
    jump_offset: Vec<[f64; 2]>,
}

/// The strength and direction of the Hessian's dominant eigenvalue at every defined cell and, in
/// 2D, the jump across the gradient with the offset to the step's centre.
fn measure_cells(grid: &Grid, scale: f64, r: &Responses, defined: &[bool]) -> Measures {
    let n = grid.len();
    let ndim = grid.ndim();
    let h = grid.cell;
    let h_geo = h[..ndim].iter().product::<f64>().powf(1.0 / ndim as f64);
    let norm2 = (scale * h_geo).powi(2);
    let mut strength = vec![0.0; n];
    let mut dir = vec![[0.0; 3]; n];
    let mut jump = vec![0.0; n];
    let mut jump_offset = vec![[0.0; 2]; n];
    for i in 0..n {
        if !defined[i] {
            continue;
        }
        let m = hessian_at(r, h, i);
        let (lambda, d) = dominant_eigen(m, ndim);
        strength[i] = (lambda.abs() * norm2).min(f64::MAX);
        // The eigenvector is in physical axes; report it so (unit length).
        dir[i] = d;
        if ndim == 2 {
            let (gx, gy) = (r.gradient[0][i] / h[0], r.gradient[1][i] / h[1]);
            let g = gx.hypot(gy);
            if g > 0.0 {
                let (j, offset) = jump_at(r, h, i, &m, (gx / g, gy / g), scale * h_geo);
                jump[i] = j;
                if let Some(o) = offset {
                    jump_offset[i] = o;
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
    Measures {
        strength,
        dir,
        jump,
        jump_offset,
    }
}

/// The physical Hessian at cell `i`: cell-unit derivatives divided by the cell sizes `h`.
fn hessian_at(r: &Responses, h: [f64; 3], i: usize) -> [[f64; 3]; 3] {
    let mut m = [[0.0; 3]; 3];
    for (c, o) in r.hessian_orders.iter().enumerate() {
        let axes: Vec<usize> = (0..3).flat_map(|a| std::iter::repeat_n(a, o[a])).collect();
        let (a, b) = (axes[0], axes[1]);
        let v = r.hessian[c][i] / (h[a] * h[b]);
        m[a][b] = v;
        m[b][a] = v;
    }
    m
}

/// The jump strength at cell `i` of a 2D field whose unit gradient direction is `(nx, ny)` and
/// Hessian `m`, with `s` the scale in scene units; and the offset, in cells, from the cell centre
/// to the zero of σ_nn (the step's centre), when one Newton step finds it within a cell.
fn jump_at(
    r: &Responses,
    h: [f64; 3],
    i: usize,
    m: &[[f64; 3]; 3],
    (nx, ny): (f64, f64),
    s: f64,
) -> (f64, Option<[f64; 2]>) {
    let d3 = |c: usize, a: i32| r.third[c][i] / (h[0].powi(3 - a) * h[1].powi(a));
    let nnn = nx.powi(3) * d3(0, 0)
        + 3.0 * nx * nx * ny * d3(1, 1)
        + 3.0 * nx * ny * ny * d3(2, 2)
        + ny.powi(3) * d3(3, 3);
    // A blurred step D Phi(x/s) has the third derivative -D/(s^3 sqrt(2 pi)) at its centre.
    let jump = (-nnn).max(0.0) * s.powi(3) * (2.0 * std::f64::consts::PI).sqrt();
    // One Newton step to the zero of σ_nn (the step's centre): −σ_nn / σ_nnn.
    let nn = nx * nx * m[0][0] + 2.0 * nx * ny * m[0][1] + ny * ny * m[1][1];
    let mut offset = None;
    if nnn < 0.0 {
        let d = -nn / nnn;
        let (dx, dy) = (d * nx / h[0], d * ny / h[1]);
        if dx.is_finite() && dy.is_finite() && dx.hypot(dy) <= 1.0 {
            offset = Some([dx, dy]);
        }
    }
    (jump, offset)
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
