//! Lights: emissive triangles (area lights, Lambertian, front side only) and isotropic point lights,
//! in 3D and, with the triangles' cross-sections as emitters, in flatland. One light is chosen in proportion to its power (`PowerCdf`); sampling a point on it and the
//! densities at the receiving point are light transport (`crate::transport::light`).

use crate::math::{Rgb, luminance};
use crate::scene::material::Material;
use glam::{DVec3, Vec3};
use std::f64::consts::{PI, TAU};

/// The shape of an area emitter as a run's space of directions sees it: a triangle in 3D, or the
/// segment where a triangle crosses the flatland plane. Uniform points on it are light transport
/// (`crate::kernel::Space::point_on`).
pub trait Shape: Clone + std::fmt::Debug + PartialEq + Send + Sync + 'static {
    /// ∫ cos θ over the directions of one side: π (per steradian) or 2 (per radian); the power of
    /// a Lambertian emitter is this × radiance × its measure.
    const COSINE_INTEGRAL: f64;
    /// The measure of all directions: 4π, or 2π; the power of an isotropic point light is this ×
    /// its intensity.
    const FULL_ANGLE: f64;
}

/// A triangle of the scene, by its three vertices.
#[derive(Clone, Debug, PartialEq)]
pub struct Triangle(pub [DVec3; 3]);

impl Shape for Triangle {
    const COSINE_INTEGRAL: f64 = PI;
    const FULL_ANGLE: f64 = 4.0 * PI;
}

/// A segment in the flatland plane, from `a` to `b`.
#[derive(Clone, Debug, PartialEq)]
pub struct Segment {
    pub a: DVec3,
    pub b: DVec3,
}

impl Shape for Segment {
    const COSINE_INTEGRAL: f64 = 2.0;
    const FULL_ANGLE: f64 = TAU;
}

/// A light source, with emitters of shape `S` ([`Triangle`] in 3D, [`Segment`] in flatland).
#[derive(Clone, Debug, PartialEq)]
pub enum Light<S = Triangle> {
    /// Triangle `prim` of the scene (in flatland, its cross-section with the plane), emitting
    /// radiance `emission` to the side of the unit `normal`; `measure` is its area (length).
    Area {
        prim: u32,
        shape: S,
        normal: DVec3,
        measure: f64,
        emission: Rgb,
    },
    /// Isotropic point light of radiant intensity `intensity` (per steradian; per radian in
    /// flatland).
    Point { position: DVec3, intensity: Rgb },
}

impl<S: Shape> Light<S> {
    /// Total emitted power (luminance), the light-selection weight.
    pub fn power(&self) -> f64 {
        match self {
            Light::Area {
                measure, emission, ..
            } => S::COSINE_INTEGRAL * measure * luminance(*emission).max(0.0),
            Light::Point { intensity, .. } => S::FULL_ANGLE * luminance(*intensity).max(0.0),
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

/// The lights of a run: one is chosen in proportion to its power, then a point on it uniformly.
#[derive(Clone, Debug, PartialEq)]
pub struct Lights<S = Triangle> {
    pub lights: Vec<Light<S>>,
    pub(crate) choice: PowerCdf,
    /// For each scene triangle, its index in `lights` or `u32::MAX`.
    pub(crate) light_of_prim: Vec<u32>,
}

impl<S> Default for Lights<S> {
    fn default() -> Self {
        Lights {
            lights: Vec::new(),
            choice: PowerCdf::default(),
            light_of_prim: Vec::new(),
        }
    }
}

/// The lights of a 3D run.
pub type LightSet = Lights<Triangle>;

impl<S: Shape> Lights<S> {
    /// `light_of_prim[t]` is the index in `lights` of triangle t's light, or `u32::MAX`.
    pub(crate) fn new(lights: Vec<Light<S>>, light_of_prim: Vec<u32>) -> Lights<S> {
        Lights {
            choice: PowerCdf::new(lights.iter().map(Light::power)),
            lights,
            light_of_prim,
        }
    }

    pub fn is_empty(&self) -> bool {
        self.lights.is_empty() || self.choice.is_empty()
    }

    pub fn total_power(&self) -> f64 {
        self.lights.iter().map(Light::power).sum()
    }
}

impl LightSet {
    /// Collects every triangle whose material emits.
    pub fn from_emitters(
        positions: &[Vec3],
        triangles: &[[u32; 3]],
        normals: &[DVec3],
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
            lights.push(Light::Area {
                prim: i as u32,
                shape: Triangle(v),
                normal: normals[i],
                measure: area,
                emission: m.emission,
            });
        }
        Lights::new(lights, light_of_prim)
    }

    pub(super) fn add_point(&mut self, position: DVec3, intensity: Rgb) {
        self.lights.push(Light::Point {
            position,
            intensity,
        });
        self.choice = PowerCdf::new(self.lights.iter().map(Light::power));
    }
}
