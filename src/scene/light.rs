//! Lights: emissive triangles (area lights, Lambertian, front side only) and isotropic point lights,
//! in 3D and, with the triangles' cross-sections as emitters, in flatland. One light is chosen in proportion to its power (`PowerCdf`); sampling a point on it and the
//! densities at the receiving point are light transport (`crate::transport::light`).

use crate::math::{Rgb, luminance};
use crate::scene::env::Environment;
use crate::scene::material::Material;
use glam::{DVec3, Vec3};
use std::f64::consts::{PI, TAU};

/// The sun's angular diameter when a scene or flag does not give one, degrees (as seen from the
/// Earth).
pub const DEFAULT_SUN_DIAMETER_DEG: f64 = 0.53;

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
    /// The measure of the directions within `alpha` of an axis: 2π(1 − cos α) = 4π sin²(α/2)
    /// steradians, or 2α radians.
    fn cone_measure(alpha: f64) -> f64;
    /// ∫ cos θ over those directions, θ measured from the axis: π sin²α, or 2 sin α. A light of
    /// radiance L uniform over the cone gives this × L of irradiance to a surface facing it.
    fn cone_cosine_integral(alpha: f64) -> f64;
    /// The cross-section of the scene's bounding ball of radius `r` (π r², or 2r): the power of a
    /// distant light of irradiance E that reaches the scene is this × E.
    fn cross_section(r: f64) -> f64;
}

/// A triangle of the scene, by its three vertices.
#[derive(Clone, Debug, PartialEq)]
pub struct Triangle(pub [DVec3; 3]);

impl Shape for Triangle {
    const COSINE_INTEGRAL: f64 = PI;
    const FULL_ANGLE: f64 = 4.0 * PI;
    fn cone_measure(alpha: f64) -> f64 {
        4.0 * PI * (0.5 * alpha).sin().powi(2)
    }
    fn cone_cosine_integral(alpha: f64) -> f64 {
        PI * alpha.sin().powi(2)
    }
    fn cross_section(r: f64) -> f64 {
        PI * r * r
    }
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
    fn cone_measure(alpha: f64) -> f64 {
        2.0 * alpha
    }
    fn cone_cosine_integral(alpha: f64) -> f64 {
        2.0 * alpha.sin()
    }
    fn cross_section(r: f64) -> f64 {
        2.0 * r
    }
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
    /// A spot light: a point light whose intensity along `direction` (unit) is `intensity`, full
    /// inside the cone of cosine `cos_inner`, none outside `cos_outer`, with glTF's smooth falloff
    /// (`KHR_lights_punctual`) between.
    Spot {
        position: DVec3,
        direction: DVec3,
        intensity: Rgb,
        cos_inner: f64,
        cos_outer: f64,
    },
    /// Light from beyond the scene from one direction (the sun): `direction` (unit) points towards
    /// it and `irradiance` is what it gives a surface facing it. With `half_angle` > 0 its radiance
    /// `radiance` is uniform over the cone of directions within `half_angle` (the sun's angular
    /// radius); with 0 it is a Dirac delta in direction.
    Distant {
        direction: DVec3,
        irradiance: Rgb,
        half_angle: f64,
        /// cos(half_angle): directions with a larger cosine to `direction` see the disc.
        cos_max: f64,
        /// `irradiance` / ∫ cos over the cone (0 for a delta).
        radiance: Rgb,
        /// The cone's measure (steradians or radians; 0 for a delta).
        measure: f64,
    },
    /// Constant radiance `radiance` from every direction that leaves the scene (a uniform sky).
    Sky { radiance: Rgb },
    /// Radiance from a lat-long HDR map in every direction that leaves the scene.
    Env(Environment),
}

impl<S: Shape> Light<S> {
    /// The sun: irradiance `irradiance` from the unit `direction`, spread over a disc of angular
    /// radius `half_angle` (radians; 0 for a Dirac delta).
    pub fn distant(direction: DVec3, irradiance: Rgb, half_angle: f64) -> Light<S> {
        let (radiance, measure) = if half_angle > 0.0 {
            (
                irradiance / S::cone_cosine_integral(half_angle),
                S::cone_measure(half_angle),
            )
        } else {
            (Rgb::ZERO, 0.0)
        };
        Light::Distant {
            direction,
            irradiance,
            half_angle,
            cos_max: half_angle.cos(),
            radiance,
            measure,
        }
    }

    /// Seen by rays that leave the scene (sky, or a sun with a disc), so a path that escapes
    /// collects it.
    pub fn is_infinite(&self) -> bool {
        matches!(self, Light::Sky { .. } | Light::Env(_))
            || matches!(self, Light::Distant { half_angle, .. } if *half_angle > 0.0)
    }

    /// Outside the scene (sky and sun): shadow rays towards it run past the scene's bounds.
    pub fn is_distant(&self) -> bool {
        matches!(
            self,
            Light::Sky { .. } | Light::Env(_) | Light::Distant { .. }
        )
    }
}

impl<S: Shape> Light<S> {
    /// Total emitted power (luminance), the light-selection weight; `radius` is that of the
    /// scene's bounding ball, which distant lights fill.
    pub fn power(&self, radius: f64) -> f64 {
        match self {
            Light::Area {
                measure, emission, ..
            } => S::COSINE_INTEGRAL * measure * luminance(*emission).max(0.0),
            // An upper bound for a spot: a selection weight need not be exact.
            Light::Point { intensity, .. } | Light::Spot { intensity, .. } => {
                S::FULL_ANGLE * luminance(*intensity).max(0.0)
            }
            Light::Distant { irradiance, .. } => {
                S::cross_section(radius) * luminance(*irradiance).max(0.0)
            }
            Light::Sky { radiance } => {
                S::FULL_ANGLE * S::cross_section(radius) * luminance(*radiance).max(0.0)
            }
            Light::Env(env) => S::FULL_ANGLE * S::cross_section(radius) * env.mean_weight(),
        }
    }
}

/// A light of the scene file as a run names it to switch or scale it
/// ([`crate::scene::dimmer`]): an emissive material by its name, any other light by its kind and
/// its number among the file's lights of that kind (`point1`, `spot1`, `sun1`, `sky1`, `env1`).
#[derive(Clone, Debug, PartialEq)]
pub struct FileLight {
    pub name: String,
    /// `emissive material`, `point light`, `spot light`, `sun`, `sky`, `environment map`.
    pub kind: &'static str,
    /// The factor its emission was scaled by (1: as the file says; 0: off).
    pub scale: f64,
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
        // The number of leading entries ≤ u (the cdf is non-decreasing): counted one by one for
        // the few lights or mirror planes most scenes have, where a binary search's bookkeeping
        // cost more than the comparisons it saves.
        let n = if self.cdf.len() <= 8 {
            self.cdf.iter().take_while(|&&c| c <= u).count()
        } else {
            self.cdf.partition_point(|&c| c <= u)
        };
        let i = n.min(self.cdf.len() - 1);
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
    /// The lights that rays leaving the scene see ([`Light::is_infinite`]); empty in scenes
    /// without, which then never look.
    pub(crate) infinite: Vec<u32>,
    /// The scene's bounding ball, which distant lights fill and their shadow rays leave.
    pub(crate) center: DVec3,
    pub(crate) radius: f64,
}

impl<S> Default for Lights<S> {
    fn default() -> Self {
        Lights {
            lights: Vec::new(),
            choice: PowerCdf::default(),
            light_of_prim: Vec::new(),
            infinite: Vec::new(),
            center: DVec3::ZERO,
            radius: 1.0,
        }
    }
}

/// The lights of a 3D run.
pub type LightSet = Lights<Triangle>;

impl<S: Shape> Lights<S> {
    /// `light_of_prim[t]` is the index in `lights` of triangle t's light, or `u32::MAX`.
    /// `center` and `radius` bound the scene.
    pub(crate) fn new(
        lights: Vec<Light<S>>,
        light_of_prim: Vec<u32>,
        center: DVec3,
        radius: f64,
    ) -> Lights<S> {
        let mut set = Lights {
            lights,
            light_of_prim,
            center,
            radius,
            ..Lights::default()
        };
        set.rebuild();
        set
    }

    /// Changes the lights (keeping every area light where it is: `light_of_prim` indexes them) and
    /// rebuilds the power table.
    pub(crate) fn edit(&mut self, f: impl FnOnce(&mut Vec<Light<S>>)) {
        f(&mut self.lights);
        self.rebuild();
    }

    /// Adds a light that is not a triangle of the scene.
    pub(crate) fn push(&mut self, light: Light<S>) {
        self.lights.push(light);
        self.rebuild();
    }

    fn rebuild(&mut self) {
        let r = self.radius;
        self.choice = PowerCdf::new(self.lights.iter().map(|l| l.power(r)));
        self.infinite = (0..self.lights.len() as u32)
            .filter(|&i| self.lights[i as usize].is_infinite())
            .collect();
    }

    pub fn is_empty(&self) -> bool {
        self.lights.is_empty() || self.choice.is_empty()
    }

    pub fn total_power(&self) -> f64 {
        self.lights.iter().map(|l| l.power(self.radius)).sum()
    }

    /// How far a shadow ray from `x` towards a distant light must run to leave the scene's
    /// bounding ball.
    pub fn beyond(&self, x: DVec3) -> f64 {
        (x - self.center).length() + 2.0 * self.radius
    }
}

impl LightSet {
    /// Collects every triangle whose material emits.
    pub fn from_emitters(
        positions: &[Vec3],
        triangles: &[[u32; 3]],
        normal: impl Fn(usize) -> DVec3,
        tri_material: &[u32],
        materials: &[Material],
        center: DVec3,
        radius: f64,
    ) -> LightSet {
        use rayon::prelude::*;
        let mut lights = Vec::new();
        let mut light_of_prim = Vec::with_capacity(triangles.len());
        light_of_prim.par_extend(rayon::iter::repeat_n(u32::MAX, triangles.len()));
        // The emitting triangles, in order (found in parallel: scenes have millions of triangles
        // and few emitters).
        let emitting: Vec<usize> = (0..triangles.len())
            .into_par_iter()
            .filter(|&i| luminance(materials[tri_material[i] as usize].emission) > 0.0)
            .collect();
        for i in emitting {
            let m = &materials[tri_material[i] as usize];
            let tri = &triangles[i];
            let v = tri.map(|k| positions[k as usize].as_dvec3());
            let area = 0.5 * (v[1] - v[0]).cross(v[2] - v[0]).length();
            if area <= 0.0 {
                continue;
            }
            light_of_prim[i] = lights.len() as u32;
            lights.push(Light::Area {
                prim: i as u32,
                shape: Triangle(v),
                normal: normal(i),
                measure: area,
                emission: m.emission,
            });
        }
        Lights::new(lights, light_of_prim, center, radius)
    }

    pub(super) fn add_point(&mut self, position: DVec3, intensity: Rgb) {
        self.push(Light::Point {
            position,
            intensity,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pick_chooses_by_the_cdf_on_either_side_of_the_linear_scan() {
        // Short cdfs are scanned, long ones searched: both must give the entry whose interval
        // holds u, and its probability, including zero-power entries (never chosen).
        for powers in [
            vec![2.0],
            vec![1.0, 0.0, 3.0],
            (0..8).map(f64::from).collect::<Vec<_>>(),
            (0..13).map(|k| f64::from(k % 3)).collect(),
        ] {
            let cdf = PowerCdf::new(powers.iter().copied());
            let total: f64 = powers.iter().sum();
            for k in 0..1000 {
                let u = (f64::from(k) + 0.5) / 1000.0;
                let (i, p) = cdf.pick(u).unwrap();
                let lo: f64 = powers[..i].iter().sum::<f64>() / total;
                let hi = lo + powers[i] / total;
                assert!(lo <= u && u < hi, "{powers:?} u {u} -> {i}");
                assert!((p - powers[i] / total).abs() < 1e-15);
            }
        }
        assert!(PowerCdf::new([0.0, 0.0]).pick(0.5).is_none());
    }
}
