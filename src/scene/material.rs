//! Materials: a scattering model ([`Bsdf`]) and an emitted radiance. How a [`Bsdf`] is sampled and
//! evaluated is light transport (`crate::transport::bsdf`).
//!
//! OBJ/MTL mapping (the loader's table, also in the README):
//!
//! | MTL                                   | material                                              |
//! |---------------------------------------|-------------------------------------------------------|
//! | `illum 0`, `illum 1`                  | Lambertian `Kd`                                       |
//! | `illum 2` (or none) with `Ks` > 0     | `Kd` Lambertian + normalised Phong `Ks`, exponent `Ns` |
//! | `illum 2` (or none) with `Ks` = 0     | Lambertian `Kd`                                       |
//! | `illum 3`, `5`, `8`                   | `Kd` Lambertian + perfect mirror `Ks` (default 1)     |
//! | `illum 4`, `6`, `7`, `9`              | smooth dielectric, index `Ni` (default 1.5), tint `Tf` |
//! | `Ke` > 0 (any illum)                  | area light of radiance `Ke`, front side only          |
//! | no `Kd`                               | `Kd` = 0.5 grey (0 when the material emits)           |
//!
//! Albedos whose sum exceeds 1 in some channel are scaled down to 1 (energy conservation) with a
//! warning.

use crate::math::Rgb;
use crate::scene::texture::{UvTransform, Wrap};

/// A surface's scattering model.
#[derive(Clone, Debug, PartialEq)]
pub enum Bsdf {
    /// Absorbs everything (e.g. a pure emitter).
    Black,
    /// Lambertian with albedo `kd`.
    Diffuse { kd: Rgb },
    /// `kd` Lambertian plus `ks` glossy Phong lobe of exponent `exponent` around the mirror
    /// direction: `f = ks (n+1)/(2π) cos^n α / max(cos θi, cos θo)`, which is reciprocal, never
    /// reflects more than `ks`, and tends to the perfect mirror `ks` as n → ∞ (the max-cosine
    /// denominator of Ashikhmin and Shirley's specular term). The lobe is chosen in proportion to
    /// the albedos' luminance.
    Glossy { kd: Rgb, ks: Rgb, exponent: f64 },
    /// `kd` Lambertian plus a perfect mirror of reflectance `ks`.
    Mirror { kd: Rgb, ks: Rgb },
    /// Smooth dielectric of relative index `ior` (inside over outside), transmission tinted by `tint`.
    Dielectric { ior: f64, tint: Rgb },
}

#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    pub bsdf: Bsdf,
    /// Emitted radiance (front side of the triangle only).
    pub emission: Rgb,
    /// A texture whose colour (times its factor) replaces the Lambertian albedo `kd` at each hit.
    pub base_color: Option<TextureRef>,
}

/// A material's reference to one of the scene's textures.
#[derive(Clone, Debug, PartialEq)]
pub struct TextureRef {
    /// Index into [`crate::scene::Scene::textures`].
    pub texture: u32,
    /// Multiplies the texel (glTF's `baseColorFactor`).
    pub factor: Rgb,
    pub wrap: (Wrap, Wrap),
    pub transform: UvTransform,
}

impl Bsdf {
    /// The same model with its Lambertian albedo replaced (a texel); models without one are
    /// returned as they are. Out of line: only textured scenes call it.
    #[inline(never)]
    pub fn with_kd(&self, kd: Rgb) -> Bsdf {
        match self {
            Bsdf::Diffuse { .. } => Bsdf::Diffuse { kd },
            Bsdf::Glossy { ks, exponent, .. } => Bsdf::Glossy {
                kd,
                ks: *ks,
                exponent: *exponent,
            },
            Bsdf::Mirror { ks, .. } => Bsdf::Mirror { kd, ks: *ks },
            other => other.clone(),
        }
    }
}

impl Material {
    pub fn default_grey() -> Material {
        Material {
            name: "default".into(),
            bsdf: Bsdf::Diffuse {
                kd: Rgb::splat(0.5),
            },
            emission: Rgb::ZERO,
            base_color: None,
        }
    }

    pub fn diffuse(name: &str, kd: Rgb) -> Material {
        Material {
            name: name.into(),
            bsdf: Bsdf::Diffuse { kd },
            emission: Rgb::ZERO,
            base_color: None,
        }
    }
}

/// Scales `kd` and `ks` so that `kd + ks` ≤ 1 in every channel; returns whether it had to.
pub fn conserve_energy(kd: &mut Rgb, ks: &mut Rgb) -> bool {
    let m = (*kd + *ks).max_element();
    if m > 1.0 {
        *kd /= m;
        *ks /= m;
        true
    } else {
        false
    }
}
