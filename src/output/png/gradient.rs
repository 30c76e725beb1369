//! The gradient view: the Sobel gradient of a field, with direction as CIELAB chromaticity and
//! magnitude as lightness.

use super::colormap::{equalize, lab_to_srgb_clipped, to_u8};
use super::{INVALID_RGB, cell_ok};

/// Derivative along one row (or column) from the samples before, at and after a cell, each `None`
/// if unusable: central difference if both neighbours exist, else one-sided with the centre.
#[inline]
fn line_derivative(prev: Option<f64>, centre: Option<f64>, next: Option<f64>) -> Option<f64> {
    match (prev, centre, next) {
        (Some(p), _, Some(n)) => Some(0.5 * (n - p)),
        (None, Some(c), Some(n)) => Some(n - c),
        (Some(p), Some(c), None) => Some(c - p),
        _ => None,
    }
}

/// Sobel gradient `(gx, gy)` of a field, in value units per cell, `gx` along +x (increasing
/// column), `gy` along +v (increasing row index: up, since row 0 is the bottom).
///
/// With all nine cells valid this is the Sobel operator normalised by 1/8, so a linear ramp
/// `a·x + b·y` gives exactly `(a, b)`. Near invalid cells and borders it degrades gracefully: each of
/// the three rows (columns) contributes a central difference if both its neighbours are usable, a
/// one-sided difference if only one is (with its centre), or nothing; the contributions are
/// averaged with the remaining Sobel weights (1, 2, 1, renormalised). This keeps linear ramps exact
/// up to the border. If nothing is usable, or the centre cell itself is invalid, the result is 0.
/// Never NaN.
pub fn sobel(values: &[f64], valid: &[bool], width: usize, height: usize) -> (Vec<f64>, Vec<f64>) {
    let n = width.saturating_mul(height);
    let mut gx = vec![0.0; n];
    let mut gy = vec![0.0; n];
    let at = |x: isize, y: isize| -> Option<f64> {
        if x < 0 || y < 0 || x as usize >= width || y as usize >= height {
            return None;
        }
        let i = y as usize * width + x as usize;
        cell_ok(values, valid, i).then(|| values[i])
    };
    for y in 0..height {
        for x in 0..width {
            let i = y * width + x;
            if !cell_ok(values, valid, i) {
                continue;
            }
            let (xi, yi) = (x as isize, y as isize);
            let (mut sx, mut wx, mut sy, mut wy) = (0.0, 0.0, 0.0, 0.0);
            for (k, w) in [(-1isize, 1.0), (0, 2.0), (1, 1.0)] {
                if let Some(d) =
                    line_derivative(at(xi - 1, yi + k), at(xi, yi + k), at(xi + 1, yi + k))
                {
                    sx += w * d;
                    wx += w;
                }
                if let Some(d) =
                    line_derivative(at(xi + k, yi - 1), at(xi + k, yi), at(xi + k, yi + 1))
                {
                    sy += w * d;
                    wy += w;
                }
            }
            let fx = if wx > 0.0 { sx / wx } else { 0.0 };
            let fy = if wy > 0.0 { sy / wy } else { 0.0 };
            gx[i] = if fx.is_finite() { fx } else { 0.0 };
            gy[i] = if fy.is_finite() { fy } else { 0.0 };
        }
    }
    (gx, gy)
}

/// Lightness of the gradient view at zero and at full (normalised) magnitude.
const GRAD_L: (f64, f64) = (6.0, 86.0);
/// Chroma of the gradient view at full magnitude (scaled linearly with magnitude, so the hue of a
/// direction fades out where there is no gradient to have a direction).
const GRAD_CHROMA: f64 = 70.0;

/// CIELAB colour of a gradient view cell: `m` normalised magnitude in `[0, 1]`, direction `phi`.
pub(super) fn gradient_lab(m: f64, phi: f64) -> (f64, f64, f64) {
    let l = GRAD_L.0 + (GRAD_L.1 - GRAD_L.0) * m;
    let c = GRAD_CHROMA * m;
    (l, c * phi.cos(), c * phi.sin())
}

/// Gradient view: the Sobel gradient ([`sobel`]) of the [`equalize`]d field, direction φ (+x = 0,
/// counter-clockwise towards +v) as CIELAB chromaticity `a* = C cos φ, b* = C sin φ` and magnitude
/// as L*. Hues: +x magenta-red, +v yellow, −x green, −v blue. Invalid cells [`INVALID_RGB`].
/// Returns `width * height` colours in input order (row 0 = bottom).
///
/// Magnitude normalisation is robust and never clips: with `s` the median magnitude over valid
/// cells (the median of the non-zero ones if that is 0), a magnitude `m` becomes `m / (m + s)`. A
/// typical cell thus sits at mid lightness, where its direction hue is clearly visible, while
/// discontinuities (magnitudes many times the typical one) approach full lightness and stay
/// distinguishable from each other; a single huge jump cannot darken the rest of the picture, as
/// it would with division by the maximum, and textures are not saturated away, as with clipping at
/// a percentile. Chroma grows with the normalised magnitude, so hue fades out where there is no
/// gradient to have a direction.
pub fn gradient_colors(
    values: &[f64],
    valid: &[bool],
    width: usize,
    height: usize,
) -> Vec<[u8; 3]> {
    let n = width.saturating_mul(height);
    let values = &values[..n.min(values.len())];
    let eq = equalize(values, valid);
    // `ok`, not `valid`: cells flagged valid but non-finite are 0 in `eq` and must stay excluded.
    let ok: Vec<bool> = (0..n).map(|i| cell_ok(values, valid, i)).collect();
    let (gx, gy) = sobel(&eq, &ok, width, height);
    let mag: Vec<f64> = (0..n).map(|i| gx[i].hypot(gy[i])).collect();
    let scale = typical_magnitude(&mag, &ok);
    (0..n)
        .map(|i| {
            if !ok[i] {
                return INVALID_RGB;
            }
            let m = if scale > 0.0 && mag[i].is_finite() {
                mag[i] / (mag[i] + scale)
            } else {
                0.0
            };
            let (l, a, b) = gradient_lab(m, gy[i].atan2(gx[i]));
            to_u8(lab_to_srgb_clipped(l, a, b))
        })
        .collect()
}

/// Median of the valid finite magnitudes, or of the non-zero ones if that is 0; 0 if there are
/// none.
fn typical_magnitude(mag: &[f64], ok: &[bool]) -> f64 {
    let median = |mut m: Vec<f64>| -> f64 {
        if m.is_empty() {
            return 0.0;
        }
        let k = m.len() / 2;
        *m.select_nth_unstable_by(k, f64::total_cmp).1
    };
    let m: Vec<f64> = mag
        .iter()
        .zip(ok)
        .filter(|&(v, &o)| o && v.is_finite())
        .map(|(&v, _)| v)
        .collect();
    let med = median(m.clone());
    if med > 0.0 {
        med
    } else {
        median(m.into_iter().filter(|&v| v > 0.0).collect())
    }
}

#[cfg(test)]
mod tests {
    use super::super::field_colors;
    use super::super::test_support::lab_of_u8;
    use super::*;

    #[test]
    fn sobel_is_exact_on_a_linear_ramp() {
        let (w, h) = (7, 5);
        let (ax, ay) = (0.7, -1.3);
        let values: Vec<f64> = (0..w * h)
            .map(|i| ax * (i % w) as f64 + ay * (i / w) as f64 + 2.0)
            .collect();
        let mut valid = vec![true; w * h];
        let (gx, gy) = sobel(&values, &valid, w, h);
        // Interior: plain Sobel / 8. Border: one-sided rows keep a ramp exact too.
        for i in 0..w * h {
            assert!(
                (gx[i] - ax).abs() < 1e-12 && (gy[i] - ay).abs() < 1e-12,
                "cell {i}"
            );
        }
        // Holes (and a NaN flagged valid) are skipped: neighbours stay exact, the holes get 0.
        let mut values = values;
        valid[2 * w + 3] = false;
        values[w + 1] = f64::NAN;
        let (gx, gy) = sobel(&values, &valid, w, h);
        for i in 0..w * h {
            if i == 2 * w + 3 || i == w + 1 {
                assert_eq!((gx[i], gy[i]), (0.0, 0.0));
            } else {
                assert!(
                    (gx[i] - ax).abs() < 1e-12 && (gy[i] - ay).abs() < 1e-12,
                    "cell {i}"
                );
            }
        }
    }

    #[test]
    fn sobel_degenerate_inputs() {
        assert_eq!(sobel(&[], &[], 0, 0), (vec![], vec![]));
        assert_eq!(sobel(&[5.0], &[true], 1, 1), (vec![0.0], vec![0.0]));
        // An isolated valid cell has no usable neighbour; short slices are invalid cells.
        let (gx, gy) = sobel(&[1.0, 9.0, 4.0], &[false, true], 3, 1);
        assert_eq!((gx, gy), (vec![0.0; 3], vec![0.0; 3]));
        let (gx, gy) = sobel(&[0.0, f64::MAX, -f64::MAX], &[true; 3], 3, 1);
        assert!(gx.iter().chain(&gy).all(|g| g.is_finite()));
    }

    #[test]
    fn gradient_hue_follows_direction() {
        let (w, h) = (16, 16);
        let valid = vec![true; w * h];
        let ramp = |fx: f64, fy: f64| -> Vec<f64> {
            (0..w * h)
                .map(|i| fx * (i % w) as f64 + fy * (i / w) as f64)
                .collect()
        };
        let centre = (h / 2) * w + w / 2;
        let lab = |fx, fy| lab_of_u8(gradient_colors(&ramp(fx, fy), &valid, w, h)[centre]);
        let right = lab(1.0, 0.0);
        assert!(right.a > 0.0 && right.a > 3.0 * right.b.abs(), "{right:?}");
        let up = lab(0.0, 1.0);
        assert!(up.b > 0.0 && up.b > 3.0 * up.a.abs(), "{up:?}");
        let left = lab(-1.0, 0.0);
        assert!(left.a < 0.0 && -left.a > 3.0 * left.b.abs(), "{left:?}");
        let down = lab(0.0, -1.0);
        assert!(down.b < 0.0 && -down.b > 3.0 * down.a.abs(), "{down:?}");
        // A uniform gradient is the typical magnitude: mid lightness.
        assert!(
            (right.l - 0.5 * (GRAD_L.0 + GRAD_L.1)).abs() < 1.0,
            "{right:?}"
        );
        // A jump is brighter than the smooth ramp around it.
        let mut jump = ramp(1.0, 0.0);
        for (i, v) in jump.iter_mut().enumerate() {
            if i / w >= h / 2 {
                *v += 100.0;
            }
        }
        let c = gradient_colors(&jump, &valid, w, h);
        let (at_jump, away) = (lab_of_u8(c[centre]), lab_of_u8(c[2 * w + w / 2]));
        assert!(at_jump.l > away.l + 20.0, "{at_jump:?} vs {away:?}");

        // No gradient: dark and grey. Invalid: the neutral colour. Nothing valid: no panic.
        let flat = gradient_colors(&vec![1.0; w * h], &valid, w, h);
        assert!(flat.iter().all(|&c| lab_of_u8(c).l < GRAD_L.0 + 1.0));
        let mut v = ramp(1.0, 0.5);
        v[centre] = f64::NAN;
        assert_eq!(gradient_colors(&v, &valid, w, h)[centre], INVALID_RGB);
        let none = gradient_colors(&v, &vec![false; w * h], w, h);
        assert!(none.iter().all(|&c| c == INVALID_RGB));
        assert!(
            field_colors(&v, &[], w, h)
                .iter()
                .all(|&c| c == INVALID_RGB)
        );
    }
}
