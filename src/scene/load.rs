//! Loading by file extension: `.obj`, `.gltf`/`.glb`, or a sidecar `.toml` naming a mesh plus
//! lights, cameras and named slices. The scene's [`Features`](crate::scene::Features) are computed
//! as lights come in, so a caller adds its own lights here, before anything reads them.

use crate::scene::error::LoadError;
use crate::scene::files::Reach;
pub use crate::scene::files::extension;
use crate::scene::light::Light;
use crate::scene::model::Scene;
use crate::scene::{gltf, obj, sidecar};
use std::path::Path;

/// How a scene file is read. The default is a tolerant load, as mainstream loaders read files.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LoadOptions {
    /// Strict loading: refuse, naming the file and line, what the OBJ reader otherwise goes on
    /// past with a warning (faces of fewer than 3 vertices, `usemtl` or `mtllib` without a name,
    /// statements it does not use, text that is not UTF-8).
    pub strict: bool,
    /// Flatten instanced glTF (EXT_mesh_gpu_instancing) into one copy of the mesh per instance
    /// instead of instances of one prototype ([`crate::scene::instance`]): the same field, at the
    /// memory of every copy. For comparisons and tests.
    pub flatten_instances: bool,
    /// Read files the scene names wherever they lie. By default a scene file reads only inside
    /// its own folder and the folders below it (buffer and image URIs, material libraries and
    /// their maps, a sidecar's mesh and environment map): a downloaded file must not make the
    /// tool read elsewhere ([`Reach`]); what leaves is a [`LoadError::Outside`].
    pub allow_outside_uris: bool,
    /// The scene file's own lights scaled by a factor (0: off), by name or `*` for all
    /// ([`crate::scene::dimmer`]); factors finite and ≥ 0.
    pub light_scale: Vec<(String, f64)>,
}

/// Loads a scene by its extension (see the module docs), tolerantly.
pub fn load_scene(path: &Path) -> Result<Scene, LoadError> {
    load_scene_with(path, &[], &LoadOptions::default())
}

/// Loads a scene tolerantly and adds lights to it (e.g. point lights: position and radiant
/// intensity).
pub fn load_scene_with_lights(path: &Path, lights: &[Light]) -> Result<Scene, LoadError> {
    load_scene_with(path, lights, &LoadOptions::default())
}

/// Loads a scene as `options` say and adds `lights` to it.
pub fn load_scene_with(
    path: &Path,
    lights: &[Light],
    options: &LoadOptions,
) -> Result<Scene, LoadError> {
    let mut scene = match extension(path).as_deref() {
        Some("toml") => load_sidecar(path, options)?,
        _ => load_mesh(path, options, &Reach::of(path, options.allow_outside_uris))?,
    };
    crate::scene::dimmer::apply(&mut scene, &options.light_scale)?;
    for l in lights {
        if let Light::Env(env) = l {
            scene.report.warnings.extend(env.map.notes.iter().cloned());
        }
        scene.add_light(l.clone());
    }
    Ok(scene)
}

/// A sidecar scene file: its mesh, then its lights, cameras and named slices.
fn load_sidecar(path: &Path, options: &LoadOptions) -> Result<Scene, LoadError> {
    let sc = sidecar::read(path)?;
    // The sidecar's folder bounds its mesh and everything the mesh names.
    let reach = Reach::of(path, options.allow_outside_uris);
    let dir = path.parent().unwrap_or(Path::new(""));
    let mesh = reach
        .resolve(dir, &sc.mesh)
        .map_err(|o| sidecar::outside(path, "mesh", &sc.mesh, o))?;
    if extension(&mesh).as_deref() == Some("toml") {
        return Err(LoadError::Malformed {
            file: path.to_path_buf(),
            line: None,
            what: format!(
                "mesh = \"{}\" must be a mesh file, not another .toml",
                sc.mesh
            ),
        });
    }
    let mut scene = load_mesh(&mesh, options, &reach).map_err(|source| LoadError::Mesh {
        sidecar: path.to_path_buf(),
        source: Box::new(source),
    })?;
    sidecar::apply(&sc, path, &reach, &mut scene)?;
    scene.named_slices = sc
        .slice
        .iter()
        .map(|s| (s.name.clone(), s.plane.clone()))
        .collect();
    Ok(scene)
}

/// Loads a mesh file, reading the files it names within `reach`; its report's `parse_seconds` is
/// the time of everything but the BVH build.
fn load_mesh(path: &Path, options: &LoadOptions, reach: &Reach) -> Result<Scene, LoadError> {
    let start = std::time::Instant::now();
    let mut scene = match extension(path).as_deref() {
        Some("obj") => obj::load_within(path, options.strict, reach)?,
        Some("gltf" | "glb") => gltf::load_within(path, !options.flatten_instances, reach)?,
        other => {
            return Err(LoadError::UnsupportedFormat {
                file: path.to_path_buf(),
                extension: other.map(str::to_string),
            });
        }
    };
    let total = start.elapsed().as_secs_f64();
    scene.report.parse_seconds = (total - scene.report.bvh_seconds).max(0.0);
    Ok(scene)
}
