//! KHR_draco_mesh_compression: a primitive's attributes and triangles decoded from its Draco
//! stream by the `draco-core` crate (pure Rust). A decoder error, or a panic of the decoder on
//! malformed input, becomes an error naming the primitive.

/// A decoded Draco mesh: its points' attributes (looked up by the unique ids the glTF extension
/// names) and its triangles.
pub(super) struct DracoMesh {
    mesh: draco_core::Mesh,
}

impl DracoMesh {
    /// Decodes the Draco stream `bytes`.
    pub(super) fn decode(bytes: &[u8]) -> Result<DracoMesh, String> {
        let decoded = std::panic::catch_unwind(|| {
            let mut buffer = draco_core::DecoderBuffer::new(bytes);
            let mut mesh = draco_core::Mesh::new();
            draco_core::MeshDecoder::new()
                .decode(&mut buffer, &mut mesh)
                .map(|()| mesh)
        });
        match decoded {
            Ok(Ok(mesh)) => Ok(DracoMesh { mesh }),
            Ok(Err(e)) => Err(format!("Draco stream: {e}")),
            Err(_) => Err("Draco stream: the decoder failed on it (malformed data)".into()),
        }
    }

    /// The number of decoded points (vertices).
    pub(super) fn points(&self) -> usize {
        self.mesh.num_points()
    }

    /// The triangles, as point indices.
    pub(super) fn triangles(&self) -> Vec<u32> {
        self.mesh
            .faces()
            .iter()
            .flat_map(|f| f.map(|p| p.0))
            .collect()
    }

    /// The values of the attribute of unique id `id`, `N` components per point, widened to f32
    /// (integers as their values); `None` when the stream has no such attribute or it has another
    /// number of components.
    pub(super) fn attribute<const N: usize>(&self, id: u32) -> Option<Vec<[f32; N]>> {
        let att = self.mesh.attribute_by_unique_id(id)?;
        if att.num_components() as usize != N {
            return None;
        }
        let flat = att.read_f32s(self.points(), N);
        Some(
            flat.chunks_exact(N)
                .map(|c| std::array::from_fn(|k| c[k]))
                .collect(),
        )
    }
}
