//! Loading by file extension: `.obj`, `.gltf`/`.glb`, or a sidecar `.toml` naming a mesh plus
//! point lights, cameras and named slices. The scene's [`Features`] are computed here, once, after
//! every light (the file's, the sidecar's, the command line's) is in.

pub use crate::scene::files::extension;
use crate::scene::light::Light;
use crate::scene::model::Scene;
use crate::scene::{gltf, obj, sidecar};
use anyhow::{Context, bail};
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};

/// `--strict`: refuse what the OBJ loader otherwise goes on past with a warning (faces of fewer
/// than 3 vertices, `usemtl` or `mtllib` without a name, unsupported statements, text that is not
/// UTF-8). Process-wide, set once by the command line before loading.
static STRICT: AtomicBool = AtomicBool::new(false);

/// Sets the `--strict` mode of every later load (see [`STRICT`]).
pub fn set_strict(strict: bool) {
    STRICT.store(strict, Ordering::Relaxed);
}

/// Whether loads are strict (see [`set_strict`]).
pub fn strict() -> bool {
    STRICT.load(Ordering::Relaxed)
}

/// Loads a scene by its extension (see the module docs).
pub fn load_scene(path: &Path) -> anyhow::Result<Scene> {
    load_scene_with_lights(path, &[])
}

/// Loads a scene and adds point lights (position, radiant intensity) to it.
pub fn load_scene_with_lights(path: &Path, lights: &[Light]) -> anyhow::Result<Scene> {
    let mut scene = match extension(path).as_deref() {
        Some("toml") => {
            let sc = sidecar::read(path)?;
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
            sidecar::apply(&sc, path, &mut scene)?;
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

/// Loads a mesh file; its report's `parse_seconds` is the time of everything but the BVH build.
fn load_mesh(path: &Path) -> anyhow::Result<Scene> {
    let start = std::time::Instant::now();
    let mut scene = load_mesh_by_extension(path)?;
    let total = start.elapsed().as_secs_f64();
    scene.report.parse_seconds = (total - scene.report.bvh_seconds).max(0.0);
    Ok(scene)
}

fn load_mesh_by_extension(path: &Path) -> anyhow::Result<Scene> {
    match extension(path).as_deref() {
        Some("obj") => obj::load(path, strict()),
        Some("gltf" | "glb") => gltf::load(path),
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
