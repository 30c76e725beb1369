//! Reading accessors: the bytes of buffer views and accessors (stride and sparse substitution
//! resolved, every range checked, so a bad file gives an error and never a panic), and the
//! element types the mesh reader takes. Decoders of compressed or quantized attributes belong
//! here too, behind the same functions.

use ::gltf::accessor::{DataType, Dimensions};
use glam::{Vec2, Vec3};

/// Bytes an accessor without a buffer view (all zeros, maybe sparse) may expand to.
const MAX_IMPLICIT_ACCESSOR_BYTES: usize = 1 << 30;

/// The bytes of `view` within its buffer.
pub(super) fn view_bytes<'b>(
    view: &::gltf::buffer::View,
    buffers: &'b [Vec<u8>],
) -> Result<&'b [u8], String> {
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

/// The component types a vertex attribute may have: f32 in core glTF, the integer ones that
/// KHR_mesh_quantization adds in files that use it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Quantized {
    /// f32 only (core glTF: the file does not use KHR_mesh_quantization).
    FloatOnly,
    /// f32, or any 8- or 16-bit integer type, normalised or not (POSITION, TEXCOORD_n).
    Any,
    /// f32, or normalised signed 8- or 16-bit integers (NORMAL).
    SignedNormalized,
}

impl Quantized {
    /// The formats an attribute may have in a file that does (`quantized`) or does not declare
    /// KHR_mesh_quantization: `with` in the first case, f32 only in the second.
    pub(super) fn when(quantized: bool, with: Quantized) -> Quantized {
        if quantized {
            with
        } else {
            Quantized::FloatOnly
        }
    }

    pub(super) fn allows(self, t: DataType, normalized: bool) -> bool {
        match (self, t) {
            (_, DataType::F32) => true,
            (Quantized::FloatOnly, _) => false,
            (Quantized::Any, DataType::I8 | DataType::U8 | DataType::I16 | DataType::U16) => true,
            (Quantized::SignedNormalized, DataType::I8 | DataType::I16) => normalized,
            _ => false,
        }
    }

    fn names(self) -> &'static str {
        match self {
            Quantized::FloatOnly => "f32",
            Quantized::Any => "f32 or 8- or 16-bit integers (KHR_mesh_quantization)",
            Quantized::SignedNormalized => "f32 or normalized i8 or i16 (KHR_mesh_quantization)",
        }
    }
}

/// Reads an accessor of `N` components as f32: floats as stored; integers (KHR_mesh_quantization)
/// as glTF says: normalised ones to [0, 1] (unsigned) or [-1, 1] (signed: c / max, clamped to -1),
/// the others as their values (a node's transform, or a texture transform, scales them back).
/// `allowed` are the component types the attribute `what` may have.
pub(super) fn read_components<const N: usize>(
    acc: &::gltf::Accessor,
    buffers: &[Vec<u8>],
    what: &str,
    allowed: Quantized,
) -> Result<Vec<[f32; N]>, String> {
    let (t, normalized) = (acc.data_type(), acc.normalized());
    let dims = match N {
        2 => Dimensions::Vec2,
        3 => Dimensions::Vec3,
        _ => Dimensions::Vec4,
    };
    if acc.dimensions() != dims || !allowed.allows(t, normalized) {
        return Err(format!(
            "{what} accessor #{} is not {} {} (it is {} {}{})",
            acc.index(),
            dims_name(dims),
            allowed.names(),
            dims_name(acc.dimensions()),
            if normalized { "normalized " } else { "" },
            type_name(t),
        ));
    }
    let raw = accessor_bytes(acc, buffers)?;
    let size = t.size();
    let component = |b: &[u8]| -> f32 {
        let v = match t {
            DataType::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
            DataType::I8 => b[0] as i8 as f32,
            DataType::U8 => b[0] as f32,
            DataType::I16 => i16::from_le_bytes([b[0], b[1]]) as f32,
            DataType::U16 => u16::from_le_bytes([b[0], b[1]]) as f32,
            // Refused above (`allows`).
            DataType::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f32,
        };
        dequantize(t, normalized, v)
    };
    Ok(raw
        .chunks_exact(N * size)
        .map(|e| std::array::from_fn(|k| component(&e[k * size..(k + 1) * size])))
        .collect())
}

/// An integer component's value `v` as glTF reads it: a normalised one divided by its type's
/// largest value (signed ones clamped to -1), others as they are.
pub(super) fn dequantize(t: DataType, normalized: bool, v: f32) -> f32 {
    if !normalized {
        return v;
    }
    match t {
        DataType::I8 => (v / 127.0).max(-1.0),
        DataType::U8 => v / 255.0,
        DataType::I16 => (v / 32767.0).max(-1.0),
        DataType::U16 => v / 65535.0,
        DataType::F32 | DataType::U32 => v,
    }
}

/// Reads a VEC3 accessor (positions, normals) of the component types `allowed`.
pub(super) fn read_vec3(
    acc: &::gltf::Accessor,
    buffers: &[Vec<u8>],
    what: &str,
    allowed: Quantized,
) -> Result<Vec<Vec3>, String> {
    Ok(read_components::<3>(acc, buffers, what, allowed)?
        .into_iter()
        .map(Vec3::from)
        .collect())
}

/// Reads an index accessor (SCALAR, unsigned 8, 16 or 32 bits).
pub(super) fn read_indices(
    acc: &::gltf::Accessor,
    buffers: &[Vec<u8>],
) -> Result<Vec<u32>, String> {
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

/// Reads a VEC2 accessor of texture coordinates (f32 or quantized), with v turned up (glTF's v
/// points down).
pub(super) fn read_uv(
    acc: &::gltf::Accessor,
    buffers: &[Vec<u8>],
    allowed: Quantized,
) -> Result<Vec<Vec2>, String> {
    Ok(read_components::<2>(acc, buffers, "TEXCOORD_0", allowed)?
        .into_iter()
        .map(|[u, v]| Vec2::new(u, 1.0 - v))
        .collect())
}

pub(super) fn dims_name(d: Dimensions) -> &'static str {
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

pub(super) fn type_name(t: DataType) -> &'static str {
    match t {
        DataType::I8 => "i8",
        DataType::U8 => "u8",
        DataType::I16 => "i16",
        DataType::U16 => "u16",
        DataType::U32 => "u32",
        DataType::F32 => "f32",
    }
}
