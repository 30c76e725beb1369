//! glTF 2.0 loading (the `gltf` crate): `.gltf` with embedded (data-URI) or external buffers, and
//! `.glb`. The default scene (or the first one) is flattened: every node's world transform is applied
//! to its mesh's positions and normals (normals with the inverse transpose, renormalised; triangle
//! winding flipped where the transform mirrors), and a mesh used by several nodes is copied once per
//! node. TRIANGLES, TRIANGLE_STRIP and TRIANGLE_FAN primitives are read, indexed or not; points and
//! lines are skipped with a warning. Buffers are read by this module; images (base-colour, emissive
//! and metallic-roughness textures) are decoded by `crate::scene::texture`.
//!
//! Metallic-roughness mapping (base = `baseColorFactor` RGB, m = `metallicFactor`, r =
//! `roughnessFactor`, all clamped to [0, 1]; α = r², Phong exponent n = 2/α² − 2 clamped to
//! [1, 10⁶], the usual Blinn-Phong ↔ GGX correspondence; ks = mix(0.04, base, m), kd = base·(1 − m)):
//!
//! | glTF material                                     | material                                       |
//! |---------------------------------------------------|------------------------------------------------|
//! | `KHR_materials_transmission` factor > 0.5         | smooth dielectric, index `KHR_materials_ior` (default 1.5), tint base |
//! | `metallicRoughnessTexture` (TEXCOORD_0)           | always `kd` Lambertian + normalised Phong `ks`, exponent n: per hit the rows below for the texel's m and r, but of the glossy kind at every texel (see below) |
//! | m ≤ 0.05 and r ≥ 0.9 (rough dielectric)           | Lambertian base                                |
//! | n(r) reaches 10⁶ (r ≲ 0.038: smooth)              | `kd` Lambertian + perfect mirror `ks` (m = 1, r = 0: mirror of reflectance base) |
//! | otherwise                                         | `kd` Lambertian + normalised Phong `ks`, exponent n(r) |
//! | `emissiveFactor` × `KHR_materials_emissive_strength` > 0 | area light of that radiance, front side only |
//! | primitive without a material                      | 0.5 grey Lambertian                            |
//!
//! `kd + ks` is scaled down to 1 where it exceeds it (a white non-metal gives 1 + 0.04): the additive
//! model has no Fresnel weighting, so this is part of the mapping and not reported. A Lambertian of
//! albedo 0 becomes black. The base-colour texture (TEXCOORD_0, the sampler's wrap modes,
//! `KHR_texture_transform`) multiplies the Lambertian albedo at each hit (the material's own `kd`,
//! which holds `baseColorFactor`, times the sRGB-decoded texel). The emissive texture likewise
//! multiplies the emitted radiance (`emissiveFactor` × strength) at each hit and at each light
//! sample's point.
//!
//! The metallic-roughness texture (TEXCOORD_0, its sampler's wrap modes, `KHR_texture_transform`;
//! read as stored, linear, never sRGB-decoded) gives at each hit r = `roughnessFactor` × G and
//! m = `metallicFactor` × B (R and A are not read), and the material's model is rebuilt there by
//! the formulas above ([`pbr_lobes`]) from those and base = `baseColorFactor` × the base-colour
//! texel (so with this texture the base colour reaches `ks` too). The material's kind is decided
//! once, from the range the texture can produce: always glossy, because the kernel's effects (and
//! `--explain`) follow the kinds, and a texel must never make a material a kind they do not
//! cover. A texel in the Lambertian corner gives `ks` = 0 (it scatters exactly as the Lambertian
//! model), a texel at the mirror limit the Phong lobe of exponent 10⁶ (f cos/pdf → ks, within about
//! a milliradian of the mirror direction), never a Dirac mirror. In flatland the lobe's
//! normalisation for a texel's exponent is computed per hit, in closed form
//! ([`PhongLobe::at`](crate::scene::flat::PhongLobe::at)). On a transmissive material the texture
//! has nothing to act on and is ignored with a warning. Normal, occlusion and transmission
//! textures are ignored with one warning per file, their factors are used; `doubleSided` (opaque
//! surfaces are two-sided anyway) and other extensions are ignored.
//! `alphaMode` `MASK` makes a cut-out where the base colour's alpha (factor × texel) is below
//! `alphaCutoff` (default 0.5); `BLEND` makes a stochastic cut-out, present with probability α
//! (exact where α is 0 or 1, and unbiased between); both are seen by every ray.
//!
//! Lights (`KHR_lights_punctual`): a point light becomes an isotropic point light at the node's world
//! position with intensity `color × intensity`. glTF gives that intensity in candela (lm/sr); it is
//! used as is as radiant intensity in scene units (per steradian), with no photometric conversion,
//! and `range` is ignored. Spot lights keep their cone and glTF's smooth falloff between the inner
//! and outer angle. A directional light becomes a sun without a disc (a Dirac delta in direction,
//! as glTF defines it): its intensity, in lux, is used as the irradiance.
//!
//! Cameras: perspective cameras become [`Camera`]s (eye at the node's world origin, looking along its
//! world −Z with world +Y up, `yfov`, `aspectRatio`); orthographic ones are skipped with a warning.

use crate::math::Rgb;
use crate::scene::files::percent_decode;
use crate::scene::light::Light;
use crate::scene::material::Bsdf;
use crate::scene::material::Material;
use crate::scene::material::{Alpha, AlphaMode, MetallicRoughness, TextureRef};
use crate::scene::model::{Camera, LoadReport, Scene};
use crate::scene::pbr::is_lambertian;
pub use crate::scene::pbr::{MAX_PHONG_EXPONENT, pbr_lobes, phong_exponent};
use crate::scene::texture::{Encoding, Texture, TextureSet, UvTransform, Wrap};
use ::gltf::accessor::{DataType, Dimensions};
use ::gltf::khr_lights_punctual::Kind as LightKind;
use ::gltf::mesh::{Mode, Semantic};
use anyhow::{Context, anyhow, bail};
use base64::Engine as _;
use glam::Vec2;
use glam::{DMat3, DMat4, DQuat, DVec3, Vec3};
use rayon::prelude::*;
use std::collections::HashMap;
use std::path::Path;

/// Bytes an accessor without a buffer view (all zeros, maybe sparse) may expand to.
const MAX_IMPLICIT_ACCESSOR_BYTES: usize = 1 << 30;

/// `asset.version` of a JSON glTF document, if it is JSON and says.
fn json_version(bytes: &[u8]) -> Option<String> {
    let v: ::gltf::json::Value = ::gltf::json::deserialize::from_slice(bytes).ok()?;
    Some(v.get("asset")?.get("version")?.as_str()?.to_string())
}

/// Loads a `.gltf` or `.glb` file (and the buffers it names) into a [`Scene`].
pub fn load(path: &Path) -> anyhow::Result<Scene> {
    let file = path.display().to_string();
    if !path.is_file() {
        bail!("{file}: no such scene file");
    }
    let bytes = std::fs::read(path).with_context(|| format!("{file}: cannot read"))?;
    check_glb_header(&bytes).map_err(|e| anyhow!("{file}: {e}"))?;
    let invalid = |e: &dyn std::fmt::Display| anyhow!("{file}: not a valid glTF 2.0 file: {e}");
    let ::gltf::Gltf { document, blob } = ::gltf::Gltf::from_slice_without_validation(&bytes)
        .map_err(|e| match json_version(&bytes) {
            // glTF 1.0 documents are JSON too, but of another schema: say so, not which field
            // failed to parse.
            Some(v) if !v.starts_with('2') => {
                anyhow!("{file}: glTF version {v}; only version 2 is supported")
            }
            _ => invalid(&e),
        })?;
    drop(bytes);
    let root = document.into_json();
    check_attribute_indices(&root).map_err(|e| invalid(&e))?;
    let doc = ::gltf::Document::from_json(root).map_err(|e| invalid(&e))?;
    let buffers = load_buffers(path, &doc, blob)?;

    let mut loader = Loader {
        file: file.clone(),
        buffers,
        report: LoadReport::default(),
        materials: Vec::new(),
        default_material: 0,
        meshes: HashMap::new(),
        positions: Vec::new(),
        normals: Vec::new(),
        any_normals: false,
        uvs: Vec::new(),
        texture_requests: Vec::new(),
        triangles: Vec::new(),
        tri_material: Vec::new(),
        points: Vec::new(),
        others: Vec::new(),
        cameras: Vec::new(),
    };
    loader.convert_materials(&doc);
    loader.walk(&doc)?;
    let Loader {
        mut report,
        mut materials,
        positions,
        normals,
        any_normals,
        uvs,
        texture_requests,
        buffers,
        triangles,
        tri_material,
        points,
        others,
        cameras,
        ..
    } = loader;
    // Textures: each image decoded once per encoding (in parallel), the materials pointing at
    // them.
    let textures = if texture_requests.is_empty() {
        TextureSet::default()
    } else {
        let images: Vec<(usize, Encoding)> = {
            let mut v: Vec<_> = texture_requests
                .iter()
                .map(|r| (r.1, r.4.encoding()))
                .collect();
            v.sort_unstable_by_key(|&(i, e)| (i, e == Encoding::Linear));
            v.dedup();
            v
        };
        let decoded = images
            .par_iter()
            .map(|&(i, e)| decode_image(&doc, i, e, &buffers, path))
            .collect::<anyhow::Result<Vec<_>>>()?;
        // Materials whose whole glossy model is rebuilt per hit: their base-colour texture
        // multiplies `baseColorFactor` (not the Lambertian albedo).
        let mut per_hit = vec![false; materials.len()];
        for r in &texture_requests {
            per_hit[r.0] |= r.4 == Slot::MetallicRoughness;
        }
        for (m, image, wrap, transform, slot) in texture_requests {
            let key = (image, slot.encoding());
            let texture = TextureRef {
                texture: images.iter().position(|k| *k == key).unwrap_or(0) as u32,
                factor: Rgb::ONE,
                wrap,
                transform,
            };
            match slot {
                Slot::Emissive => {
                    // The texel times `emissiveFactor` (the material's emission, which lights
                    // use).
                    materials[m].maps.emission = Some(texture);
                    continue;
                }
                Slot::MetallicRoughness => {
                    let Some(gm) = doc.materials().nth(m) else {
                        continue;
                    };
                    let (base, metallic, roughness) = pbr_params(&gm).0.unit();
                    let mr = MetallicRoughness {
                        map: texture,
                        metallic,
                        roughness,
                        base,
                    };
                    // Its own model: the factors alone (a white texel), of the kind every texel
                    // gives.
                    materials[m].bsdf = mr.bsdf(base, [1.0; 4]);
                    materials[m].maps.metallic_roughness = Some(mr);
                    continue;
                }
                Slot::BaseColour => {}
            }
            // The base colour's alpha channel is the coverage of a cut-out.
            if let Some(alpha) = materials[m].maps.alpha.as_mut() {
                alpha.map = Some(texture.clone());
            }
            let factor = if per_hit[m] {
                let Some(gm) = doc.materials().nth(m) else {
                    continue;
                };
                pbr_params(&gm).0.unit().0
            } else {
                match &materials[m].bsdf {
                    Bsdf::Diffuse { kd } | Bsdf::Glossy { kd, .. } | Bsdf::Mirror { kd, .. } => *kd,
                    _ => continue,
                }
            };
            materials[m].maps.base_color = Some(TextureRef { factor, ..texture });
        }
        let set = TextureSet {
            textures: decoded.into_iter().map(std::sync::Arc::new).collect(),
        };
        report.texture_bytes = set.bytes();
        set
    };
    let normals = if any_normals { normals } else { Vec::new() };
    let n_triangles = triangles.len();
    let mut scene = Scene::build(
        path,
        positions,
        normals,
        triangles,
        tri_material,
        materials,
        report,
    )
    .with_context(|| format!("{file}: building the scene"))?;
    // As the OBJ loader: a scene without triangles has nothing to deflect light, and no bounds to
    // place a slice or a camera's run lengths in.
    if scene.triangles.is_empty() {
        if n_triangles == 0 {
            bail!(
                "{file}: no geometry: the scene's nodes reference no triangles (primitives of \
                 mode TRIANGLES, TRIANGLE_STRIP or TRIANGLE_FAN)"
            );
        }
        bail!(
            "{file}: no geometry: all {n_triangles} triangles are degenerate (zero area or \
             non-finite coordinates)"
        );
    }
    scene.set_textures(uvs, textures);
    scene.cameras = cameras;
    for (position, intensity) in points {
        scene.add_point_light(position, intensity);
    }
    for light in others {
        scene.add_light(light);
    }
    Ok(scene)
}

/// A material's texture: (material, image, wrap modes, transform, which map it fills).
type TextureRequest = (usize, usize, (Wrap, Wrap), UvTransform, Slot);

/// Which map a texture request fills.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Slot {
    BaseColour,
    Emissive,
    MetallicRoughness,
}

impl Slot {
    /// Colour textures are sRGB-encoded; the metallic-roughness texture holds data, read as
    /// stored (glTF's rule).
    fn encoding(self) -> Encoding {
        match self {
            Slot::BaseColour | Slot::Emissive => Encoding::Colour,
            Slot::MetallicRoughness => Encoding::Linear,
        }
    }
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
) -> anyhow::Result<Texture> {
    let file = path.display();
    let image = doc
        .images()
        .nth(index)
        .ok_or_else(|| anyhow!("{file}: image #{index} does not exist"))?;
    let label = named("image", index, image.name());
    match image.source() {
        ::gltf::image::Source::Uri { uri, .. } if uri.starts_with("data:") => {
            let bytes = decode_data_uri(uri).map_err(|e| anyhow!("{file}: {label}: {e}"))?;
            Texture::from_bytes(&bytes, &format!("{file}: {label}"), encoding)
        }
        ::gltf::image::Source::Uri { uri, .. } => {
            Texture::load(&path.parent().unwrap_or(Path::new(".")).join(uri), encoding)
                .with_context(|| format!("{file}: {label}"))
        }
        ::gltf::image::Source::View { view, .. } => {
            let bytes = view_bytes(&view, buffers).map_err(|e| anyhow!("{file}: {label}: {e}"))?;
            Texture::from_bytes(bytes, &format!("{file}: {label}"), encoding)
        }
    }
}

/// Checks a binary glTF's header and chunk lengths against the file size, so that a truncated file
/// gets a clear message (and never reaches the parser with inconsistent lengths).
fn check_glb_header(bytes: &[u8]) -> Result<(), String> {
    if !bytes.starts_with(b"glTF") {
        return Ok(());
    }
    let u32_at = |o: usize| {
        bytes
            .get(o..o + 4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize)
    };
    let (Some(version), Some(length)) = (u32_at(4), u32_at(8)) else {
        return Err(format!(
            "truncated .glb: {} bytes, shorter than the 12-byte header",
            bytes.len()
        ));
    };
    if version != 2 {
        return Err(format!(
            "binary glTF version {version}; only version 2 is supported"
        ));
    }
    if length > bytes.len() {
        return Err(format!(
            "truncated .glb: the header declares {length} bytes, the file has {}",
            bytes.len()
        ));
    }
    let Some(json_len) = u32_at(12) else {
        return Err(format!(
            "truncated .glb: {} bytes, no JSON chunk header",
            bytes.len()
        ));
    };
    if 20 + json_len > length {
        return Err(format!(
            "truncated .glb: the JSON chunk of {json_len} bytes runs past the declared end ({length} bytes)"
        ));
    }
    let bin_at = 20 + json_len;
    if bin_at < length {
        let Some(bin_len) = u32_at(bin_at) else {
            return Err(format!(
                "truncated .glb: the chunk header at byte {bin_at} is cut off"
            ));
        };
        if bin_at + 8 + bin_len > length {
            return Err(format!(
                "truncated .glb: the binary chunk of {bin_len} bytes runs past the declared end ({length} bytes)"
            ));
        }
    }
    Ok(())
}

/// Checks that every primitive attribute names an existing accessor. The crate's validation looks
/// up the POSITION accessor before checking its index (and panics on a bad one), so this runs first.
fn check_attribute_indices(root: &::gltf::json::Root) -> Result<(), String> {
    for (i, mesh) in root.meshes.iter().enumerate() {
        for (j, prim) in mesh.primitives.iter().enumerate() {
            for index in prim.attributes.values() {
                if index.value() >= root.accessors.len() {
                    return Err(format!(
                        "meshes[{i}].primitives[{j}].attributes: accessor {} does not exist ({} accessors)",
                        index.value(),
                        root.accessors.len()
                    ));
                }
            }
        }
    }
    Ok(())
}

/// Reads every buffer: the GLB binary chunk, a base64 data URI, or a file relative to the glTF file.
fn load_buffers(
    path: &Path,
    doc: &::gltf::Document,
    mut blob: Option<Vec<u8>>,
) -> anyhow::Result<Vec<Vec<u8>>> {
    let file = path.display();
    let dir = path.parent().unwrap_or(Path::new(""));
    let mut out = Vec::new();
    for buffer in doc.buffers() {
        let label = named("buffer", buffer.index(), buffer.name());
        let mut data = match buffer.source() {
            ::gltf::buffer::Source::Bin => blob.take().ok_or_else(|| {
                anyhow!(
                    "{file}: {label} has no URI and there is no (unused) GLB binary chunk to take its data from"
                )
            })?,
            ::gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => {
                decode_data_uri(uri).map_err(|e| anyhow!("{file}: {label}: {e}"))?
            }
            ::gltf::buffer::Source::Uri(uri) => {
                let target = dir.join(percent_decode(uri));
                // Only regular files: /dev/zero or a FIFO would never end.
                if target.exists() && !target.is_file() {
                    bail!(
                        "{file}: {label}: '{uri}' ({}) is not a regular file",
                        target.display()
                    );
                }
                std::fs::read(&target).map_err(|e| {
                    anyhow!(
                        "{file}: {label}: cannot read '{uri}' ({}): {e}",
                        target.display()
                    )
                })?
            }
        };
        if data.len() < buffer.length() {
            bail!(
                "{file}: {label}: {} bytes of data, but the file declares a byteLength of {}",
                data.len(),
                buffer.length()
            );
        }
        data.truncate(buffer.length());
        out.push(data);
    }
    Ok(out)
}

/// Decodes `data:[<media type>];base64,<data>`.
fn decode_data_uri(uri: &str) -> Result<Vec<u8>, String> {
    let Some((header, payload)) = uri.split_once(',') else {
        return Err("malformed data URI (no ',')".into());
    };
    if !header.ends_with(";base64") {
        return Err("data URI is not base64-encoded".into());
    }
    base64::engine::general_purpose::STANDARD_PAD_INDIFFERENT
        .decode(payload.trim())
        .map_err(|e| format!("invalid base64 in data URI: {e}"))
}

/// `kind 'name'` when the object has a non-empty name, `kind #index` otherwise.
fn named(kind: &str, index: usize, name: Option<&str>) -> String {
    match name {
        Some(n) if !n.is_empty() => format!("{kind} '{n}'"),
        _ => format!("{kind} #{index}"),
    }
}

/// One triangle primitive in its mesh's local frame.
struct LocalPrimitive {
    positions: Vec<Vec3>,
    normals: Option<Vec<Vec3>>,
    /// TEXCOORD_0 with v turned up (glTF's v points down).
    uvs: Option<Vec<Vec2>>,
    triangles: Vec<[u32; 3]>,
    material: u32,
}

struct Loader {
    file: String,
    buffers: Vec<Vec<u8>>,
    report: LoadReport,
    materials: Vec<Material>,
    default_material: u32,
    /// Each mesh's triangle primitives, decoded on first use.
    meshes: HashMap<usize, Vec<LocalPrimitive>>,
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    any_normals: bool,
    /// Texture coordinates per vertex (zero where a primitive has none).
    uvs: Vec<Vec2>,
    /// Base-colour textures: (material, image index, sampler wrap, transform).
    texture_requests: Vec<TextureRequest>,
    triangles: Vec<[u32; 3]>,
    tri_material: Vec<u32>,
    /// Point lights: world position and intensity.
    points: Vec<(DVec3, Rgb)>,
    /// Spot and directional lights.
    others: Vec<Light>,
    cameras: Vec<Camera>,
}

impl Loader {
    fn warn(&mut self, s: String) {
        self.report.warnings.push(format!("{}: {s}", self.file));
    }

    fn convert_materials(&mut self, doc: &::gltf::Document) {
        let mut textured = Vec::new();
        for m in doc.materials() {
            let label = named("material", m.index().unwrap_or(0), m.name());
            let (material, warnings) = convert_material(&m, &label);
            for w in warnings {
                self.warn(format!("{label}: {w}"));
            }
            let base = m.pbr_metallic_roughness().base_color_texture();
            let emissive = m.emissive_texture();
            let mut metallic_roughness = m.pbr_metallic_roughness().metallic_roughness_texture();
            // A smooth dielectric has no metallic or roughness to read.
            if metallic_roughness.is_some() && matches!(material.bsdf, Bsdf::Dielectric { .. }) {
                self.warn(format!(
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
                if info.tex_coord() != 0 {
                    self.warn(format!(
                        "{label}: {what} texture on TEXCOORD_{}; only TEXCOORD_0 is read",
                        info.tex_coord()
                    ));
                } else {
                    self.texture_requests.push((
                        self.materials.len(),
                        info.texture().source().index(),
                        (wrap(sampler.wrap_s()), wrap(sampler.wrap_t())),
                        transform,
                        slot,
                    ));
                }
            }
            // Normal, occlusion and transmission textures are not read.
            if other_textures(&m) {
                textured.push(label);
            }
            self.materials.push(material);
        }
        if let Some(first) = textured.first() {
            let w = format!(
                "normal, occlusion and transmission textures are ignored ({} material(s) use them, first {first}); their constant factors are used",
                textured.len()
            );
            self.warn(w);
        }
        self.default_material = self.materials.len() as u32;
        self.materials.push(Material::default_grey());
    }

    /// Visits the default scene's node trees (or the first scene's, or every root node when the file
    /// defines no scene), accumulating world-space geometry, lights and cameras.
    fn walk(&mut self, doc: &::gltf::Document) -> anyhow::Result<()> {
        let roots: Vec<::gltf::Node> = match doc.default_scene().or_else(|| doc.scenes().next()) {
            Some(scene) => {
                if doc.default_scene().is_none() && doc.scenes().len() > 1 {
                    let w = format!(
                        "{} scenes and no default one; loading the first",
                        doc.scenes().len()
                    );
                    self.warn(w);
                }
                scene.nodes().collect()
            }
            None => {
                let mut is_child = vec![false; doc.nodes().len()];
                for n in doc.nodes() {
                    for c in n.children() {
                        is_child[c.index()] = true;
                    }
                }
                let roots: Vec<_> = doc.nodes().filter(|n| !is_child[n.index()]).collect();
                if !roots.is_empty() {
                    self.warn("no scene defined; loading every root node".into());
                }
                roots
            }
        };
        let mut seen = vec![false; doc.nodes().len()];
        let mut stack: Vec<(::gltf::Node, DMat4)> = roots
            .into_iter()
            .rev()
            .map(|n| (n, DMat4::IDENTITY))
            .collect();
        while let Some((node, parent)) = stack.pop() {
            let label = named("node", node.index(), node.name());
            if std::mem::replace(&mut seen[node.index()], true) {
                self.warn(format!(
                    "{label} is reached more than once (the node hierarchy must be a forest); skipped"
                ));
                continue;
            }
            let world = parent * local_matrix(node.transform());
            if !world.is_finite() {
                bail!("{}: {label}: non-finite transform", self.file);
            }
            if let Some(mesh) = node.mesh() {
                if node.skin().is_some() {
                    self.warn(format!(
                        "{label}: skin ignored; the mesh is placed by the node's transform"
                    ));
                }
                self.instance(&mesh, world)?;
            }
            if let Some(camera) = node.camera() {
                self.camera(doc, &camera, &node, world)?;
            }
            if let Some(light) = node.light() {
                self.light(&light, world);
            }
            let children: Vec<_> = node.children().collect();
            stack.extend(children.into_iter().rev().map(|c| (c, world)));
        }
        Ok(())
    }

    /// Appends a copy of `mesh`'s triangle primitives transformed by `world`.
    fn instance(&mut self, mesh: &::gltf::Mesh, world: DMat4) -> anyhow::Result<()> {
        if !self.meshes.contains_key(&mesh.index()) {
            let decoded = self.decode_mesh(mesh)?;
            self.meshes.insert(mesh.index(), decoded);
        }
        let linear = DMat3::from_mat4(world);
        let det = linear.determinant();
        let normal_matrix = (det != 0.0 && det.is_finite()).then(|| linear.inverse().transpose());
        let flip = det < 0.0;
        let prims = &self.meshes[&mesh.index()];
        for prim in prims {
            let base = self.positions.len();
            if base as u64 + prim.positions.len() as u64 >= u32::MAX as u64 {
                bail!("{}: more than 2^32 vertices", self.file);
            }
            self.positions.extend(
                prim.positions
                    .iter()
                    .map(|p| world.transform_point3(p.as_dvec3()).as_vec3()),
            );
            match (&prim.normals, normal_matrix) {
                (Some(ns), Some(nm)) => {
                    self.any_normals = true;
                    self.normals.extend(ns.iter().map(|n| {
                        let w = nm * n.as_dvec3();
                        let len = w.length();
                        if len > 0.0 && len.is_finite() {
                            (w / len).as_vec3()
                        } else {
                            Vec3::ZERO
                        }
                    }));
                }
                // Zero normals fall back to the geometric normal.
                _ => self
                    .normals
                    .extend(std::iter::repeat_n(Vec3::ZERO, prim.positions.len())),
            }
            match &prim.uvs {
                Some(uv) => self.uvs.extend_from_slice(uv),
                None => self
                    .uvs
                    .extend(std::iter::repeat_n(Vec2::ZERO, prim.positions.len())),
            }
            let base = base as u32;
            self.triangles
                .extend(prim.triangles.iter().map(|&[a, b, c]| {
                    if flip {
                        [a + base, c + base, b + base]
                    } else {
                        [a + base, b + base, c + base]
                    }
                }));
            self.tri_material
                .extend(std::iter::repeat_n(prim.material, prim.triangles.len()));
        }
        Ok(())
    }

    /// Reads a mesh's triangle primitives (once per mesh, however many nodes use it).
    fn decode_mesh(&mut self, mesh: &::gltf::Mesh) -> anyhow::Result<Vec<LocalPrimitive>> {
        let mesh_label = named("mesh", mesh.index(), mesh.name());
        let mut out = Vec::new();
        for prim in mesh.primitives() {
            let label = format!("{mesh_label} primitive {}", prim.index());
            let mode = prim.mode();
            if !matches!(
                mode,
                Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
            ) {
                self.warn(format!(
                    "{label}: mode {} is not triangles; skipped",
                    mode_name(mode)
                ));
                continue;
            }
            if prim.morph_targets().len() > 0 {
                self.warn(format!("{label}: morph targets ignored (base shape used)"));
            }
            let decoded = self
                .decode_primitive(&prim, mode, &label)
                .map_err(|e| anyhow!("{}: {label}: {e}", self.file))?;
            out.push(decoded);
        }
        Ok(out)
    }

    fn decode_primitive(
        &mut self,
        prim: &::gltf::Primitive,
        mode: Mode,
        label: &str,
    ) -> Result<LocalPrimitive, String> {
        let pos_acc = prim
            .get(&Semantic::Positions)
            .ok_or("no POSITION attribute")?;
        let positions = read_vec3_f32(&pos_acc, &self.buffers, "POSITION")?;
        let n = positions.len();
        let normals = match prim.get(&Semantic::Normals) {
            Some(acc) => {
                let normals = read_vec3_f32(&acc, &self.buffers, "NORMAL")?;
                if normals.len() == n {
                    Some(normals)
                } else {
                    self.warn(format!(
                        "{label}: {} normals for {n} positions; normals ignored",
                        normals.len()
                    ));
                    None
                }
            }
            None => None,
        };
        let indices: Vec<u32> = match prim.indices() {
            Some(acc) => {
                let idx = read_indices(&acc, &self.buffers)?;
                if let Some((k, i)) = idx.iter().enumerate().find(|(_, i)| **i as usize >= n) {
                    return Err(format!(
                        "index {i} (entry {k} of accessor #{}) is outside the {n} vertices",
                        acc.index()
                    ));
                }
                idx
            }
            None => (0..n as u32).collect(),
        };
        let triangles: Vec<[u32; 3]> = match mode {
            Mode::Triangles => {
                if !indices.len().is_multiple_of(3) {
                    self.warn(format!(
                        "{label}: {} vertices is not a multiple of 3; the last {} ignored",
                        indices.len(),
                        indices.len() % 3
                    ));
                }
                indices
                    .chunks_exact(3)
                    .map(|t| [t[0], t[1], t[2]])
                    .collect()
            }
            // p_i = {v_i, v_{i+1+i%2}, v_{i+2-i%2}}: every other triangle swapped to keep the winding.
            Mode::TriangleStrip => (0..indices.len().saturating_sub(2))
                .map(|i| {
                    let odd = i % 2;
                    [indices[i], indices[i + 1 + odd], indices[i + 2 - odd]]
                })
                .collect(),
            // p_i = {v_{i+1}, v_{i+2}, v_0}.
            Mode::TriangleFan => (0..indices.len().saturating_sub(2))
                .map(|i| [indices[i + 1], indices[i + 2], indices[0]])
                .collect(),
            _ => unreachable!("non-triangle modes are skipped by the caller"),
        };
        let material = prim
            .material()
            .index()
            .map_or(self.default_material, |i| i as u32);
        let uvs = match prim.get(&Semantic::TexCoords(0)) {
            Some(acc)
                if acc.dimensions() == Dimensions::Vec2 && acc.data_type() == DataType::F32 =>
            {
                let raw = accessor_bytes(&acc, &self.buffers)?;
                let f = |b: &[u8]| f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
                let uv: Vec<Vec2> = raw
                    .chunks_exact(8)
                    .map(|c| Vec2::new(f(&c[0..4]), 1.0 - f(&c[4..8])))
                    .collect();
                (uv.len() == n).then_some(uv)
            }
            Some(acc) => {
                self.warn(format!(
                    "{label}: TEXCOORD_0 accessor #{} is {} {}, not VEC2 f32; textures ignored on it",
                    acc.index(),
                    dims_name(acc.dimensions()),
                    type_name(acc.data_type())
                ));
                None
            }
            None => None,
        };
        Ok(LocalPrimitive {
            positions,
            normals,
            uvs,
            triangles,
            material,
        })
    }

    fn camera(
        &mut self,
        doc: &::gltf::Document,
        camera: &::gltf::Camera,
        node: &::gltf::Node,
        world: DMat4,
    ) -> anyhow::Result<()> {
        let label = named("camera", camera.index(), camera.name());
        // The crate's validation only asks for one of the two blocks; `projection()` unwraps the
        // one that `type` names.
        {
            use ::gltf::json::camera::Type;
            use ::gltf::json::validation::Checked;
            let json = &doc.as_json().cameras[camera.index()];
            let consistent = match json.type_ {
                Checked::Valid(Type::Perspective) => json.perspective.is_some(),
                Checked::Valid(Type::Orthographic) => json.orthographic.is_some(),
                Checked::Invalid => false,
            };
            if !consistent {
                bail!(
                    "{}: {label}: its type has no matching 'perspective' or 'orthographic' block",
                    self.file
                );
            }
        }
        let name = camera
            .name()
            .or(node.name())
            .filter(|n| !n.is_empty())
            .map_or_else(|| format!("camera {}", camera.index()), str::to_string);
        match camera.projection() {
            ::gltf::camera::Projection::Perspective(p) => {
                let eye = world.transform_point3(DVec3::ZERO);
                let forward = world.transform_vector3(-DVec3::Z).normalize_or_zero();
                let up0 = world.transform_vector3(DVec3::Y);
                let up = (up0 - forward * up0.dot(forward)).normalize_or_zero();
                let fov_y = p.yfov() as f64;
                if forward == DVec3::ZERO || up == DVec3::ZERO {
                    self.warn(format!(
                        "{label}: degenerate node transform (no view or up direction); skipped"
                    ));
                    return Ok(());
                }
                if !(fov_y > 0.0 && fov_y < std::f64::consts::PI) {
                    self.warn(format!("{label}: yfov {fov_y} is not in (0, π); skipped"));
                    return Ok(());
                }
                let aspect = p
                    .aspect_ratio()
                    .map(|a| a as f64)
                    .filter(|a| *a > 0.0 && a.is_finite());
                self.cameras.push(Camera {
                    name,
                    eye,
                    forward,
                    up,
                    fov_y,
                    aspect,
                });
            }
            ::gltf::camera::Projection::Orthographic(_) => {
                self.warn(format!(
                    "{label}: orthographic cameras are not supported; skipped"
                ));
            }
        }
        Ok(())
    }

    fn light(&mut self, light: &::gltf::khr_lights_punctual::Light, world: DMat4) {
        let label = named("light", light.index(), light.name());
        let [r, g, b] = light.color();
        let intensity =
            (Rgb::new(r as f64, g as f64, b as f64) * light.intensity() as f64).max(Rgb::ZERO);
        let position = world.transform_point3(DVec3::ZERO);
        // Spots and directional lights shine along the node's local −Z.
        let axis = world.transform_vector3(DVec3::NEG_Z).try_normalize();
        match (light.kind(), axis) {
            (LightKind::Point, _) => self.points.push((position, intensity)),
            (
                LightKind::Spot {
                    inner_cone_angle,
                    outer_cone_angle,
                },
                Some(direction),
            ) => self.others.push(Light::Spot {
                position,
                direction,
                intensity,
                cos_inner: (inner_cone_angle as f64).cos(),
                cos_outer: (outer_cone_angle as f64).cos(),
            }),
            // glTF gives a directional light's intensity in lux: used as the irradiance, with no
            // photometric conversion, and as a Dirac delta (glTF's lights have no extent).
            (LightKind::Directional, Some(direction)) => {
                self.others.push(Light::distant(-direction, intensity, 0.0))
            }
            (_, None) => self.warn(format!(
                "{label}: degenerate node transform (no direction); skipped"
            )),
        }
    }
}

fn mode_name(mode: Mode) -> &'static str {
    match mode {
        Mode::Points => "POINTS",
        Mode::Lines => "LINES",
        Mode::LineLoop => "LINE_LOOP",
        Mode::LineStrip => "LINE_STRIP",
        Mode::Triangles => "TRIANGLES",
        Mode::TriangleStrip => "TRIANGLE_STRIP",
        Mode::TriangleFan => "TRIANGLE_FAN",
    }
}

fn dims_name(d: Dimensions) -> &'static str {
    match d {
        Dimensions::Scalar => "SCALAR",
        Dimensions::Vec2 => "VEC2",
        Dimensions::Vec3 => "VEC3",
        Dimensions::Vec4 => "VEC4",
        Dimensions::Mat2 => "MAT2",
        Dimensions::Mat3 => "MAT3",
        Dimensions::Mat4 => "MAT4",
    }
}

fn type_name(t: DataType) -> &'static str {
    match t {
        DataType::I8 => "i8",
        DataType::U8 => "u8",
        DataType::I16 => "i16",
        DataType::U16 => "u16",
        DataType::U32 => "u32",
        DataType::F32 => "f32",
    }
}

/// A node's local transform in f64 (the matrix, or translation · rotation · scale).
fn local_matrix(t: ::gltf::scene::Transform) -> DMat4 {
    match t {
        ::gltf::scene::Transform::Matrix { matrix } => {
            DMat4::from_cols_array_2d(&matrix.map(|c| c.map(f64::from)))
        }
        ::gltf::scene::Transform::Decomposed {
            translation,
            rotation,
            scale,
        } => {
            let [x, y, z, w] = rotation.map(f64::from);
            let q = DQuat::from_xyzw(x, y, z, w);
            let q = if q.length() > 0.0 {
                q.normalize()
            } else {
                DQuat::IDENTITY
            };
            DMat4::from_scale_rotation_translation(
                DVec3::from(scale.map(f64::from)),
                q,
                DVec3::from(translation.map(f64::from)),
            )
        }
    }
}

/// The bytes of `view` within its buffer.
fn view_bytes<'b>(view: &::gltf::buffer::View, buffers: &'b [Vec<u8>]) -> Result<&'b [u8], String> {
    let buffer = &buffers[view.buffer().index()];
    view.offset()
        .checked_add(view.length())
        .and_then(|end| buffer.get(view.offset()..end))
        .ok_or_else(|| {
            format!(
                "buffer view #{} (bytes {}..{}) runs past the end of buffer #{} ({} bytes)",
                view.index(),
                view.offset(),
                view.offset() as u128 + view.length() as u128,
                view.buffer().index(),
                buffer.len()
            )
        })
}

/// Each element of `acc`, tightly packed (`acc.size()` bytes each), with the buffer view's stride and
/// sparse substitution resolved. Every range is checked: a bad file gives an error, never a panic.
fn accessor_bytes(acc: &::gltf::Accessor, buffers: &[Vec<u8>]) -> Result<Vec<u8>, String> {
    let elem = acc.size();
    let count = acc.count();
    let total = count
        .checked_mul(elem)
        .ok_or_else(|| format!("accessor #{}: count {count} is too large", acc.index()))?;
    let mut out = match acc.view() {
        Some(view) => {
            let data = view_bytes(&view, buffers)?;
            let stride = view.stride().unwrap_or(elem);
            if stride < elem {
                return Err(format!(
                    "accessor #{}: byteStride {stride} is smaller than its element size {elem}",
                    acc.index()
                ));
            }
            let start = acc.offset();
            let fits = count == 0
                || (count - 1)
                    .checked_mul(stride)
                    .and_then(|x| x.checked_add(start))
                    .and_then(|x| x.checked_add(elem))
                    .is_some_and(|end| end <= data.len());
            if !fits {
                return Err(format!(
                    "accessor #{}: {count} elements of {elem} bytes (stride {stride}) from offset {start} run past the end of buffer view #{} ({} bytes)",
                    acc.index(),
                    view.index(),
                    data.len()
                ));
            }
            let mut out = Vec::with_capacity(total);
            for k in 0..count {
                let s = start + k * stride;
                out.extend_from_slice(&data[s..s + elem]);
            }
            out
        }
        None => {
            if total > MAX_IMPLICIT_ACCESSOR_BYTES {
                return Err(format!(
                    "accessor #{}: {count} elements without a buffer view",
                    acc.index()
                ));
            }
            vec![0; total]
        }
    };
    if let Some(sparse) = acc.sparse() {
        let n = sparse.count();
        let indices = sparse.indices();
        let index_size = match indices.index_type() {
            ::gltf::accessor::sparse::IndexType::U8 => 1,
            ::gltf::accessor::sparse::IndexType::U16 => 2,
            ::gltf::accessor::sparse::IndexType::U32 => 4,
        };
        let idata = view_bytes(&indices.view(), buffers)?;
        let values = sparse.values();
        let vdata = view_bytes(&values.view(), buffers)?;
        let range = |offset: usize, size: usize, data: &[u8]| {
            n.checked_mul(size)
                .and_then(|len| offset.checked_add(len))
                .filter(|end| *end <= data.len())
                .is_some()
        };
        if !range(indices.offset(), index_size, idata) || !range(values.offset(), elem, vdata) {
            return Err(format!(
                "accessor #{}: sparse indices or values run past the end of their buffer view",
                acc.index()
            ));
        }
        for k in 0..n {
            let b = &idata[indices.offset() + k * index_size..][..index_size];
            let i = match index_size {
                1 => b[0] as usize,
                2 => u16::from_le_bytes([b[0], b[1]]) as usize,
                _ => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize,
            };
            if i >= count {
                return Err(format!(
                    "accessor #{}: sparse index {i} is outside its {count} elements",
                    acc.index()
                ));
            }
            let v = &vdata[values.offset() + k * elem..][..elem];
            out[i * elem..(i + 1) * elem].copy_from_slice(v);
        }
    }
    Ok(out)
}

/// Reads a VEC3 f32 accessor (positions, normals).
fn read_vec3_f32(
    acc: &::gltf::Accessor,
    buffers: &[Vec<u8>],
    what: &str,
) -> Result<Vec<Vec3>, String> {
    if acc.dimensions() != Dimensions::Vec3 || acc.data_type() != DataType::F32 {
        return Err(format!(
            "{what} accessor #{} is not VEC3 f32 (it is {} {})",
            acc.index(),
            dims_name(acc.dimensions()),
            type_name(acc.data_type())
        ));
    }
    let raw = accessor_bytes(acc, buffers)?;
    let f = |b: &[u8]| f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
    Ok(raw
        .chunks_exact(12)
        .map(|c| Vec3::new(f(&c[0..4]), f(&c[4..8]), f(&c[8..12])))
        .collect())
}

/// Reads an index accessor (SCALAR, unsigned 8, 16 or 32 bits).
fn read_indices(acc: &::gltf::Accessor, buffers: &[Vec<u8>]) -> Result<Vec<u32>, String> {
    let t = acc.data_type();
    if acc.dimensions() != Dimensions::Scalar
        || !matches!(t, DataType::U8 | DataType::U16 | DataType::U32)
    {
        return Err(format!(
            "indices accessor #{} is not SCALAR u8, u16 or u32 (it is {} {})",
            acc.index(),
            dims_name(acc.dimensions()),
            type_name(t)
        ));
    }
    let raw = accessor_bytes(acc, buffers)?;
    Ok(match t {
        DataType::U8 => raw.iter().map(|&b| b as u32).collect(),
        DataType::U16 => raw
            .chunks_exact(2)
            .map(|b| u16::from_le_bytes([b[0], b[1]]) as u32)
            .collect(),
        _ => raw
            .chunks_exact(4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect(),
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
fn pbr_params(m: &::gltf::Material) -> (PbrParams, Vec<String>) {
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

    #[test]
    fn gltf_glb_header_checks() {
        assert!(check_glb_header(b"{\"asset\":{}}").is_ok());
        let e = check_glb_header(b"glTF\x02\x00\x00\x00").unwrap_err();
        assert!(e.contains("truncated"), "{e}");
        let mut glb = b"glTF".to_vec();
        glb.extend(2u32.to_le_bytes());
        glb.extend(100u32.to_le_bytes());
        let e = check_glb_header(&glb).unwrap_err();
        assert!(e.contains("declares 100 bytes"), "{e}");
    }
}
