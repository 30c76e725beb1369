//! Lights: emissive triangles (area lights, Lambertian, front side only) and isotropic point lights.
//! One light is chosen in proportion to its power (`PowerCdf`); sampling a point on it and the
//! densities at the receiving point are light transport (`crate::transport::light`).

use crate::math::{Rgb, luminance};
use crate::scene::material::Material;
use glam::{DVec3, Vec3};
use std::f64::consts::PI;

#[derive(Clone, Debug)]
pub enum Light {
    /// Triangle `prim` of the scene with radiance `emission` leaving its front side.
    Triangle {
        prim: u32,
        v: [DVec3; 3],
        normal: DVec3,
        area: f64,
        emission: Rgb,
    },
    /// Isotropic point light of radiant intensity `intensity` (per steradian).
    Point { position: DVec3, intensity: Rgb },
}

impl Light {
    /// Total emitted power (luminance), the light-selection weight.
    pub fn power(&self) -> f64 {
        match self {
            Light::Triangle { area, emission, .. } => PI * area * luminance(*emission).max(0.0),
            Light::Point { intensity, .. } => 4.0 * PI * luminance(*intensity).max(0.0),
        }
    }
}

/// Chooses one of several lights in proportion to its power (3D and flatland alike).
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct PowerCdf {
    /// Cumulative power, normalised to 1 at the end.
    cdf: Vec<f64>,
}

impl PowerCdf {
    pub(crate) fn new(powers: impl IntoIterator<Item = f64>) -> PowerCdf {
        let mut acc = 0.0;
        let mut cdf: Vec<f64> = powers
            .into_iter()
            .map(|p| {
                acc += p;
                acc
            })
            .collect();
        if acc > 0.0 {
            for c in &mut cdf {
                *c /= acc;
            }
        }
        PowerCdf { cdf }
    }

    /// True when nothing can be chosen (no lights, or none with power).
    pub(crate) fn is_empty(&self) -> bool {
        self.cdf.last().is_none_or(|&t| t <= 0.0)
    }

    /// Probability of choosing light `i`.
    pub(crate) fn prob(&self, i: usize) -> f64 {
        let lo = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        self.cdf[i] - lo
    }

    /// The light that `u` ∈ [0, 1) chooses, with its probability; `None` when it has none.
    #[inline]
    pub(crate) fn pick(&self, u: f64) -> Option<(usize, f64)> {
        if self.is_empty() {
            return None;
        }
        let i = self
            .cdf
            .partition_point(|&c| c <= u)
            .min(self.cdf.len() - 1);
        let p = self.prob(i);
        (p > 0.0).then_some((i, p))
    }
}

#[derive(Clone, Debug, Default)]
pub struct LightSet {
    pub lights: Vec<Light>,
    pub(crate) choice: PowerCdf,
    /// For each scene triangle, its index in `lights` or `u32::MAX`.
    pub(crate) light_of_prim: Vec<u32>,
}

impl LightSet {
    /// Collects every triangle whose material emits.
    pub fn from_emitters(
        positions: &[Vec3],
        triangles: &[[u32; 3]],
        normal: impl Fn(usize) -> DVec3,
        tri_material: &[u32],
        materials: &[Material],
    ) -> LightSet {
        let mut lights = Vec::new();
        let mut light_of_prim = vec![u32::MAX; triangles.len()];
        for (i, tri) in triangles.iter().enumerate() {
            let m = &materials[tri_material[i] as usize];
            if luminance(m.emission) <= 0.0 {
                continue;
            }
            let v = tri.map(|k| positions[k as usize].as_dvec3());
            let area = 0.5 * (v[1] - v[0]).cross(v[2] - v[0]).length();
            if area <= 0.0 {
                continue;
            }
            light_of_prim[i] = lights.len() as u32;
            lights.push(Light::Triangle {
                prim: i as u32,
                v,
                normal: normal(i),
                area,
                emission: m.emission,
            });
        }
        let mut set = LightSet {
            lights,
            choice: PowerCdf::default(),
            light_of_prim,
        };
        set.rebuild_cdf();
        set
    }

    pub(super) fn add_point(&mut self, position: DVec3, intensity: Rgb) {
        self.lights.push(Light::Point {
            position,
            intensity,
        });
        self.rebuild_cdf();
    }

    fn rebuild_cdf(&mut self) {
        self.choice = PowerCdf::new(self.lights.iter().map(Light::power));
    }

    pub fn is_empty(&self) -> bool {
        self.lights.is_empty() || self.choice.is_empty()
    }

    pub fn total_power(&self) -> f64 {
        self.lights.iter().map(Light::power).sum()
    }
}
