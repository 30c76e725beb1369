//! Meshes: each triangle primitive (TRIANGLES, TRIANGLE_STRIP, TRIANGLE_FAN; indexed or not) read
//! once in its mesh's local frame, with its normals and TEXCOORD_0; points and lines are skipped
//! with a warning.

use crate::scene::error::LoadError;
use crate::scene::gltf::accessor::{
    Quantized, dequantize, read_indices, read_uv, read_vec3, view_bytes,
};
use crate::scene::gltf::document::{DRACO, QUANTIZATION, Warnings, malformed, named};
use crate::scene::gltf::draco::DracoMesh;
use ::gltf::accessor::Dimensions;
use ::gltf::json::Value;
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

/// Reads a mesh's triangle primitives (once per mesh, however many nodes use it) of document `doc`
/// from `buffers`; primitives without a material get `default_material`. Errors name the glTF file
/// `path`.
pub(super) fn decode_mesh(
    mesh: &::gltf::Mesh,
    doc: &::gltf::Document,
    buffers: &[Vec<u8>],
    default_material: u32,
    path: &Path,
    warnings: &mut Warnings,
) -> Result<Vec<LocalPrimitive>, LoadError> {
    let mesh_label = named("mesh", mesh.index(), mesh.name());
    let quantized = doc.extensions_used().any(|e| e == QUANTIZATION);
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
            doc,
            buffers,
            label: &label,
            quantized,
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
    doc: &'a ::gltf::Document,
    buffers: &'a [Vec<u8>],
    label: &'a str,
    /// The file declares KHR_mesh_quantization: attributes may be integers.
    quantized: bool,
}

impl Primitive<'_> {
    fn decode(
        &self,
        mode: Mode,
        default_material: u32,
        warnings: &mut Warnings,
    ) -> Result<LocalPrimitive, String> {
        if let Some(ext) = self.prim.extension_value(DRACO) {
            return self.decode_draco(ext, default_material, warnings);
        }
        let pos_acc = self
            .prim
            .get(&Semantic::Positions)
            .ok_or("no POSITION attribute")?;
        let allowed = Quantized::when(self.quantized, Quantized::Any);
        let positions = read_vec3(&pos_acc, self.buffers, "POSITION", allowed)?;
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
        let allowed = Quantized::when(self.quantized, Quantized::SignedNormalized);
        let normals = read_vec3(&acc, self.buffers, "NORMAL", allowed)?;
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

    /// TEXCOORD_0 when it has one entry per vertex; one of another type than the file allows (f32,
    /// or with KHR_mesh_quantization 8- and 16-bit integers) is ignored with a warning.
    fn uvs(&self, n: usize, warnings: &mut Warnings) -> Result<Option<Vec<Vec2>>, String> {
        let Some(acc) = self.prim.get(&Semantic::TexCoords(0)) else {
            return Ok(None);
        };
        let allowed = Quantized::when(self.quantized, Quantized::Any);
        if acc.dimensions() != Dimensions::Vec2
            || !allowed.allows(acc.data_type(), acc.normalized())
        {
            // The reader's message names the accessor, its type and what is allowed.
            let e = read_uv(&acc, self.buffers, allowed)
                .err()
                .unwrap_or_default();
            warnings.warn(format!("{}: {e}; textures ignored on it", self.label));
            return Ok(None);
        }
        let uv = read_uv(&acc, self.buffers, allowed)?;
        Ok((uv.len() == n).then_some(uv))
    }

    /// A primitive compressed with KHR_draco_mesh_compression: its triangles and the attributes
    /// the extension names decoded from the Draco stream (integer attributes read as their
    /// accessors say, as [`dequantize`] does); attributes it does not name are read from their
    /// accessors as usual. The decoded stream is a triangle list whatever the primitive's mode.
    fn decode_draco(
        &self,
        ext: &Value,
        default_material: u32,
        warnings: &mut Warnings,
    ) -> Result<LocalPrimitive, String> {
        let fail = |e: String| format!("{DRACO}: {e}");
        let view = ext
            .get("bufferView")
            .and_then(Value::as_u64)
            .ok_or_else(|| fail("no bufferView".into()))?;
        let view = self
            .doc
            .views()
            .nth(view as usize)
            .ok_or_else(|| fail(format!("buffer view #{view} does not exist")))?;
        let mesh = DracoMesh::decode(view_bytes(&view, self.buffers)?).map_err(fail)?;
        let ids = ext.get("attributes").and_then(Value::as_object);
        let id = |name: &str| {
            ids.and_then(|m| m.get(name))
                .and_then(Value::as_u64)
                .and_then(|v| u32::try_from(v).ok())
        };
        let n = mesh.points();
        // An attribute the stream holds, dequantized as its accessor describes it.
        let decoded = |semantic: Semantic, name: &str| -> Result<Option<Vec<Vec3>>, String> {
            let Some(id) = id(name) else { return Ok(None) };
            let values = mesh.attribute::<3>(id).ok_or_else(|| {
                fail(format!(
                    "the stream has no 3-component attribute of id {id} ({name})"
                ))
            })?;
            let (t, norm) = self
                .prim
                .get(&semantic)
                .map_or((::gltf::accessor::DataType::F32, false), |a| {
                    (a.data_type(), a.normalized())
                });
            Ok(Some(
                values
                    .into_iter()
                    .map(|c| Vec3::from(c.map(|v| dequantize(t, norm, v))))
                    .collect(),
            ))
        };
        let positions = decoded(Semantic::Positions, "POSITION")?
            .ok_or_else(|| fail("no POSITION in its attributes".into()))?;
        let normals = match decoded(Semantic::Normals, "NORMAL")? {
            Some(ns) => Some(ns),
            None => self.normals(n, warnings)?,
        };
        let uvs = match id("TEXCOORD_0") {
            Some(uv_id) => {
                let values = mesh.attribute::<2>(uv_id).ok_or_else(|| {
                    fail(format!(
                        "the stream has no 2-component attribute of id {uv_id} (TEXCOORD_0)"
                    ))
                })?;
                let (t, norm) = self
                    .prim
                    .get(&Semantic::TexCoords(0))
                    .map_or((::gltf::accessor::DataType::F32, false), |a| {
                        (a.data_type(), a.normalized())
                    });
                Some(
                    values
                        .into_iter()
                        .map(|[u, v]| {
                            Vec2::new(dequantize(t, norm, u), 1.0 - dequantize(t, norm, v))
                        })
                        .collect(),
                )
            }
            None => self.uvs(n, warnings)?,
        };
        let indices = mesh.triangles();
        if let Some(i) = indices.iter().find(|&&i| i as usize >= n) {
            return Err(fail(format!("index {i} is outside the {n} decoded points")));
        }
        let triangles = self.triangles(Mode::Triangles, &indices, warnings);
        let material = self
            .prim
            .material()
            .index()
            .map_or(default_material, |i| i as u32);
        Ok(LocalPrimitive {
            positions,
            normals,
            uvs,
            triangles,
            material,
        })
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
