//! glTF textures: each image a material asks for decoded once per encoding (in parallel), from a
//! data URI, a file next to the glTF file or a buffer view, and the materials pointed at them.

use crate::math::Rgb;
use crate::scene::error::{ImageError, LoadError};
use crate::scene::files::{Reach, percent_decode};
use crate::scene::gltf::accessor::view_bytes;
use crate::scene::gltf::document::{decode_data_uri, named};
use crate::scene::gltf::document::{malformed, outside};
use crate::scene::gltf::material::{Slot, TextureRequest, pbr_params};
use crate::scene::material::{Bsdf, Material, MetallicRoughness, TextureRef};
use crate::scene::texture::{Encoding, Texture, TextureSet};
use rayon::prelude::*;
use std::path::Path;

/// Decodes the images of `requests` and gives the materials (indexed as in `doc`) their texture
/// references; `buffers` are the document's, `path` the glTF file's, `reach` where its image
/// files may lie (an image outside it refuses the file). An image that cannot be
/// read or decoded (missing, not a regular file, a format not decoded here such as KTX2) is a
/// warning in `warnings` naming it and the materials that use it, and those materials keep their
/// factors in that slot.
pub(super) fn resolve(
    doc: &::gltf::Document,
    requests: Vec<TextureRequest>,
    materials: &mut [Material],
    buffers: &[Vec<u8>],
    (path, reach): (&Path, &Reach),
    warnings: &mut Vec<String>,
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
        .map(|&(i, e)| decode_image(doc, i, e, buffers, (path, reach)))
        .collect::<Vec<_>>();
    // The images that decoded, renumbered; the others leave a warning (once per image, both
    // encodings of one image fail alike).
    let mut textures = Vec::new();
    let mut index = Vec::with_capacity(images.len());
    let mut warned = Vec::new();
    for (k, d) in decoded.into_iter().enumerate() {
        match d {
            Ok(t) => {
                if !warned.contains(&images[k].0) {
                    warned.push(images[k].0);
                    warnings.extend(t.notes.iter().cloned());
                }
                index.push(Some(textures.len() as u32));
                textures.push(std::sync::Arc::new(t));
            }
            // A FIFO, device or directory named as an image is not an unreadable image but a
            // mistake in the file: refused at once, like a scene file of that kind.
            Err(
                e @ LoadError::Image {
                    source: ImageError::NotRegular { .. },
                    ..
                },
            ) => return Err(e),
            Err(e) if matches!(e, LoadError::Image { .. }) => {
                let image = images[k].0;
                if !warned.contains(&image) {
                    warned.push(image);
                    warnings.push(unread_warning(doc, image, &requests, &e));
                }
                index.push(None);
            }
            Err(e) => return Err(e),
        }
    }
    // Materials whose whole glossy model is rebuilt per hit: their base-colour texture
    // multiplies `baseColorFactor` (not the Lambertian albedo).
    let mut per_hit = vec![false; materials.len()];
    for r in &requests {
        per_hit[r.0] |= r.4 == Slot::MetallicRoughness && found(&images, &index, r);
    }
    for r in requests {
        let Some(texture) = images
            .iter()
            .position(|k| *k == (r.1, r.4.encoding()))
            .and_then(|k| index[k])
        else {
            continue;
        };
        let (m, _, wrap, transform, slot) = r;
        let texture = TextureRef {
            texture,
            factor: Rgb::ONE,
            wrap,
            transform,
        };
        attach(doc, m, &mut materials[m], texture, slot, per_hit[m]);
    }
    Ok(TextureSet { textures })
}

/// Whether the image of request `r` decoded.
fn found(images: &[(usize, Encoding)], index: &[Option<u32>], r: &TextureRequest) -> bool {
    images
        .iter()
        .position(|k| *k == (r.1, r.4.encoding()))
        .is_some_and(|k| index[k].is_some())
}

/// The warning for image `image`, which could not be read (`error`): the image, why, and the
/// materials that use it, which keep their factors.
fn unread_warning(
    doc: &::gltf::Document,
    image: usize,
    requests: &[TextureRequest],
    error: &LoadError,
) -> String {
    let mut users: Vec<usize> = requests
        .iter()
        .filter(|r| r.1 == image)
        .map(|r| r.0)
        .collect();
    users.dedup();
    let label = |m: usize| {
        let name = doc
            .materials()
            .nth(m)
            .and_then(|gm| gm.name().map(str::to_string));
        named("material", m, name.as_deref())
    };
    let first = users.first().map_or_else(String::new, |&m| label(m));
    let whose = match users.len() {
        0 | 1 => format!("{first} keeps its factors"),
        n => format!("{first} and {} other material(s) keep their factors", n - 1),
    };
    format!("{error:#}; {whose} in place of this texture")
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

/// Decodes image `index` of the document: a data URI, a file next to the glTF (its URI
/// percent-decoded, within `reach`: one outside is a [`LoadError::Outside`], not a warning), or a buffer view (PNG, JPEG, TGA, HDR). Colour textures (`encoding`) are
/// sRGB-encoded (glTF's rule), decoded to linear; data textures are read as stored. An image that
/// cannot be used is a [`LoadError::Image`] (the caller makes it a warning).
fn decode_image(
    doc: &::gltf::Document,
    index: usize,
    encoding: Encoding,
    buffers: &[Vec<u8>],
    (path, reach): (&Path, &Reach),
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
            let dir = path.parent().unwrap_or(Path::new("."));
            let file = reach
                .resolve(dir, &percent_decode(uri))
                .map_err(|o| outside(path, &label, uri, o))?;
            Texture::load(&file, encoding).map_err(image_error)
        }
        ::gltf::image::Source::View { view, .. } => {
            let bytes =
                view_bytes(&view, buffers).map_err(|e| malformed(path, format!("{label}: {e}")))?;
            Texture::from_bytes(bytes, &held, encoding).map_err(image_error)
        }
    }
}
