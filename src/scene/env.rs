//! The environment map: radiance from every direction that leaves the scene, read from a lat-long
//! (equirectangular) HDR image (`.exr`, `.hdr`), with its importance-sampling tables.
//!
//! Convention: Mitsuba 3's (its `envmap` emitter). +y is up. The map coordinate u ∈ [0, 1) runs
//! along the image's columns, v ∈ [0, 1] down its rows, θ = π v from +y and φ = 2π u, and the
//! direction is `(sin θ sin φ, cos θ, −sin θ cos φ)` turned about +y by the map's rotation:
//! u = 0 looks along −z, u = ¼ along +x, u = ½ along +z, u = ¾ along −x; the top row is the
//! zenith. A rotation of α turns every direction from +x towards +z by α (it is Mitsuba's
//! `to_world` rotation about +y by −α).
//!
//! Lookup, as Mitsuba's: bilinear between texel centres. Column i's centre is at u = (i + ½)/W
//! and φ wraps around; row j lies at v = j/(H − 1) (the first row at the zenith, the last at the
//! nadir, between them linear in θ). A map of one row is read as two equal rows.
//!
//! Sampling (in light transport, `crate::transport::space`): in 3D, (u, v) from the density that is
//! bilinear between the same points, with vertex values luminance × the mean of sin θ over the
//! vertex's tent (so it is never 0 at a row of positive radiance, even at the poles), sampled
//! exactly (a row cell by its mass, v within it by the linear marginal, then u from the linear
//! conditional at that v, by the cumulative sums of the two rows interpolated); the density per
//! steradian is that density / (2π² sin θ). It is positive wherever the bilinear radiance is, and
//! [`EnvMap::pdf_sphere`] evaluates the same continuous function, so a sample's density and the
//! density at its direction agree to rounding. In flatland a piecewise-constant 1D distribution
//! over angle around the plane's circle.
//!
//! Texels that are negative or not finite are set to 0, with a note that counts them.

use crate::math::Rgb;
use crate::scene::error::ImageError;
use glam::DVec3;
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::path::Path;

/// A piecewise-constant density on [0, 1) with `n` equal cells, and its inversion.
#[derive(Clone, Debug, PartialEq)]
pub struct Piecewise1D {
    /// Cumulative weight at the end of each cell, normalised to 1 at the end.
    cdf: Vec<f64>,
    /// Integral of the unnormalised weights (mean weight).
    pub integral: f64,
}

impl Piecewise1D {
    /// From non-negative finite weights (at least one positive).
    pub fn new(weights: &[f64]) -> Option<Piecewise1D> {
        let total: f64 = weights.iter().sum();
        if !(total > 0.0 && total.is_finite()) {
            return None;
        }
        let mut acc = 0.0;
        let cdf = weights
            .iter()
            .map(|w| {
                acc += w;
                acc / total
            })
            .collect();
        Some(Piecewise1D {
            cdf,
            integral: total / weights.len() as f64,
        })
    }

    pub fn len(&self) -> usize {
        self.cdf.len()
    }

    pub fn is_empty(&self) -> bool {
        self.cdf.is_empty()
    }

    /// Probability of cell `i`.
    pub fn prob(&self, i: usize) -> f64 {
        self.cdf[i] - if i == 0 { 0.0 } else { self.cdf[i - 1] }
    }

    /// Density on [0, 1) at a point of cell `i`.
    pub fn density(&self, i: usize) -> f64 {
        self.prob(i) * self.len() as f64
    }

    /// `u` ∈ [0, 1) → (x ∈ [0, 1), its cell), uniform within the cell; `None` for a cell of zero
    /// probability (not reached for u < 1).
    pub fn sample(&self, u: f64) -> Option<(f64, usize)> {
        let n = self.len();
        let i = self.cdf.partition_point(|&c| c <= u).min(n - 1);
        let lo = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        let p = self.cdf[i] - lo;
        if !(p > 0.0) {
            return None;
        }
        let t = ((u - lo) / p).clamp(0.0, 1.0);
        let x = ((i as f64 + t) / n as f64).min(1.0 - f64::EPSILON / 2.0);
        Some((x, i))
    }
}

/// A lat-long environment map with its 3D sampling tables.
#[derive(Clone, PartialEq)]
pub struct EnvMap {
    pub width: usize,
    pub height: usize,
    /// Row-major from the top (zenith) row, scaled radiance.
    pub texels: Vec<Rgb>,
    /// Turn about +y, radians (from +x towards +z).
    pub rotation: f64,
    /// The factor the file's radiance was multiplied by.
    pub scale: f64,
    /// The 3D sampling density over (u, v).
    warp: Warp,
    /// Where the map came from (messages, metadata).
    pub source: String,
    /// What the load changed, for the loader's warnings (texels set to 0, each naming the file).
    pub notes: Vec<String>,
}

impl std::fmt::Debug for EnvMap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "EnvMap({}, {}×{}, rotation {})",
            self.source, self.width, self.height, self.rotation
        )
    }
}

/// The sampling weight of a texel: its luminance (0 only for black).
pub fn texel_weight(c: Rgb) -> f64 {
    crate::math::luminance(c).max(0.0)
}

/// Where (u, v) falls between the texel centres: columns `i0`, `i1` (wrapped) and rows `j0`,
/// `j1 = j0 + 1`, with the weights of the second of each.
#[derive(Clone, Copy, Debug)]
struct Cell {
    i0: usize,
    i1: usize,
    fx: f64,
    j0: usize,
    fy: f64,
}

/// The cell of (u, v) on a grid of `w` columns (periodic, centres at (i + ½)/w) and `h` ≥ 2 rows
/// (at j/(h − 1)).
#[inline]
fn cell(u: f64, v: f64, w: usize, h: usize) -> Cell {
    let x = u * w as f64 - 0.5;
    let x = if x.is_finite() {
        x.rem_euclid(w as f64)
    } else {
        0.0
    };
    let i0 = (x as usize).min(w - 1);
    let y = if v.is_finite() {
        v.clamp(0.0, 1.0)
    } else {
        0.0
    } * (h - 1) as f64;
    let j0 = (y as usize).min(h - 2);
    Cell {
        i0,
        i1: (i0 + 1) % w,
        fx: (x - i0 as f64).clamp(0.0, 1.0),
        j0,
        fy: (y - j0 as f64).clamp(0.0, 1.0),
    }
}

impl Cell {
    /// The bilinear mix of `at(i, j)` at this cell.
    #[inline]
    fn mix<T>(&self, at: impl Fn(usize, usize) -> T) -> T
    where
        T: std::ops::Mul<f64, Output = T> + std::ops::Add<Output = T>,
    {
        let (gx, gy) = (1.0 - self.fx, 1.0 - self.fy);
        let j1 = self.j0 + 1;
        (at(self.i0, self.j0) * gx + at(self.i1, self.j0) * self.fx) * gy
            + (at(self.i0, j1) * gx + at(self.i1, j1) * self.fx) * self.fy
    }
}

/// The mean of sin(π v) over the tent of vertex row `j` of `h` rows (rows at v = j/(h − 1)): the
/// solid angle the row's vertex stands for, per unit of (u, v) area, / 2π².
fn tent_sin(j: usize, h: usize) -> f64 {
    let d = 1.0 / (h - 1) as f64;
    if j == 0 || j == h - 1 {
        // 2/d · ∫₀ᵈ (1 − s/d) sin(π s) ds
        2.0 / d * (1.0 / PI - (PI * d).sin() / (PI * PI * d))
    } else {
        (PI * j as f64 * d).sin() * 2.0 * (1.0 - (PI * d).cos()) / (PI * d).powi(2)
    }
}

/// `t` ∈ [0, 1] from a uniform `r` for the density ∝ a (1 − t) + b t (a, b ≥ 0).
#[inline]
fn linear_inverse(a: f64, b: f64, r: f64) -> f64 {
    let den = a + ((1.0 - r) * a * a + r * b * b).sqrt();
    if den > 0.0 {
        (r * (a + b) / den).clamp(0.0, 1.0)
    } else {
        r
    }
}

/// A density on the unit square, bilinear between vertex values on the map's grid (periodic in
/// u), with the cumulative sums that sample it exactly.
#[derive(Clone, Debug, PartialEq)]
struct Warp {
    w: usize,
    h: usize,
    /// Vertex values, row-major.
    f: Vec<f64>,
    /// Per vertex row, the cumulative masses of its `w` cells (trapezoids, periodic), `w + 1`
    /// entries from 0; the last is the row's sum.
    cum: Vec<f64>,
    /// Cumulative masses of the `h − 1` row cells, normalised to 1 at the end.
    rows: Vec<f64>,
    /// The integral of the bilinear function over the unit square.
    total: f64,
}

impl Warp {
    fn new(f: Vec<f64>, w: usize, h: usize) -> Option<Warp> {
        let mut cum = Vec::with_capacity(h * (w + 1));
        for j in 0..h {
            let row = &f[j * w..(j + 1) * w];
            let mut acc = 0.0;
            cum.push(0.0);
            for i in 0..w {
                acc += 0.5 * (row[i] + row[(i + 1) % w]);
                cum.push(acc);
            }
        }
        let sum = |j: usize| cum[j * (w + 1) + w];
        // Row cell j: ∫ over u is (1 − t) S_j + t S_{j+1} with S = sum / w; its mass over v is
        // their mean × 1/(h − 1).
        let masses: Vec<f64> = (0..h - 1)
            .map(|j| 0.5 * (sum(j) + sum(j + 1)) / (w * (h - 1)) as f64)
            .collect();
        let total: f64 = masses.iter().sum();
        if !(total > 0.0 && total.is_finite()) {
            return None;
        }
        let mut acc = 0.0;
        let rows = masses
            .iter()
            .map(|m| {
                acc += m;
                acc / total
            })
            .collect();
        Some(Warp {
            w,
            h,
            f,
            cum,
            rows,
            total,
        })
    }

    /// The density at (u, v).
    #[inline]
    fn density(&self, u: f64, v: f64) -> f64 {
        cell(u, v, self.w, self.h).mix(|i, j| self.f[j * self.w + i]) / self.total
    }

    /// (u, v) with its density, from two uniform numbers.
    fn sample(&self, xi: (f64, f64)) -> Option<(f64, f64, f64)> {
        let (w, h) = (self.w, self.h);
        // The row cell by its mass, then v within it by the linear marginal.
        let j = self.rows.partition_point(|&c| c <= xi.0).min(h - 2);
        let lo = if j == 0 { 0.0 } else { self.rows[j - 1] };
        let p = self.rows[j] - lo;
        if !(p > 0.0) {
            return None;
        }
        let sum = |j: usize| self.cum[j * (w + 1) + w];
        let (a, b) = (sum(j), sum(j + 1));
        let t = linear_inverse(a, b, ((xi.0 - lo) / p).clamp(0.0, 1.0));
        // u from the conditional at that v: the two rows' cumulative sums interpolated.
        let cdf =
            |k: usize| (1.0 - t) * self.cum[j * (w + 1) + k] + t * self.cum[(j + 1) * (w + 1) + k];
        let target = xi.1.clamp(0.0, 1.0) * cdf(w);
        let (mut lo_k, mut hi_k) = (0usize, w);
        // The last k with cdf(k) ≤ target, below w.
        while hi_k - lo_k > 1 {
            let mid = (lo_k + hi_k) / 2;
            if cdf(mid) <= target {
                lo_k = mid;
            } else {
                hi_k = mid;
            }
        }
        let k = lo_k;
        let g = |i: usize| (1.0 - t) * self.f[j * w + i] + t * self.f[(j + 1) * w + i];
        let (ga, gb) = (g(k), g((k + 1) % w));
        let mass = 0.5 * (ga + gb);
        if !(mass > 0.0) {
            return None;
        }
        let s = linear_inverse(ga, gb, ((target - cdf(k)) / mass).clamp(0.0, 1.0));
        let mut u = (k as f64 + 0.5 + s) / w as f64;
        if u >= 1.0 {
            u -= 1.0;
        }
        let v = (j as f64 + t) / (h - 1) as f64;
        let density = ((1.0 - s) * ga + s * gb) / self.total;
        Some((u, v, density))
    }
}

impl EnvMap {
    /// From texels (row-major from the zenith row), a scale and a rotation in degrees. Texels that
    /// are negative or not finite (after scaling) become 0, with a note; errors on a black map.
    pub fn new(
        width: usize,
        height: usize,
        texels: Vec<Rgb>,
        scale: f64,
        rotation_deg: f64,
        source: &str,
    ) -> Result<EnvMap, ImageError> {
        let invalid = |what: String| ImageError::Invalid {
            name: Some(source.to_string()),
            what,
        };
        if width == 0 || height == 0 || texels.len() != width * height {
            return Err(invalid(
                "an environment map needs at least one texel".into(),
            ));
        }
        if !(scale >= 0.0 && scale.is_finite() && rotation_deg.is_finite()) {
            return Err(invalid(
                "the scale must be finite and ≥ 0 and the rotation finite".into(),
            ));
        }
        let mut cleared = 0usize;
        let mut texels: Vec<Rgb> = texels
            .into_iter()
            .map(|c| {
                let c = c * scale;
                if c.min_element() >= 0.0 && c.is_finite() {
                    c
                } else {
                    cleared += 1;
                    Rgb::new(c.x, c.y, c.z).map(|x| if x >= 0.0 && x.is_finite() { x } else { 0.0 })
                }
            })
            .collect();
        let mut notes = Vec::new();
        if cleared > 0 {
            notes.push(format!(
                "{source}: {cleared} of {} texels had negative or non-finite values, set to 0",
                texels.len()
            ));
        }
        // One row: the same radiance at every θ, as two equal rows.
        let height = if height == 1 {
            texels.extend_from_within(..);
            2
        } else {
            height
        };
        let f = (0..height)
            .flat_map(|j| {
                let s = tent_sin(j, height);
                texels[j * width..(j + 1) * width]
                    .iter()
                    .map(move |c| texel_weight(*c) * s)
            })
            .collect();
        let Some(warp) = Warp::new(f, width, height) else {
            return Err(invalid(
                "the environment map is black everywhere (or its scale is 0)".into(),
            ));
        };
        Ok(EnvMap {
            width,
            height,
            texels,
            rotation: rotation_deg.to_radians(),
            scale,
            warp,
            source: source.to_string(),
            notes,
        })
    }

    /// Reads `.exr` (the first layer: R, G, B, or a luminance-only Y) or `.hdr` (Radiance RGBE).
    /// Only a regular file is opened.
    pub fn load(path: &Path, scale: f64, rotation_deg: f64) -> Result<EnvMap, ImageError> {
        let name = path.display().to_string();
        // Only regular files: a FIFO would block the load.
        if let Some(kind) = crate::scene::files::not_regular(path) {
            return Err(ImageError::NotRegular { name, kind });
        }
        let ext = crate::scene::files::extension(path);
        let (w, h, texels) = match ext.as_deref() {
            Some("exr") => {
                let exr =
                    crate::scene::files::read_exr(path).map_err(|source| ImageError::Decode {
                        name: Some(name.clone()),
                        what: "cannot read as an OpenEXR image",
                        source,
                    })?;
                let px = exr
                    .rgba
                    .iter()
                    .map(|p| Rgb::new(p[0] as f64, p[1] as f64, p[2] as f64))
                    .collect();
                (exr.width, exr.height, px)
            }
            Some("hdr") => {
                let img = image::ImageReader::open(path)
                    .map_err(ImageError::failed(&name, "cannot open"))?
                    .with_guessed_format()
                    .map_err(ImageError::failed(&name, "cannot read"))?
                    .decode()
                    .map_err(ImageError::failed(
                        &name,
                        "cannot read as a Radiance HDR image",
                    ))?
                    .into_rgb32f();
                let (w, h) = (img.width() as usize, img.height() as usize);
                let px = img
                    .pixels()
                    .map(|p| Rgb::new(p[0] as f64, p[1] as f64, p[2] as f64))
                    .collect();
                (w, h, px)
            }
            _ => {
                return Err(ImageError::Invalid {
                    name: Some(name),
                    what:
                        "an environment map must be .exr or .hdr (lat-long, Mitsuba 3's convention)"
                            .into(),
                });
            }
        };
        EnvMap::new(w, h, texels, scale, rotation_deg, &name)
    }

    /// The map coordinates (u, v) ∈ [0, 1) × [0, 1] of the unit direction `d`.
    #[inline]
    pub fn uv(&self, d: DVec3) -> (f64, f64) {
        let v = d.y.clamp(-1.0, 1.0).acos() / PI;
        let u = ((d.z.atan2(d.x) + FRAC_PI_2 - self.rotation) / TAU).rem_euclid(1.0);
        (if u < 1.0 { u } else { 0.0 }, v)
    }

    /// Radiance along the unit direction `d` (light arriving from `d`): bilinear between the
    /// texel centres.
    #[inline]
    pub fn radiance(&self, d: DVec3) -> Rgb {
        let (u, v) = self.uv(d);
        self.radiance_at(u, v)
    }

    /// Radiance at the map coordinates (u, v).
    #[inline]
    pub fn radiance_at(&self, u: f64, v: f64) -> Rgb {
        cell(u, v, self.width, self.height).mix(|i, j| self.texels[j * self.width + i])
    }

    /// The direction for the map coordinates (u, v) = (φ/2π, θ/π).
    #[inline]
    pub fn direction(&self, u: f64, v: f64) -> DVec3 {
        let (sin_t, cos_t) = (PI * v).sin_cos();
        let (sin_p, cos_p) = (TAU * u - FRAC_PI_2 + self.rotation).sin_cos();
        DVec3::new(sin_t * cos_p, cos_t, sin_t * sin_p)
    }

    /// A direction from the bilinear density over (u, v), and its density per steradian.
    pub fn sample_sphere(&self, xi: (f64, f64)) -> Option<(DVec3, f64)> {
        let (u, v, p_uv) = self.warp.sample(xi)?;
        let sin_t = (PI * v).sin();
        if !(sin_t > 0.0 && p_uv > 0.0) {
            return None;
        }
        Some((self.direction(u, v), p_uv / (2.0 * PI * PI * sin_t)))
    }

    /// The density per steradian of [`sample_sphere`](Self::sample_sphere) at the unit `d`.
    pub fn pdf_sphere(&self, d: DVec3) -> f64 {
        let sin_t = (1.0 - d.y * d.y).max(0.0).sqrt();
        if !(sin_t > 0.0) {
            return 0.0;
        }
        let (u, v) = self.uv(d);
        self.warp.density(u, v) / (2.0 * PI * PI * sin_t)
    }

    /// The integral of the luminance over the sphere / 4π (the map's mean luminance).
    pub fn mean_luminance(&self) -> f64 {
        // ∫ lum dω = 2π² ∫∫ lum(u, v) sin(π v) du dv, which is the warp's total (its vertex
        // values carry the tents' mean sin θ): / 4π gives π/2 × total.
        self.warp.total * PI / 2.0
    }
}

/// The environment as a light: the map, and in flatland the distribution over the plane's circle.
#[derive(Clone, Debug, PartialEq)]
pub struct Environment {
    pub map: std::sync::Arc<EnvMap>,
    /// Flatland: angle φ around the plane (direction `e1 cos φ + e2 sin φ`), in bins of equal
    /// angle weighted by the radiance at their centres (floored, so that no direction the map
    /// lights has density 0).
    pub circle: Option<(DVec3, DVec3, Piecewise1D)>,
}

/// Bins around the flatland circle per texel column of the map.
const CIRCLE_BINS_PER_COLUMN: usize = 4;

impl Environment {
    pub fn new(map: EnvMap) -> Environment {
        Environment {
            map: std::sync::Arc::new(map),
            circle: None,
        }
    }

    /// The same map seen in the flatland plane spanned by `e1`, `e2`.
    pub fn in_plane(&self, e1: DVec3, e2: DVec3) -> Environment {
        let n = (CIRCLE_BINS_PER_COLUMN * self.map.width).max(64);
        let mut w: Vec<f64> = (0..n)
            .map(|k| {
                let (s, c) = (TAU * (k as f64 + 0.5) / n as f64).sin_cos();
                texel_weight(self.map.radiance(e1 * c + e2 * s))
            })
            .collect();
        let mean = w.iter().sum::<f64>() / n as f64;
        let floor = if mean > 0.0 { 1e-3 * mean } else { 1.0 };
        for x in &mut w {
            *x += floor;
        }
        let dist = Piecewise1D::new(&w).expect("floored weights are positive");
        Environment {
            map: self.map.clone(),
            circle: Some((e1, e2, dist)),
        }
    }

    /// The mean luminance over the sphere, for the light's power.
    pub fn mean_weight(&self) -> f64 {
        self.map.mean_luminance()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A Radiance HDR file (written by the image crate's encoder) reads back within RGBE's
    /// precision (8-bit mantissas: < 1 %), rows from the top, scaled.
    #[test]
    fn hdr_maps_read_back() {
        let dir = std::env::temp_dir().join(format!("ftpd3d-env-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("m.hdr");
        let (w, h) = (4usize, 2usize);
        let px: Vec<image::Rgb<f32>> = (0..w * h)
            .map(|k| image::Rgb([0.5 + k as f32, 2.0, 0.25 * (k + 1) as f32]))
            .collect();
        let file = std::fs::File::create(&path).unwrap();
        image::codecs::hdr::HdrEncoder::new(file)
            .encode(&px, w, h)
            .unwrap();
        let map = EnvMap::load(&path, 2.0, 0.0).unwrap();
        assert_eq!((map.width, map.height), (w, h));
        for (k, p) in px.iter().enumerate() {
            let want = Rgb::new(p.0[0] as f64, p.0[1] as f64, p.0[2] as f64) * 2.0;
            let got = map.texels[k];
            assert!(
                (got - want).abs().max_element() <= 0.01 * want.max_element(),
                "texel {k}: {got} vs {want}"
            );
        }
        std::fs::remove_dir_all(&dir).ok();
    }
}
