//! Lights: emissive triangles (area lights, Lambertian, front side only) and isotropic point lights.
//! One light is chosen in proportion to its power, then a point on it uniformly by area; densities
//! are converted to solid angle at the receiving point (`sample_x` next to `pdf_x`).

use crate::math::{Rgb, luminance};
use crate::scene::material::Material;
use crate::transport::sampling::sample_uniform_triangle;
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

/// A sampled connection from a receiving point to a light.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Unit direction from the receiver to the light point.
    pub wi: DVec3,
    /// Distance to the light point (the shadow ray stops just short of it).
    pub dist: f64,
    /// Radiance arriving along `-wi` (area light) or `I / d²` (point light).
    pub li: Rgb,
    /// Solid-angle density including the light choice; for a point light the choice probability.
    pub pdf: f64,
    /// Point lights can only be reached by light sampling.
    pub delta: bool,
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

/// `dist^(dims−1)`: how densities per unit of an emitter's measure (area in 3D, length in
/// flatland) turn into densities per solid angle (per angle), and how a point light's intensity
/// falls off. `d2` is the squared distance and `dist` its square root.
#[inline]
fn falloff(d2: f64, dist: f64, dims: i32) -> f64 {
    if dims == 3 { d2 } else { dist }
}

/// The connection from `x` to the point `y` of an emitter (unit `normal`, emitting radiance
/// `emission` from its front side) chosen with probability `p_choice` and then uniformly on its
/// `measure` (area in 3D, length in flatland; `dims` = 3 or 2): the density is converted to solid
/// angle (angle) by `dist^(dims−1) / cos θ_light`. `None` from behind.
#[inline]
pub(crate) fn connect_emitter(
    x: DVec3,
    y: DVec3,
    normal: DVec3,
    p_choice: f64,
    measure: f64,
    emission: Rgb,
    dims: i32,
) -> Option<LightSample> {
    let to = y - x;
    let d2 = to.length_squared();
    let dist = d2.sqrt();
    if !(dist > 0.0) {
        return None;
    }
    let wi = to / dist;
    let cos_l = -wi.dot(normal);
    if cos_l <= 0.0 {
        return None;
    }
    let pdf = p_choice * falloff(d2, dist, dims) / (measure * cos_l);
    pdf.is_finite().then_some(LightSample {
        wi,
        dist,
        li: emission,
        pdf,
        delta: false,
    })
}

/// The density with which [`connect_emitter`] picks the point `y` of that emitter from `x`; 0 from
/// behind.
#[inline]
pub(crate) fn emitter_pdf(
    x: DVec3,
    y: DVec3,
    normal: DVec3,
    p_choice: f64,
    measure: f64,
    dims: i32,
) -> f64 {
    let to = y - x;
    let d2 = to.length_squared();
    let dist = d2.sqrt();
    let cos_l = -to.dot(normal) / dist;
    if !(cos_l > 0.0) {
        return 0.0;
    }
    p_choice * falloff(d2, dist, dims) / (measure * cos_l)
}

/// The connection from `x` to an isotropic point light of radiant intensity `intensity` (per
/// steradian in 3D, per radian in flatland) chosen with probability `p_choice`: what arrives is
/// `I / dist^(dims−1)`, and only light sampling finds it (`delta`).
#[inline]
pub(crate) fn connect_point(
    x: DVec3,
    position: DVec3,
    intensity: Rgb,
    p_choice: f64,
    dims: i32,
) -> Option<LightSample> {
    let to = position - x;
    let d2 = to.length_squared();
    let dist = d2.sqrt();
    if !(dist > 0.0) {
        return None;
    }
    Some(LightSample {
        wi: to / dist,
        dist,
        li: intensity / falloff(d2, dist, dims),
        pdf: p_choice,
        delta: true,
    })
}

#[derive(Clone, Debug, Default)]
pub struct LightSet {
    pub lights: Vec<Light>,
    choice: PowerCdf,
    /// For each scene triangle, its index in `lights` or `u32::MAX`.
    light_of_prim: Vec<u32>,
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
            lights.push(Light::Triangle {
                prim: i as u32,
                v,
                normal: normals[i],
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

    pub fn add_point(&mut self, position: DVec3, intensity: Rgb) {
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

    /// Samples a light point as seen from `x`. `None` when there are no lights or the point faces
    /// away (back of a one-sided emitter).
    #[inline]
    pub fn sample(&self, x: DVec3, u_light: f64, u: (f64, f64)) -> Option<LightSample> {
        let (i, p_choice) = self.choice.pick(u_light)?;
        match &self.lights[i] {
            Light::Triangle {
                v,
                normal,
                area,
                emission,
                ..
            } => {
                let (b0, b1, b2) = sample_uniform_triangle(u);
                let y = b0 * v[0] + b1 * v[1] + b2 * v[2];
                connect_emitter(x, y, *normal, p_choice, *area, *emission, 3)
            }
            Light::Point {
                position,
                intensity,
            } => connect_point(x, *position, *intensity, p_choice, 3),
        }
    }

    /// Solid-angle density with which [`sample`](Self::sample) would pick the point `y` on triangle
    /// `prim` (normal `ng`) as seen from `x`; 0 when `prim` is not an emitter.
    pub fn pdf_hit(&self, x: DVec3, prim: u32, y: DVec3, ng: DVec3) -> f64 {
        let Some(&li) = self.light_of_prim.get(prim as usize) else {
            return 0.0;
        };
        if li == u32::MAX {
            return 0.0;
        }
        let Light::Triangle { area, .. } = &self.lights[li as usize] else {
            return 0.0;
        };
        emitter_pdf(x, y, ng, self.choice.prob(li as usize), *area, 3)
    }
}
