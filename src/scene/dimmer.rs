//! A scene file's own lights by name, switched off and scaled: the light and occluder placement
//! the paper names as what FTPD is for asks "what if this lamp were off, or brighter?".
//!
//! Names ([`FileLight`]): an emissive material is one light, named by its material name (every
//! triangle of it, an OBJ `newmtl` with `Ke`, a glTF material with `emissiveFactor`); every other
//! light of the file (glTF `KHR_lights_punctual`, a sidecar's `[[point_light]]`, `[[spot_light]]`,
//! `[[sun]]`, `[sky]`, `[environment]`) by its kind and its number from 1 among the file's lights
//! of that kind, in the order the scene holds them: `point1`, `spot1`, `sun1`, `sky1`, `env1`
//! (glTF point lights come before its spot and directional lights). `*` names them all; a name
//! given beside `*` takes its own factor.
//!
//! Scaling by k multiplies the emitted radiance, intensity or irradiance by k where the scene is
//! built, before anything samples it: the emissive materials (hence what a path sees when it hits
//! them, and their flatland cross-sections) and the lights' power table. A factor of 0 switches a
//! light off: an emissive material emits nothing (its triangles stay, with power 0, never chosen),
//! and any other light leaves the scene. Scaling by a power of two is exact in floating point, so
//! it scales every radiance weight exactly, and σ (a ratio of weighted sums) is unchanged bit for
//! bit.

use crate::math::Rgb;
use crate::scene::env::Environment;
use crate::scene::error::{ImageError, LoadError};
use crate::scene::light::{FileLight, Light};
use crate::scene::model::Scene;

/// The scene's lights as they stand (before a run adds its own) by name, each at scale 1: one per
/// emissive material name, in the order of their first triangle, then the others in order.
pub fn name_lights(scene: &Scene) -> Vec<FileLight> {
    let mut out: Vec<FileLight> = Vec::new();
    let mut counts = [0usize; 5];
    for l in &scene.lights.lights {
        let (prefix, kind, slot) = match l {
            Light::Area { prim, .. } => {
                let m = &scene.materials[scene.tri_material[*prim as usize] as usize];
                if !out.iter().any(|f| f.name == m.name) {
                    out.push(FileLight {
                        name: m.name.clone(),
                        kind: "emissive material",
                        scale: 1.0,
                    });
                }
                continue;
            }
            Light::Point { .. } => ("point", "point light", 0),
            Light::Spot { .. } => ("spot", "spot light", 1),
            Light::Distant { .. } => ("sun", "sun", 2),
            Light::Sky { .. } => ("sky", "sky", 3),
            Light::Env(_) => ("env", "environment map", 4),
        };
        counts[slot] += 1;
        out.push(FileLight {
            name: format!("{prefix}{}", counts[slot]),
            kind,
            scale: 1.0,
        });
    }
    out
}

/// Names the scene file's lights ([`Scene::file_lights`]) and scales them by `scales` (name or
/// `*`, factor ≥ 0 and finite, as the caller checked). Call it before a run adds lights of its
/// own. Errors on a name the scene does not have, or one given twice.
pub fn apply(scene: &mut Scene, scales: &[(String, f64)]) -> Result<(), LoadError> {
    let mut names = name_lights(scene);
    if scales.is_empty() {
        scene.file_lights = names;
        return Ok(());
    }
    let error = |name: &str, twice: bool, names: &[FileLight]| LoadError::UnknownLight {
        file: scene.source.clone(),
        name: name.to_string(),
        known: names.iter().map(|f| f.name.clone()).collect(),
        twice,
    };
    for (i, (name, _)) in scales.iter().enumerate() {
        if scales[..i].iter().any(|(n, _)| n == name) {
            return Err(error(name, true, &names));
        }
        if name != "*" && !names.iter().any(|f| &f.name == name) {
            return Err(error(name, false, &names));
        }
    }
    let factor = |name: &str| {
        let of = |n: &str| scales.iter().find(|(s, _)| s == n).map(|&(_, k)| k);
        of(name).or_else(|| of("*")).unwrap_or(1.0)
    };
    for f in &mut names {
        f.scale = factor(&f.name);
    }
    // Emissive materials: the material and every area light of it.
    for m in &mut scene.materials {
        let k = factor(&m.name);
        if k != 1.0 && m.emission != Rgb::ZERO {
            m.emission *= k;
        }
    }
    let materials = &scene.materials;
    let tri_material = &scene.tri_material;
    let mut env_error = None;
    let mut others = names.iter().filter(|f| f.kind != "emissive material");
    scene.lights.edit(|lights| {
        let mut kept = Vec::with_capacity(lights.len());
        for mut l in lights.drain(..) {
            if let Light::Area { prim, emission, .. } = &mut l {
                *emission = materials[tri_material[*prim as usize] as usize].emission;
                kept.push(l);
                continue;
            }
            let k = others.next().map_or(1.0, |f| f.scale);
            if k == 0.0 {
                continue;
            }
            if k != 1.0 {
                match &mut l {
                    Light::Point { intensity, .. } | Light::Spot { intensity, .. } => {
                        *intensity *= k
                    }
                    Light::Distant {
                        irradiance,
                        radiance,
                        ..
                    } => {
                        *irradiance *= k;
                        *radiance *= k;
                    }
                    Light::Sky { radiance } => *radiance *= k,
                    Light::Env(env) => match scaled_env(env, k) {
                        Ok(e) => *env = e,
                        Err(e) => env_error = Some(e),
                    },
                    Light::Area { .. } => {}
                }
            }
            kept.push(l);
        }
        *lights = kept;
    });
    if let Some(source) = env_error {
        return Err(LoadError::Image {
            file: scene.source.clone(),
            image: "its environment map, scaled".into(),
            source,
        });
    }
    scene.file_lights = names;
    Ok(())
}

/// The environment map `env` with its radiance times `k` (> 0), sampled as before.
fn scaled_env(env: &Environment, k: f64) -> Result<Environment, ImageError> {
    let m = &env.map;
    let mut map =
        crate::scene::env::EnvMap::new(m.width, m.height, m.texels.clone(), k, 0.0, &m.source)?;
    map.rotation = m.rotation;
    map.scale = m.scale * k;
    map.notes.clear();
    Ok(Environment::new(map))
}
