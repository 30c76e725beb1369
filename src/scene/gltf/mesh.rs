//! Meshes: each triangle primitive (TRIANGLES, TRIANGLE_STRIP, TRIANGLE_FAN; indexed or not) read
//! once in its mesh's local frame, with its normals and TEXCOORD_0; points and lines are skipped
//! with a warning.

use crate::scene::error::LoadError;
use crate::scene::gltf::accessor::{
    dims_name, read_indices, read_uv_f32, read_vec3_f32, type_name,
};
use crate::scene::gltf::document::malformed;
use crate::scene::gltf::document::{Warnings, named};
use ::gltf::accessor::{DataType, Dimensions};
use ::gltf::mesh::{Mode, Semantic};
use glam::{Vec2, Vec3};
use std::path::Path;

/// One triangle primitive in its mesh's local frame.
pub(super) struct LocalPrimitive {
    pub(super) positions: Vec<Vec3>,
    pub(super) normals: Option<Vec<Vec3>>,
    /// TEXCOORD_0 with v turned up (glTF's v points down).
    pub(super) uvs: Option<Vec<Vec2>>,
    pub(super) triangles: Vec<[u32; 3]>,
    pub(super) material: u32,
}

/// Reads a mesh's triangle primitives (once per mesh, however many nodes use it) from `buffers`;
/// primitives without a material get `default_material`. Errors name the glTF file `path`.
pub(super) fn decode_mesh(
    mesh: &::gltf::Mesh,
    buffers: &[Vec<u8>],
    default_material: u32,
    path: &Path,
    warnings: &mut Warnings,
) -> Result<Vec<LocalPrimitive>, LoadError> {
    let mesh_label = named("mesh", mesh.index(), mesh.name());
    let mut out = Vec::new();
    for prim in mesh.primitives() {
        let label = format!("{mesh_label} primitive {}", prim.index());
        let mode = prim.mode();
        if !matches!(
            mode,
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
        ) {
            warnings.warn(format!(
                "{label}: mode {} is not triangles; skipped",
                mode_name(mode)
            ));
            continue;
        }
        if prim.morph_targets().len() > 0 {
            warnings.warn(format!("{label}: morph targets ignored (base shape used)"));
        }
        let read = Primitive {
            prim: &prim,
            buffers,
            label: &label,
        };
        let decoded = read
            .decode(mode, default_material, warnings)
            .map_err(|e| malformed(path, format!("{label}: {e}")))?;
        out.push(decoded);
    }
    Ok(out)
}

/// A primitive being read, named `label` in warnings.
struct Primitive<'a> {
    prim: &'a ::gltf::Primitive<'a>,
    buffers: &'a [Vec<u8>],
    label: &'a str,
}

impl Primitive<'_> {
    fn decode(
        &self,
        mode: Mode,
        default_material: u32,
        warnings: &mut Warnings,
    ) -> Result<LocalPrimitive, String> {
        let pos_acc = self
            .prim
            .get(&Semantic::Positions)
            .ok_or("no POSITION attribute")?;
        let positions = read_vec3_f32(&pos_acc, self.buffers, "POSITION")?;
        let n = positions.len();
        let normals = self.normals(n, warnings)?;
        let indices = self.indices(n)?;
        let triangles = self.triangles(mode, &indices, warnings);
        let material = self
            .prim
            .material()
            .index()
            .map_or(default_material, |i| i as u32);
        let uvs = self.uvs(n, warnings)?;
        Ok(LocalPrimitive {
            positions,
            normals,
            uvs,
            triangles,
            material,
        })
    }

    /// The NORMAL attribute, when it has one normal per position.
    fn normals(&self, n: usize, warnings: &mut Warnings) -> Result<Option<Vec<Vec3>>, String> {
        let Some(acc) = self.prim.get(&Semantic::Normals) else {
            return Ok(None);
        };
        let normals = read_vec3_f32(&acc, self.buffers, "NORMAL")?;
        if normals.len() == n {
            Ok(Some(normals))
        } else {
            warnings.warn(format!(
                "{}: {} normals for {n} positions; normals ignored",
                self.label,
                normals.len()
            ));
            Ok(None)
        }
    }

    /// The vertex indices (all of the `n` vertices in order when the primitive has none), each
    /// checked against `n`.
    fn indices(&self, n: usize) -> Result<Vec<u32>, String> {
        let Some(acc) = self.prim.indices() else {
            return Ok((0..n as u32).collect());
        };
        let idx = read_indices(&acc, self.buffers)?;
        if let Some((k, i)) = idx.iter().enumerate().find(|(_, i)| **i as usize >= n) {
            return Err(format!(
                "index {i} (entry {k} of accessor #{}) is outside the {n} vertices",
                acc.index()
            ));
        }
        Ok(idx)
    }

    /// The triangles of `indices` in the primitive's mode, with glTF's winding.
    fn triangles(&self, mode: Mode, indices: &[u32], warnings: &mut Warnings) -> Vec<[u32; 3]> {
        match mode {
            Mode::Triangles => {
                if !indices.len().is_multiple_of(3) {
                    warnings.warn(format!(
                        "{}: {} vertices is not a multiple of 3; the last {} ignored",
                        self.label,
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
        }
    }

    /// TEXCOORD_0 when it is VEC2 f32 with one entry per vertex; another type is ignored with a
    /// warning.
    fn uvs(&self, n: usize, warnings: &mut Warnings) -> Result<Option<Vec<Vec2>>, String> {
        match self.prim.get(&Semantic::TexCoords(0)) {
            Some(acc)
                if acc.dimensions() == Dimensions::Vec2 && acc.data_type() == DataType::F32 =>
            {
                let uv = read_uv_f32(&acc, self.buffers)?;
                Ok((uv.len() == n).then_some(uv))
            }
            Some(acc) => {
                warnings.warn(format!(
                    "{}: TEXCOORD_0 accessor #{} is {} {}, not VEC2 f32; textures ignored on it",
                    self.label,
                    acc.index(),
                    dims_name(acc.dimensions()),
                    type_name(acc.data_type())
                ));
                Ok(None)
            }
            None => Ok(None),
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
