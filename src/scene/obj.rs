//! Wavefront OBJ + MTL loading (tobj): triangulated meshes with one shared index per vertex, shading
//! normals when present, one material per triangle. See [`crate::scene::material`] for the MTL table.

use crate::math::Rgb;
use crate::scene::material::{Material, conserve_energy};
use crate::scene::{LoadReport, Scene};
use crate::transport::bsdf::Bsdf;
use anyhow::{Context, bail};
use glam::Vec3;
use std::path::Path;

/// Loads an OBJ file (and the MTL files it names) into a [`Scene`].
pub fn load(path: &Path) -> anyhow::Result<Scene> {
    if !path.is_file() {
        bail!("{}: no such scene file", path.display());
    }
    let opts = tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, mtl) = tobj::load_obj(path, &opts)
        .map_err(|e| anyhow::anyhow!("{}: {}", path.display(), describe(&e)))?;
    let mut report = LoadReport::default();
    let mut materials: Vec<Material> = match mtl {
        Ok(list) => list
            .iter()
            .map(|m| {
                let (mat, warn) = convert_material(m);
                if let Some(w) = warn {
                    report
                        .warnings
                        .push(format!("{}: material '{}': {w}", path.display(), m.name));
                }
                mat
            })
            .collect(),
        Err(e) => {
            report.warnings.push(format!(
                "{}: material library not loaded ({}); using grey diffuse",
                path.display(),
                describe(&e)
            ));
            Vec::new()
        }
    };
    // Index of the default material for faces without one.
    let default_id = materials.len() as u32;
    materials.push(Material::default_grey());

    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut triangles = Vec::new();
    let mut tri_material = Vec::new();
    let mut all_have_normals = true;
    for model in &models {
        let mesh = &model.mesh;
        let base = positions.len() as u64;
        let nverts = mesh.positions.len() / 3;
        if base + nverts as u64 >= u32::MAX as u64 {
            bail!("{}: more than 2^32 vertices", path.display());
        }
        positions.extend(
            mesh.positions
                .chunks_exact(3)
                .map(|p| Vec3::new(p[0], p[1], p[2])),
        );
        if mesh.normals.len() == mesh.positions.len() {
            normals.extend(
                mesh.normals
                    .chunks_exact(3)
                    .map(|n| Vec3::new(n[0], n[1], n[2])),
            );
        } else {
            all_have_normals = false;
            normals.extend(std::iter::repeat_n(Vec3::ZERO, nverts));
        }
        let mat = match mesh.material_id {
            Some(id) if id < default_id as usize => id as u32,
            Some(id) => {
                report.warnings.push(format!(
                    "{}: object '{}' names material #{id}, which is not defined",
                    path.display(),
                    model.name
                ));
                default_id
            }
            None => default_id,
        };
        for f in mesh.indices.chunks_exact(3) {
            let tri = [f[0], f[1], f[2]];
            if tri.iter().any(|&i| i as usize >= nverts) {
                bail!(
                    "{}: object '{}' has a face index outside its {} vertices",
                    path.display(),
                    model.name,
                    nverts
                );
            }
            triangles.push(tri.map(|i| i + base as u32));
            tri_material.push(mat);
        }
    }
    if !all_have_normals {
        // A mix of meshes with and without normals: zero normals fall back to the geometric one.
        if normals.iter().all(|n| *n == Vec3::ZERO) {
            normals.clear();
        }
    }
    Scene::build(
        path,
        positions,
        normals,
        triangles,
        tri_material,
        materials,
        report,
    )
    .with_context(|| format!("{}: building the scene", path.display()))
}

fn describe(e: &tobj::LoadError) -> String {
    use tobj::LoadError::*;
    match e {
        OpenFileFailed => "cannot open file".into(),
        ReadError => "read error".into(),
        UnrecognizedCharacter => "unrecognised character".into(),
        PositionParseError => "malformed vertex position (v)".into(),
        NormalParseError => "malformed normal (vn)".into(),
        TexcoordParseError => "malformed texture coordinate (vt)".into(),
        FaceParseError => "malformed face (f)".into(),
        MaterialParseError => "malformed material statement".into(),
        InvalidObjectName => "invalid object name".into(),
        InvalidPolygon => "invalid polygon (fewer than 3 vertices)".into(),
        FaceVertexOutOfBounds => "face refers to a vertex that does not exist".into(),
        FaceTexCoordOutOfBounds => "face refers to a texture coordinate that does not exist".into(),
        FaceNormalOutOfBounds => "face refers to a normal that does not exist".into(),
        FaceColorOutOfBounds => "face refers to a vertex colour that does not exist".into(),
        InvalidLoadOptionConfig => "invalid load options".into(),
        ScalingByZeroError => "texture scale of zero".into(),
        ColorParseError => "malformed vertex colour".into(),
        GenericFailure => "unreadable".into(),
    }
}

/// The f64 nearest the decimal written in the file (tobj parses to f32; `0.8f32 as f64` would be
/// 0.800000011920929).
fn decimal(x: f32) -> f64 {
    x.to_string().parse().unwrap_or(x as f64)
}

fn rgb(v: Option<[f32; 3]>) -> Option<Rgb> {
    v.map(|c| Rgb::new(decimal(c[0]), decimal(c[1]), decimal(c[2])).max(Rgb::ZERO))
}

fn parse_rgb(s: &str) -> Option<Rgb> {
    let v: Vec<f64> = s
        .split_whitespace()
        .filter_map(|t| t.parse().ok())
        .collect();
    match v.as_slice() {
        [g] => Some(Rgb::splat(*g)),
        [r, g, b, ..] => Some(Rgb::new(*r, *g, *b)),
        _ => None,
    }
}

/// Maps one MTL material onto the material model (the table in [`crate::scene::material`]).
pub fn convert_material(m: &tobj::Material) -> (Material, Option<String>) {
    let emission = rgb(m.emissive).unwrap_or(Rgb::ZERO);
    let emits = emission != Rgb::ZERO;
    let mut kd = rgb(m.diffuse).unwrap_or(if emits { Rgb::ZERO } else { Rgb::splat(0.5) });
    let ks_given = rgb(m.specular);
    let mut warn = None;
    let illum = m.illumination_model.unwrap_or(2);
    let bsdf = match illum {
        0 | 1 => Bsdf::Diffuse {
            kd: kd.min(Rgb::ONE),
        },
        3 | 5 | 8 => {
            let mut ks = ks_given.unwrap_or(Rgb::ONE);
            if conserve_energy(&mut kd, &mut ks) {
                warn = Some("Kd + Ks exceeds 1; scaled down".to_string());
            }
            Bsdf::Mirror { kd, ks }
        }
        4 | 6 | 7 | 9 => {
            let ior = m
                .optical_density
                .map(decimal)
                .filter(|n| *n > 0.0 && n.is_finite())
                .unwrap_or(1.5);
            let tint = m
                .unknown_param
                .get("Tf")
                .and_then(|s| parse_rgb(s))
                .unwrap_or(Rgb::ONE)
                .clamp(Rgb::ZERO, Rgb::ONE);
            Bsdf::Dielectric { ior, tint }
        }
        _ => {
            let mut ks = ks_given.unwrap_or(Rgb::ZERO);
            if ks == Rgb::ZERO {
                Bsdf::Diffuse {
                    kd: kd.min(Rgb::ONE),
                }
            } else {
                if conserve_energy(&mut kd, &mut ks) {
                    warn = Some("Kd + Ks exceeds 1; scaled down".to_string());
                }
                let exponent = m
                    .shininess
                    .map(decimal)
                    .filter(|n| n.is_finite() && *n >= 0.0)
                    .unwrap_or(1.0);
                Bsdf::Glossy { kd, ks, exponent }
            }
        }
    };
    let bsdf = match bsdf {
        Bsdf::Diffuse { kd } if kd == Rgb::ZERO => Bsdf::Black,
        b => b,
    };
    (
        Material {
            name: m.name.clone(),
            bsdf,
            emission,
        },
        warn,
    )
}
