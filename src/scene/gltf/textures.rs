//! glTF textures: each image a material asks for decoded once per encoding (in parallel), from a
//! data URI, a file next to the glTF file or a buffer view, and the materials pointed at them.

use crate::math::Rgb;
use crate::scene::error::LoadError;
use crate::scene::gltf::accessor::view_bytes;
use crate::scene::gltf::document::malformed;
use crate::scene::gltf::document::{decode_data_uri, named};
use crate::scene::gltf::material::{Slot, TextureRequest, pbr_params};
use crate::scene::material::{Bsdf, Material, MetallicRoughness, TextureRef};
use crate::scene::texture::{Encoding, Texture, TextureSet};
use rayon::prelude::*;
use std::path::Path;

/// Decodes the images of `requests` and gives the materials (indexed as in `doc`) their texture
/// references; `buffers` are the document's, `path` the glTF file's.
pub(super) fn resolve(
    doc: &::gltf::Document,
    requests: Vec<TextureRequest>,
    materials: &mut [Material],
    buffers: &[Vec<u8>],
    path: &Path,
) -> Result<TextureSet, LoadError> {
    if requests.is_empty() {
        return Ok(TextureSet::default());
    }
    let images: Vec<(usize, Encoding)> = {
        let mut v: Vec<_> = requests.iter().map(|r| (r.1, r.4.encoding())).collect();
        v.sort_unstable_by_key(|&(i, e)| (i, e == Encoding::Linear));
        v.dedup();
        v
    };
    let decoded = images
        .par_iter()
        .map(|&(i, e)| decode_image(doc, i, e, buffers, path))
        .collect::<Result<Vec<_>, _>>()?;
    // Materials whose whole glossy model is rebuilt per hit: their base-colour texture
    // multiplies `baseColorFactor` (not the Lambertian albedo).
    let mut per_hit = vec![false; materials.len()];
    for r in &requests {
        per_hit[r.0] |= r.4 == Slot::MetallicRoughness;
    }
    for (m, image, wrap, transform, slot) in requests {
        let key = (image, slot.encoding());
        let texture = TextureRef {
            texture: images.iter().position(|k| *k == key).unwrap_or(0) as u32,
            factor: Rgb::ONE,
            wrap,
            transform,
        };
        attach(doc, m, &mut materials[m], texture, slot, per_hit[m]);
    }
    Ok(TextureSet {
        textures: decoded.into_iter().map(std::sync::Arc::new).collect(),
    })
}

/// Gives material `m` (`material`) the texture of one request in `slot`; `per_hit`: its glossy
/// model is rebuilt per hit from a metallic-roughness texture.
fn attach(
    doc: &::gltf::Document,
    m: usize,
    material: &mut Material,
    texture: TextureRef,
    slot: Slot,
    per_hit: bool,
) {
    match slot {
        Slot::Emissive => {
            // The texel times `emissiveFactor` (the material's emission, which lights use).
            material.maps.emission = Some(texture);
            return;
        }
        Slot::MetallicRoughness => {
            let Some(gm) = doc.materials().nth(m) else {
                return;
            };
            let (base, metallic, roughness) = pbr_params(&gm).0.unit();
            let mr = MetallicRoughness {
                map: texture,
                metallic,
                roughness,
                base,
            };
            // Its own model: the factors alone (a white texel), of the kind every texel gives.
            material.bsdf = mr.bsdf(base, [1.0; 4]);
            material.maps.metallic_roughness = Some(mr);
            return;
        }
        Slot::BaseColour => {}
    }
    // The base colour's alpha channel is the coverage of a cut-out.
    if let Some(alpha) = material.maps.alpha.as_mut() {
        alpha.map = Some(texture.clone());
    }
    let factor = if per_hit {
        let Some(gm) = doc.materials().nth(m) else {
            return;
        };
        pbr_params(&gm).0.unit().0
    } else {
        match &material.bsdf {
            Bsdf::Diffuse { kd } | Bsdf::Glossy { kd, .. } | Bsdf::Mirror { kd, .. } => *kd,
            _ => return,
        }
    };
    material.maps.base_color = Some(TextureRef { factor, ..texture });
}

/// Decodes image `index` of the document: a data URI, a file next to the glTF, or a buffer view
/// (PNG, JPEG, TGA, HDR). Colour textures (`encoding`) are sRGB-encoded (glTF's rule), decoded to
/// linear; data textures are read as stored.
fn decode_image(
    doc: &::gltf::Document,
    index: usize,
    encoding: Encoding,
    buffers: &[Vec<u8>],
    path: &Path,
) -> Result<Texture, LoadError> {
    let image = doc
        .images()
        .nth(index)
        .ok_or_else(|| malformed(path, format!("image #{index} does not exist")))?;
    let label = named("image", index, image.name());
    // Images held in the file are named by it: "FILE: image 'x'".
    let held = format!("{}: {label}", path.display());
    let image_error = |source| LoadError::Image {
        file: path.to_path_buf(),
        image: label.clone(),
        source,
    };
    match image.source() {
        ::gltf::image::Source::Uri { uri, .. } if uri.starts_with("data:") => {
            let bytes =
                decode_data_uri(uri).map_err(|e| malformed(path, format!("{label}: {e}")))?;
            Texture::from_bytes(&bytes, &held, encoding).map_err(image_error)
        }
        ::gltf::image::Source::Uri { uri, .. } => {
            Texture::load(&path.parent().unwrap_or(Path::new(".")).join(uri), encoding)
                .map_err(image_error)
        }
        ::gltf::image::Source::View { view, .. } => {
            let bytes =
                view_bytes(&view, buffers).map_err(|e| malformed(path, format!("{label}: {e}")))?;
            Texture::from_bytes(bytes, &held, encoding).map_err(image_error)
        }
    }
}
