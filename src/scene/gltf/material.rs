//! glTF materials onto the material model (the table in [`crate::scene::gltf`]): the
//! metallic-roughness parameters, alpha modes, and the textures each material asks for.

use crate::math::Rgb;
use crate::scene::gltf::document::{IMAGE_EXTENSIONS, Warnings, named};
use crate::scene::material::{Alpha, AlphaMode, Bsdf, Material};
use crate::scene::pbr::{MAX_PHONG_EXPONENT, is_lambertian, pbr_lobes};
use crate::scene::texture::{Encoding, UvTransform, Wrap};

/// A material's texture: (material, image, wrap modes, transform, which map it fills).
pub(super) type TextureRequest = (usize, usize, (Wrap, Wrap), UvTransform, Slot);

/// Which map a texture request fills.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Slot {
    BaseColour,
    Emissive,
    MetallicRoughness,
}

impl Slot {
    /// Colour textures are sRGB-encoded; the metallic-roughness texture holds data, read as
    /// stored (glTF's rule).
    pub(super) fn encoding(self) -> Encoding {
        match self {
            Slot::BaseColour | Slot::Emissive => Encoding::Colour,
            Slot::MetallicRoughness => Encoding::Linear,
        }
    }
}

/// The document's materials, converted, in order, with the default material (for primitives
/// without one) last, and the textures they ask for.
pub(super) struct Converted {
    pub(super) materials: Vec<Material>,
    pub(super) default_material: u32,
    pub(super) requests: Vec<TextureRequest>,
}

/// Converts every material of `doc`, with its warnings.
pub(super) fn convert_materials(doc: &::gltf::Document, warnings: &mut Warnings) -> Converted {
    let mut materials = Vec::new();
    let mut requests = Vec::new();
    let mut textured = Vec::new();
    for m in doc.materials() {
        let label = named("material", m.index().unwrap_or(0), m.name());
        let (material, notes) = convert_material(&m, &label);
        for w in notes {
            warnings.warn(format!("{label}: {w}"));
        }
        let base = m.pbr_metallic_roughness().base_color_texture();
        let emissive = m.emissive_texture();
        let mut metallic_roughness = m.pbr_metallic_roughness().metallic_roughness_texture();
        // A smooth dielectric has no metallic or roughness to read.
        if metallic_roughness.is_some() && matches!(material.bsdf, Bsdf::Dielectric { .. }) {
            warnings.warn(format!(
                "{label}: metallic-roughness texture ignored on a transmissive material (a \
                 smooth dielectric)"
            ));
            metallic_roughness = None;
        }
        for (info, slot, what) in [
            (&base, Slot::BaseColour, "base colour"),
            (&emissive, Slot::Emissive, "emissive"),
            (
                &metallic_roughness,
                Slot::MetallicRoughness,
                "metallic-roughness",
            ),
        ] {
            let Some(info) = info else {
                continue;
            };
            if info.tex_coord() != 0 {
                warnings.warn(format!(
                    "{label}: {what} texture on TEXCOORD_{}; only TEXCOORD_0 is read",
                    info.tex_coord()
                ));
            } else if let Some(r) = texture_request(materials.len(), info, slot, doc.images().len())
            {
                requests.push(r);
            } else {
                warnings.warn(format!(
                    "{label}: {what} texture #{} names no image; its factor is used",
                    info.texture().index()
                ));
            }
        }
        // Normal, occlusion and transmission textures are not read.
        if other_textures(&m) {
            textured.push(label);
        }
        materials.push(material);
    }
    if let Some(first) = textured.first() {
        warnings.warn(format!(
            "normal, occlusion and transmission textures are ignored ({} material(s) use them, first {first}); their constant factors are used",
            textured.len()
        ));
    }
    let default_material = materials.len() as u32;
    materials.push(Material::default_grey());
    Converted {
        materials,
        default_material,
        requests,
    }
}

/// The request of material `material` for the texture `info` names, with its sampler's wrap modes
/// and `KHR_texture_transform`.
fn texture_request(
    material: usize,
    info: &::gltf::texture::Info,
    slot: Slot,
    images: usize,
) -> Option<TextureRequest> {
    let sampler = info.texture().sampler();
    let wrap = |w: ::gltf::texture::WrappingMode| match w {
        ::gltf::texture::WrappingMode::ClampToEdge => Wrap::ClampToEdge,
        ::gltf::texture::WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
        ::gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
    };
    let transform = info
        .texture_transform()
        .map_or_else(UvTransform::default, |t| UvTransform {
            offset: t.offset().map(|x| x as f64),
            rotation: t.rotation() as f64,
            scale: t.scale().map(|x| x as f64),
        });
    (
        material,
        image_of(&info.texture(), images)?,
        (wrap(sampler.wrap_s()), wrap(sampler.wrap_t())),
        transform,
        slot,
    )
        .into()
}

/// The image a texture shows: its `source`, else the image of an image-format extension
/// (`KHR_texture_basisu`, `EXT_texture_webp`, `EXT_texture_avif`), whose `source` is then the
/// fallback those extensions allow to be absent. The texture decoder says which formats it reads
/// (KTX2 is not among them: a warning, and the material keeps its factors).
fn image_of(texture: &::gltf::Texture, images: usize) -> Option<usize> {
    if let Some(image) = texture.source() {
        return Some(image.index());
    }
    let extensions = texture.extensions()?;
    IMAGE_EXTENSIONS.iter().find_map(|name| {
        let i = extensions.get(*name)?.get("source")?.as_u64()? as usize;
        (i < images).then_some(i)
    })
}

/// The numbers of a glTF material that the mapping uses (see the module table).
#[derive(Clone, Debug, PartialEq)]
pub struct PbrParams {
    pub base: Rgb,
    pub metallic: f64,
    pub roughness: f64,
    /// `emissiveFactor` × `emissive_strength`.
    pub emission: Rgb,
    /// `KHR_materials_transmission` factor (0 without the extension).
    pub transmission: f64,
    /// `KHR_materials_ior` (1.5 without the extension).
    pub ior: f64,
}

impl Default for PbrParams {
    /// glTF's defaults: white, metallic 1, roughness 1, no emission, no transmission, ior 1.5.
    fn default() -> Self {
        PbrParams {
            base: Rgb::ONE,
            metallic: 1.0,
            roughness: 1.0,
            emission: Rgb::ZERO,
            transmission: 0.0,
            ior: 1.5,
        }
    }
}

impl PbrParams {
    /// Base colour, metallic and roughness as the mapping uses them: clamped to [0, 1], and
    /// glTF's defaults where non-finite (out-of-range JSON numbers).
    pub fn unit(&self) -> (Rgb, f64, f64) {
        let finite_or = |x: f64, d: f64| if x.is_finite() { x.clamp(0.0, 1.0) } else { d };
        let base = self.base.to_array().map(|c| finite_or(c, 1.0)).into();
        (
            base,
            finite_or(self.metallic, 1.0),
            finite_or(self.roughness, 1.0),
        )
    }
}

/// Maps metallic-roughness parameters onto the material model (the module table).
pub fn map_pbr(name: &str, p: &PbrParams) -> Material {
    let (base, m, r) = p.unit();
    let emission = if p.emission.is_finite() {
        p.emission.max(Rgb::ZERO)
    } else {
        Rgb::ZERO
    };
    let bsdf = if p.transmission > 0.5 {
        Bsdf::Dielectric {
            ior: p.ior,
            tint: base,
        }
    } else if is_lambertian(m, r) {
        Bsdf::Diffuse { kd: base }
    } else {
        let (kd, ks, exponent) = pbr_lobes(base, m, r);
        if exponent >= MAX_PHONG_EXPONENT {
            Bsdf::Mirror { kd, ks }
        } else {
            Bsdf::Glossy { kd, ks, exponent }
        }
    };
    let bsdf = match bsdf {
        Bsdf::Diffuse { kd } if kd == Rgb::ZERO => Bsdf::Black,
        b => b,
    };
    Material {
        name: name.to_string(),
        bsdf,
        emission,
        maps: Default::default(),
    }
}

fn rgb3(c: [f32; 3]) -> Rgb {
    Rgb::new(c[0] as f64, c[1] as f64, c[2] as f64)
}

/// Whether `m` uses a texture that is not read (normal, occlusion, transmission).
fn other_textures(m: &::gltf::Material) -> bool {
    m.normal_texture().is_some()
        || m.occlusion_texture().is_some()
        || m.transmission()
            .is_some_and(|t| t.transmission_texture().is_some())
}

/// The numbers of `m` that the mapping uses, and warnings about them.
pub(super) fn pbr_params(m: &::gltf::Material) -> (PbrParams, Vec<String>) {
    let mut warnings = Vec::new();
    let pbr = m.pbr_metallic_roughness();
    let [r, g, b, _] = pbr.base_color_factor();
    let strength = m.emissive_strength().unwrap_or(1.0) as f64;
    let ior = match m.ior() {
        None => 1.5,
        Some(n) if n.is_finite() && n >= 1.0 => n as f64,
        Some(n) => {
            warnings.push(format!("KHR_materials_ior {n} is not ≥ 1; using 1.5"));
            1.5
        }
    };
    let params = PbrParams {
        base: rgb3([r, g, b]),
        metallic: pbr.metallic_factor() as f64,
        roughness: pbr.roughness_factor() as f64,
        emission: rgb3(m.emissive_factor()) * strength,
        transmission: m
            .transmission()
            .as_ref()
            .map_or(0.0, |t| t.transmission_factor() as f64),
        ior,
    };
    (params, warnings)
}

/// Refuses a material whose `emissiveFactor` has a negative or non-finite component, or whose
/// `KHR_materials_emissive_strength` is negative or not finite (glTF: both ≥ 0; the glTF
/// validator reports such values as errors), naming the material and the field: clamping them to
/// 0 would silently turn off a light the file means to have.
pub(super) fn check_emission(doc: &::gltf::Document) -> Result<(), String> {
    for m in doc.materials() {
        let label = named("material", m.index().unwrap_or(0), m.name());
        let factor = m.emissive_factor();
        if !factor.iter().all(|c| c.is_finite() && *c >= 0.0) {
            return Err(format!(
                "{label}: emissiveFactor {factor:?} must be finite and ≥ 0 in each component"
            ));
        }
        if let Some(s) = m.emissive_strength()
            && !(s.is_finite() && s >= 0.0)
        {
            return Err(format!(
                "{label}: KHR_materials_emissive_strength {s} must be finite and ≥ 0"
            ));
        }
    }
    Ok(())
}

/// Converts a glTF material: the material and its warnings.
fn convert_material(m: &::gltf::Material, label: &str) -> (Material, Vec<String>) {
    let (params, warnings) = pbr_params(m);
    let alpha = m.pbr_metallic_roughness().base_color_factor()[3];
    let name = m.name().map_or_else(|| label.to_string(), str::to_string);
    let mut material = map_pbr(&name, &params);
    // Coverage: the base colour's alpha (factor times texel, set with the texture).
    let mode = match m.alpha_mode() {
        ::gltf::material::AlphaMode::Opaque => None,
        ::gltf::material::AlphaMode::Mask => Some(AlphaMode::Mask {
            cutoff: m.alpha_cutoff().unwrap_or(0.5) as f64,
        }),
        ::gltf::material::AlphaMode::Blend => Some(AlphaMode::Stochastic),
    };
    material.maps.alpha = mode.map(|mode| Alpha {
        factor: (alpha as f64).clamp(0.0, 1.0),
        map: None,
        channel: 3,
        mode,
    });
    (material, warnings)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::material::{MetallicRoughness, TextureRef};

    fn pbr(base: f64, metallic: f64, roughness: f64) -> PbrParams {
        PbrParams {
            base: Rgb::splat(base),
            metallic,
            roughness,
            ..Default::default()
        }
    }

    #[test]
    fn gltf_rough_dielectric_is_diffuse() {
        let m = map_pbr("a", &pbr(0.8, 0.0, 1.0));
        assert_eq!(
            m.bsdf,
            Bsdf::Diffuse {
                kd: Rgb::splat(0.8)
            }
        );
    }

    #[test]
    fn gltf_smooth_metal_is_mirror() {
        let m = map_pbr("a", &pbr(0.9, 1.0, 0.0));
        assert_eq!(
            m.bsdf,
            Bsdf::Mirror {
                kd: Rgb::ZERO,
                ks: Rgb::splat(0.9)
            }
        );
    }

    #[test]
    fn gltf_glossy_mixes_metal_and_dielectric() {
        let m = map_pbr("a", &pbr(0.5, 0.5, 0.5));
        let Bsdf::Glossy { kd, ks, exponent } = m.bsdf else {
            panic!("{:?}", m.bsdf)
        };
        assert!((kd - Rgb::splat(0.25)).abs().max_element() < 1e-12);
        assert!((ks - Rgb::splat(0.27)).abs().max_element() < 1e-12);
        assert!((exponent - 30.0).abs() < 1e-9);
    }

    #[test]
    fn gltf_energy_is_conserved() {
        for &(b, m, r) in &[
            (1.0, 0.0, 0.5),
            (1.0, 0.2, 0.0),
            (1.0, 0.0, 0.0),
            (1.0, 1.0, 0.3),
        ] {
            let mat = map_pbr("a", &pbr(b, m, r));
            let (kd, ks) = match mat.bsdf {
                Bsdf::Glossy { kd, ks, .. } | Bsdf::Mirror { kd, ks } => (kd, ks),
                Bsdf::Diffuse { kd } => (kd, Rgb::ZERO),
                other => panic!("{other:?}"),
            };
            assert!((kd + ks).max_element() <= 1.0 + 1e-12, "{b} {m} {r}");
        }
    }

    #[test]
    fn gltf_transmission_is_dielectric() {
        let p = PbrParams {
            base: Rgb::new(0.9, 1.0, 0.8),
            transmission: 1.0,
            ior: 1.33,
            ..Default::default()
        };
        assert_eq!(
            map_pbr("w", &p).bsdf,
            Bsdf::Dielectric {
                ior: 1.33,
                tint: Rgb::new(0.9, 1.0, 0.8)
            }
        );
    }

    #[test]
    fn gltf_black_emitter_is_black() {
        let p = PbrParams {
            base: Rgb::ZERO,
            metallic: 0.0,
            emission: Rgb::splat(4.0),
            ..Default::default()
        };
        let m = map_pbr("l", &p);
        assert_eq!(m.bsdf, Bsdf::Black);
        assert_eq!(m.emission, Rgb::splat(4.0));
    }

    fn glossy(b: &Bsdf) -> (Rgb, Rgb, f64) {
        match b {
            Bsdf::Glossy { kd, ks, exponent } => (*kd, *ks, *exponent),
            other => panic!("not glossy: {other:?}"),
        }
    }

    fn close(a: Rgb, b: Rgb) -> bool {
        (a - b).abs().max_element() < 1e-12
    }

    fn mr(metallic: f64, roughness: f64) -> MetallicRoughness {
        MetallicRoughness {
            map: TextureRef {
                texture: 0,
                factor: Rgb::ONE,
                wrap: (Wrap::Repeat, Wrap::Repeat),
                transform: UvTransform::default(),
            },
            metallic,
            roughness,
            base: Rgb::splat(0.8),
        }
    }

    /// Per hit, roughness is the texel's G channel times `roughnessFactor` and metallic its B
    /// channel times `metallicFactor`; R and A are not read. The values are the table's formulas
    /// written out by hand.
    #[test]
    fn gltf_metallic_roughness_texel_reads_g_and_b_times_the_factors() {
        let base = Rgb::splat(0.8);
        // G = 0.5, B = 0.25: r = 0.5 (α = 0.25, n = 2/0.0625 − 2 = 30), m = 0.25:
        // kd = 0.8 · 0.75 = 0.6, ks = 0.04 · 0.75 + 0.8 · 0.25 = 0.23.
        let (kd, ks, n) = glossy(&mr(1.0, 1.0).bsdf(base, [0.9, 0.5, 0.25, 0.1]));
        assert!(
            close(kd, Rgb::splat(0.6)) && close(ks, Rgb::splat(0.23)),
            "{kd:?} {ks:?}"
        );
        assert!((n - 30.0).abs() < 1e-9, "{n}");
        // R and A do not matter; R and B swapped would.
        let other = mr(1.0, 1.0).bsdf(base, [0.0, 0.5, 0.25, 1.0]);
        assert_eq!(glossy(&other), (kd, ks, n));
        assert_ne!(
            glossy(&mr(1.0, 1.0).bsdf(base, [0.25, 0.5, 0.9, 1.0])).0,
            kd
        );
        // The factors multiply: metallic 0.5 × B 0.5, roughness 0.625 × G 0.8 give the same.
        let (kd2, ks2, n2) = glossy(&mr(0.5, 0.625).bsdf(base, [0.0, 0.8, 0.5, 0.0]));
        assert!(close(kd2, kd) && close(ks2, ks) && (n2 - n).abs() < 1e-9);
        // r = 0.6 × 1: α = 0.36, n = 2/0.1296 − 2.
        let (_, _, n3) = glossy(&mr(0.0, 0.6).bsdf(base, [0.0, 1.0, 1.0, 0.0]));
        assert!((n3 - (2.0 / 0.1296 - 2.0)).abs() < 1e-9, "{n3}");
        // The base colour given per hit (a base-colour texel) is the one used.
        let (kd4, ks4, _) =
            glossy(&mr(1.0, 1.0).bsdf(Rgb::new(0.4, 0.2, 0.0), [0.0, 0.5, 1.0, 0.0]));
        assert!(close(kd4, Rgb::ZERO) && close(ks4, Rgb::new(0.4, 0.2, 0.0)));
    }

    /// The ends of the mapping stay of the glossy kind: the Lambertian corner (m ≤ 0.05, r ≥ 0.9)
    /// has ks = 0 and kd = base, as [`map_pbr`]'s Lambertian; r = 0 is the lobe of the largest
    /// exponent with ks = base for a metal, where [`map_pbr`] makes a mirror of reflectance base.
    /// Between them the texel gives what [`map_pbr`] gives for the same constants.
    #[test]
    fn gltf_metallic_roughness_texels_stay_glossy_at_the_limits() {
        let base = Rgb::splat(0.8);
        let (kd, ks, _) = glossy(&mr(1.0, 1.0).bsdf(base, [0.0, 1.0, 0.0, 1.0]));
        assert_eq!((kd, ks), (base, Rgb::ZERO));
        assert_eq!(
            map_pbr("a", &pbr(0.8, 0.0, 1.0)).bsdf,
            Bsdf::Diffuse { kd: base }
        );
        let (kd, ks, n) = glossy(&mr(1.0, 1.0).bsdf(base, [0.0, 0.0, 1.0, 1.0]));
        assert_eq!((kd, ks, n), (Rgb::ZERO, base, MAX_PHONG_EXPONENT));
        assert_eq!(
            map_pbr("a", &pbr(0.8, 1.0, 0.0)).bsdf,
            Bsdf::Mirror {
                kd: Rgb::ZERO,
                ks: base
            }
        );
        for (m, r) in [(0.3, 0.7), (0.0, 0.5), (1.0, 0.2), (0.06, 0.95)] {
            let texel = glossy(&mr(1.0, 1.0).bsdf(base, [0.0, r, m, 1.0]));
            let constant = glossy(&map_pbr("a", &pbr(0.8, m, r)).bsdf);
            assert!(
                close(texel.0, constant.0) && close(texel.1, constant.1),
                "{m} {r}"
            );
            assert!((texel.2 / constant.2 - 1.0).abs() < 1e-12, "{m} {r}");
        }
        // White base, no metal: kd + ks = 1.04 is scaled down, as at load.
        let (kd, ks, _) = glossy(&mr(1.0, 1.0).bsdf(Rgb::ONE, [0.0, 0.5, 0.0, 1.0]));
        assert!(((kd + ks).max_element() - 1.0).abs() < 1e-12);
    }
}
