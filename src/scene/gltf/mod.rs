//! glTF 2.0 loading (the `gltf` crate): `.gltf` with embedded (data-URI) or external buffers, and
//! `.glb`. The default scene (or the first one) is flattened: every node's world transform is applied
//! to its mesh's positions and normals (normals with the inverse transpose, renormalised; triangle
//! winding flipped where the transform mirrors), and a mesh used by several nodes is copied once per
//! node. A mesh placed by EXT_mesh_gpu_instancing is stored once, as a prototype, and placed by
//! Embree instances ([`crate::scene::instance`]; copied per instance when it emits, has alpha or
//! is a perfect mirror, or when [`load_within`] is told not to instance). TRIANGLES, TRIANGLE_STRIP and
//! TRIANGLE_FAN primitives are read, indexed or not; points and lines are skipped with a warning.
//! Vertex data may be quantized (KHR_mesh_quantization) or compressed (EXT_meshopt_compression
//! and KHR_meshopt_compression, KHR_draco_mesh_compression); a file that requires any other
//! extension is refused, naming it. Buffers are read by this module; images (base-colour,
//! emissive and metallic-roughness textures) are decoded by `crate::scene::texture`. File URIs
//! are percent-decoded and must lie in the glTF file's folder or below it unless the load's
//! reach allows more ([`Reach`]; one that leaves is an error naming it), and an image
//! that is missing, not a regular file or not decodable (KTX2 from `KHR_texture_basisu`, WebP,
//! AVIF) is a warning naming it and its materials, which keep their factors in that slot.
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
//! the run's list of them) follow the kinds, and a texel must never make a material a kind they
//! do not cover. A texel in the Lambertian corner gives `ks` = 0 (it scatters exactly as the Lambertian
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
//! Cameras: perspective cameras become [`Camera`](crate::scene::Camera)s (eye at the node's world origin, looking along its
//! world −Z with world +Y up, `yfov`, `aspectRatio`); orthographic ones are skipped with a warning.
//!
//! The reader's parts: `document` (the file, its buffers), `accessor` (typed views of buffer
//! data), `mesh` (triangle primitives), `material` (the mapping above), `textures` (images
//! and the materials' references to them), `nodes` (the node trees flattened into world space).
//! Extensions that change how vertex data is stored (compression, quantization) belong to
//! `accessor` and `mesh`, image formats to `textures`, instancing to `nodes`.

mod accessor;
mod document;
mod draco;
mod material;
mod mesh;
mod meshopt;
mod nodes;
mod textures;

pub use crate::scene::pbr::{MAX_PHONG_EXPONENT, pbr_lobes, phong_exponent};
pub use material::{PbrParams, map_pbr};

use crate::scene::error::LoadError;
use crate::scene::files::Reach;
use crate::scene::instance::{Instancing, instanceable};
use crate::scene::model::{LoadReport, Scene, Shading, TexCoords};
use document::Warnings;
use material::Converted;
use nodes::{Geometry, World};
use std::path::Path;

/// Loads a `.gltf` or `.glb` file (and the buffers and images it names) into a [`Scene`], with
/// EXT_mesh_gpu_instancing as instances.
pub fn load(path: &Path) -> Result<Scene, LoadError> {
    load_within(path, true, &Reach::of(path, false))
}

/// As [`load`]; with `instancing` false, EXT_mesh_gpu_instancing is flattened (one copy of the
/// mesh per instance) instead. Buffer and image URIs are read within `reach` (by default the
/// glTF file's folder): one that leaves it is a [`LoadError::Outside`].
pub fn load_within(path: &Path, instancing: bool, reach: &Reach) -> Result<Scene, LoadError> {
    let file = path.display().to_string();
    if let Some(kind) = crate::scene::files::not_regular(path) {
        return Err(LoadError::NotRegular {
            file: path.to_path_buf(),
            kind,
        });
    }
    if let Err(source) = std::fs::metadata(path) {
        return Err(LoadError::unopened(path, source));
    }
    let document::Read {
        doc,
        blob,
        ignored_extensions,
    } = document::read(path)?;
    nodes::check_lights(&doc)
        .and_then(|()| material::check_emission(&doc))
        .map_err(|e| document::malformed(path, e))?;
    let mut buffers = document::load_buffers(path, &doc, blob, reach)?;
    let doc = document::decode_compressed_views(path, doc, &mut buffers)?;
    let mut warnings = Warnings::new(&file);
    if !ignored_extensions.is_empty() {
        warnings.warn(format!(
            "extensions not supported, ignored: {}",
            ignored_extensions.join(", ")
        ));
    }
    let Converted {
        mut materials,
        default_material,
        requests,
    } = material::convert_materials(&doc, &mut warnings);
    let mut world = World::new(path, &buffers, default_material, warnings);
    if instancing {
        world.instancing = materials.iter().map(instanceable).collect();
    }
    world.walk(&doc)?;
    let World {
        warnings,
        mut geometry,
        proto_geometry,
        mut prototypes,
        instances,
        points,
        others,
        cameras,
        ..
    } = world;
    // The prototypes' triangles go after the world-space ones.
    let world_triangles = geometry.triangles.len() as u32;
    for p in &mut prototypes {
        p.triangles = p.triangles.start + world_triangles..p.triangles.end + world_triangles;
    }
    geometry.extend(proto_geometry);
    let Geometry {
        positions,
        normals,
        any_normals,
        uvs,
        triangles,
        tri_material,
    } = geometry;
    let mut report = LoadReport {
        warnings: warnings.list,
        ..Default::default()
    };
    let textures = textures::resolve(
        &doc,
        requests,
        &mut materials,
        &buffers,
        (path, reach),
        &mut report.warnings,
    )?;
    report.texture_bytes = textures.bytes();
    let normals = if any_normals { normals } else { Vec::new() };
    let n_triangles = triangles.len();
    let shading = if normals.len() == positions.len() && !normals.is_empty() {
        Shading::PerVertex(normals)
    } else {
        Shading::None
    };
    let mut scene = Scene::from_instanced_parts(
        path,
        positions,
        triangles,
        tri_material,
        shading,
        TexCoords::None,
        materials,
        report,
        Instancing {
            prototypes,
            instances,
        },
    )
    .map_err(|source| LoadError::Build {
        file: path.to_path_buf(),
        source,
    })?;
    // As the OBJ loader: a scene without triangles has nothing to deflect light, and no bounds to
    // place a slice or a camera's run lengths in.
    if scene.triangles.is_empty() {
        let what = if n_triangles == 0 {
            "the scene's nodes reference no triangles (primitives of mode TRIANGLES, \
             TRIANGLE_STRIP or TRIANGLE_FAN)"
                .to_string()
        } else {
            format!(
                "all {n_triangles} triangles are degenerate (zero area or non-finite coordinates)"
            )
        };
        return Err(LoadError::NoGeometry {
            file: path.to_path_buf(),
            what,
        });
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
