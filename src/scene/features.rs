//! Which effects a scene calls for, decided once at load time. The sample kernel is chosen from this
//! set, so a scene never pays for effects it does not have.

use crate::scene::light::{Light, LightSet};
use crate::scene::material::Bsdf;
use crate::scene::material::Material;
use std::fmt;

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Features {
    pub diffuse: bool,
    pub glossy: bool,
    pub mirror: bool,
    /// Planar perfect mirrors, whose images of the lights are sampled
    /// ([`crate::scene::mirror::Mirrors`]). Not in the printed set, which files carry as a merge
    /// key: a run's list of effects reports it as `mirror-images`.
    pub planar_mirrors: bool,
    pub dielectric: bool,
    pub area_lights: bool,
    pub point_lights: bool,
    pub spot_lights: bool,
    /// A distant light (the sun).
    pub sun: bool,
    /// Constant radiance from every escaping direction.
    pub sky: bool,
    /// Albedos read from textures at each hit.
    pub textures: bool,
    /// Emitters whose radiance is read from a texture (light samples and hits look it up).
    pub emission_textures: bool,
    /// Cut-out (alpha-masked) triangles, which rays pass through where their coverage says.
    pub cutouts: bool,
}

impl Features {
    /// The effects of the materials actually used by triangles, and of the lights.
    pub fn of(materials: &[Material], tri_material: &[u32], lights: &LightSet) -> Features {
        let mut used = vec![false; materials.len()];
        for &m in tri_material {
            used[m as usize] = true;
        }
        let mut f = Features::default();
        for (m, _) in materials.iter().zip(&used).filter(|(_, u)| **u) {
            match &m.bsdf {
                Bsdf::Black => {}
                Bsdf::Diffuse { .. } => f.diffuse = true,
                Bsdf::Glossy { kd, .. } => {
                    f.glossy = true;
                    f.diffuse |= *kd != crate::math::Rgb::ZERO;
                    // Per hit, metallic below the factor leaves a Lambertian part of the base.
                    if let Some(mr) = &m.maps.metallic_roughness {
                        f.diffuse |= mr.base != crate::math::Rgb::ZERO;
                    }
                }
                Bsdf::Mirror { kd, .. } => {
                    f.mirror = true;
                    f.diffuse |= *kd != crate::math::Rgb::ZERO;
                }
                Bsdf::Dielectric { .. } => f.dielectric = true,
            }
        }
        for l in &lights.lights {
            match l {
                Light::Area { .. } => f.area_lights = true,
                Light::Point { .. } => f.point_lights = true,
                Light::Spot { .. } => f.spot_lights = true,
                Light::Distant { .. } => f.sun = true,
                Light::Sky { .. } | Light::Env(_) => f.sky = true,
            }
        }
        f
    }
}

impl fmt::Display for Features {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let names: Vec<&str> = [
            (self.diffuse, "diffuse"),
            (self.glossy, "glossy"),
            (self.mirror, "mirror"),
            (self.dielectric, "dielectric"),
            (self.area_lights, "area-lights"),
            (self.point_lights, "point-lights"),
            (self.spot_lights, "spot-lights"),
            (self.sun, "sun"),
            (self.sky, "sky"),
            (self.textures, "textures"),
            (self.cutouts, "cut-outs"),
        ]
        .iter()
        .filter(|(on, _)| *on)
        .map(|(_, n)| *n)
        .collect();
        if names.is_empty() {
            write!(f, "(nothing)")
        } else {
            write!(f, "{}", names.join(" "))
        }
    }
}
