//! Loading by file extension: `.obj`, `.gltf`/`.glb`, or a sidecar `.toml` naming a mesh plus
//! point lights, cameras and named slices. The scene's [`Features`] are computed here, once, after
//! every light (the file's, the sidecar's, the command line's) is in.

use crate::scene::{self, Scene};
use anyhow::{Context, bail};
use std::path::Path;

/// Loads a scene by its extension (see the module docs).
pub fn load_scene(path: &Path) -> anyhow::Result<Scene> {
    load_scene_with_lights(path, &[])
}

/// Loads a scene and adds point lights (position, radiant intensity) to it.
pub fn load_scene_with_lights(path: &Path, lights: &[scene::Light]) -> anyhow::Result<Scene> {
    let mut scene = match extension(path).as_deref() {
        Some("toml") => {
            let sc = scene::sidecar::read(path)?;
            let mesh = path.parent().unwrap_or(Path::new(".")).join(&sc.mesh);
            if extension(&mesh).as_deref() == Some("toml") {
                bail!(
                    "{}: mesh = \"{}\" must be a mesh file, not another .toml",
                    path.display(),
                    sc.mesh
                );
            }
            let mut scene = load_mesh(&mesh)
                .with_context(|| format!("{}: loading its mesh", path.display()))?;
            scene::sidecar::apply(&sc, path, &mut scene)?;
            scene.named_slices = sc
                .slice
                .iter()
                .map(|s| (s.name.clone(), s.plane.clone()))
                .collect();
            scene
        }
        _ => load_mesh(path)?,
    };
    for l in lights {
        scene.add_light(l.clone());
    }
    Ok(scene)
}

/// A path's extension in lower case.
pub fn extension(path: &Path) -> Option<String> {
    path.extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
}

fn load_mesh(path: &Path) -> anyhow::Result<Scene> {
    match extension(path).as_deref() {
        Some("obj") => scene::obj::load(path),
        Some("gltf" | "glb") => scene::gltf::load(path),
        Some(other) => bail!(
            "{}: unsupported scene format '.{other}' (supported: .obj, .gltf, .glb, .toml)",
            path.display()
        ),
        None => bail!(
            "{}: no file extension; expected a .obj, .gltf, .glb or .toml scene",
            path.display()
        ),
    }
}
