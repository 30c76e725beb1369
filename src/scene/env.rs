//! The environment map: radiance from every direction that leaves the scene, read from a lat-long
//! (equirectangular) HDR image (`.exr`, `.hdr`), with its importance-sampling tables.
//!
//! Convention: +y is up. Texel column `i` of `width` covers φ ∈ [2π i/w, 2π (i+1)/w), row `j` of
//! `height` covers θ ∈ [π j/h, π (j+1)/h) from +y (the top row is the zenith), and the direction is
//! `(sin θ cos φ', cos θ, sin θ sin φ')` with φ' = φ + rotation (a turn of the map about +y).
//! Radiance is constant over a texel (nearest lookup), so the map is exactly the function that is
//! sampled.
//!
//! Sampling (in light transport, `crate::transport::space`): in 3D a piecewise-constant 2D
//! distribution over texels proportional to their mean channel × sin θ at the row's centre, then
//! uniform within the texel in (φ, θ), so the density per steradian is `p(texel) · w h / (2π² sin θ)`;
//! in flatland a piecewise-constant 1D distribution over angle around the plane's circle.

use crate::math::Rgb;
use crate::scene::error::ImageError;
use glam::DVec3;
use std::f64::consts::{PI, TAU};
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
    /// Turn about +y, radians.
    pub rotation: f64,
    /// The factor the file's radiance was multiplied by.
    pub scale: f64,
    /// Row choice ∝ the row's weight (3D).
    pub rows: Piecewise1D,
    /// Column choice within each row.
    pub cols: Vec<Option<Piecewise1D>>,
    /// Where the map came from (messages, metadata).
    pub source: String,
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

/// The sampling weight of a texel: its mean channel (0 only for black).
pub fn texel_weight(c: Rgb) -> f64 {
    ((c.x + c.y + c.z) / 3.0).max(0.0)
}

impl EnvMap {
    /// From texels (row-major from the zenith row), a scale and a rotation in degrees. Errors on
    /// negative or non-finite texels and on a black map.
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
        if let Some(k) = texels
            .iter()
            .position(|c| !(c.min_element() >= 0.0 && c.is_finite()))
        {
            return Err(invalid(format!(
                "texel ({}, {}) is negative or not finite",
                k % width,
                k / width
            )));
        }
        let texels: Vec<Rgb> = texels.into_iter().map(|c| c * scale).collect();
        let mut row_w = Vec::with_capacity(height);
        let mut cols = Vec::with_capacity(height);
        for j in 0..height {
            let sin_t = (PI * (j as f64 + 0.5) / height as f64).sin();
            let w: Vec<f64> = texels[j * width..(j + 1) * width]
                .iter()
                .map(|c| texel_weight(*c) * sin_t)
                .collect();
            let d = Piecewise1D::new(&w);
            row_w.push(d.as_ref().map_or(0.0, |d| d.integral));
            cols.push(d);
        }
        let Some(rows) = Piecewise1D::new(&row_w) else {
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
            rows,
            cols,
            source: source.to_string(),
        })
    }

    /// Reads `.exr` (the first RGB(A) layer) or `.hdr` (Radiance RGBE).
    pub fn load(path: &Path, scale: f64, rotation_deg: f64) -> Result<EnvMap, ImageError> {
        let name = path.display().to_string();
        // Only regular files: a FIFO would block the load.
        if let Some(kind) = crate::scene::files::not_regular(path) {
            return Err(ImageError::NotRegular { name, kind });
        }
        let ext = crate::scene::files::extension(path);
        let (w, h, texels) = match ext.as_deref() {
            Some("exr") => {
                use exr::prelude::*;
                let img = read_first_rgba_layer_from_file(
                    path,
                    |res, _| {
                        (
                            res.width(),
                            res.height(),
                            vec![Rgb::ZERO; res.width() * res.height()],
                        )
                    },
                    |(w, _, px): &mut (usize, usize, Vec<Rgb>),
                     pos,
                     (r, g, b, _a): (f32, f32, f32, f32)| {
                        px[pos.y() * *w + pos.x()] = Rgb::new(r as f64, g as f64, b as f64);
                    },
                )
                .map_err(ImageError::failed(&name, "cannot read as an OpenEXR image"))?;
                img.layer_data.channel_data.pixels
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
                    what: "an environment map must be .exr or .hdr (lat-long, +y up)".into(),
                });
            }
        };
        EnvMap::new(w, h, texels, scale, rotation_deg, &name)
    }

    /// The texel seen along the unit direction `d`.
    #[inline]
    pub fn texel_of(&self, d: DVec3) -> (usize, usize) {
        let theta = d.y.clamp(-1.0, 1.0).acos();
        let phi = (d.z.atan2(d.x) - self.rotation).rem_euclid(TAU);
        let i = ((phi / TAU * self.width as f64) as usize).min(self.width - 1);
        let j = ((theta / PI * self.height as f64) as usize).min(self.height - 1);
        (i, j)
    }

    /// Radiance along the unit direction `d` (light arriving from `d`).
    #[inline]
    pub fn radiance(&self, d: DVec3) -> Rgb {
        let (i, j) = self.texel_of(d);
        self.texels[j * self.width + i]
    }

    /// The direction for the map coordinates (φ/2π, θ/π) ∈ [0, 1)².
    #[inline]
    pub fn direction(&self, u: f64, v: f64) -> DVec3 {
        let (sin_t, cos_t) = (PI * v).sin_cos();
        let (sin_p, cos_p) = (TAU * u + self.rotation).sin_cos();
        DVec3::new(sin_t * cos_p, cos_t, sin_t * sin_p)
    }

    /// A direction with density ∝ weight × sin θ per texel, and its density per steradian.
    pub fn sample_sphere(&self, u: (f64, f64)) -> Option<(DVec3, f64)> {
        let (v, j) = self.rows.sample(u.0)?;
        let cols = self.cols[j].as_ref()?;
        let (uu, i) = cols.sample(u.1)?;
        let sin_t = (PI * v).sin();
        if !(sin_t > 0.0) {
            return None;
        }
        let p_uv = self.rows.density(j) * cols.density(i);
        Some((self.direction(uu, v), p_uv / (2.0 * PI * PI * sin_t)))
    }

    /// The density per steradian of [`sample_sphere`](Self::sample_sphere) at the unit `d`.
    pub fn pdf_sphere(&self, d: DVec3) -> f64 {
        let sin_t = (1.0 - d.y * d.y).max(0.0).sqrt();
        if !(sin_t > 0.0) {
            return 0.0;
        }
        let (i, j) = self.texel_of(d);
        let Some(cols) = &self.cols[j] else {
            return 0.0;
        };
        self.rows.density(j) * cols.density(i) / (2.0 * PI * PI * sin_t)
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

    /// The mean radiance (channel mean) over the sphere, for the light's power.
    pub fn mean_weight(&self) -> f64 {
        // Σ weight · sin θ · (π/h)(2π/w) over texels, over 4π: the row table's mean × π/2.
        self.map.rows.integral * PI / 2.0
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
