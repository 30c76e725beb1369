//! Separatrices extracted from a finished field: eq. 13 of the paper (Zirr, Ament, Dachsbacher,
//! CGF 34(3), 2015), S_τ = {x | ∃ω: |∇²_ω σ(x)| ≥ τ}, with a threshold that is a significance, so
//! that Monte Carlo noise is not called a separatrix.
//!
//! # What is computed
//!
//! σ is smoothed by a Gaussian of standard deviation `scale` cells, and differentiated by the
//! derivatives of that Gaussian (separable, sampled, each normalised so that it is exact on
//! polynomials of its order: a linear ramp has gradient its slope, a parabola x²/2 has second
//! derivative 1). Per cell:
//!
//! - the Hessian H of σ; the largest |ωᵀHω| over unit ω is the eigenvalue of largest magnitude,
//!   its direction the eigenvector: `separatrix.strength` is that value scale-normalised (× (scale
//!   in scene units)²), so it is in units of σ and does not change with the resolution;
//! - in 2D, the third derivative σ_nnn along the gradient direction n: a step Δ of σ blurred at
//!   scale s has σ_nnn = −Δ/(s³√(2π)) at its centre, and a ramp or any smooth field almost none,
//!   so −σ_nnn × s³ × √(2π) is the *jump strength* (the step's height, in units of σ). The
//!   gradient's magnitude itself would not do: a steep smooth ramp has it everywhere.
//!
//! # Standard errors, and the maximum over directions
//!
//! Every filter is linear in the cells, and the cells use independent random streams (keyed by
//! seed, pass and cell: `crate::rng`), so the covariance of two filter outputs K_p and K_q at a
//! cell is Σ_i K_p(i) K_q(i) se_i², with se_i the cell's standard error of σ. Each product of two
//! separable kernels is separable, so these sums are separable filters of se² as well.
//!
//! The direction ω is chosen *after* looking at the data (the largest |∇²_ω σ|), so the z-score of
//! ωᵀHω in that direction would be optimistic: under pure noise its maximum over ω is not a
//! standard normal. Instead `separatrix.z` is the simultaneous (Scheffé) test: with h the Hessian's
//! k independent components (k = 3 in 2D, 6 in 3D) and Σ their covariance, d² = hᵀΣ⁻¹h is the
//! largest squared z of any linear combination of h, so it bounds the squared z of ωᵀHω for every
//! ω at once; under noise alone (H = 0) it is χ²_k. `separatrix.z` is the normal deviate with the
//! same two-sided tail probability as d², so "z ≥ 3" means the same false-alarm rate (0.27 %) as
//! for one normal variable, whatever the direction. The jump's z is the same test for the four
//! third derivatives (k = 4), since n too is chosen from the data.
//!
//! A cell is marked (`separatrix` = 1) where strength ≥ τ and z ≥ Z. τ (`--sep-tau`) is in units of
//! σ; its default is a tenth of the median σ of the valid cells with σ > 0, so that smooth but significant
//! curvature (which a field with many samples shows everywhere) is not called a separatrix. The
//! default scale is the smallest of 1, 1.25, 1.5, 2, 2.5, 3, 4, 5, 6 cells at which a step of height
//! τ would be significant at Z in the median cell (the noise of a derivative falls with the scale).
//!
//! # Which detector draws the lines (paper, sections 4.3 and 5.5)
//!
//! Section 4.3 derives separatrices as discontinuities of the change of influence; section 5.5
//! observes that in FTPD fields most of them show as *zero-order* discontinuities (σ itself steps,
//! because the pairs span a finite cone), the rest as *first-order* ones (σ has a kink). The
//! Hessian of a blurred step is zero on the step and extreme at ± scale beside it, so the maximum
//! of |∇²_ω σ| lies beside a jump, not on it; on a kink it lies on the line. So lines are drawn by
//! two detectors, and the choice is made per place:
//!
//! - **jump**: maxima of the jump strength along the gradient (Canny's non-maximum
//!   suppression), where it is ≥ τ at z ≥ Z (hysteresis down to τ/2 and Z − 1, to neighbours
//!   that lie along the line rather than across it and whose normal turns by less than 45°);
//! - **ridge** (height ridges of |∇²_ω σ|, eq. 13 itself): maxima of the strength along its
//!   direction, same thresholds, except within 2·scale + 1.5 cells of a jump line (where the
//!   Hessian only shows the flanks of that jump).
//!
//! # From line cells to polylines: what noise can and cannot draw
//!
//! The filtered field's noise is correlated over about ±2·scale cells, so one noise excursion
//! makes a short maximum line, and a real line that fades into the noise ends in a hook along
//! whatever smooth structure is next to it. So the linked chains are refined, all in units of the
//! scale:
//!
//! - the thinned cells are made one cell wide first: where a diagonal line runs between cell
//!   centres, non-maximum suppression keeps two cells per row, and a chain through both zigzags
//!   by half a cell, which the turn test below read as bends and cut lines into pieces too short
//!   to keep (see [`one_cell_wide`]; on the ground-truth sweeps of `tests/separatrix.rs`, seeds
//!   1–20 at two resolutions, it raised the runs that pass every check from 34 to 37 of 40 for
//!   the shadow boundary and from 36 to 38 of 40 for its mirror image; it also makes lines drawn
//!   by noise shorter: 1.4 instead of 2.1 per 10⁶ cells in `pure_noise_draws_few_lines`);
//! - a chain is cut where it turns by more than 45° within ⌈scale⌉ + 1 points on either side (a
//!   junction, or a hook);
//! - each piece is trimmed back to its first and last *strong* cell (τ and Z): weak cells join
//!   strong ones, they do not prolong a line where its own significance is gone;
//! - pieces shorter than max(3, ⌈4·scale⌉) cells are dropped ([`MIN_LINE_CELLS`] is the floor);
//! - ends of two lines of one kind are joined across a gap of at most 2·⌈3·scale⌉ cells (one
//!   filter support) when each end lies within 1.5 cells of the other's tangent and the tangents
//!   agree within 30°; the points laid across carry strength and z 0 (bridged, not measured);
//! - lines shorter than [`LINE_MIN_SCALES`] = 6 scales, measured along their points and not
//!   across the bridged gaps, are dropped: that is the length noise does not reach. On fields of
//!   pure noise (no separatrix, τ = 0, Z = 3, scales 1–2, flat or with a ramp under it), a floor
//!   of 4 scales let noise draw about 50 lines per 10⁶ cells, almost all 2–5 scales long; at 6
//!   scales, 1–4 per 10⁶ remain (the test `pure_noise_draws_few_lines` asserts under 10 per 10⁶,
//!   i.e. under 0.05 stray lines in a window of 4 000 cells). Along a line the filtered noise has
//!   the correlation exp(−d²/(4·scale²)) (the Gaussian factor of every filter, convolved with
//!   itself), 10⁻⁴ at 6 scales: a line that long is significant at two places whose noise is
//!   independent, which one noise excursion is not.
//!
//! Where the step across a line passes through zero (a shadow boundary whose step changes sign
//! along it) nothing is drawn: there is no discontinuity to find at that noise level, and the
//! bridge does not guess across more than one filter support.
//!
//! Lines are located to a fraction of a cell: a jump line where the second derivative across it
//! vanishes (one Newton step from the cell centre, −σ_nn/σ_nnn along the gradient), a ridge by a
//! parabola through the maximum and its two neighbours across the line.
//!
//! Cells whose filter support (± ⌈3·scale⌉ cells) holds an invalid cell are left out (strength and
//! z 0, never marked). At the grid's borders σ is continued by point reflection (σ(−k) = 2σ(0) −
//! σ(k)), which keeps linear ramps linear, so borders make no false curvature.

use crate::field::Field;
use anyhow::{Context, bail};
use glam::DVec3;
use std::fmt::Write as _;
use std::path::Path;

/// Shortest chain of line cells kept as a polyline at any scale (see [`LINE_MIN_SCALES`]).
pub const MIN_LINE_CELLS: usize = 3;

/// Shortest line kept, in scales, measured along its points (see the module docs: the length
/// that lines drawn by noise alone do not reach).
pub const LINE_MIN_SCALES: f64 = 6.0;

/// Candidate default scales, in cells.
const SCALES: &[f64] = &[1.0, 1.25, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0];

/// Smallest scale accepted: below it the sampled Gaussian is no longer smooth.
pub const MIN_SCALE: f64 = 0.7;

/// z written where the standard error is 0 but the quantity is not (a noiseless field).
pub const Z_CAP: f64 = 1e3;

/// The user's settings (`None`: the default described in the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SepParams {
    /// Gaussian scale in cells.
    pub scale: Option<f64>,
    /// Significance threshold Z (standard errors).
    pub z: f64,
    /// Strength threshold τ in units of σ.
    pub tau: Option<f64>,
}

impl Default for SepParams {
    fn default() -> Self {
        SepParams {
            scale: None,
            z: 3.0,
            tau: None,
        }
    }
}

impl SepParams {
    /// Refuses values that cannot be used, naming the flag.
    pub fn check(&self) -> anyhow::Result<()> {
        if let Some(s) = self.scale
            && !(s.is_finite() && s >= MIN_SCALE)
        {
            bail!("--sep-scale {s}: the scale must be a number of cells ≥ {MIN_SCALE}");
        }
        if !(self.z.is_finite() && self.z >= 0.0) {
            bail!("--sep-threshold {}: Z must be a finite number ≥ 0", self.z);
        }
        if let Some(t) = self.tau
            && !(t.is_finite() && t >= 0.0)
        {
            bail!("--sep-tau {t}: τ must be a finite number ≥ 0");
        }
        Ok(())
    }
}

/// A grid of σ with its standard errors, as the extraction reads it.
#[derive(Clone, Debug)]
pub struct Grid {
    /// Cells along x, y, z (z = 1 for a 2D field).
    pub dims: [usize; 3],
    pub sigma: Vec<f64>,
    pub stderr: Vec<f64>,
    pub valid: Vec<bool>,
    /// Cell size along each axis in scene units (1 for pixels).
    pub cell: [f64; 3],
}

impl Grid {
    /// The grid of a field; `cell` its cell size per axis. A cell whose σ > 0 has no error
    /// estimate (`Moments::has_estimate`: one unit, or its weight in effectively one) takes σ itself
    /// as its standard error, not the 0 its output stores: unknown is not exact, and such cells'
    /// σ is typically off by half (the glass sphere at 512 spp, against a 16× reference).
    pub fn of_field(field: &Field, cell: [f64; 3]) -> Grid {
        let vals = field.values();
        let ok = |x: f64| x.is_finite();
        Grid {
            dims: [field.width, field.height, field.depth],
            sigma: vals
                .iter()
                .map(|v| if ok(v.sigma) { v.sigma } else { 0.0 })
                .collect(),
            stderr: vals
                .iter()
                .map(|v| match v.estimated {
                    true if ok(v.stderr) => v.stderr.abs(),
                    false if v.valid && ok(v.sigma) => v.sigma.abs(),
                    _ => 0.0,
                })
                .collect(),
            valid: vals
                .iter()
                .map(|v| v.valid && ok(v.sigma) && ok(v.stderr))
                .collect(),
            cell,
        }
    }

    fn ndim(&self) -> usize {
        if self.dims[2] > 1 { 3 } else { 2 }
    }

    fn len(&self) -> usize {
        self.dims.iter().product()
    }
}

/// Which detector found a line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LineKind {
    /// σ steps across the line (zero-order discontinuity).
    Jump,
    /// Height ridge of |∇²_ω σ| (first-order discontinuity, eq. 13).
    Ridge,
}

impl LineKind {
    pub fn name(self) -> &'static str {
        match self {
            LineKind::Jump => "jump",
            LineKind::Ridge => "ridge",
        }
    }
}

/// A polyline in cell coordinates: x = i + 0.5 is the centre of column i, y = j + 0.5 of row j
/// (row 0 at the bottom), each point with the strength and z of its cell.
#[derive(Clone, Debug, PartialEq)]
pub struct Polyline {
    pub kind: LineKind,
    pub points: Vec<[f64; 2]>,
    pub strength: Vec<f64>,
    pub z: Vec<f64>,
}

/// What the extraction found.
#[derive(Clone, Debug)]
pub struct Separatrices {
    pub dims: [usize; 3],
    /// The scale used, in cells; τ and Z used.
    pub scale: f64,
    pub tau: f64,
    pub z_threshold: f64,
    /// Scale-normalised max |∇²_ω σ| (units of σ); 0 where undefined.
    pub strength: Vec<f64>,
    /// Scheffé z of the Hessian (see the module docs); 0 where undefined.
    pub z: Vec<f64>,
    /// Unit direction ω of the largest |∇²_ω σ|, in the grid's axes (x, y, z).
    pub dir: Vec<[f64; 3]>,
    /// Step height across a jump (−σ_nnn · scale³ · √(2π), 2D) and its Scheffé z; 0 in 3D.
    pub jump: Vec<f64>,
    pub jump_z: Vec<f64>,
    /// Cells whose filter support holds only valid cells.
    pub defined: Vec<bool>,
    /// strength ≥ τ and z ≥ Z.
    pub marked: Vec<bool>,
    /// Thinned line cells: 0 none, 1 jump, 2 ridge (2D only; all 0 for volumes).
    pub line: Vec<u8>,
    /// Linked polylines (2D only).
    pub lines: Vec<Polyline>,
}

impl Separatrices {
    pub fn marked_count(&self) -> usize {
        self.marked.iter().filter(|&&m| m).count()
    }

    /// The per-cell arrays, named as the outputs name them (`dir` in the grid's axes: for a slice
    /// x = u, y = v).
    pub fn arrays(&self) -> Vec<(&'static str, Vec<f64>)> {
        let b = |v: &[bool]| v.iter().map(|&m| if m { 1.0 } else { 0.0 }).collect();
        let mut out = vec![
            ("separatrix", b(&self.marked)),
            ("separatrix.strength", self.strength.clone()),
            ("separatrix.z", self.z.clone()),
            ("separatrix.dir.x", self.dir.iter().map(|d| d[0]).collect()),
            ("separatrix.dir.y", self.dir.iter().map(|d| d[1]).collect()),
        ];
        if self.dims[2] > 1 {
            out.push(("separatrix.dir.z", self.dir.iter().map(|d| d[2]).collect()));
        }
        if self.dims[2] == 1 {
            out.push(("separatrix.jump", self.jump.clone()));
            out.push(("separatrix.jump.z", self.jump_z.clone()));
            out.push((
                "separatrix.line",
                self.line.iter().map(|&l| l as f64).collect(),
            ));
        }
        out
    }

    /// One line for a run summary.
    pub fn summary(&self) -> String {
        let n = self.marked.len().max(1);
        let jumps = self.lines.iter().filter(|l| l.kind == LineKind::Jump);
        let ridges = self.lines.iter().filter(|l| l.kind == LineKind::Ridge);
        format!(
            "separatrices (eq. 13, scale {:.3} cells, τ {:.4e}, Z {}): {} of {} cells marked \
             ({:.2} %){}",
            self.scale,
            self.tau,
            self.z_threshold,
            self.marked_count(),
            self.marked.len(),
            100.0 * self.marked_count() as f64 / n as f64,
            if self.dims[2] == 1 {
                format!(
                    ", {} jump lines and {} ridge lines",
                    jumps.count(),
                    ridges.count()
                )
            } else {
                String::new()
            }
        )
    }
}

// ------------------------------------------------------------------------------------------------
// Filters

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
fn hessian_orders(ndim: usize) -> Vec<[usize; 3]> {
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
const THIRD_ORDERS: [[usize; 3]; 4] = [[3, 0, 0], [2, 1, 0], [1, 2, 0], [0, 3, 0]];

fn gradient_orders(ndim: usize) -> Vec<[usize; 3]> {
    (0..ndim)
        .map(|a| {
            let mut o = [0; 3];
            o[a] = 1;
            o
        })
        .collect()
}

/// The filters of one grid at one scale: for each axis, orders 0..=2 and the products of pairs.
struct Bank {
    dims: [usize; 3],
    ndim: usize,
    r: usize,
    axes: Vec<[AxisFilter; 4]>,
}

impl Bank {
    fn new(dims: [usize; 3], ndim: usize, scale: f64) -> Bank {
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
    fn apply(&self, data: &[f64], o: [usize; 3]) -> Vec<f64> {
        let mut f: [Option<&AxisFilter>; 3] = [None; 3];
        for a in 0..self.ndim {
            f[a] = Some(&self.axes[a][o[a]]);
        }
        separable(data, self.dims, f)
    }

    /// Σ_i Kp(i) Kq(i) var_i at every cell, for the kernels of orders `p` and `q`.
    fn covariance(&self, var: &[f64], p: [usize; 3], q: [usize; 3]) -> Vec<f64> {
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
    fn components(
        &self,
        grid: &Grid,
        var: &[f64],
        orders: &[[usize; 3]],
    ) -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
        let vals = orders.iter().map(|&o| self.apply(&grid.sigma, o)).collect();
        let mut cov = Vec::new();
        for (i, &p) in orders.iter().enumerate() {
            for &q in &orders[i..] {
                cov.push(self.covariance(var, p, q));
            }
        }
        (vals, cov)
    }
}

// ------------------------------------------------------------------------------------------------
// Statistics

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

// ------------------------------------------------------------------------------------------------
// Extraction

/// Median of the finite values (0 if none).
fn median(mut v: Vec<f64>) -> f64 {
    v.retain(|x| x.is_finite());
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Cells whose box of half-width r (per active axis) holds only valid cells.
fn defined_cells(grid: &Grid, r: usize) -> Vec<bool> {
    let [nx, ny, nz] = grid.dims;
    let rz = if grid.ndim() == 3 { r } else { 0 };
    // Summed-volume table of invalid cells, (nx+1)(ny+1)(nz+1).
    let (sx, sy) = (nx + 1, (nx + 1) * (ny + 1));
    let mut s = vec![0u32; (nx + 1) * (ny + 1) * (nz + 1)];
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let bad = !grid.valid[i + nx * (j + ny * k)] as u32;
                let at = |i: usize, j: usize, k: usize| i + sx * j + sy * k;
                s[at(i + 1, j + 1, k + 1)] =
                    bad + s[at(i, j + 1, k + 1)] + s[at(i + 1, j, k + 1)] + s[at(i + 1, j + 1, k)]
                        - s[at(i, j, k + 1)]
                        - s[at(i, j + 1, k)]
                        - s[at(i + 1, j, k)]
                        + s[at(i, j, k)];
            }
        }
    }
    let at = |i: usize, j: usize, k: usize| s[i + sx * j + sy * k] as i64;
    let mut out = vec![false; grid.len()];
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let (i0, i1) = (i.saturating_sub(r), (i + r + 1).min(nx));
                let (j0, j1) = (j.saturating_sub(r), (j + r + 1).min(ny));
                let (k0, k1) = (k.saturating_sub(rz), (k + rz + 1).min(nz));
                let bad = at(i1, j1, k1) - at(i0, j1, k1) - at(i1, j0, k1) - at(i1, j1, k0)
                    + at(i0, j0, k1)
                    + at(i0, j1, k0)
                    + at(i1, j0, k0)
                    - at(i0, j0, k0);
                out[i + nx * (j + ny * k)] = bad == 0;
            }
        }
    }
    out
}

/// The Scheffé z of each cell's component vector.
fn z_map(vals: &[Vec<f64>], cov: &[Vec<f64>], defined: &[bool]) -> Vec<f64> {
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

/// The default scale: the smallest of [`SCALES`] at which the noise of the line measure (2D: the
/// jump's step height; 3D: the strength) in the median valid cell is at most τ, so that a step of
/// Z·τ is significant at Z (the largest that fits the grid otherwise).
fn default_scale(grid: &Grid, tau: f64, z: f64) -> f64 {
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
        let v = bank.covariance(&var, o, o);
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

// ------------------------------------------------------------------------------------------------
// Lines (2D)

/// The neighbour step across a line whose normal is `d` (quantised to 8 directions).
fn normal_step(d: [f64; 2]) -> (isize, isize) {
    let a = d[1].atan2(d[0]).rem_euclid(std::f64::consts::PI);
    let oct = ((a / (std::f64::consts::PI / 4.0)).round() as usize) % 4;
    [(1, 0), (1, 1), (0, 1), (-1, 1)][oct]
}

/// Non-maximum suppression + hysteresis of `value` across the normals `normal`, candidates where
/// `ok(i, strong)`. Returns kept cells and the sub-cell offset along the normal step.
fn thin(
    dims: [usize; 3],
    value: &[f64],
    normal: &[[f64; 2]],
    ok: &dyn Fn(usize, bool) -> bool,
) -> (Vec<bool>, Vec<[f64; 2]>) {
    let (w, hgt) = (dims[0] as isize, dims[1] as isize);
    let n = value.len();
    let at = |i: isize, j: isize| -> Option<usize> {
        (i >= 0 && j >= 0 && i < w && j < hgt).then(|| (i + w * j) as usize)
    };
    let mut weak = vec![false; n];
    let mut strong = vec![false; n];
    let mut offset = vec![[0.0; 2]; n];
    for j in 0..hgt {
        for i in 0..w {
            let c = (i + w * j) as usize;
            if !ok(c, false) {
                continue;
            }
            let (di, dj) = normal_step(normal[c]);
            let v0 = value[c];
            let vm = at(i - di, j - dj).map_or(0.0, |k| value[k]);
            let vp = at(i + di, j + dj).map_or(0.0, |k| value[k]);
            // Ties broken to one side, so a plateau two cells wide keeps one.
            if !(v0 > vm && v0 >= vp) {
                continue;
            }
            weak[c] = true;
            strong[c] = ok(c, true);
            let denom = vm - 2.0 * v0 + vp;
            let t = if denom < 0.0 {
                (0.5 * (vm - vp) / denom).clamp(-0.5, 0.5)
            } else {
                0.0
            };
            offset[c] = [t * di as f64, t * dj as f64];
        }
    }
    // Hysteresis: weak cells 8-connected to kept ones along their line, with a normal within 45°
    // of theirs (so that a line does not wander off where its contrast fades and the normals
    // turn).
    let unit = |c: usize| {
        let l = normal[c][0].hypot(normal[c][1]);
        if l > 0.0 {
            [normal[c][0] / l, normal[c][1] / l]
        } else {
            [0.0, 0.0]
        }
    };
    let mut keep = strong.clone();
    let mut stack: Vec<usize> = (0..n).filter(|&c| strong[c]).collect();
    while let Some(c) = stack.pop() {
        let (i, j) = ((c % dims[0]) as isize, (c / dims[0]) as isize);
        for dj in -1..=1 {
            for di in -1..=1 {
                if let Some(k) = at(i + di, j + dj)
                    && weak[k]
                    && !keep[k]
                    && {
                        let (a, b) = (unit(c), unit(k));
                        // Along the line, not across it: the step to the neighbour makes at least
                        // 45° with the normal (so a parallel response beside the line is not
                        // joined to it).
                        let along = (di as f64 * a[0] + dj as f64 * a[1]).abs()
                            <= std::f64::consts::FRAC_1_SQRT_2 * (di as f64).hypot(dj as f64);
                        along
                            && (a[0] * b[0] + a[1] * b[1]).abs() >= std::f64::consts::FRAC_1_SQRT_2
                    }
                {
                    keep[k] = true;
                    stack.push(k);
                }
            }
        }
    }
    one_cell_wide(dims, &mut keep, &strong, value);
    (keep, offset)
}

/// Makes the kept cells a line one cell wide (8-connected). Non-maximum suppression across a
/// quantised normal keeps two cells per row where a diagonal line runs between cell centres
/// (each is the maximum along its own diagonal), and the chain linked through both zigzags: its
/// points alternate between the located line and the centre of a cell half a cell off it, which
/// the turn test (over ⌈scale⌉ + 1 points) read as bends of 45° and more and cut the line into
/// pieces too short to keep. A kept cell at the corner of such a staircase (a kept neighbour to
/// its side and one above or below it) whose other kept neighbours stay 8-connected without it
/// is dropped, weak before strong and weaker first, in one pass (a line is thinned, not eroded
/// from its ends).
fn one_cell_wide(dims: [usize; 3], keep: &mut [bool], strong: &[bool], value: &[f64]) {
    let (w, hgt) = (dims[0] as isize, dims[1] as isize);
    let at = |i: isize, j: isize| -> Option<usize> {
        (i >= 0 && j >= 0 && i < w && j < hgt).then(|| (i + w * j) as usize)
    };
    let mut order: Vec<usize> = (0..keep.len()).filter(|&c| keep[c]).collect();
    // Weak cells before strong ones, weaker first: of two cells side by side, the one kept is
    // the stronger.
    order.sort_by(|&a, &b| {
        strong[a]
            .cmp(&strong[b])
            .then(value[a].total_cmp(&value[b]))
    });
    // The 8 neighbours in ring order, so that ring neighbours are adjacent cells.
    const RING: [(isize, isize); 8] = [
        (1, 0),
        (1, 1),
        (0, 1),
        (-1, 1),
        (-1, 0),
        (-1, -1),
        (0, -1),
        (1, -1),
    ];
    for c in order {
        let (i, j) = ((c % dims[0]) as isize, (c / dims[0]) as isize);
        let on: [bool; 8] = RING.map(|(di, dj)| at(i + di, j + dj).is_some_and(|k| keep[k]));
        let side = on[0] || on[4];
        let above = on[2] || on[6];
        if !(side && above) {
            continue;
        }
        // Count the 8-connected groups of kept neighbours without c: walking the ring, a kept
        // cell starts a group unless the cell before it is kept, or (for a 4-neighbour, at even
        // ring positions) the 4-neighbour two before it is: two 4-neighbours at a right angle
        // touch diagonally even when the diagonal cell between them is not kept. Two diagonal
        // cells two apart do not touch.
        let mut groups = 0;
        for k in 0..8 {
            let prev = (k + 7) % 8;
            let prev2 = (k + 6) % 8;
            let joined = on[prev] || (k % 2 == 0 && on[prev2]);
            if on[k] && !joined {
                groups += 1;
            }
        }
        // 0: every kept neighbour joins the one before it, the ring is closed, one group.
        if groups <= 1 {
            keep[c] = false;
        }
    }
}

/// Links 8-connected kept cells into chains (ends and junctions first, then loops).
fn link(dims: [usize; 3], keep: &[bool]) -> Vec<Vec<usize>> {
    let (w, hgt) = (dims[0] as isize, dims[1] as isize);
    let nb = |c: usize| -> Vec<usize> {
        let (i, j) = ((c % dims[0]) as isize, (c / dims[0]) as isize);
        let mut out = Vec::new();
        // 4-neighbours first, so chains follow the line rather than cut corners.
        for (di, dj) in [
            (1, 0),
            (0, 1),
            (-1, 0),
            (0, -1),
            (1, 1),
            (-1, 1),
            (-1, -1),
            (1, -1),
        ] {
            let (a, b) = (i + di, j + dj);
            if a >= 0 && b >= 0 && a < w && b < hgt && keep[(a + w * b) as usize] {
                out.push((a + w * b) as usize);
            }
        }
        out
    };
    let mut used = vec![false; keep.len()];
    let mut chains = Vec::new();
    let walk = |start: usize, used: &mut [bool]| {
        let mut chain = vec![start];
        used[start] = true;
        let mut cur = start;
        while let Some(next) = nb(cur).into_iter().find(|&k| !used[k]) {
            used[next] = true;
            chain.push(next);
            cur = next;
        }
        chain
    };
    let cells: Vec<usize> = (0..keep.len()).filter(|&c| keep[c]).collect();
    for pass in 0..2 {
        for &c in &cells {
            if used[c] || (pass == 0 && nb(c).len() == 2) {
                continue;
            }
            let mut chain = walk(c, &mut used);
            // A start in the middle of a line: extend backwards from the start too.
            let back = walk_back(&nb, &mut used, c);
            if !back.is_empty() {
                let mut b = back;
                b.reverse();
                b.append(&mut chain);
                chain = b;
            }
            chains.push(chain);
        }
    }
    chains
}

fn walk_back(nb: &dyn Fn(usize) -> Vec<usize>, used: &mut [bool], start: usize) -> Vec<usize> {
    let mut out = Vec::new();
    let mut cur = start;
    while let Some(next) = nb(cur).into_iter().find(|&k| !used[k]) {
        used[next] = true;
        out.push(next);
        cur = next;
    }
    out
}

/// The points of a chain of cells (cell centres moved by their sub-cell offsets).
fn chain_points(dims: [usize; 3], chain: &[usize], off: &[[f64; 2]]) -> Vec<[f64; 2]> {
    chain
        .iter()
        .map(|&c| {
            let (i, j) = (c % dims[0], c / dims[0]);
            [i as f64 + 0.5 + off[c][0], j as f64 + 0.5 + off[c][1]]
        })
        .collect()
}

/// The shortest piece of a chain kept for bridging at `scale`: max([`MIN_LINE_CELLS`],
/// ⌈4·scale⌉) cells (the filtered noise is correlated over about ±2·scale).
fn min_piece_cells(scale: f64) -> usize {
    ((4.0 * scale).ceil() as usize).max(MIN_LINE_CELLS)
}

/// Whether a bridged line is long enough to be kept at `scale` (see the module docs): at least
/// [`LINE_MIN_SCALES`] scales measured along it, not counting the segments laid across gaps
/// (whose points carry z 0).
fn long_enough(line: &Polyline, scale: f64) -> bool {
    let arc: f64 = line
        .points
        .windows(2)
        .zip(line.z.windows(2))
        .filter(|(_, z)| z[0] > 0.0 && z[1] > 0.0)
        .map(|(w, _)| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]))
        .sum();
    arc >= LINE_MIN_SCALES * scale
}

/// Cuts chains where they turn by more than 45° over ⌈scale⌉ + 1 cells on either side (two lines
/// met at a junction, or a line hooking off), trims each piece back to its first and last strong
/// cell (weak cells join strong ones, they do not extend a line where its contrast fades), then
/// drops the pieces shorter than [`min_piece_cells`] (whole lines are judged by [`long_enough`]
/// after bridging).
fn refine_chains(
    dims: [usize; 3],
    chains: Vec<Vec<usize>>,
    off: &[[f64; 2]],
    scale: f64,
    strong: &dyn Fn(usize) -> bool,
) -> Vec<Vec<usize>> {
    let k = (scale.ceil() as usize + 1).max(2);
    let min_len = min_piece_cells(scale);
    let mut out = Vec::new();
    for chain in chains {
        let p = chain_points(dims, &chain, off);
        let n = p.len();
        let cos_turn = |i: usize| {
            let a = [p[i][0] - p[i - k][0], p[i][1] - p[i - k][1]];
            let b = [p[i + k][0] - p[i][0], p[i + k][1] - p[i][1]];
            let l = a[0].hypot(a[1]) * b[0].hypot(b[1]);
            if l > 0.0 {
                (a[0] * b[0] + a[1] * b[1]) / l
            } else {
                1.0
            }
        };
        let cos: Vec<f64> = (0..n)
            .map(|i| {
                if i >= k && i + k < n {
                    cos_turn(i)
                } else {
                    1.0
                }
            })
            .collect();
        let mut start = 0;
        for i in 0..n {
            let local_min =
                (i == 0 || cos[i] <= cos[i - 1]) && (i + 1 == n || cos[i] <= cos[i + 1]);
            if cos[i] < std::f64::consts::FRAC_1_SQRT_2 && local_min {
                out.push(chain[start..i].to_vec());
                start = i + 1;
            }
        }
        out.push(chain[start..].to_vec());
    }
    out.into_iter()
        .filter_map(|c| {
            let first = c.iter().position(|&x| strong(x))?;
            let last = c.iter().rposition(|&x| strong(x))?;
            let c = c[first..=last].to_vec();
            (c.len() >= min_len).then_some(c)
        })
        .collect()
}

/// Unit tangent at one end of a polyline, pointing out of it, from the point `k` back.
fn end_tangent(p: &[[f64; 2]], head: bool, k: usize) -> Option<[f64; 2]> {
    let n = p.len();
    let k = k.min(n.checked_sub(1)?);
    let (a, b) = if head {
        (p[k], p[0])
    } else {
        (p[n - 1 - k], p[n - 1])
    };
    let d = [b[0] - a[0], b[1] - a[1]];
    let l = d[0].hypot(d[1]);
    (l > 0.0).then(|| [d[0] / l, d[1] / l])
}

/// Joins lines of one kind across gaps along their own direction: an end of one and an end of
/// another at most 2·⌈3·scale⌉ cells apart (one filter support, over which one noise excursion can
/// hide a line), each lying within 1.5 cells of the other's tangent line and the two tangents
/// within 30° of each other. Nearest pairs first. The points laid across a gap (one a cell) carry
/// strength and z 0: they are bridged, not measured.
fn bridge(mut lines: Vec<(Polyline, Vec<usize>)>, scale: f64) -> Vec<(Polyline, Vec<usize>)> {
    let max_gap = 2.0 * (3.0 * scale).ceil();
    let k = (scale.ceil() as usize + 1).max(2);
    let cos30 = 0.75f64.sqrt();
    loop {
        let mut best: Option<(f64, usize, bool, usize, bool)> = None;
        for a in 0..lines.len() {
            for b in 0..lines.len() {
                if a == b || lines[a].0.kind != lines[b].0.kind {
                    continue;
                }
                for a_head in [false, true] {
                    for b_head in [false, true] {
                        let (pa, pb) = (&lines[a].0.points, &lines[b].0.points);
                        let ea = if a_head { pa[0] } else { pa[pa.len() - 1] };
                        let eb = if b_head { pb[0] } else { pb[pb.len() - 1] };
                        let (Some(ta), Some(tb)) =
                            (end_tangent(pa, a_head, k), end_tangent(pb, b_head, k))
                        else {
                            continue;
                        };
                        let g = [eb[0] - ea[0], eb[1] - ea[1]];
                        let d = g[0].hypot(g[1]);
                        if !(d > 0.0 && d <= max_gap) {
                            continue;
                        }
                        // The tangents point out of their lines: towards each other, opposed.
                        let along_a = g[0] * ta[0] + g[1] * ta[1];
                        let along_b = -(g[0] * tb[0] + g[1] * tb[1]);
                        let lat_a = (g[0] * ta[1] - g[1] * ta[0]).abs();
                        let lat_b = (g[0] * tb[1] - g[1] * tb[0]).abs();
                        let opposed = -(ta[0] * tb[0] + ta[1] * tb[1]);
                        if along_a > 0.0
                            && along_b > 0.0
                            && lat_a <= 1.5
                            && lat_b <= 1.5
                            && opposed >= cos30
                            && best.is_none_or(|b| d < b.0)
                        {
                            best = Some((d, a, a_head, b, b_head));
                        }
                    }
                }
            }
        }
        let Some((d, a, a_head, b, b_head)) = best else {
            return lines;
        };
        let (hi, lo) = (a.max(b), a.min(b));
        let (lb, cb) = lines.remove(hi);
        let (la, ca) = lines.remove(lo);
        let (mut la, mut lb) = if a > b { (lb, la) } else { (la, lb) };
        let mut cells = ca;
        cells.extend(cb);
        // Orient: la ends at the gap, lb starts at it.
        let rev = |l: &mut Polyline| {
            l.points.reverse();
            l.strength.reverse();
            l.z.reverse();
        };
        if a_head {
            rev(&mut la);
        }
        if !b_head {
            rev(&mut lb);
        }
        let (ea, eb) = (la.points[la.points.len() - 1], lb.points[0]);
        let steps = d.ceil() as usize;
        for s in 1..steps {
            let t = s as f64 / steps as f64;
            la.points
                .push([ea[0] + t * (eb[0] - ea[0]), ea[1] + t * (eb[1] - ea[1])]);
            la.strength.push(0.0);
            la.z.push(0.0);
        }
        la.points.extend(lb.points);
        la.strength.extend(lb.strength);
        la.z.extend(lb.z);
        lines.push((la, cells));
    }
}

fn trace_lines(sep: &mut Separatrices, grads: &[[f64; 2]], jump_offset: &[[f64; 2]]) {
    let dims = sep.dims;
    let n = grads.len();
    let (tau, zt) = (sep.tau, sep.z_threshold);
    let z_low = (zt - 1.0).max(0.5 * zt);
    let (jump, jz, def) = (&sep.jump, &sep.jump_z, &sep.defined);
    let jump_ok = |c: usize, strong: bool| {
        let (t, z) = if strong {
            (tau, zt)
        } else {
            (0.5 * tau, z_low)
        };
        def[c] && jump[c] > 0.0 && jump[c] >= t && jz[c] >= z
    };
    let (jkeep, _) = thin(dims, jump, grads, &jump_ok);
    let joff = jump_offset;
    let jchains = refine_chains(dims, link(dims, &jkeep), joff, sep.scale, &|c| {
        jump_ok(c, true)
    });
    let mut jump_cells = vec![false; n];
    for c in jchains.iter().flatten() {
        jump_cells[*c] = true;
    }
    // Ridges: not within 2·scale + 1.5 cells of a jump line.
    let near = 2.0 * sep.scale + 1.5;
    let ri = near.ceil() as isize;
    let (w, hgt) = (dims[0] as isize, dims[1] as isize);
    let near_jump = |c: usize| {
        let (i, j) = ((c % dims[0]) as isize, (c / dims[0]) as isize);
        for dj in -ri..=ri {
            for di in -ri..=ri {
                let (a, b) = (i + di, j + dj);
                if a >= 0
                    && b >= 0
                    && a < w
                    && b < hgt
                    && ((di * di + dj * dj) as f64) <= near * near
                    && jump_cells[(a + w * b) as usize]
                {
                    return true;
                }
            }
        }
        false
    };
    let (st, z, dir) = (&sep.strength, &sep.z, &sep.dir);
    let ridge_ok = |c: usize, strong: bool| {
        let (t, zz) = if strong {
            (tau, zt)
        } else {
            (0.5 * tau, z_low)
        };
        def[c] && st[c] > 0.0 && st[c] >= t && z[c] >= zz && !near_jump(c)
    };
    let normals: Vec<[f64; 2]> = dir.iter().map(|d| [d[0], d[1]]).collect();
    let (rkeep, roff) = thin(dims, st, &normals, &ridge_ok);
    let rchains = refine_chains(dims, link(dims, &rkeep), &roff, sep.scale, &|c| {
        ridge_ok(c, true)
    });
    let mut lines = Vec::new();
    let mut line = vec![0u8; n];
    for (kind, chains, off, val, zv) in [
        (LineKind::Jump, &jchains, joff, jump, jz),
        (LineKind::Ridge, &rchains, &roff[..], st, z),
    ] {
        for chain in chains {
            let mut p = Polyline {
                kind,
                points: Vec::with_capacity(chain.len()),
                strength: Vec::with_capacity(chain.len()),
                z: Vec::with_capacity(chain.len()),
            };
            for &c in chain {
                let (i, j) = (c % dims[0], c / dims[0]);
                p.points
                    .push([i as f64 + 0.5 + off[c][0], j as f64 + 0.5 + off[c][1]]);
                p.strength.push(val[c]);
                p.z.push(zv[c]);
            }
            lines.push((p, chain.clone()));
        }
    }
    let scale = sep.scale;
    let kept: Vec<(Polyline, Vec<usize>)> = bridge(lines, scale)
        .into_iter()
        .filter(|(l, _)| long_enough(l, scale))
        .collect();
    for (l, cells) in &kept {
        for &c in cells {
            line[c] = if l.kind == LineKind::Jump { 1 } else { 2 };
        }
    }
    sep.line = line;
    sep.lines = kept.into_iter().map(|(l, _)| l).collect();
}

// ------------------------------------------------------------------------------------------------
// Surfaces (3D): marching tetrahedra

/// A triangle mesh in grid coordinates (voxel centre (i, j, k) at (i, j, k)).
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub points: Vec<[f64; 3]>,
    pub triangles: Vec<[usize; 3]>,
}

/// The surface where min(strength/τ, z/Z) = 1 (τ = 0 or Z = 0: that term left out), by marching
/// tetrahedra over the voxel centres (six tetrahedra per cube): it encloses the marked voxels.
pub fn surface(sep: &Separatrices) -> Mesh {
    let [nx, ny, nz] = sep.dims;
    let f: Vec<f64> = (0..sep.strength.len())
        .map(|i| {
            if !sep.defined[i] {
                return 0.0;
            }
            let a = if sep.tau > 0.0 {
                sep.strength[i] / sep.tau
            } else {
                f64::INFINITY
            };
            let b = if sep.z_threshold > 0.0 {
                sep.z[i] / sep.z_threshold
            } else {
                f64::INFINITY
            };
            let v = a.min(b);
            if v.is_finite() {
                v
            } else if sep.strength[i] > 0.0 {
                2.0
            } else {
                0.0
            }
        })
        .collect();
    let mut mesh = Mesh::default();
    if nx < 2 || ny < 2 || nz < 2 {
        return mesh;
    }
    let idx = |i: usize, j: usize, k: usize| i + nx * (j + ny * k);
    let mut edge_point = std::collections::HashMap::new();
    let mut point_on = |a: usize, b: usize, mesh: &mut Mesh| -> usize {
        let key = (a.min(b), a.max(b));
        *edge_point.entry(key).or_insert_with(|| {
            let pos = |c: usize| {
                [
                    (c % nx) as f64,
                    ((c / nx) % ny) as f64,
                    (c / (nx * ny)) as f64,
                ]
            };
            let (fa, fb) = (f[key.0] - 1.0, f[key.1] - 1.0);
            let t = if fa != fb {
                (fa / (fa - fb)).clamp(0.0, 1.0)
            } else {
                0.5
            };
            let (pa, pb) = (pos(key.0), pos(key.1));
            mesh.points.push([
                pa[0] + t * (pb[0] - pa[0]),
                pa[1] + t * (pb[1] - pa[1]),
                pa[2] + t * (pb[2] - pa[2]),
            ]);
            mesh.points.len() - 1
        })
    };
    // Cube corners 0..8 (bit 0: +x, bit 1: +y, bit 2: +z); six tetrahedra around the 0–7 diagonal.
    const TETS: [[usize; 4]; 6] = [
        [0, 1, 3, 7],
        [0, 3, 2, 7],
        [0, 2, 6, 7],
        [0, 6, 4, 7],
        [0, 4, 5, 7],
        [0, 5, 1, 7],
    ];
    for k in 0..nz - 1 {
        for j in 0..ny - 1 {
            for i in 0..nx - 1 {
                let corner = |c: usize| idx(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1));
                for tet in TETS {
                    let v = tet.map(corner);
                    let inside: Vec<usize> = (0..4).filter(|&t| f[v[t]] >= 1.0).collect();
                    let outside: Vec<usize> = (0..4).filter(|&t| f[v[t]] < 1.0).collect();
                    match inside.len() {
                        1 | 3 => {
                            let (lone, others) = if inside.len() == 1 {
                                (inside[0], outside)
                            } else {
                                (outside[0], inside)
                            };
                            let p: Vec<usize> = others
                                .iter()
                                .map(|&o| point_on(v[lone], v[o], &mut mesh))
                                .collect();
                            mesh.triangles.push([p[0], p[1], p[2]]);
                        }
                        2 => {
                            let (a, b) = (inside[0], inside[1]);
                            let (c, d) = (outside[0], outside[1]);
                            let p1 = point_on(v[a], v[c], &mut mesh);
                            let p2 = point_on(v[a], v[d], &mut mesh);
                            let p3 = point_on(v[b], v[d], &mut mesh);
                            let p4 = point_on(v[b], v[c], &mut mesh);
                            mesh.triangles.push([p1, p2, p3]);
                            mesh.triangles.push([p1, p3, p4]);
                        }
                        _ => {}
                    }
                }
            }
        }
    }
    mesh
}

// ------------------------------------------------------------------------------------------------
// Writers: VTK PolyData (.vtp), SVG

/// A polyline in scene coordinates: kind, points, and per point strength and z.
pub type SceneLine = (LineKind, Vec<DVec3>, Vec<f64>, Vec<f64>);

/// Writes polylines (points already in scene coordinates) and/or triangles as VTK XML PolyData,
/// ASCII, with the point arrays `strength` and `z` and the cell array `kind` (0 jump, 1 ridge, 2
/// surface). Written to a temporary name, then renamed.
pub fn write_vtp(
    path: &Path,
    lines: &[SceneLine],
    mesh: Option<(&[DVec3], &[[usize; 3]])>,
) -> anyhow::Result<()> {
    let mut pts: Vec<DVec3> = Vec::new();
    let mut strength = Vec::new();
    let mut zs = Vec::new();
    let mut conn = Vec::new();
    let mut offs = Vec::new();
    let mut kinds = Vec::new();
    for (kind, p, s, z) in lines {
        let base = pts.len();
        pts.extend(p);
        strength.extend(s);
        zs.extend(z);
        conn.extend(base..base + p.len());
        offs.push(conn.len());
        kinds.push(match kind {
            LineKind::Jump => 0,
            LineKind::Ridge => 1,
        });
    }
    let n_lines = offs.len();
    let (mut pconn, mut poffs) = (Vec::new(), Vec::new());
    if let Some((mp, tris)) = mesh {
        let base = pts.len();
        pts.extend(mp);
        strength.extend(std::iter::repeat_n(0.0, mp.len()));
        zs.extend(std::iter::repeat_n(0.0, mp.len()));
        for t in tris {
            pconn.extend(t.iter().map(|v| v + base));
            poffs.push(pconn.len());
        }
    }
    let n_polys = poffs.len();
    let fin = |x: f64| if x.is_finite() { x } else { 0.0 };
    let mut s = String::new();
    let _ = writeln!(s, "<?xml version=\"1.0\"?>");
    let _ = writeln!(
        s,
        "<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\">"
    );
    let _ = writeln!(s, "<PolyData>");
    let _ = writeln!(
        s,
        "<Piece NumberOfPoints=\"{}\" NumberOfVerts=\"0\" NumberOfLines=\"{n_lines}\" \
         NumberOfStrips=\"0\" NumberOfPolys=\"{n_polys}\">",
        pts.len()
    );
    let join = |v: &mut dyn Iterator<Item = String>| v.collect::<Vec<_>>().join(" ");
    // Empty sections are left out (VTK needs none of them; vtkio cannot read an empty array).
    if !pts.is_empty() {
        let _ = writeln!(s, "<PointData Scalars=\"strength\">");
        let _ = writeln!(
            s,
            "<DataArray type=\"Float64\" Name=\"strength\" format=\"ascii\">{}</DataArray>",
            join(&mut strength.iter().map(|v| format!("{:e}", fin(*v))))
        );
        let _ = writeln!(
            s,
            "<DataArray type=\"Float64\" Name=\"z\" format=\"ascii\">{}</DataArray>",
            join(&mut zs.iter().map(|v| format!("{:e}", fin(*v))))
        );
        let _ = writeln!(s, "</PointData>");
    }
    let mut all_kinds: Vec<i32> = kinds.clone();
    all_kinds.extend(std::iter::repeat_n(2, n_polys));
    if !all_kinds.is_empty() {
        let _ = writeln!(s, "<CellData Scalars=\"kind\">");
        let _ = writeln!(
            s,
            "<DataArray type=\"Int32\" Name=\"kind\" format=\"ascii\">{}</DataArray>",
            join(&mut all_kinds.iter().map(|v| v.to_string()))
        );
        let _ = writeln!(s, "</CellData>");
    }
    let _ = writeln!(s, "<Points>");
    let _ = writeln!(
        s,
        "<DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">{}</DataArray>",
        join(
            &mut pts
                .iter()
                .map(|p| format!("{:e} {:e} {:e}", fin(p.x), fin(p.y), fin(p.z)))
        )
    );
    let _ = writeln!(s, "</Points>");
    for (tag, c, o) in [("Lines", &conn, &offs), ("Polys", &pconn, &poffs)] {
        if o.is_empty() {
            continue;
        }
        let _ = writeln!(s, "<{tag}>");
        let _ = writeln!(
            s,
            "<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">{}</DataArray>",
            join(&mut c.iter().map(|v| v.to_string()))
        );
        let _ = writeln!(
            s,
            "<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">{}</DataArray>",
            join(&mut o.iter().map(|v| v.to_string()))
        );
        let _ = writeln!(s, "</{tag}>");
    }
    let _ = writeln!(s, "</Piece>");
    let _ = writeln!(s, "</PolyData>");
    let _ = writeln!(s, "</VTKFile>");
    crate::output::write_atomically(path, |tmp| {
        std::fs::write(tmp, s.as_bytes()).with_context(|| format!("writing {}", tmp.display()))
    })
}

/// Writes the polylines as SVG over the grid (one user unit per cell, y up as in the field).
pub fn write_svg(path: &Path, sep: &Separatrices) -> anyhow::Result<()> {
    let (w, h) = (sep.dims[0], sep.dims[1]);
    let mut s = String::new();
    let _ = writeln!(
        s,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 {w} {h}\" width=\"{}\" \
         height=\"{}\">",
        w * 4,
        h * 4
    );
    let _ = writeln!(
        s,
        "<title>separatrices: scale {:.3} cells, tau {:e}, Z {}</title>",
        sep.scale, sep.tau, sep.z_threshold
    );
    let _ = writeln!(
        s,
        "<rect width=\"{w}\" height=\"{h}\" fill=\"white\" stroke=\"#888\" stroke-width=\"0.2\"/>"
    );
    for l in &sep.lines {
        let colour = match l.kind {
            LineKind::Jump => "#8e24aa",
            LineKind::Ridge => "#fb8c00",
        };
        let pts: Vec<String> = l
            .points
            .iter()
            .map(|p| format!("{:.3},{:.3}", p[0], h as f64 - p[1]))
            .collect();
        let _ = writeln!(
            s,
            "<polyline class=\"{}\" fill=\"none\" stroke=\"{colour}\" stroke-width=\"0.4\" \
             points=\"{}\"/>",
            l.kind.name(),
            pts.join(" ")
        );
    }
    let _ = writeln!(s, "</svg>");
    crate::output::write_atomically(path, |tmp| {
        std::fs::write(tmp, s.as_bytes()).with_context(|| format!("writing {}", tmp.display()))
    })
}

/// σ's preview with the lines drawn over it (jump lines magenta, ridges orange), upscaled so that
/// the longer side has at least 512 pixels.
pub fn write_overlay_png(
    path: &Path,
    sigma: &[f64],
    valid: &[bool],
    sep: &Separatrices,
) -> anyhow::Result<()> {
    let (w, h) = (sep.dims[0], sep.dims[1]);
    let base = crate::output::png::field_colors(sigma, valid, w, h);
    let f = (512 / w.max(h).max(1)).max(1);
    let (bw, bh) = (w * f, h * f);
    let mut img = vec![[0u8; 3]; bw * bh];
    for (y, row) in img.chunks_exact_mut(bw).enumerate() {
        for (x, px) in row.iter_mut().enumerate() {
            *px = base[(x / f) + w * (y / f)];
        }
    }
    let mut dot = |x: f64, y: f64, c: [u8; 3]| {
        let (px, py) = (
            (x * f as f64).floor() as isize,
            (y * f as f64).floor() as isize,
        );
        let r = (f as isize / 4).max(0);
        for dy in -r..=r {
            for dx in -r..=r {
                let (a, b) = (px + dx, py + dy);
                if a >= 0 && b >= 0 && (a as usize) < bw && (b as usize) < bh {
                    img[a as usize + bw * b as usize] = c;
                }
            }
        }
    };
    for l in &sep.lines {
        let c = match l.kind {
            LineKind::Jump => [230, 0, 230],
            LineKind::Ridge => [255, 140, 0],
        };
        for seg in l.points.windows(2) {
            let (a, b) = (seg[0], seg[1]);
            let steps = (((b[0] - a[0]).abs().max((b[1] - a[1]).abs())) * f as f64 * 2.0)
                .ceil()
                .max(1.0) as usize;
            for s in 0..=steps {
                let t = s as f64 / steps as f64;
                dot(a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), c);
            }
        }
        if let [p] = l.points.as_slice() {
            dot(p[0], p[1], c);
        }
    }
    Ok(crate::output::png::write_png(path, bw, bh, &img)?)
}

// ------------------------------------------------------------------------------------------------
// A field's separatrices, end to end

/// Where a field's cells are in the scene.
#[derive(Clone, Debug)]
pub enum Placement {
    /// A slice: corner, axes (unit), size; cells w × h.
    Plane {
        origin: DVec3,
        u: DVec3,
        v: DVec3,
        size: (f64, f64),
    },
    /// A volume: the centre of voxel (0, 0, 0), the voxel size.
    Volume { origin: DVec3, spacing: DVec3 },
    /// A camera image (or a field without a plane): pixel coordinates, z = 0.
    Pixels,
}

impl Placement {
    /// The placement a field's description gives (`file` names it in errors).
    pub fn of_field(field: &Field, file: &str) -> anyhow::Result<Placement> {
        let info = field.info(file)?;
        Ok(if field.depth > 1 {
            match info.volume {
                Some(v) => Placement::Volume {
                    origin: v.min + 0.5 * v.spacing,
                    spacing: v.spacing,
                },
                None => Placement::Volume {
                    origin: DVec3::ZERO,
                    spacing: DVec3::ONE,
                },
            }
        } else {
            match info.plane {
                Some(p) if p.size.0 > 0.0 && p.size.1 > 0.0 => Placement::Plane {
                    origin: p.origin,
                    u: p.u,
                    v: p.v,
                    size: p.size,
                },
                _ => Placement::Pixels,
            }
        })
    }

    /// Cell size per axis in scene units.
    pub fn cell(&self, dims: [usize; 3]) -> [f64; 3] {
        match self {
            Placement::Plane { size, .. } => [
                size.0 / dims[0].max(1) as f64,
                size.1 / dims[1].max(1) as f64,
                1.0,
            ],
            Placement::Volume { spacing, .. } => spacing.to_array(),
            Placement::Pixels => [1.0; 3],
        }
    }

    /// Scene position of grid coordinates (2D: cell units from the lower-left corner; 3D: voxel
    /// index units, voxel centres at integers).
    pub fn position(&self, dims: [usize; 3], p: [f64; 3]) -> DVec3 {
        match self {
            Placement::Plane { origin, u, v, size } => {
                *origin
                    + *u * (p[0] / dims[0].max(1) as f64 * size.0)
                    + *v * (p[1] / dims[1].max(1) as f64 * size.1)
            }
            Placement::Volume { origin, spacing } => *origin + *spacing * DVec3::from_array(p),
            Placement::Pixels => DVec3::new(p[0], p[1], 0.0),
        }
    }
}

/// Extracts the separatrices of `field` (`file` names it in errors).
pub fn of_field(
    field: &Field,
    file: &str,
    params: &SepParams,
) -> anyhow::Result<(Separatrices, Placement)> {
    let placement = Placement::of_field(field, file)?;
    let grid = Grid::of_field(
        field,
        placement.cell([field.width, field.height, field.depth]),
    );
    let sep = extract(&grid, params).with_context(|| format!("{file}: separatrices"))?;
    Ok((sep, placement))
}

/// The files written beside an output `path`: `<name>.sep.vtp` (lines, or a volume's surface),
/// and for 2D fields `<name>.sep.svg` and `<name>.sep.png` (σ with the lines over it).
pub fn side_paths(path: &Path, volume: bool) -> Vec<std::path::PathBuf> {
    let mut out = vec![path.with_extension("sep.vtp")];
    if !volume {
        out.push(path.with_extension("sep.svg"));
        out.push(path.with_extension("sep.png"));
    }
    out
}

/// Writes the side files of [`side_paths`] for `sep` beside `path`.
pub fn write_side_files(
    path: &Path,
    field: &Field,
    sep: &Separatrices,
    placement: &Placement,
) -> anyhow::Result<()> {
    let dims = sep.dims;
    let files = side_paths(path, dims[2] > 1);
    if dims[2] > 1 {
        let mesh = surface(sep);
        let pts: Vec<DVec3> = mesh
            .points
            .iter()
            .map(|p| placement.position(dims, *p))
            .collect();
        write_vtp(&files[0], &[], Some((&pts, &mesh.triangles)))?;
        return Ok(());
    }
    let lines: Vec<_> = sep
        .lines
        .iter()
        .map(|l| {
            (
                l.kind,
                l.points
                    .iter()
                    .map(|p| placement.position(dims, [p[0], p[1], 0.0]))
                    .collect(),
                l.strength.clone(),
                l.z.clone(),
            )
        })
        .collect();
    write_vtp(&files[0], &lines, None)?;
    write_svg(&files[1], sep)?;
    let grid_sigma = Grid::of_field(field, [1.0; 3]);
    write_overlay_png(&files[2], &grid_sigma.sigma, &grid_sigma.valid, sep)
}

/// What [`rerun`] wrote.
#[derive(Clone, Debug)]
pub struct Rerun {
    pub summary: String,
    /// The field first, then the side files.
    pub files: Vec<std::path::PathBuf>,
    pub separatrices: Separatrices,
}

/// `ftpd3d separatrices`: reads a finished (or merged) field, extracts its separatrices with
/// `params` and writes the field again with the `separatrix*` channels (its sums unchanged, so it
/// still merges) to `output` [default: `<input name>_sep.<ext>`], with the side files beside it.
pub fn rerun(
    input: &Path,
    output: Option<&Path>,
    params: &SepParams,
    png: bool,
) -> anyhow::Result<Rerun> {
    use crate::output;
    let ext = crate::scene::load::extension(input).unwrap_or_default();
    let volume = match ext.as_str() {
        "exr" => false,
        "vti" => true,
        _ => bail!(
            "{}: not a field: separatrices reads .exr fields and .vti volumes",
            input.display()
        ),
    };
    let out = match output {
        Some(p) => p.to_path_buf(),
        None => {
            let stem = input
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "field".into());
            input.with_file_name(format!("{stem}_sep.{ext}"))
        }
    };
    if crate::scene::load::extension(&out).as_deref() != Some(ext.as_str()) {
        bail!(
            "-o {}: the output must be a .{ext} like the input {}",
            out.display(),
            input.display()
        );
    }
    output::check_writable(&out)?;
    let name = input.display().to_string();
    let (field, placement, origin_spacing) = if volume {
        let v = output::vti::read_vti(input)?;
        let placement = Placement::Volume {
            origin: v.origin,
            spacing: v.spacing,
        };
        (v.field, placement, Some((v.origin, v.spacing)))
    } else {
        let f = output::exr::read_exr(input)?;
        let placement = Placement::of_field(&f, &name)?;
        (f, placement, None)
    };
    let dims = [field.width, field.height, field.depth];
    let grid = Grid::of_field(&field, placement.cell(dims));
    let sep = extract(&grid, params).with_context(|| format!("{name}: separatrices"))?;
    let arrays = sep.arrays();
    match origin_spacing {
        Some((origin, spacing)) => {
            output::write_volume_outputs_with(&field, origin, spacing, &out, png, &arrays)?
        }
        None => output::write_outputs_with(&field, &out, png, arrays)?,
    }
    write_side_files(&out, &field, &sep, &placement)?;
    let mut files = vec![out.clone()];
    files.extend(side_paths(&out, volume));
    Ok(Rerun {
        summary: sep.summary(),
        files,
        separatrices: sep,
    })
}
