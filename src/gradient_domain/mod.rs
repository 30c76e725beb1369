//! Gradient-domain estimation (paper eqs. 10-14 over cells, differences from correlated samples).
//!
//! Every sample of a cell is replayed at the cell's upper neighbour along each axis: the same
//! random numbers (the start point's place in its cell, run length, directions, walk decisions),
//! the start point moved by one cell spacing ("random replay", the simplest shift mapping of
//! gradient-domain rendering). Walks from the two points follow each other wherever the scene does
//! not split them, so the difference of the two samples is small except where the transport
//! changes, and it estimates the difference of the two cells' moments m0 = E[c], m1 = E[cΔ],
//! m2 = E[cΔ²] with far less noise than two independent cells would. The replayed sample is also
//! an unbiased sample of the neighbour's own moments (its start point is uniform in that cell), so
//! it adds to the neighbour's primal estimate: nothing traced is wasted.
//!
//! The field is then the screened Poisson reconstruction of the moments in the L2 norm
//! ([`recon`]): per moment, the values I minimising Σ α²·nⱼ (Iⱼ − Pⱼ)² + Σₑ fₑ·nₑ (I_b − I_a − Dₑ)²
//! over cells j (primal estimates P from nⱼ samples) and neighbour edges e (difference estimates D
//! from nₑ replayed pairs). The factor fₑ weighs each edge by how far the walks of its pairs part
//! ([`edge_weights`]), measured on the other half of the replicates than the one it weighs, so
//! the solution of each half is linear in its estimates with weights that do not depend on them:
//! each cell keeps its expectation (the reconstruction is unbiased); σ is eq. 14 of the
//! reconstructed moments. Where a cell's replicates say the reconstruction is less precise than
//! the cell's own samples (with those replayed into it), as at a cell of little weight beside
//! bright ones whose moments the neighbours' differences swamp, the cell keeps its own estimate.
//!
//! Everything stored is a sum, so runs still merge, tile and resume by addition. The samples of a
//! cell are dealt round-robin by QMC group into [`REPLICATES`] independent replicates, each kept
//! apart: the reconstruction of each replicate alone gives the spread of the reconstructed moments
//! with every correlation between cells included, which the standard errors of σ and of anything
//! linear in the field (differences, filters) are computed from.

pub mod recon;
pub mod solve;

use crate::ftpd::moments::{GroupSums, sigma_from};

/// Independent replicates the samples are dealt into (by QMC group, round robin): the units of the
/// reconstructed field's standard error. 16 replicates give the error estimate 15 degrees of
/// freedom (its own relative spread about 18 %), at 16 × (1 + 3·(1 + axes)) sums per cell.
pub const REPLICATES: usize = 16;

/// Weight α of the primal estimates against the differences (α² per sample, differences 1 per
/// pair); chosen by measurement (docs/performance.md).
pub const DEFAULT_ALPHA: f64 = 0.5;

/// Bytes a cell of a gradient-domain grid with `axes` axes needs besides an ordinary one's, at
/// most: its replicates' sums ([`Shift::stride`] f64), the two halves' edge weights (2·axes f64)
/// and the spreads they are measured from ((1 + axes) `Option<f64>`), and what finishing the
/// field holds at once when all [`REPLICATES`] + 2 reconstructions ([`recon::values`]: one per
/// replicate, one per half) run together, and the two halves joined: each keeps per cell the
/// sample counts, primal sums, edge weights and difference sums (5 + 4·axes f64), the finished
/// moments, the plain ones and the arrays of the solve in progress (11 f64), and one flag.
pub const fn bytes_per_cell(axes: usize) -> usize {
    let stored = REPLICATES * (1 + 3 * (1 + axes)) * size_of::<f64>();
    let weights = 2 * axes * size_of::<f64>() + (1 + axes) * size_of::<Option<f64>>();
    let per_reconstruction = (5 + 4 * axes + 11) * size_of::<f64>() + size_of::<bool>();
    stored + weights + (REPLICATES + 3) * per_reconstruction
}

/// The sums of a gradient-domain run, per cell and replicate: the sample count, the sums
/// (Σc, ΣcΔ, ΣcΔ²) of the cell's own samples, and those of their replays at the upper neighbour
/// along each axis (zero where the cell has none).
#[derive(Clone, Debug, PartialEq)]
pub struct Shift {
    /// α of the reconstruction.
    pub alpha: f64,
    /// Axes with neighbours: 2 for planes and images, 3 for volumes.
    pub axes: usize,
    /// Cell-major, [`Shift::stride`] values per cell: per replicate, [n, B0, B1, B2, S₀0, S₀1,
    /// S₀2, S₁0, …] with B the cell's own sums and Sₐ those of its replays along axis a.
    pub data: Vec<f64>,
}

/// A replicate's sums for one cell as [`Shift::add`] takes them.
#[derive(Clone, Copy, Debug, Default)]
pub struct Replayed {
    pub base: GroupSums,
    pub shifted: [GroupSums; 3],
}

impl Shift {
    pub fn new(cells: usize, axes: usize, alpha: f64) -> Shift {
        let mut s = Shift {
            alpha,
            axes,
            data: Vec::new(),
        };
        s.data = vec![0.0; cells * s.stride()];
        s
    }

    /// The axes of a grid of `dims`: 3 for a volume (depth > 1), else 2.
    pub fn axes_of(dims: (usize, usize, usize)) -> usize {
        if dims.2 > 1 { 3 } else { 2 }
    }

    /// Values per replicate of a cell: the count and 3 sums for the cell and each axis.
    pub fn block(&self) -> usize {
        1 + 3 * (1 + self.axes)
    }

    /// Values per cell.
    pub fn stride(&self) -> usize {
        REPLICATES * self.block()
    }

    /// Adds one sample of replicate `rep` (its own sums and its replays) to a cell's values.
    #[inline]
    pub fn add(cell: &mut [f64], block: usize, rep: usize, axes: usize, s: &Replayed) {
        let b = &mut cell[rep * block..(rep + 1) * block];
        b[0] += 1.0;
        b[1] += s.base.c;
        b[2] += s.base.a;
        b[3] += s.base.b;
        for a in 0..axes {
            let o = 4 + 3 * a;
            b[o] += s.shifted[a].c;
            b[o + 1] += s.shifted[a].a;
            b[o + 2] += s.shifted[a].b;
        }
    }

    /// Adds the sums of `o` (same grid and axes, checked by the caller).
    pub fn merge(&mut self, o: &Shift) {
        for (a, b) in self.data.iter_mut().zip(&o.data) {
            *a += b;
        }
    }

    /// The replicate QMC group `group` of cell `cell`'s pass falls in, counting the groups the
    /// cell already has: round robin from a phase of the cell ([`phase`]), so that a cell's own
    /// samples and those replayed into it from its lower neighbours fill different replicates and
    /// every replicate has samples in a cell after a few groups, not after [`REPLICATES`].
    #[inline]
    pub fn replicate(phase: u64, groups_before: u64, group: u32) -> usize {
        ((phase + groups_before + group as u64) % REPLICATES as u64) as usize
    }
}

/// The phase of cell `idx`'s replicates: 5i + 11j + 7k. A cell's lower neighbours along x, y and
/// z start 5, 11 ≡ −5 and 7 replicates before it, so the samples replayed into an inner cell of a
/// plane from its two lower neighbours and its own cover all 16 replicates after 6 groups each.
#[inline]
pub fn phase(dims: (usize, usize, usize), idx: usize) -> u64 {
    let (w, h, _) = dims;
    let (i, j, k) = (idx % w, (idx / w) % h, idx / (w * h));
    (5 * i as u64 + 11 * j as u64 + 7 * k as u64) % REPLICATES as u64
}

/// How much the replayed differences of σ gain over those of independent cells: the variance of
/// σ's difference across a replayed neighbour pair over the sum of the two cells' variances of σ
/// (what independent cells' difference would have), each per sample and summed over every
/// neighbour pair, so that the pairs weigh as much as their σ's errors do in the field's error.
/// 0 where the replayed walks never part, about 1 where they always do. Per replicate, σ (eq.
/// 14) of the cell's own sums, of their replays into the neighbour, and of the neighbour's own;
/// each variance is the spread of the [`REPLICATES`] replicates' values weighted by their sample
/// counts. σ, not the moments: near a point light m0 differs wildly between neighbours while σ,
/// a ratio of moments, does not. `None` without a pair that two replicates sampled.
///
/// The summary of a gradient-domain run reports it as how far the scene's walks part. Whether the
/// replay pays is read from the field instead ([`recon::gain`]): the edges weigh by their own
/// share ([`edge_weights`]), so a scene whose pooled share is high can still gain where its walks
/// stay together (docs/performance.md#gradient-domain).
pub fn difference_share(shift: &Shift, dims: (usize, usize, usize)) -> Option<f64> {
    let all: Vec<usize> = (0..REPLICATES).collect();
    let sp = Spreads::of(shift, dims, &all);
    let (mut num, mut den) = (0.0, 0.0);
    for j in 0..sp.own.len() {
        for a in 0..shift.axes {
            if let Some((d, own)) = sp.pair(dims, j, a) {
                num += d;
                den += own;
            }
        }
    }
    let share = num / den;
    (den > 0.0 && share.is_finite()).then_some(share)
}

/// Per-sample spreads of σ over a set of replicates: each cell's own, and per axis that of the
/// difference across each replayed pair (indexed by the pair's lower cell).
struct Spreads {
    own: Vec<Option<f64>>,
    diff: Vec<Vec<Option<f64>>>,
}

impl Spreads {
    /// The spreads of the replicates `reps` of `shift`: per replicate, σ (eq. 14) of the cell's
    /// own sums, of their replays into the neighbour and of the neighbour's own, each variance the
    /// spread of the replicates' values weighted by their sample counts.
    fn of(shift: &Shift, dims: (usize, usize, usize), reps: &[usize]) -> Spreads {
        let (stride, block, axes) = (shift.stride(), shift.block(), shift.axes);
        let n = dims.0 * dims.1 * dims.2;
        let rep =
            |j: usize, r: usize| &shift.data[j * stride + r * block..j * stride + (r + 1) * block];
        // σ of one replicate's sums at offset `o` (the cell's own at 1, a replay's at 4 + 3a).
        let sigma = |b: &[f64], o: usize| -> Option<f64> {
            let m0 = b[o];
            if !(b[0] > 0.0 && m0 > 0.0) {
                return None;
            }
            let s = sigma_from(b[o + 1] / m0, b[o + 2] / m0);
            s.is_finite().then_some(s)
        };
        // The count-weighted spread of per-replicate values about their weighted mean:
        // Σᵣ nᵣ (xᵣ − x̄)² over (R − 1), the variance of one sample's worth.
        let spread = |items: &mut dyn Iterator<Item = Option<(f64, f64)>>| -> Option<f64> {
            let (mut cnt, mut sum, mut k) = (0.0, 0.0, 0usize);
            let mut seen = [(0.0, 0.0); REPLICATES];
            for (c, x) in items.flatten() {
                seen[k] = (c, x);
                k += 1;
                cnt += c;
                sum += c * x;
            }
            if k < 2 {
                return None;
            }
            let mean = sum / cnt;
            let ss: f64 = seen[..k].iter().map(|&(c, x)| c * (x - mean).powi(2)).sum();
            Some(ss / (k - 1) as f64)
        };
        let own = (0..n)
            .map(|c| {
                spread(
                    &mut reps
                        .iter()
                        .map(|&r| Some((rep(c, r)[0], sigma(rep(c, r), 1)?))),
                )
            })
            .collect();
        let diff = (0..axes)
            .map(|a| {
                (0..n)
                    .map(|j| {
                        neighbour(dims, j, a)?;
                        spread(&mut reps.iter().map(|&r| {
                            let b = rep(j, r);
                            Some((b[0], sigma(b, 4 + 3 * a)? - sigma(b, 1)?))
                        }))
                    })
                    .collect()
            })
            .collect();
        Spreads { own, diff }
    }

    /// The pair (j, its upper neighbour along `a`): its difference's spread and the sum of the two
    /// cells' own, where all three are known.
    fn pair(&self, dims: (usize, usize, usize), j: usize, a: usize) -> Option<(f64, f64)> {
        let nb = neighbour(dims, j, a)?;
        Some((self.diff[a][j]?, self.own[j]? + self.own[nb]?))
    }
}

/// Cells each side of an edge, along every axis of the grid, whose pairs' spreads are pooled into
/// the edge's share in [`edge_weights`]: 1, a 3×3 window of parallel edges in a plane (3×3×3 in a
/// volume). Measured on the same samples: one edge's own share, from 15 degrees of freedom, left
/// the Cornell box's field error 12 % higher; a 5×5 window 2 % higher there and 6 % on the
/// flatland stair wall, whose edges where walks part it blurs.
const SHARE_WINDOW: usize = 1;

/// Bounds of [`edge_weights`]' factors: an edge weighs at most 4 times and at least an eighth of
/// what the uniform α gives it. Above, a share measured as nearly 0 from few replicates would pin
/// two cells together, and the solve's conjugate gradients need more iterations the heavier the
/// edges weigh against the cells (47 per solve without factors, 90 up to 4, 124 up to 8, on a
/// 256² Cornell box) for errors within 3 % of those up to 8 on every shipped scene; below, edges
/// where walks always part keep 1/8 (a share of 1 at α = 0.5).
const WEIGHT_MAX: f64 = 4.0;
const WEIGHT_MIN: f64 = 0.125;

/// The factor each replayed edge's weight in the reconstruction gets from the share of σ's
/// difference across it (as [`difference_share`], pooled over a window of parallel edges,
/// [`SHARE_WINDOW`]) measured from the replicates `reps`: α² / (2 · share), clamped to
/// [[`WEIGHT_MIN`], [`WEIGHT_MAX`]], 1 where no share is known. With the primal weight α²
/// per sample, a difference of per-pair variance `share` × (the two cells' variance) then weighs
/// as its variance says (the least-squares weights of independent estimates), where a uniform
/// weight over-trusts the differences where walks part (edges, mirrors) and under-trusts them
/// where walks stay together. The reconstruction reads weights measured on other replicates than
/// the sums it weighs ([`recon`]), so that the weights never depend on the estimates they weigh
/// and each cell keeps its expectation. Per axis, indexed by the edge's lower cell.
pub fn edge_weights(shift: &Shift, dims: (usize, usize, usize), reps: &[usize]) -> Vec<Vec<f64>> {
    let sp = Spreads::of(shift, dims, reps);
    let target = shift.alpha * shift.alpha / 2.0;
    let (w, h, d) = dims;
    let r = SHARE_WINDOW as isize;
    // A window reaches along the axes the grid has: a plane's depth is 1.
    let rz = if d > 1 { r } else { 0 };
    let at = |x: isize, y: isize, z: isize| -> Option<usize> {
        let inside = (0..w as isize).contains(&x)
            && (0..h as isize).contains(&y)
            && (0..d as isize).contains(&z);
        inside.then(|| x as usize + w * (y as usize + h * z as usize))
    };
    (0..shift.axes)
        .map(|a| {
            (0..sp.own.len())
                .map(|j| {
                    if neighbour(dims, j, a).is_none() {
                        return 1.0;
                    }
                    let (x, y, z) = (
                        (j % w) as isize,
                        ((j / w) % h) as isize,
                        (j / (w * h)) as isize,
                    );
                    let (mut num, mut den) = (0.0, 0.0);
                    for dz in -rz..=rz {
                        for dy in -r..=r {
                            for dx in -r..=r {
                                let pair =
                                    at(x + dx, y + dy, z + dz).and_then(|q| sp.pair(dims, q, a));
                                if let Some((dd, own)) = pair {
                                    num += dd;
                                    den += own;
                                }
                            }
                        }
                    }
                    let share = num / den;
                    if den > 0.0 && share.is_finite() {
                        (target / share.max(target / WEIGHT_MAX)).clamp(WEIGHT_MIN, WEIGHT_MAX)
                    } else {
                        1.0
                    }
                })
                .collect()
        })
        .collect()
}

/// The upper neighbour of cell `idx` along `axis` in a grid of `dims` (x fastest), if any.
#[inline]
pub fn neighbour(dims: (usize, usize, usize), idx: usize, axis: usize) -> Option<usize> {
    let (w, h, d) = dims;
    let (i, j, k) = (idx % w, (idx / w) % h, idx / (w * h));
    match axis {
        0 => (i + 1 < w).then_some(idx + 1),
        1 => (j + 1 < h).then_some(idx + w),
        _ => (k + 1 < d).then_some(idx + w * h),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn neighbours_stop_at_the_upper_edges() {
        let dims = (3, 2, 2);
        assert_eq!(neighbour(dims, 0, 0), Some(1));
        assert_eq!(neighbour(dims, 2, 0), None);
        assert_eq!(neighbour(dims, 2, 1), Some(5));
        assert_eq!(neighbour(dims, 5, 1), None);
        assert_eq!(neighbour(dims, 5, 2), Some(11));
        assert_eq!(neighbour(dims, 11, 2), None);
    }

    #[test]
    fn an_inner_cell_has_every_replicate_after_six_groups() {
        let dims = (9, 9, 1);
        let idx = 4 + 9 * 4;
        let mut seen = [false; REPLICATES];
        for src in [idx, idx - 1, idx - 9] {
            for g in 0..6 {
                seen[Shift::replicate(phase(dims, src), 0, g)] = true;
            }
        }
        assert!(seen.iter().all(|&s| s), "{seen:?}");
    }

    /// A grid whose replicates hold, per cell, `k` samples of unit variance per sum: the replays
    /// of cell j either equal the cell's own sums (`same(j)`: walks that never part, in a field
    /// without gradient) or are independent of everything.
    fn grid(same: impl Fn(usize) -> bool, seed: u64) -> (Shift, (usize, usize, usize)) {
        // Per-sample means of c, cΔ, cΔ² where σ is nearly linear in the sums' noise.
        const MEAN: [f64; 3] = [10.0, 2.0, 5.0];
        let dims = (12, 10, 1);
        let cells = dims.0 * dims.1;
        let mut s = Shift::new(cells, 2, 0.5);
        let (stride, block) = (s.stride(), s.block());
        let mut rng = crate::rng::Sampler::new(seed, 0, 0);
        let k: f64 = 16.0;
        // The sum of k unit-variance samples: normal with variance k (Box-Muller).
        let mut normal = move || {
            let (u, v) = (rng.next_f64().max(1e-300), rng.next_f64());
            (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos() * k.sqrt()
        };
        for j in 0..cells {
            for r in 0..REPLICATES {
                let b = &mut s.data[j * stride + r * block..j * stride + (r + 1) * block];
                b[0] = k;
                for (v, mean) in b[1..4].iter_mut().zip(MEAN) {
                    *v = mean * k + normal();
                }
            }
        }
        for j in 0..cells {
            for a in 0..2 {
                for r in 0..REPLICATES {
                    for (m, mean) in MEAN.into_iter().enumerate() {
                        let v = match neighbour(dims, j, a) {
                            Some(_) if same(j) => s.data[j * stride + r * block + 1 + m],
                            Some(_) => mean * k + normal(),
                            None => 0.0,
                        };
                        s.data[j * stride + r * block + 4 + 3 * a + m] = v;
                    }
                }
            }
        }
        (s, dims)
    }

    /// Replays equal to the cell's own samples: their difference has no variance. Independent
    /// replays: the pooled ratio is 1 within 4 of its standard errors: numerator and
    /// denominator, sums of per-pair spreads of 15 degrees of freedom over the grid's 218 pairs
    /// and (the denominator's cells recur in up to four pairs) its 120 cells, have relative
    /// errors of about √(2 / (15 · pairs)) and √(2 / (15 · cells)).
    #[test]
    fn difference_share_is_zero_for_equal_replays_and_one_for_independent_ones() {
        let (s, dims) = grid(|_| true, 3);
        assert_eq!(difference_share(&s, dims), Some(0.0));
        let (s, dims) = grid(|_| false, 4);
        let share = difference_share(&s, dims).unwrap();
        let pairs = (11 * 10 + 12 * 9) as f64;
        let tol = 4.0 * (2.0 / (15.0 * pairs) + 2.0 / (15.0 * 120.0)).sqrt();
        assert!((share - 1.0).abs() <= tol, "{share} (tolerance {tol})");
        assert_eq!(difference_share(&Shift::new(4, 2, 0.5), (2, 2, 1)), None);
    }

    /// Replays equal to the cell's own sums in the grid's left half and independent in its right:
    /// the edges of the left half weigh the most they may, those of the right the least (α² / 2
    /// over a share of 1 is 1/8 at α = 0.5, the lower bound; the window's share is 1 within 4 of
    /// its standard errors, √(2 / (15 · 4)) for at least 4 pairs of 15 degrees of freedom), and
    /// no edge without an upper neighbour has a factor other than 1.
    #[test]
    fn edges_weigh_as_their_replays_follow_the_cell() {
        let left = |j: usize| j % 12 < 6;
        let (s, dims) = grid(left, 5);
        let all: Vec<usize> = (0..REPLICATES).collect();
        let w = edge_weights(&s, dims, &all);
        let low = WEIGHT_MIN;
        let high = low / (1.0 - 4.0 * (2.0 / (15.0 * 4.0_f64)).sqrt());
        for (a, edges) in w.iter().enumerate() {
            for (j, &f) in edges.iter().enumerate() {
                let (x, y) = (j % 12, j / 12);
                match neighbour(dims, j, a) {
                    None => assert_eq!(f, 1.0),
                    // The window reaches one cell each way: edges whose window keeps to one
                    // half pool pairs of one kind only.
                    Some(_) if x < 5 => {
                        assert_eq!(f, WEIGHT_MAX, "edge {a} at ({x}, {y})")
                    }
                    Some(_) if x > 6 => {
                        assert!((low..=high).contains(&f), "edge {a} at ({x}, {y}): {f}")
                    }
                    Some(_) => assert!((low..=WEIGHT_MAX).contains(&f)),
                }
            }
        }
    }

    #[test]
    fn replicates_are_dealt_round_robin_across_passes() {
        let mut seen = [0; REPLICATES];
        for g in 0..3 * REPLICATES as u32 {
            seen[Shift::replicate(phase((4, 4, 1), 7), 5, g)] += 1;
        }
        assert!(seen.iter().all(|&n| n == 3));
    }
}
