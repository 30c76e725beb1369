//! Adaptive allocation: how a pass's samples are spread over the cells by their estimated error.

use crate::ftpd::moments::{CellValue, Moments};
use rayon::prelude::*;

/// Adaptive allocation of one pass: how many units (of the schedule's per-pass samples; each unit
/// is one independent batch) each cell gets, `budget` units in all, at most `max_share` per cell.
///
/// A cell with an error estimate (σ > 0 defined, at least two batches) has relative error r after
/// n samples; its per-sample relative variance is estimated as a² = r²·n (r ≈ a/√n), shrunk
/// towards the median over cells with a pseudo-count of one batch, (k·a² + med)/(k + 1) for k
/// batches, so that a cell whose few batches happened to agree is not starved on that evidence
/// alone. A cell whose σ is exactly 0 so far has a² = 0 before shrinking. The pass then fills the
/// cells up to a common error level λ (water-filling): a cell gets the samples it lacks to reach
/// a²/(n + m) = λ, clamped to [0, max_share] units, with λ chosen so that the units add up to the
/// budget. Cells without an estimate (no defined σ yet, fewer than two batches, or none by
/// [`Moments::has_estimate`], e.g. the weight in effectively one unit) get the uniform share, one
/// unit. Shares are rounded by cumulative rounding, so the total is the budget.
///
/// What this does to the estimate. The allocation of pass p is a function of the sums after passes
/// < p only, never of pass p's samples, and pass p's samples come from the stream keyed (seed, p,
/// cell) whatever the allocation; the allocation only decides how many of them are drawn. Each
/// sample added is therefore, given the past, an independent draw from the cell's sampling
/// distribution, and the cell's sums stay plain sums of such draws: `E[Σc] = E[n]·E[c]`, and
/// likewise for ΣcΔ and ΣcΔ² (Wald's identity), so sums still merge and resume exactly, and every
/// normalised quantity (σ, S0/n, fluence) converges to the same limit as in a uniform run. What is
/// not exact at finite n is the normalisation: n depends on the earlier samples' values (a cell
/// whose first passes looked noisy, e.g. because of one large contribution, gets more samples,
/// which dilute that contribution), so S/n is not an unbiased mean, and σ, a nonlinear function of
/// ratios of sums, is biased at finite n in any run. Both biases shrink as the samples grow; the
/// driver tests compare the mean of σ over a slice with that of a uniform run of four times the
/// samples. Each unit is a batch of the same size as a uniform pass's, taken in groups of
/// [`QMC_GROUP`](crate::rng::QMC_GROUP) samples (one scrambled sequence each) like a uniform pass,
/// and the standard error comes from sums over those groups, so it does not depend on how many
/// units a cell gets.
pub fn allocate(cells: &[Moments], unit: u32, budget: u64, max_share: u32) -> Vec<u32> {
    let values: Vec<CellValue> = cells.par_iter().map(Moments::finalize).collect();
    allocate_by(cells, &values, unit, budget, max_share)
}

/// [`allocate`] by the cells' finished `values` (a gradient-domain field's reconstructed ones,
/// whose errors include the neighbours' share); `cells` gives their sample and batch counts.
pub fn allocate_by(
    cells: &[Moments],
    values: &[CellValue],
    unit: u32,
    budget: u64,
    max_share: u32,
) -> Vec<u32> {
    let unit = unit.max(1) as f64;
    let kmax = max_share.max(1) as f64;
    // (a², n, k) of cells with an estimate; None: uniform share.
    let est: Vec<Option<(f64, f64, f64)>> = cells
        .par_iter()
        .zip(values)
        .map(|(m, &v)| {
            if !v.valid || m.batches < 2 || !v.estimated {
                return None;
            }
            let r = if v.sigma > 0.0 {
                v.stderr / v.sigma
            } else {
                0.0
            };
            let a2 = r * r * m.n as f64;
            a2.is_finite().then_some((a2, m.n as f64, m.batches as f64))
        })
        .collect();
    let mut out = vec![0u32; cells.len()];
    let mut budget = budget;
    // Uniform share for cells without an estimate, in cell order while the budget lasts.
    for (o, e) in out.iter_mut().zip(&est) {
        if e.is_none() && budget > 0 {
            *o = 1;
            budget -= 1;
        }
    }
    let mut a2s: Vec<f64> = est.iter().flatten().map(|e| e.0).collect();
    if a2s.is_empty() || budget == 0 {
        return out;
    }
    let mid = a2s.len() / 2;
    let med = *a2s.select_nth_unstable_by(mid, f64::total_cmp).1;
    let shrunk: Vec<(usize, f64, f64)> = est
        .iter()
        .enumerate()
        .filter_map(|(i, e)| e.map(|(a2, n, k)| (i, (k * a2 + med) / (k + 1.0), n)))
        .collect();
    let share = |lambda: f64| -> f64 {
        shrunk
            .par_iter()
            .map(|&(_, a2, n)| ((a2 / lambda - n) / unit).clamp(0.0, kmax))
            .sum()
    };
    let b = budget as f64;
    let lambda = if kmax * shrunk.len() as f64 <= b {
        0.0 // every cell at its cap
    } else {
        // Σ share is non-increasing in λ: bisect on log λ between a level every cell has reached
        // (share 0) and one where all are capped.
        let hi0 = shrunk
            .iter()
            .map(|&(_, a2, n)| a2 / n.max(1.0))
            .fold(0.0, f64::max);
        if !(hi0 > 0.0) {
            return out; // no cell has any error left to reduce
        }
        let (mut lo, mut hi) = (hi0 * 1e-12, hi0);
        for _ in 0..100 {
            let mid = (lo * hi).sqrt();
            if share(mid) > b {
                lo = mid;
            } else {
                hi = mid;
            }
            if hi / lo < 1.0 + 1e-9 {
                break;
            }
        }
        hi
    };
    let x: Vec<f64> = shrunk
        .iter()
        .map(|&(_, a2, n)| {
            if lambda > 0.0 {
                ((a2 / lambda - n) / unit).clamp(0.0, kmax)
            } else {
                kmax
            }
        })
        .collect();
    let total: f64 = x.iter().sum();
    if !(total > 0.0) {
        return out;
    }
    let scale = b.min(total) / total;
    let (mut acc, mut prev) = (0.0f64, 0u64);
    for (&(i, _, _), xi) in shrunk.iter().zip(&x) {
        acc += xi * scale;
        let now = (acc.round() as u64).min(budget);
        out[i] = ((now - prev) as u32).min(max_share.max(1));
        prev = now;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::error_stats::tests::cell;

    #[test]
    fn allocation_spends_the_budget_where_the_error_is() {
        // 10 noisy cells, 10 quiet ones, 2 without an estimate.
        let mut cells: Vec<Moments> = (0..10).map(|_| cell(&[1.0, 3.0])).collect();
        cells.extend((0..10).map(|_| cell(&[1.0, 1.01])));
        cells.push(cell(&[1.0]));
        cells.push(Moments::default());
        let u = allocate(&cells, 2, 22, 4);
        assert_eq!(u.iter().map(|&x| x as u64).sum::<u64>(), 22, "{u:?}");
        assert!(u.iter().all(|&x| x <= 4));
        assert_eq!(&u[20..], &[1, 1]);
        let noisy: u32 = u[..10].iter().sum();
        let quiet: u32 = u[10..20].iter().sum();
        assert!(noisy > 2 * quiet, "{u:?}");
        // Deterministic.
        assert_eq!(u, allocate(&cells, 2, 22, 4));
        // A budget larger than all caps: everyone capped.
        let all = allocate(&cells, 2, 1000, 4);
        assert!(all[..20].iter().all(|&x| x == 4), "{all:?}");
    }
}
