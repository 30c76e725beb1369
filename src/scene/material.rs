//! Materials: a scattering model ([`Bsdf`]) and an emitted radiance. How a [`Bsdf`] is sampled and
//! evaluated is light transport (`crate::transport::bsdf`).
//!
//! OBJ/MTL mapping (the loader's table, also in `docs/scenes.md#obj-and-mtl`):
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
//! | `map_Kd`, `map_Ks`                    | textures replacing `Kd`, `Ks` at each hit             |
//! | `d` < 1, `map_d` (not on dielectrics) | stochastic cut-out of coverage `d` × texel            |
//!
//! Albedos whose sum exceeds 1 in some channel are scaled down to 1 (energy conservation) with a
//! warning.

use crate::math::Rgb;
use crate::scene::pbr::{conserve_energy, pbr_lobes};
use crate::scene::texture::{Texture, UvTransform, Wrap};

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
    /// Textures read at each hit, and the cut-out.
    pub maps: Maps,
}

/// What a material reads from textures at each hit. All `None` (the default) for a material
/// without textures, which then costs nothing per hit.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Maps {
    /// Replaces the Lambertian albedo `kd` by its colour times its factor (glTF
    /// `baseColorTexture`, MTL `map_Kd`).
    pub base_color: Option<TextureRef>,
    /// Replaces the specular albedo `ks` of glossy and mirror models (MTL `map_Ks`).
    pub specular: Option<TextureRef>,
    /// Replaces the emitted radiance (glTF `emissiveTexture`, MTL `map_Ke`); the factor holds the
    /// material's emission.
    pub emission: Option<TextureRef>,
    /// Metallic and roughness read per hit (glTF `metallicRoughnessTexture`): the whole glossy
    /// model is rebuilt from them at each hit ([`MetallicRoughness`]).
    pub metallic_roughness: Option<MetallicRoughness>,
    /// Where the surface is cut out: rays pass through it there ([`Alpha`]).
    pub alpha: Option<Alpha>,
}

/// A cut-out: the surface is present where its coverage α (a constant, times a texture channel
/// when there is one) says so, and every ray (walks, radiance paths, shadow rays, the on-surface
/// point query) passes through it elsewhere.
#[derive(Clone, Debug, PartialEq)]
pub struct Alpha {
    /// Constant coverage (MTL `d`, glTF `baseColorFactor`'s alpha).
    pub factor: f64,
    /// The texture whose channel `channel` multiplies `factor` (MTL `map_d`, glTF base colour).
    pub map: Option<TextureRef>,
    /// 3 for the alpha channel; 0 (red) for an MTL `map_d` image without one.
    pub channel: usize,
    pub mode: AlphaMode,
}

/// How coverage decides presence.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AlphaMode {
    /// Present where α ≥ the cutoff (glTF `MASK`).
    Mask { cutoff: f64 },
    /// Present with probability α, decided per ray by a hash of the ray and the triangle (glTF
    /// `BLEND`, MTL `d`/`map_d`): unbiased for fractional coverage, and exactly a mask where α is
    /// 0 or 1, as in leaf textures.
    Stochastic,
}

impl Maps {
    /// True when some map reads a texture, so hits need texture coordinates.
    pub fn reads_textures(&self) -> bool {
        self.base_color.is_some()
            || self.specular.is_some()
            || self.emission.is_some()
            || self.metallic_roughness.is_some()
            || self.alpha.as_ref().is_some_and(|a| a.map.is_some())
    }
}

impl Alpha {
    /// True when the surface is present everywhere (no texture and a coverage that always
    /// passes): then it is no cut-out at all.
    pub fn is_opaque(&self) -> bool {
        self.map.is_none()
            && match self.mode {
                AlphaMode::Mask { cutoff } => self.factor >= cutoff,
                AlphaMode::Stochastic => self.factor >= 1.0,
            }
    }

    /// True when the surface is absent at texture coordinate `uv` (v up) for a ray whose hash in
    /// [0, 1) `xi` gives: stochastic coverage draws it, a mask (glTF `MASK`) decides by α alone
    /// and never calls it.
    #[inline]
    pub fn cut(
        &self,
        textures: &[std::sync::Arc<Texture>],
        uv: [f64; 2],
        xi: impl FnOnce() -> f64,
    ) -> bool {
        let mut a = self.factor;
        if let Some(map) = &self.map
            && let Some(t) = textures.get(map.texture as usize)
        {
            a *= map.texel(t, uv)[self.channel.min(3)];
        }
        match self.mode {
            AlphaMode::Mask { cutoff } => !(a >= cutoff),
            // Coverage 0 or 1 (most texels of a leaf mask) decides without the hash.
            AlphaMode::Stochastic if a >= 1.0 => false,
            AlphaMode::Stochastic if a <= 0.0 => true,
            AlphaMode::Stochastic => !(xi() < a),
        }
    }
}

/// glTF's metallic-roughness texture: at each hit, roughness r = `roughness` × the texel's G
/// channel and metallic m = `metallic` × its B channel (both read as stored, linear, and clamped to
/// [0, 1]) give the glossy model through the loader's metallic-roughness mapping
/// ([`pbr_lobes`]): `kd` = base·(1 − m), `ks` = mix(0.04, base, m), Phong
/// exponent n(r), with base the base colour (the material's base-colour texel times
/// `baseColorFactor` where it has one, else `base`).
///
/// A material with this map is always [`Bsdf::Glossy`], whatever its factors alone would give, so
/// that its kind (and with it the kernel's effects and the run's list of them) covers every texel: a texel in
/// the Lambertian corner of the mapping (m ≤ 0.05, r ≥ 0.9) gives `ks` = 0, which scatters exactly
/// as the Lambertian model, and one at the mirror limit a lobe of the largest exponent
/// ([`crate::scene::pbr::MAX_PHONG_EXPONENT`]), never a Dirac mirror.
#[derive(Clone, Debug, PartialEq)]
pub struct MetallicRoughness {
    /// The texture (its factor is unused: the factors are below).
    pub map: TextureRef,
    /// `metallicFactor`, clamped to [0, 1].
    pub metallic: f64,
    /// `roughnessFactor`, clamped to [0, 1].
    pub roughness: f64,
    /// `baseColorFactor`'s RGB, clamped to [0, 1], for materials without a base-colour texture.
    pub base: Rgb,
}

impl MetallicRoughness {
    /// The model at a hit whose metallic-roughness texel is `texel` (RGBA, linear) and whose base
    /// colour is `base`.
    #[inline]
    pub fn bsdf(&self, base: Rgb, texel: [f64; 4]) -> Bsdf {
        let roughness = self.roughness * texel[1];
        let metallic = self.metallic * texel[2];
        let (kd, ks, exponent) = pbr_lobes(base, metallic, roughness);
        Bsdf::Glossy { kd, ks, exponent }
    }
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

impl TextureRef {
    /// The RGBA texel of `texture` (this reference's image) at `uv` (v up), bilinear, after the
    /// wrap and the transform (which acts in glTF's UV space, whose v points down); the factor is
    /// not applied.
    #[inline]
    pub fn texel(&self, texture: &Texture, uv: [f64; 2]) -> [f64; 4] {
        let (s, t) = self.transform.apply(uv[0], 1.0 - uv[1]);
        texture.lookup(s, 1.0 - t, self.wrap)
    }
}

impl Bsdf {
    /// The same model with its Lambertian albedo `kd` and specular albedo `ks` replaced where given
    /// (texels), scaled down where their sum exceeds 1 as at load; models without them are returned
    /// as they are. Out of line: only textured scenes call it.
    #[inline(never)]
    pub fn with_albedos(&self, kd: Option<Rgb>, ks: Option<Rgb>) -> Bsdf {
        match self {
            Bsdf::Diffuse { kd: own } => Bsdf::Diffuse {
                kd: kd.unwrap_or(*own).min(Rgb::ONE),
            },
            Bsdf::Glossy {
                kd: kd0,
                ks: ks0,
                exponent,
            } => {
                let (mut kd, mut ks) = (kd.unwrap_or(*kd0), ks.unwrap_or(*ks0));
                conserve_energy(&mut kd, &mut ks);
                Bsdf::Glossy {
                    kd,
                    ks,
                    exponent: *exponent,
                }
            }
            Bsdf::Mirror { kd: kd0, ks: ks0 } => {
                let (mut kd, mut ks) = (kd.unwrap_or(*kd0), ks.unwrap_or(*ks0));
                conserve_energy(&mut kd, &mut ks);
                Bsdf::Mirror { kd, ks }
            }
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
            maps: Maps::default(),
        }
    }

    pub fn diffuse(name: &str, kd: Rgb) -> Material {
        Material {
            name: name.into(),
            bsdf: Bsdf::Diffuse { kd },
            emission: Rgb::ZERO,
            maps: Maps::default(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn alpha(factor: f64, mode: AlphaMode) -> Alpha {
        Alpha {
            factor,
            map: None,
            channel: 3,
            mode,
        }
    }

    /// A mask decides by α and the cutoff alone (it never asks for the ray's hash); stochastic
    /// coverage asks for it exactly where α is strictly between 0 and 1.
    #[test]
    fn only_fractional_stochastic_coverage_draws_the_hash() {
        let no_hash = || -> f64 { panic!("the hash was drawn") };
        let mask = AlphaMode::Mask { cutoff: 0.5 };
        assert!(alpha(0.3, mask).cut(&[], [0.0; 2], no_hash));
        assert!(!alpha(0.5, mask).cut(&[], [0.0; 2], no_hash));
        assert!(alpha(f64::NAN, mask).cut(&[], [0.0; 2], no_hash));
        assert!(!alpha(1.0, AlphaMode::Stochastic).cut(&[], [0.0; 2], no_hash));
        assert!(alpha(0.0, AlphaMode::Stochastic).cut(&[], [0.0; 2], no_hash));
        let drawn = &std::cell::Cell::new(0);
        let xi = |v: f64| {
            move || {
                drawn.set(drawn.get() + 1);
                v
            }
        };
        assert!(!alpha(0.4, AlphaMode::Stochastic).cut(&[], [0.0; 2], xi(0.39)));
        assert!(alpha(0.4, AlphaMode::Stochastic).cut(&[], [0.0; 2], xi(0.4)));
        assert!(alpha(f64::NAN, AlphaMode::Stochastic).cut(&[], [0.0; 2], xi(0.1)));
        assert_eq!(drawn.get(), 3);
    }
}
