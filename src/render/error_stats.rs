//! The relative standard error over a field: what a target error is checked against and what the
//! adaptive allocation reads.

use crate::field::Field;
use crate::ftpd::moments::{CellValue, Moments};
use rayon::prelude::*;

/// Relative standard error over a field (stderr / σ per cell).
///
/// The cells counted are those with a defined σ > 0. A cell among them with fewer than two batches
/// has no error estimate yet and counts as infinitely uncertain, so a target error is never met
/// on cells that have not been measured. `p95` is the nearest-rank 95th percentile: at least 95 %
/// of the counted cells have a relative error ≤ `p95`, so `p95 ≤ target` means that 95 % of the
/// cells reached the target. The mean is over cells with an estimate. A field without such cells
/// (empty space, no light) has `p95 = 0`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ErrorStats {
    pub mean: f64,
    pub p95: f64,
    /// Cells with a defined σ > 0.
    pub cells: usize,
    /// Of those, cells without an error estimate: fewer than two batches, or none by
    /// [`Moments::has_estimate`] (e.g. the weight in effectively one unit).
    pub unestimated: usize,
}

/// Relative error of one cell: `Some(stderr/σ)` (∞ without an estimate), `None` when the cell is
/// not counted (σ undefined or 0).
fn cell_relerr(m: &Moments) -> Option<f64> {
    value_relerr(&m.finalize(), m.batches)
}

/// [`cell_relerr`] of a finished value whose cell has `batches` batches.
fn value_relerr(v: &CellValue, batches: u64) -> Option<f64> {
    if !(v.valid && v.sigma > 0.0) {
        return None;
    }
    if batches < 2 || !v.estimated {
        return Some(f64::INFINITY);
    }
    let r = v.stderr / v.sigma;
    Some(if r.is_finite() { r } else { f64::INFINITY })
}

pub fn error_stats(cells: &[Moments]) -> ErrorStats {
    percentiles(cells.par_iter().filter_map(cell_relerr).collect())
}

/// [`error_stats`] of the cells `range` of a field as it is finished ([`Field::values`]): a
/// gradient-domain field's reconstructed values and their errors, else each cell's own.
pub fn field_error_stats(field: &Field, range: std::ops::Range<usize>) -> ErrorStats {
    match field.shift {
        None => error_stats(&field.cells[range]),
        Some(_) => {
            let values = field.values();
            percentiles(
                range
                    .filter_map(|k| value_relerr(&values[k], field.cells[k].batches))
                    .collect(),
            )
        }
    }
}

fn percentiles(mut rel: Vec<f64>) -> ErrorStats {
    let n = rel.len();
    if n == 0 {
        return ErrorStats::default();
    }
    let finite: Vec<f64> = rel.iter().copied().filter(|r| r.is_finite()).collect();
    let mean = if finite.is_empty() {
        0.0
    } else {
        finite.iter().sum::<f64>() / finite.len() as f64
    };
    let rank = (0.95 * n as f64).ceil() as usize;
    let k = rank.clamp(1, n) - 1;
    let (_, p95, _) = rel.select_nth_unstable_by(k, f64::total_cmp);
    ErrorStats {
        mean,
        p95: *p95,
        cells: n,
        unestimated: n - finite.len(),
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::math::Rgb;

    /// A cell whose batches give σ values `sig` (unit weights, Δ chosen so σ = 2|Δ| for one
    /// sample per batch... here: batches of 2 samples Δ = ±d give m1 = 0, m2 = d², σ = 2d).
    pub(in crate::render) fn cell(sig: &[f64]) -> Moments {
        let mut m = Moments::default();
        for &s in sig {
            let mut b = Moments::default();
            b.add_sample(1.0, s / 2.0, Rgb::ZERO);
            b.add_sample(1.0, -s / 2.0, Rgb::ZERO);
            m.add_batch(&b);
        }
        m
    }

    #[test]
    fn error_stats_percentile_and_unestimated() {
        let mut cells: Vec<Moments> = (0..19).map(|_| cell(&[1.0, 1.0])).collect();
        cells.push(cell(&[1.0])); // σ > 0, one batch: no estimate
        cells.push(Moments::default()); // invalid: not counted
        let e = error_stats(&cells);
        assert_eq!(e.cells, 20);
        assert_eq!(e.unestimated, 1);
        // 19 of 20 cells (95 %) have relative error 0: the 95th percentile is 0.
        assert_eq!(e.p95, 0.0);
        cells.push(cell(&[1.0]));
        // Now 19 of 21 < 95 %: the percentile is an unestimated cell.
        assert_eq!(error_stats(&cells).p95, f64::INFINITY);
        // Two batches, but weight in the second only (radiance found once): no estimate either.
        let mut w = Moments::default();
        let mut dark = Moments::default();
        dark.add_sample(0.0, 0.5, Rgb::ZERO);
        w.add_batch(&dark);
        let mut lit = Moments::default();
        let mut g = crate::ftpd::moments::GroupSums::default();
        g.add(lit.add_to_sums(1.0, 0.5, Rgb::ZERO));
        g.add(lit.add_to_sums(1.0, -0.5, Rgb::ZERO));
        lit.add_group(&g);
        w.add_batch(&lit);
        assert_eq!((w.batches, w.groups), (2, 2));
        assert!(w.finalize().sigma > 0.0 && !w.has_estimate());
        let e = error_stats(&[cell(&[1.0, 1.0]), w]);
        assert_eq!((e.cells, e.unestimated), (2, 1));
    }
}
