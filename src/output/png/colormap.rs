//! The field view: smooth histogram equalisation of a field and a perceptually ordered colour map
//! designed in CIELAB, with gamut clipping at constant lightness and hue.

use super::{INVALID_RGB, cell_ok};
use palette::convert::FromColorUnclamped;
use palette::white_point::D65;
use palette::{Lab, Srgb};

/// Weight of the linear (min–max) term mixed into the rank-based equalisation of [`equalize`].
///
/// Pure equalisation assigns equal colour space to equal numbers of cells, which hides how far
/// apart values are: a jump between two plateaus becomes one rank step however large it is, and a
/// large region of nearly equal values gets stretched over a wide colour range. A small linear share
/// keeps large jumps in value visible as jumps in colour and keeps a little contrast tied to actual
/// magnitude. Every output lies within this weight of its pure rank, so the output histogram stays
/// close to uniform (its CDF is within this distance of the identity); on very skewed fields the
/// top of the colour map is the part that gets thinned out.
pub const EQUALIZE_LINEAR_BLEND: f64 = 0.05;

/// Relative spread below which a field is considered constant by [`equalize`]: if
/// `max - min <= FLAT_RELATIVE_TOLERANCE * max(|min|, |max|)`, all valid cells map to 0.5 instead of
/// having rounding noise stretched over the whole colour map.
pub const FLAT_RELATIVE_TOLERANCE: f64 = 1e-10;

/// Smooth histogram equalisation of a field to `[0, 1]`; returns one value per entry of `values`.
///
/// The map is `(1 - λ) · R(v) + λ · (v - min) / (max - min)` with `λ =` [`EQUALIZE_LINEAR_BLEND`].
/// `R` is the empirical CDF by rank: over the sorted distinct valid values `u_0 < … < u_{k-1}`, the
/// value `u_j` gets the mean rank `r_j` of its ties (all tied cells get the same output), rescaled
/// so `R(u_0) = 0` and `R(u_{k-1}) = 1`, and `R` is linear between consecutive `u_j`. `R` is thus
/// a continuous, strictly increasing, piecewise-linear function of the value, so the whole map is
/// too: equal inputs give equal outputs and order is preserved.
///
/// Edge cases (never panics, never returns NaN):
/// - invalid / NaN / ±Inf cells map to 0 (callers paint them [`INVALID_RGB`]);
/// - no valid cell: all zeros;
/// - a single valid cell, or a constant field (see [`FLAT_RELATIVE_TOLERANCE`]): valid cells map
///   to 0.5, the middle of the colour map;
/// - huge ranges (`max - min` overflowing) are handled by working with halved values.
pub fn equalize(values: &[f64], valid: &[bool]) -> Vec<f64> {
    let n = values.len();
    let mut out = vec![0.0; n];
    let mut sorted: Vec<f64> = (0..n)
        .filter(|&i| cell_ok(values, valid, i))
        .map(|i| values[i])
        .collect();
    if sorted.is_empty() {
        return out;
    }
    sorted.sort_unstable_by(f64::total_cmp);
    let lo = sorted[0];
    let hi = sorted[sorted.len() - 1];
    // Halved so that the difference of two finite values cannot overflow.
    let half_span = 0.5 * hi - 0.5 * lo;
    if half_span <= FLAT_RELATIVE_TOLERANCE * 0.5 * lo.abs().max(hi.abs()) {
        for (i, o) in out.iter_mut().enumerate() {
            if cell_ok(values, valid, i) {
                *o = 0.5;
            }
        }
        return out;
    }

    // Distinct values and the mean rank of their ties. `==` groups -0.0 with 0.0 (total_cmp keeps
    // them adjacent in the sorted order).
    let mut uniq: Vec<f64> = Vec::new();
    let mut mean_rank: Vec<f64> = Vec::new();
    let mut start = 0;
    while start < sorted.len() {
        let mut end = start + 1;
        while end < sorted.len() && sorted[end] == sorted[start] {
            end += 1;
        }
        uniq.push(sorted[start]);
        mean_rank.push(0.5 * (start + end - 1) as f64);
        start = end;
    }
    // At least two distinct values here (the span is non-zero), so the rank span is positive.
    let r0 = mean_rank[0];
    let r_span = mean_rank[mean_rank.len() - 1] - r0;

    for (i, o) in out.iter_mut().enumerate() {
        if !cell_ok(values, valid, i) {
            continue;
        }
        let v = values[i];
        // Every valid value is one of the knots; `j` is its index.
        let j = uniq.partition_point(|&u| u < v).min(uniq.len() - 1);
        let rank = (mean_rank[j] - r0) / r_span;
        let linear = (0.5 * v - 0.5 * lo) / half_span;
        let t = (1.0 - EQUALIZE_LINEAR_BLEND) * rank + EQUALIZE_LINEAR_BLEND * linear;
        *o = if t.is_finite() {
            t.clamp(0.0, 1.0)
        } else {
            0.0
        };
    }
    out
}

/// sRGB (gamma-encoded, unclamped) of a CIELAB colour.
#[inline]
fn lab_to_srgb_unclamped(l: f64, a: f64, b: f64) -> [f64; 3] {
    let rgb = Srgb::<f64>::from_color_unclamped(Lab::<D65, f64>::new(l, a, b));
    [rgb.red, rgb.green, rgb.blue]
}

#[inline]
pub(super) fn in_gamut(c: [f64; 3]) -> bool {
    const EPS: f64 = 1e-9;
    c.iter().all(|&x| (-EPS..=1.0 + EPS).contains(&x))
}

/// Gamut-clipped sRGB in `[0, 1]` of the CIELAB colour `(l, a, b)`: if it lies outside sRGB, its
/// chroma is scaled down (same L*, same hue angle) to the largest in-gamut value, found by
/// bisection. L* is clamped to `[0, 100]`; non-finite inputs give black.
pub(super) fn lab_to_srgb_clipped(l: f64, a: f64, b: f64) -> [f64; 3] {
    if !(l.is_finite() && a.is_finite() && b.is_finite()) {
        return [0.0; 3];
    }
    let l = l.clamp(0.0, 100.0);
    let full = lab_to_srgb_unclamped(l, a, b);
    let rgb = if in_gamut(full) {
        full
    } else {
        // The neutral axis (scale 0) is in gamut for L* in [0, 100].
        let (mut lo, mut hi) = (0.0_f64, 1.0_f64);
        for _ in 0..20 {
            let mid = 0.5 * (lo + hi);
            if in_gamut(lab_to_srgb_unclamped(l, mid * a, mid * b)) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        lab_to_srgb_unclamped(l, lo * a, lo * b)
    };
    rgb.map(|x| x.clamp(0.0, 1.0))
}

/// 8-bit sRGB of a clipped colour (rounded to nearest).
#[inline]
pub(super) fn to_u8(c: [f64; 3]) -> [u8; 3] {
    c.map(|x| (x * 255.0).round().clamp(0.0, 255.0) as u8)
}

/// Lightness of the field colour map at its ends, and hue angles (degrees) at its ends.
const CMAP_L: (f64, f64) = (12.0, 94.0);
const CMAP_HUE: (f64, f64) = (295.0, 455.0);

/// The CIELAB coordinates of [`lab_colormap`] at `t` (before gamut clipping).
fn colormap_lab(t: f64) -> (f64, f64, f64) {
    let l = CMAP_L.0 + (CMAP_L.1 - CMAP_L.0) * t;
    let h = (CMAP_HUE.0 + (CMAP_HUE.1 - CMAP_HUE.0) * t).to_radians();
    let c = colormap_chroma(t);
    (l, c * h.cos(), c * h.sin())
}

/// Chroma profile of the colour map: 48 in the middle, easing to 34 at both ends, where sRGB has
/// less room (dark violet, near-white yellow). Along this hue path the profile stays inside the
/// gamut except for slight clipping at the yellow end (t > 0.9).
fn colormap_chroma(t: f64) -> f64 {
    48.0 - 14.0 * (2.0 * t - 1.0).powi(4)
}

/// Perceptually ordered colour map for `t` in `[0, 1]` (values outside are clamped, NaN maps
/// to 0): L* rises linearly from dark (L* 12, violet) to light (L* 94, pale yellow) while the hue
/// angle sweeps linearly from 295° through magenta, red and orange to 95°, defined in CIELAB and
/// gamut-clipped at constant L* and hue. This hue path was chosen over one through teal and green
/// because sRGB allows about twice the chroma along it at mid lightness (≈ 65 against ≈ 26), so
/// the map stays colourful without clipping.
pub fn lab_colormap(t: f64) -> [u8; 3] {
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    let (l, a, b) = colormap_lab(t);
    to_u8(lab_to_srgb_clipped(l, a, b))
}

/// Field view: [`equalize`]d values through [`lab_colormap`]; invalid cells [`INVALID_RGB`].
/// Returns `width * height` colours in input order (row 0 = bottom).
pub fn field_colors(values: &[f64], valid: &[bool], width: usize, height: usize) -> Vec<[u8; 3]> {
    let n = width.saturating_mul(height);
    let values = &values[..n.min(values.len())];
    let eq = equalize(values, valid);
    (0..n)
        .map(|i| {
            if cell_ok(values, valid, i) {
                lab_colormap(eq[i])
            } else {
                INVALID_RGB
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::super::test_support::{Rng, lab_of, lab_of_u8};
    use super::*;

    #[test]
    fn equalize_is_monotone_and_roughly_uniform() {
        // Exponentially distributed values: strongly skewed, as FTPD magnitudes are.
        let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
        let n = 20_000;
        let values: Vec<f64> = (0..n).map(|_| -(1.0 - rng.next()).ln()).collect();
        let valid = vec![true; n];
        let eq = equalize(&values, &valid);
        assert!(eq.iter().all(|t| (0.0..=1.0).contains(t)));

        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&a, &b| values[a].total_cmp(&values[b]));
        for w in order.windows(2) {
            let (a, b) = (w[0], w[1]);
            if values[a] < values[b] {
                assert!(
                    eq[a] < eq[b],
                    "{} -> {}, {} -> {}",
                    values[a],
                    eq[a],
                    values[b],
                    eq[b]
                );
            } else {
                assert_eq!(eq[a], eq[b]);
            }
        }
        assert_eq!(eq[order[0]], 0.0);
        assert_eq!(eq[order[n - 1]], 1.0);

        // Each output is within the linear blend weight of its rank, so the output CDF stays within
        // that (plus the rank discretisation) of the uniform one.
        let mut sorted_eq = eq.clone();
        sorted_eq.sort_by(f64::total_cmp);
        let ks = sorted_eq
            .iter()
            .enumerate()
            .map(|(k, &t)| (t - k as f64 / (n - 1) as f64).abs())
            .fold(0.0, f64::max);
        assert!(ks <= EQUALIZE_LINEAR_BLEND + 1e-9, "KS distance {ks}");
        let mut bins = [0usize; 10];
        for &t in &eq {
            bins[((t * 10.0) as usize).min(9)] += 1;
        }
        // Near uniform, except that the skew thins out the top bin through the linear share.
        for (k, &b) in bins.iter().enumerate() {
            let share = b as f64 / (n as f64 / 10.0);
            let lo = if k == 9 { 0.5 } else { 0.85 };
            assert!((lo..1.15).contains(&share), "bins {bins:?}");
        }
    }

    #[test]
    fn equalize_ties_share_their_mean_rank() {
        // Ranks 0, 1.5, 1.5, 3 -> R = 0, 0.5, 0.5, 1; the linear part is the same here.
        let eq = equalize(&[1.0, 2.0, 2.0, 3.0], &[true; 4]);
        assert_eq!(eq, vec![0.0, 0.5, 0.5, 1.0]);
        // -0.0 and 0.0 are one value.
        let eq = equalize(&[-0.0, 0.0, 1.0], &[true; 3]);
        assert_eq!(eq[0], eq[1]);
    }

    #[test]
    fn equalize_edge_cases() {
        assert!(equalize(&[], &[]).is_empty());
        assert_eq!(equalize(&[1.0, 2.0], &[false, false]), vec![0.0, 0.0]);
        assert_eq!(equalize(&[1.0, 2.0], &[false, true]), vec![0.0, 0.5]);
        assert_eq!(equalize(&[3.0; 4], &[true; 4]), vec![0.5; 4]);
        // Rounding noise on a constant is not stretched over the colour map.
        assert_eq!(equalize(&[1.0, 1.0 + 1e-15], &[true; 2]), vec![0.5; 2]);
        // Non-finite values flagged valid are invalid; a short `valid` slice means invalid.
        let eq = equalize(
            &[f64::NAN, 1.0, f64::INFINITY, 2.0, f64::NEG_INFINITY, 3.0],
            &[true, true, true, true, true],
        );
        assert_eq!(eq, vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0]);
        // A range whose width overflows f64.
        let eq = equalize(&[-f64::MAX, f64::MAX, 0.0], &[true; 3]);
        assert_eq!(eq, vec![0.0, 1.0, 0.5]);
        assert!(eq.iter().all(|t| t.is_finite()));
    }

    #[test]
    fn colormap_lightness_strictly_increases_and_stays_in_gamut() {
        let mut prev = f64::NEG_INFINITY;
        for i in 0..=1000 {
            let t = i as f64 / 1000.0;
            let (l, a, b) = colormap_lab(t);
            let rgb = lab_to_srgb_clipped(l, a, b);
            assert!(in_gamut(rgb), "t {t}: {rgb:?}");
            let lab = lab_of(rgb);
            assert!(
                (lab.l - l).abs() < 1e-4,
                "clipping changed L* at t {t}: {l} {}",
                lab.l
            );
            assert!(lab.l > prev, "L* not increasing at t {t}");
            prev = lab.l;
        }
        // Still strictly increasing after 8-bit quantisation at a moderate sampling.
        let mut prev = f64::NEG_INFINITY;
        for i in 0..=64 {
            let lab = lab_of_u8(lab_colormap(i as f64 / 64.0));
            assert!(lab.l > prev, "8-bit L* not increasing at step {i}");
            prev = lab.l;
        }
        assert!(lab_of_u8(lab_colormap(0.0)).l < 15.0);
        assert!(lab_of_u8(lab_colormap(1.0)).l > 90.0);
        // Out-of-range and NaN inputs are clamped, not propagated.
        assert_eq!(lab_colormap(-3.0), lab_colormap(0.0));
        assert_eq!(lab_colormap(7.0), lab_colormap(1.0));
        assert_eq!(lab_colormap(f64::NAN), lab_colormap(0.0));
    }

    #[test]
    fn gamut_clipping_keeps_lightness_and_hue() {
        let (l, a, b) = (50.0, 120.0, -90.0);
        assert!(!in_gamut(lab_to_srgb_unclamped(l, a, b)));
        let rgb = lab_to_srgb_clipped(l, a, b);
        assert!(in_gamut(rgb));
        let lab = lab_of(rgb);
        assert!((lab.l - l).abs() < 1e-4);
        assert!((lab.b.atan2(lab.a) - b.atan2(a)).abs() < 1e-4);
        // On the gamut boundary: a chroma just above is out.
        assert!(!in_gamut(lab_to_srgb_unclamped(
            l,
            lab.a * 1.001,
            lab.b * 1.001
        )));
        assert_eq!(lab_to_srgb_clipped(f64::NAN, 0.0, 0.0), [0.0; 3]);
    }
}
