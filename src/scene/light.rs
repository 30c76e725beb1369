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

#[derive(Clone, Debug, Default)]
pub struct LightSet {
    pub lights: Vec<Light>,
    /// Cumulative power, normalised to 1 at the end.
    cdf: Vec<f64>,
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
            cdf: Vec::new(),
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
        let mut acc = 0.0;
        self.cdf = self
            .lights
            .iter()
            .map(|l| {
                acc += l.power();
                acc
            })
            .collect();
        if acc > 0.0 {
            for c in &mut self.cdf {
                *c /= acc;
            }
        }
    }

    pub fn is_empty(&self) -> bool {
        self.lights.is_empty() || self.cdf.last().is_none_or(|&t| t <= 0.0)
    }

    pub fn total_power(&self) -> f64 {
        self.lights.iter().map(Light::power).sum()
    }

    /// Probability of choosing light `i`.
    fn choice_pdf(&self, i: usize) -> f64 {
        let lo = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        self.cdf[i] - lo
    }

    /// Samples a light point as seen from `x`. `None` when there are no lights or the point faces
    /// away (back of a one-sided emitter).
    pub fn sample(&self, x: DVec3, u_light: f64, u: (f64, f64)) -> Option<LightSample> {
        self.sample_k::<crate::kernel::AllFeatures>(x, u_light, u)
    }

    /// [`sample`](Self::sample) for kernel `K` (no point-light branch when it has none).
    #[inline]
    pub fn sample_k<K: crate::kernel::Kernel>(
        &self,
        x: DVec3,
        u_light: f64,
        u: (f64, f64),
    ) -> Option<LightSample> {
        if self.is_empty() {
            return None;
        }
        let i = self
            .cdf
            .partition_point(|&c| c <= u_light)
            .min(self.lights.len() - 1);
        let p_choice = self.choice_pdf(i);
        if p_choice <= 0.0 {
            return None;
        }
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
                let to = y - x;
                let d2 = to.length_squared();
                let dist = d2.sqrt();
                if !(dist > 0.0) {
                    return None;
                }
                let wi = to / dist;
                let cos_l = -wi.dot(*normal);
                if cos_l <= 0.0 {
                    return None;
                }
                let pdf = p_choice * d2 / (area * cos_l);
                pdf.is_finite().then_some(LightSample {
                    wi,
                    dist,
                    li: *emission,
                    pdf,
                    delta: false,
                })
            }
            Light::Point {
                position,
                intensity,
            } if K::POINT_LIGHTS => {
                let to = *position - x;
                let d2 = to.length_squared();
                let dist = d2.sqrt();
                if !(dist > 0.0) {
                    return None;
                }
                Some(LightSample {
                    wi: to / dist,
                    dist,
                    li: *intensity / d2,
                    pdf: p_choice,
                    delta: true,
                })
            }
            Light::Point { .. } => None,
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
        let to = y - x;
        let d2 = to.length_squared();
        let cos_l = (-to.dot(ng) / d2.sqrt()).max(0.0);
        if cos_l <= 0.0 {
            return 0.0;
        }
        self.choice_pdf(li as usize) * d2 / (area * cos_l)
    }
}
