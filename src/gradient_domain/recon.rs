//! The field of a gradient-domain run: the moments reconstructed from the primal sums and the
//! replayed differences ([`super::solve`]), σ from them (eq. 14), and its standard error from the
//! spread of the replicates' reconstructions. Each half of the replicates (even, odd) is
//! reconstructed with the edge weights the other half measures ([`super::edge_weights`]): the
//! field is the two halves' moments weighted by their sample counts, and each replicate's spread
//! is taken with its half's weights.

use super::solve::System;
use super::{REPLICATES, Shift, neighbour};
use crate::ftpd::moments::{CellValue, Moments, sigma_from};
use crate::math::Rgb;
use rayon::prelude::*;

/// The reconstructed per-sample moments (E[c], E[cΔ], E[cΔ²]) of every cell from the replicates
/// `reps` (all of them for the estimate, one for its spread), and per cell whether any sample of
/// those replicates started in it.
pub struct Moments3 {
    pub m: [Vec<f64>; 3],
    pub sampled: Vec<bool>,
    /// Σc of the samples that started in the cell or were replayed into it.
    pub weight: Vec<f64>,
    /// The plain per-sample moments of the samples that started in the cell or were replayed
    /// into it (their sums over their count): each cell's own estimate, without its neighbours.
    pub plain: [Vec<f64>; 3],
    /// The samples that started in the cell or were replayed into it.
    pub count: Vec<f64>,
}

impl Moments3 {
    /// The field of two disjoint sets of replicates: their moments weighted by their sample
    /// counts at each cell (counts that the sampling plan fixes, not the estimates), their plain
    /// estimates likewise (the plain estimate of both sets' samples), their counts and weights
    /// added.
    fn joined(a: &Moments3, b: &Moments3) -> Moments3 {
        let n = a.count.len();
        let mix = |x: &[f64], y: &[f64]| -> Vec<f64> {
            (0..n)
                .map(|j| {
                    let (ca, cb) = (a.count[j], b.count[j]);
                    if ca + cb > 0.0 {
                        (ca * x[j] + cb * y[j]) / (ca + cb)
                    } else {
                        0.5 * (x[j] + y[j])
                    }
                })
                .collect()
        };
        let count: Vec<f64> = a.count.iter().zip(&b.count).map(|(x, y)| x + y).collect();
        Moments3 {
            m: std::array::from_fn(|k| mix(&a.m[k], &b.m[k])),
            sampled: count.iter().map(|&c| c > 0.0).collect(),
            weight: a.weight.iter().zip(&b.weight).map(|(x, y)| x + y).collect(),
            plain: std::array::from_fn(|k| mix(&a.plain[k], &b.plain[k])),
            count,
        }
    }
}

/// Reconstructs the moments of the replicates in `reps` of `shift` over a grid of `dims`, each
/// replayed edge's weight (its pair count) multiplied by its factor in `factors` (per axis, by
/// the edge's lower cell; [`super::edge_weights`]), or by 1 without them.
pub fn reconstruct(
    shift: &Shift,
    dims: (usize, usize, usize),
    reps: &[usize],
    factors: Option<&[Vec<f64>]>,
) -> Moments3 {
    let n = dims.0 * dims.1 * dims.2;
    let (stride, block, axes) = (shift.stride(), shift.block(), shift.axes);
    let a2 = shift.alpha * shift.alpha;
    let mut pn = vec![0.0; n];
    let mut ps = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
    let mut edges = vec![vec![0.0; n]; axes];
    let mut diffs = [
        vec![vec![0.0; n]; axes],
        vec![vec![0.0; n]; axes],
        vec![vec![0.0; n]; axes],
    ];
    for j in 0..n {
        let cell = &shift.data[j * stride..(j + 1) * stride];
        for &r in reps {
            let b = &cell[r * block..(r + 1) * block];
            let cnt = b[0];
            if cnt == 0.0 {
                continue;
            }
            pn[j] += cnt;
            for m in 0..3 {
                ps[m][j] += b[1 + m];
            }
            for a in 0..axes {
                let Some(nb) = neighbour(dims, j, a) else {
                    continue;
                };
                pn[nb] += cnt;
                let f = factors.map_or(1.0, |f| f[a][j]);
                edges[a][j] += f * cnt;
                for m in 0..3 {
                    let s = b[4 + 3 * a + m];
                    ps[m][nb] += s;
                    diffs[m][a][j] += f * (s - b[1 + m]);
                }
            }
        }
    }
    let primal: Vec<f64> = pn.iter().map(|p| a2 * p).collect();
    let sys = System {
        dims,
        primal: &primal,
        edges: &edges,
    };
    let m: [Vec<f64>; 3] = std::array::from_fn(|k| {
        let prhs: Vec<f64> = ps[k].iter().map(|s| a2 * s).collect();
        sys.solve(&sys.rhs(&prhs, &diffs[k])).0
    });
    let plain = std::array::from_fn(|k| {
        ps[k]
            .iter()
            .zip(&pn)
            .map(|(&s, &p)| if p > 0.0 { s / p } else { 0.0 })
            .collect()
    });
    Moments3 {
        m,
        sampled: pn.iter().map(|&p| p > 0.0).collect(),
        weight: std::mem::take(&mut ps[0]),
        plain,
        count: pn,
    }
}

/// The finished values of every cell of a gradient-domain field: σ of the moments reconstructed
/// from all samples, and its standard error by the delta method over the [`REPLICATES`]
/// reconstructions of one replicate each (the units of [`Moments::stderr`], with its corrections
/// for few units and skewness). `base` gives each cell's own fluence and sample count.
pub fn values(shift: &Shift, dims: (usize, usize, usize), base: &[Moments]) -> Vec<CellValue> {
    values_and_deviations(shift, dims, base).0
}

/// [`values`], and per replicate r the linearised deviation of every cell's σ from it,
/// δᵣ = ∇σ · (Iᵣ − Ī) scaled so that Σᵣ δᵣ(i) δᵣ(j) is the covariance of σ at cells i and j (with
/// the correction for few units of [`Moments::stderr`], without its skewness factor). Anything
/// linear in σ (differences, derivative filters) has its variance from the δᵣ filtered alike,
/// with every correlation the reconstruction puts between cells: this is what the separatrices'
/// significance reads. 0 at cells without an estimate.
pub fn values_and_deviations(
    shift: &Shift,
    dims: (usize, usize, usize),
    base: &[Moments],
) -> (Vec<CellValue>, Vec<Vec<f64>>) {
    let f = finished(shift, dims, base);
    (f.values, f.deviations)
}

/// How many times lower the variance of the finished field's σ is than that of the same samples
/// without the differences (each cell's own and those replayed into it, as many paths as an
/// ordinary run traces for it): Σ over cells of the plain estimate's variance over Σ of the
/// field's, over the cells where both have an error estimate. At equal time an ordinary run's
/// cell has about the plain estimate's variance, so this is the reconstruction's gain at equal
/// time, read from the run itself. `None` without such a cell.
pub fn gain(shift: &Shift, dims: (usize, usize, usize), base: &[Moments]) -> Option<f64> {
    finished(shift, dims, base).gain
}

/// The finished field of [`values_and_deviations`] and its [`gain`].
#[derive(Clone)]
struct Finished {
    values: Vec<CellValue>,
    deviations: Vec<Vec<f64>>,
    gain: Option<f64>,
}

fn finished(shift: &Shift, dims: (usize, usize, usize), base: &[Moments]) -> Finished {
    // A finished field is read several times (its summary, each channel and file, the
    // separatrices): the last reconstruction is kept, keyed by a hash of everything it reads.
    let key = fingerprint(shift, dims, base);
    let small = base.len() <= CACHE_CELLS;
    if small
        && let Ok(c) = LAST.lock()
        && let Some((k, f)) = c.as_ref()
        && *k == key
    {
        return f.clone();
    }
    let out = compute(shift, dims, base);
    if small && let Ok(mut c) = LAST.lock() {
        *c = Some((key, out.clone()));
    }
    out
}

/// Fields of at most this many cells keep their last reconstruction ([`values_and_deviations`]).
const CACHE_CELLS: usize = 1 << 20;

/// The last reconstruction, with the fingerprint of its inputs.
static LAST: std::sync::Mutex<Option<(u64, Finished)>> = std::sync::Mutex::new(None);

/// A 64-bit hash of every input of the reconstruction: the grid, α, every replayed sum's bits
/// and each cell's sample count.
fn fingerprint(shift: &Shift, dims: (usize, usize, usize), base: &[Moments]) -> u64 {
    let words = [
        dims.0 as u64,
        dims.1 as u64,
        dims.2 as u64,
        shift.axes as u64,
        shift.alpha.to_bits(),
    ];
    let data = shift.data.iter().map(|x| x.to_bits());
    let counts = base.iter().map(|m| m.n);
    words
        .into_iter()
        .chain(data)
        .chain(counts)
        .fold(0x243f_6a88_85a3_08d3_u64, |h, w| {
            (h.rotate_left(5) ^ w).wrapping_mul(0x9e37_79b9_7f4a_7c15)
        })
}

/// [`values_and_deviations`] computed.
fn compute(shift: &Shift, dims: (usize, usize, usize), base: &[Moments]) -> Finished {
    // Cross-fitted edge weights: the even replicates are reconstructed with the weights the odd
    // ones measure and the odd with the even ones', so that no weight depends on the sums it
    // weighs and each half's reconstruction is linear in its sums with fixed weights (unbiased).
    let halves: [Vec<usize>; 2] = [
        (0..REPLICATES).step_by(2).collect(),
        (1..REPLICATES).step_by(2).collect(),
    ];
    let weights: [Vec<Vec<f64>>; 2] = [
        super::edge_weights(shift, dims, &halves[1]),
        super::edge_weights(shift, dims, &halves[0]),
    ];
    // The replicates one by one (the field's spread) and both halves.
    let mut runs: Vec<Moments3> = (0..REPLICATES + 2)
        .into_par_iter()
        .map(|r| match r {
            r if r < REPLICATES => reconstruct(shift, dims, &[r], Some(&weights[r % 2])),
            r => {
                let k = r - REPLICATES;
                reconstruct(shift, dims, &halves[k], Some(&weights[k]))
            }
        })
        .collect();
    let odd = runs.pop().expect("the odd half");
    let even = runs.pop().expect("the even half");
    let full = Moments3::joined(&even, &odd);
    let n = base.len();
    let mut dev = vec![vec![0.0; n]; REPLICATES];
    let (mut plain_var, mut field_var) = (0.0, 0.0);
    let values = (0..n)
        .map(|j| {
            if !(full.sampled[j] && full.weight[j] > 0.0) {
                return CellValue::default();
            }
            let complete = runs.iter().all(|r| r.sampled[j]);
            let rec = Candidate::of(j, complete, &full.m, runs.iter().map(|r| &r.m));
            let plain = Candidate::of(j, complete, &full.plain, runs.iter().map(|r| &r.plain));
            // The reconstruction where it is the more precise, the cell's own samples where it
            // is not (a cell of little weight beside bright ones, whose moments the neighbours'
            // differences would swamp): either estimates the cell's σ.
            let pick = match (rec, plain.clone()) {
                (Some(a), Some(b))
                    if b.value.estimated
                        && !(a.value.estimated && a.value.stderr <= b.value.stderr) =>
                {
                    b
                }
                (Some(a), _) => a,
                (None, Some(b)) => b,
                (None, None) => return CellValue::default(),
            };
            for (d, p) in dev.iter_mut().zip(pick.deviations) {
                d[j] = p;
            }
            if let Some(b) = plain.filter(|b| b.value.estimated && pick.value.estimated) {
                plain_var += b.value.stderr * b.value.stderr;
                field_var += pick.value.stderr * pick.value.stderr;
            }
            CellValue {
                estimated: pick.value.estimated && base[j].n > 0,
                ..pick.value
            }
        })
        .collect();
    let gain = plain_var / field_var;
    Finished {
        values,
        deviations: dev,
        gain: (field_var > 0.0 && gain.is_finite()).then_some(gain),
    }
}

/// One estimate of a cell's σ (reconstructed or plain) with its replicates' deviations.
#[derive(Clone)]
struct Candidate {
    value: CellValue,
    deviations: [f64; REPLICATES],
}

impl Candidate {
    /// The estimate at cell `j` from the moments `all` of every sample and `reps` of each
    /// replicate alone (`complete`: every replicate has samples there); `None` where σ is not
    /// defined (m0 ≤ 0).
    fn of<'a>(
        j: usize,
        complete: bool,
        all: &[Vec<f64>; 3],
        reps: impl Iterator<Item = &'a [Vec<f64>; 3]>,
    ) -> Option<Candidate> {
        let (m0, m1, m2) = (all[0][j], all[1][j], all[2][j]);
        if !(m0 > 0.0) {
            return None;
        }
        let (q1, q2) = (m1 / m0, m2 / m0);
        let sigma = sigma_from(q1, q2);
        if !(sigma.is_finite() && q1.is_finite() && q2.is_finite()) {
            return None;
        }
        // On the stack: this runs for every cell, twice.
        let mut at = [[0.0; 3]; REPLICATES];
        for (a, m) in at.iter_mut().zip(reps) {
            *a = [m[0][j], m[1][j], m[2][j]];
        }
        let reps = at;
        let mut units = Moments::default();
        if complete {
            for m in &reps {
                units.add_unit(m[0], m[1], m[2], Rgb::ZERO);
            }
        }
        // An error of 0 for σ > 0 is no estimate (the delta method degenerates where the
        // reconstructed moments leave no variance term): it must not win the choice below.
        let stderr = if complete && units.has_estimate() {
            units.stderr()
        } else {
            0.0
        };
        let estimated = stderr > 0.0 && stderr.is_finite();
        let mut deviations = [0.0; REPLICATES];
        if estimated {
            let g = sigma_gradient(m0, q1, q2);
            let r = REPLICATES as f64;
            let mean: [f64; 3] =
                std::array::from_fn(|k| reps.iter().map(|x| x[k]).sum::<f64>() / r);
            let scale = ((r - 1.0) / (r - 3.0) / (r * (r - 1.0))).sqrt();
            for (d, m) in deviations.iter_mut().zip(&reps) {
                let psi: f64 = (0..3).map(|k| g[k] * (m[k] - mean[k])).sum();
                *d = if psi.is_finite() { psi * scale } else { 0.0 };
            }
        }
        Some(Candidate {
            value: CellValue {
                sigma,
                mean: q1,
                m2: q2,
                stderr: if stderr.is_finite() { stderr } else { 0.0 },
                weight: m0,
                valid: true,
                estimated,
            },
            deviations,
        })
    }
}

/// ∂σ/∂(m0, m1, m2) of σ = √q2 + √(q2 − q1²), q1 = m1/m0, q2 = m2/m0 (eq. 14). Where the variance
/// term v = q2 − q1² is 0 its derivative is unbounded: that term is left out, as the per-cell
/// error does where v is not resolved ([`Moments::stderr`]).
fn sigma_gradient(m0: f64, q1: f64, q2: f64) -> [f64; 3] {
    let v = q2 - q1 * q1;
    let (dq1, dq2) = if v > 0.0 && q2 > 0.0 {
        (-q1 / v.sqrt(), 0.5 / q2.sqrt() + 0.5 / v.sqrt())
    } else if q2 > 0.0 {
        (0.0, 0.5 / q2.sqrt())
    } else {
        (0.0, 0.0)
    };
    [-(dq1 * q1 + dq2 * q2) / m0, dq1 / m0, dq2 / m0]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 4×3 field whose every replicate has samples in every cell.
    fn field() -> (Shift, Vec<Moments>) {
        let mut s = Shift::new(12, 2, 0.5);
        let block = s.block();
        let stride = s.stride();
        let mut rng = crate::rng::Sampler::new(5, 0, 0);
        for j in 0..12 {
            for r in 0..REPLICATES {
                let b = &mut s.data[j * stride + r * block..j * stride + (r + 1) * block];
                b[0] = 4.0;
                for v in &mut b[1..] {
                    *v = 1.0 + rng.next_f64();
                }
            }
        }
        let base = (0..12)
            .map(|_| Moments {
                n: 64,
                ..Moments::default()
            })
            .collect();
        (s, base)
    }

    /// Every edge's weight times c is the primal weight over c: K and r both scale by c, so the
    /// field at α with factors c is the field at α / √c without (to the solver's tolerance), and
    /// factors of 1 change nothing at all.
    #[test]
    fn edge_factors_weigh_the_differences_against_the_primal() {
        let dims = (4, 3, 1);
        let (mut s, _) = field();
        let all: Vec<usize> = (0..REPLICATES).collect();
        let ones = vec![vec![1.0; 12]; 2];
        let fours = vec![vec![4.0; 12]; 2];
        let plain = reconstruct(&s, dims, &all, None).m;
        assert_eq!(reconstruct(&s, dims, &all, Some(&ones)).m, plain);
        let weighted = reconstruct(&s, dims, &all, Some(&fours)).m;
        assert_ne!(weighted, plain);
        s.alpha = 0.25;
        let lower_alpha = reconstruct(&s, dims, &all, None).m;
        for (w, l) in weighted.iter().flatten().zip(lower_alpha.iter().flatten()) {
            assert!((w - l).abs() <= 1e-9 * l.abs(), "{w} against {l}");
        }
    }

    #[test]
    fn the_kept_reconstruction_is_the_one_of_these_sums() {
        let dims = (4, 3, 1);
        let (mut s, base) = field();
        let first = values(&s, dims, &base);
        assert_eq!(first, compute(&s, dims, &base).values);
        assert_eq!(values(&s, dims, &base), first);
        // Another sum: another reconstruction, never the kept one.
        s.data[7] += 0.25;
        let second = values(&s, dims, &base);
        assert_eq!(second, compute(&s, dims, &base).values);
        assert_ne!(second, first);
    }
}
