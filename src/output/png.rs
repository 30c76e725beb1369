//! PNG previews of a scalar field on a slice: the field itself, histogram-equalised and colour-coded
//! along a CIELAB ramp, and its Sobel gradient with direction as chromaticity and magnitude as
//! lightness (the two views of the paper's section 6.2).
//!
//! Conventions shared by every function here:
//! - A field is `width * height` values stored row by row; **row 0 is the bottom row** of the slice
//!   (the slice's v axis points up). [`write_png`] flips rows so that the picture shows v up; no other
//!   function flips anything. Consequently the `gy` of [`sobel`] is the derivative along +v (towards
//!   larger row indices, i.e. up in the picture).
//! - A cell takes part only if its `valid` flag is set **and** its value is finite; NaN and ±Inf are
//!   treated exactly like cells flagged invalid. Missing entries (a `valid` or `values` slice shorter
//!   than the field) are also invalid, so mismatched lengths never panic.
//! - Invalid cells are painted [`INVALID_RGB`], a neutral grey that neither colour map produces at
//!   full chroma, so holes in the domain stay recognisable.
//!
//! Colour: all colours are designed in CIELAB (D65) and converted to 8-bit sRGB with `palette`.
//! Colours outside the sRGB gamut are clipped by lowering chroma at constant L* and hue (bisection),
//! never by clamping channels, so lightness — the cue that carries order — is exactly preserved.

use anyhow::{Context, bail, ensure};
use palette::convert::FromColorUnclamped;
use palette::white_point::D65;
use palette::{Lab, Srgb};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

/// Colour of invalid cells (outside the domain, or a non-finite value): neutral sRGB grey
/// (L* ≈ 54). Both colour maps give mid-lightness cells a clearly visible hue, so a grey without
/// chroma reads as "no data".
pub const INVALID_RGB: [u8; 3] = [128, 128, 128];

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

/// Whether cell `i` takes part: flagged valid, present in both slices, and finite.
#[inline]
fn cell_ok(values: &[f64], valid: &[bool], i: usize) -> bool {
    valid.get(i).copied().unwrap_or(false) && values.get(i).is_some_and(|v| v.is_finite())
}

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
fn in_gamut(c: [f64; 3]) -> bool {
    const EPS: f64 = 1e-9;
    c.iter().all(|&x| (-EPS..=1.0 + EPS).contains(&x))
}

/// Gamut-clipped sRGB in `[0, 1]` of the CIELAB colour `(l, a, b)`: if it lies outside sRGB, its
/// chroma is scaled down (same L*, same hue angle) to the largest in-gamut value, found by
/// bisection. L* is clamped to `[0, 100]`; non-finite inputs give black.
fn lab_to_srgb_clipped(l: f64, a: f64, b: f64) -> [f64; 3] {
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
fn to_u8(c: [f64; 3]) -> [u8; 3] {
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
fn gradient_lab(m: f64, phi: f64) -> (f64, f64, f64) {
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

/// Writes an 8-bit sRGB PNG of `width * height` pixels given in field order: `rgb[y * width + x]`
/// with **row 0 the bottom row**, so rows are flipped on output (v axis up in the picture).
///
/// The image is written to a hidden temporary file in the destination directory, flushed to disk and
/// renamed over `path`, so `path` is never seen half-written; on failure the temporary file is
/// removed. Errors if a dimension is 0 or too large for PNG, or `rgb.len() != width * height`.
pub fn write_png(path: &Path, width: usize, height: usize, rgb: &[[u8; 3]]) -> anyhow::Result<()> {
    ensure!(
        width > 0 && height > 0,
        "PNG {}: empty image ({width}x{height})",
        path.display()
    );
    const PNG_MAX: usize = (1 << 31) - 1;
    ensure!(
        width <= PNG_MAX && height <= PNG_MAX,
        "PNG {}: {width}x{height} exceeds the PNG size limit",
        path.display()
    );
    let n = width.checked_mul(height);
    ensure!(
        n == Some(rgb.len()),
        "PNG {}: {} pixels given for {width}x{height}",
        path.display(),
        rgb.len()
    );
    let mut data = Vec::with_capacity(rgb.len() * 3);
    for row in rgb.chunks_exact(width).rev() {
        data.extend(row.iter().flatten());
    }

    if path.file_name().is_none() {
        bail!("PNG {}: not a file path", path.display());
    }
    crate::output::write_atomically(path, |tmp| {
        write_png_file(tmp, width as u32, height as u32, &data)
    })
}

/// Encodes packed RGB8 rows (top row first) to `path` and syncs the file.
fn write_png_file(path: &Path, width: u32, height: u32, data: &[u8]) -> anyhow::Result<()> {
    let file = File::create(path).with_context(|| format!("creating {}", path.display()))?;
    let mut out = BufWriter::new(file);
    let mut encoder = png::Encoder::new(&mut out, width, height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    let mut writer = encoder.write_header()?;
    writer.write_image_data(data)?;
    writer.finish()?;
    out.flush()?;
    out.get_ref().sync_all()?;
    Ok(())
}

/// Writes the field view ([`field_colors`]) of a field as a PNG (see [`write_png`]).
pub fn write_field_preview(
    path: &Path,
    values: &[f64],
    valid: &[bool],
    width: usize,
    height: usize,
) -> anyhow::Result<()> {
    write_png(
        path,
        width,
        height,
        &field_colors(values, valid, width, height),
    )
}

/// Writes the gradient view ([`gradient_colors`]) of a field as a PNG (see [`write_png`]).
pub fn write_gradient_preview(
    path: &Path,
    values: &[f64],
    valid: &[bool],
    width: usize,
    height: usize,
) -> anyhow::Result<()> {
    write_png(
        path,
        width,
        height,
        &gradient_colors(values, valid, width, height),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic xorshift64* uniform in [0, 1) for test data.
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    fn lab_of(rgb: [f64; 3]) -> Lab<D65, f64> {
        Lab::from_color_unclamped(Srgb::new(rgb[0], rgb[1], rgb[2]))
    }

    fn lab_of_u8(c: [u8; 3]) -> Lab<D65, f64> {
        lab_of(c.map(|x| x as f64 / 255.0))
    }

    /// A fresh empty directory under the system temp dir.
    fn test_dir(name: &str) -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("ftpd3d-png-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

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

    #[test]
    fn png_round_trip_flips_rows() {
        let dir = test_dir("roundtrip");
        let path = dir.join("img.png");
        let (w, h) = (3, 2);
        // Row 0 (bottom) is red-ish, row 1 (top) blue-ish; every pixel distinct.
        let rgb: Vec<[u8; 3]> = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as u8, (i / w) as u8);
                [200 - 100 * y, 10 * x, 50 + 100 * y]
            })
            .collect();
        write_png(&path, w, h, &rgb).unwrap();
        // Overwriting an existing file works too.
        write_png(&path, w, h, &rgb).unwrap();

        let file = std::io::BufReader::new(File::open(&path).unwrap());
        let mut reader = png::Decoder::new(file).read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!((info.width, info.height), (w as u32, h as u32));
        assert_eq!(info.color_type, png::ColorType::Rgb);
        assert_eq!(info.bit_depth, png::BitDepth::Eight);
        for img_y in 0..h {
            for x in 0..w {
                let o = img_y * info.line_size + 3 * x;
                let field_y = h - 1 - img_y;
                assert_eq!(buf[o..o + 3], rgb[field_y * w + x], "pixel ({x}, {img_y})");
            }
        }
        // Only the final file remains: no temporary left behind.
        let names: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, vec![std::ffi::OsString::from("img.png")]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn png_errors_are_reported_not_panicked() {
        let dir = test_dir("errors");
        let p = dir.join("x.png");
        assert!(write_png(&p, 0, 3, &[]).is_err());
        assert!(write_png(&p, 2, 2, &[[0; 3]; 3]).is_err());
        assert!(write_png(&dir.join("missing/x.png"), 1, 1, &[[0; 3]]).is_err());
        assert!(write_png(Path::new("/"), 1, 1, &[[0; 3]]).is_err());
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Writes example previews to /tmp/ftpd3d-png-preview for a person to look at:
    /// `cargo test --lib render_example_previews -- --ignored`.
    #[test]
    #[ignore = "writes example images to /tmp for visual inspection"]
    fn render_example_previews() {
        let dir = Path::new("/tmp/ftpd3d-png-preview");
        std::fs::create_dir_all(dir).unwrap();
        let (w, h) = (320, 240);
        let mut rng = Rng(7);
        let mut step = Vec::with_capacity(w * h);
        let mut radial = Vec::with_capacity(w * h);
        let mut valid = Vec::with_capacity(w * h);
        for i in 0..w * h {
            let (x, y) = ((i % w) as f64 / w as f64, (i / w) as f64 / h as f64);
            // A smooth background with a jump along a slanted line and a kink (first-order
            // discontinuity) along a vertical one, plus a little noise, FTPD-like in range.
            let jump = if y > 0.3 + 0.4 * x { 3.0 } else { 0.0 };
            let kink = 4.0 * (x - 0.7).max(0.0);
            step.push((1.0 + 2.0 * x + y * y + jump + kink) * 10f64.powf(y) + 0.02 * rng.next());
            let r =
                ((x - 0.5).powi(2) + (y - 0.5).powi(2) * (h * h) as f64 / (w * w) as f64).sqrt();
            radial.push((-12.0 * r * r).exp() + 0.3 * (30.0 * r).cos() * (-4.0 * r).exp());
            // A hole (e.g. inside an object) and a NaN.
            valid.push(((x - 0.2).powi(2) + (y - 0.75).powi(2)).sqrt() > 0.08);
        }
        step[5] = f64::NAN;
        write_field_preview(&dir.join("step_field.png"), &step, &valid, w, h).unwrap();
        write_gradient_preview(&dir.join("step_grad.png"), &step, &valid, w, h).unwrap();
        write_field_preview(&dir.join("radial_field.png"), &radial, &valid, w, h).unwrap();
        write_gradient_preview(&dir.join("radial_grad.png"), &radial, &valid, w, h).unwrap();
        // Colour bar: t along x, bottom half the colour map, top half a direction/magnitude wheel.
        let (bw, bh) = (256, 64);
        let bar: Vec<f64> = (0..bw * bh).map(|i| (i % bw) as f64).collect();
        write_field_preview(
            &dir.join("colorbar.png"),
            &bar,
            &vec![true; bw * bh],
            bw,
            bh,
        )
        .unwrap();
        let wheel: Vec<[u8; 3]> = (0..128 * 128)
            .map(|i| {
                let (x, y) = ((i % 128) as f64 - 63.5, (i / 128) as f64 - 63.5);
                let m = (x.hypot(y) / 63.5).min(1.0);
                let (l, a, b) = gradient_lab(m, y.atan2(x));
                to_u8(lab_to_srgb_clipped(l, a, b))
            })
            .collect();
        write_png(&dir.join("gradient_wheel.png"), 128, 128, &wheel).unwrap();
    }
}
