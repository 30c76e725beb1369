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

/// Reads a VEC3 f32 accessor (positions, normals).
pub(super) fn read_vec3_f32(
    acc: &::gltf::Accessor,
    buffers: &[Vec<u8>],
    what: &str,
) -> Result<Vec<Vec3>, String> {
    if acc.dimensions() != Dimensions::Vec3 || acc.data_type() != DataType::F32 {
        return Err(format!(
            "{what} accessor #{} is not VEC3 f32 (it is {} {})",
            acc.index(),
            dims_name(acc.dimensions()),
            type_name(acc.data_type())
        ));
    }
    let raw = accessor_bytes(acc, buffers)?;
    let f = |b: &[u8]| f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
    Ok(raw
        .chunks_exact(12)
        .map(|c| Vec3::new(f(&c[0..4]), f(&c[4..8]), f(&c[8..12])))
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

/// Reads a VEC2 f32 accessor of texture coordinates, with v turned up (glTF's v points down).
pub(super) fn read_uv_f32(
    acc: &::gltf::Accessor,
    buffers: &[Vec<u8>],
) -> Result<Vec<Vec2>, String> {
    let raw = accessor_bytes(acc, buffers)?;
    let f = |b: &[u8]| f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
    Ok(raw
        .chunks_exact(8)
        .map(|c| Vec2::new(f(&c[0..4]), 1.0 - f(&c[4..8])))
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
