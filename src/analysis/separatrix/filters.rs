//! The derivative-of-Gaussian filters (separable, sampled, each exact on polynomials of its
//! order) and, since every filter is linear in the cells, the covariances of two filter outputs:
//! Σ_i K_p(i) K_q(i) se_i², themselves separable filters of the cells' variances.

use super::grid::Grid;

/// Sampled Gaussian (order 0) and its first and second derivatives on offsets −r..=r, each
/// normalised to be exact on polynomials of its order (see the module docs).
fn kernels(scale: f64) -> (usize, [Vec<f64>; 4]) {
    let r = (3.0 * scale).ceil().max(1.0) as usize;
    let ks: Vec<f64> = (0..=2 * r).map(|i| i as f64 - r as f64).collect();
    let g: Vec<f64> = ks
        .iter()
        .map(|k| (-k * k / (2.0 * scale * scale)).exp())
        .collect();
    let sg: f64 = g.iter().sum();
    let g0: Vec<f64> = g.iter().map(|x| x / sg).collect();
    let m1: f64 = ks.iter().zip(&g).map(|(k, g)| k * k * g).sum();
    let g1: Vec<f64> = ks.iter().zip(&g).map(|(k, g)| k * g / m1).collect();
    let mean_k2 = m1 / sg;
    let c: f64 = ks
        .iter()
        .zip(&g)
        .map(|(k, g)| (k * k - mean_k2) * k * k * g)
        .sum::<f64>()
        / 2.0;
    let g2: Vec<f64> = ks
        .iter()
        .zip(&g)
        .map(|(k, g)| (k * k - mean_k2) * g / c)
        .collect();
    let m4: f64 = ks.iter().zip(&g).map(|(k, g)| k.powi(4) * g).sum();
    let ratio = m4 / m1;
    let c3: f64 = ks
        .iter()
        .zip(&g)
        .map(|(k, g)| (k.powi(3) - ratio * k) * k.powi(3) * g)
        .sum::<f64>()
        / 6.0;
    let g3: Vec<f64> = ks
        .iter()
        .zip(&g)
        .map(|(k, g)| (k.powi(3) - ratio * k) * g / c3)
        .collect();
    (r, [g0, g1, g2, g3])
}

/// One axis' filter: for each output position x, the weights of the source cells lo[x]..
/// (the kernel with the borders folded in by point reflection).
struct AxisFilter {
    lo: Vec<usize>,
    w: Vec<Vec<f64>>,
}

impl AxisFilter {
    fn new(n: usize, r: usize, kernel: &[f64]) -> AxisFilter {
        let mut lo = Vec::with_capacity(n);
        let mut w = Vec::with_capacity(n);
        let last = n as isize - 1;
        for x in 0..n as isize {
            let a = (x - r as isize).max(0);
            let b = (x + r as isize).min(last);
            let mut ws = vec![0.0; (b - a + 1) as usize];
            let mut add = |src: isize, v: f64| {
                let s = src.clamp(a, b);
                ws[(s - a) as usize] += v;
            };
            for (i, &kv) in kernel.iter().enumerate() {
                let j = x + i as isize - r as isize;
                if j < 0 {
                    add(0, 2.0 * kv);
                    add(-j, -kv);
                } else if j > last {
                    add(last, 2.0 * kv);
                    add(2 * last - j, -kv);
                } else {
                    add(j, kv);
                }
            }
            lo.push(a as usize);
            w.push(ws);
        }
        AxisFilter { lo, w }
    }

    /// The product of two filters, tap by tap (for covariances).
    fn product(&self, other: &AxisFilter) -> AxisFilter {
        AxisFilter {
            lo: self.lo.clone(),
            w: self
                .w
                .iter()
                .zip(&other.w)
                .map(|(a, b)| a.iter().zip(b).map(|(x, y)| x * y).collect())
                .collect(),
        }
    }
}

/// Applies one filter per axis (None: identity) to `data` on the grid `dims`.
fn separable(data: &[f64], dims: [usize; 3], filters: [Option<&AxisFilter>; 3]) -> Vec<f64> {
    let mut cur = data.to_vec();
    let stride = [1, dims[0], dims[0] * dims[1]];
    for axis in 0..3 {
        let Some(f) = filters[axis] else { continue };
        let n = dims[axis];
        let mut out = vec![0.0; cur.len()];
        for (idx, o) in out.iter_mut().enumerate() {
            let x = (idx / stride[axis]) % n;
            let base = idx - x * stride[axis];
            let lo = f.lo[x];
            *o = f.w[x]
                .iter()
                .enumerate()
                .map(|(k, w)| w * cur[base + (lo + k) * stride[axis]])
                .sum();
        }
        cur = out;
    }
    cur
}

/// Kernel orders per axis of the Hessian's components: 2D xx, xy, yy; 3D xx, yy, zz, xy, xz, yz.
pub(super) fn hessian_orders(ndim: usize) -> Vec<[usize; 3]> {
    if ndim == 2 {
        vec![[2, 0, 0], [1, 1, 0], [0, 2, 0]]
    } else {
        vec![
            [2, 0, 0],
            [0, 2, 0],
            [0, 0, 2],
            [1, 1, 0],
            [1, 0, 1],
            [0, 1, 1],
        ]
    }
}

/// The third derivatives of a 2D field: xxx, xxy, xyy, yyy.
pub(super) const THIRD_ORDERS: [[usize; 3]; 4] = [[3, 0, 0], [2, 1, 0], [1, 2, 0], [0, 3, 0]];

pub(super) fn gradient_orders(ndim: usize) -> Vec<[usize; 3]> {
    (0..ndim)
        .map(|a| {
            let mut o = [0; 3];
            o[a] = 1;
            o
        })
        .collect()
}

/// The filters of one grid at one scale: for each axis, orders 0..=2 and the products of pairs.
pub(super) struct Bank {
    dims: [usize; 3],
    ndim: usize,
    pub(super) r: usize,
    axes: Vec<[AxisFilter; 4]>,
}

impl Bank {
    pub(super) fn new(dims: [usize; 3], ndim: usize, scale: f64) -> Bank {
        let (r, k) = kernels(scale);
        let axes = (0..ndim)
            .map(|a| {
                [
                    AxisFilter::new(dims[a], r, &k[0]),
                    AxisFilter::new(dims[a], r, &k[1]),
                    AxisFilter::new(dims[a], r, &k[2]),
                    AxisFilter::new(dims[a], r, &k[3]),
                ]
            })
            .collect();
        Bank {
            dims,
            ndim,
            r,
            axes,
        }
    }

    /// The filter of kernel orders `o` applied to `data`.
    pub(super) fn apply(&self, data: &[f64], o: [usize; 3]) -> Vec<f64> {
        let mut f: [Option<&AxisFilter>; 3] = [None; 3];
        for a in 0..self.ndim {
            f[a] = Some(&self.axes[a][o[a]]);
        }
        separable(data, self.dims, f)
    }

    /// The covariance of the filter outputs of orders `p` and `q` at every cell: from a
    /// gradient-domain grid's replicate deviations when it has them (cells correlated), else
    /// Σ_i Kp(i) Kq(i) var_i (cells independent).
    pub(super) fn covariance_of(
        &self,
        grid: &Grid,
        var: &[f64],
        p: [usize; 3],
        q: [usize; 3],
    ) -> Vec<f64> {
        match &grid.deviations {
            None => self.covariance(var, p, q),
            Some(devs) => {
                let mut out = vec![0.0; var.len()];
                for d in devs {
                    let fp = self.apply(d, p);
                    let fq = if p == q { None } else { Some(self.apply(d, q)) };
                    let fq = fq.as_ref().unwrap_or(&fp);
                    for ((o, a), b) in out.iter_mut().zip(&fp).zip(fq) {
                        *o += a * b;
                    }
                }
                out
            }
        }
    }

    /// Σ_i Kp(i) Kq(i) var_i at every cell, for the kernels of orders `p` and `q`.
    pub(super) fn covariance(&self, var: &[f64], p: [usize; 3], q: [usize; 3]) -> Vec<f64> {
        let prods: Vec<AxisFilter> = (0..self.ndim)
            .map(|a| self.axes[a][p[a]].product(&self.axes[a][q[a]]))
            .collect();
        let mut f: [Option<&AxisFilter>; 3] = [None; 3];
        for (a, pf) in prods.iter().enumerate() {
            f[a] = Some(pf);
        }
        separable(var, self.dims, f)
    }

    /// Component values and their covariance matrix (upper triangle, row by row) per cell.
    pub(super) fn components(
        &self,
        grid: &Grid,
        var: &[f64],
        orders: &[[usize; 3]],
    ) -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
        let vals = orders.iter().map(|&o| self.apply(&grid.sigma, o)).collect();
        let mut cov = Vec::new();
        for (i, &p) in orders.iter().enumerate() {
            for &q in &orders[i..] {
                cov.push(self.covariance_of(grid, var, p, q));
            }
        }
        (vals, cov)
    }
}
