//! Reading a glTF file: the document (JSON or binary), checked where the `gltf` crate's own
//! validation would panic or say too little; its buffers (the GLB binary chunk, data URIs, files
//! next to it); and the names messages give its objects.

use crate::scene::error::LoadError;
use crate::scene::files::percent_decode;
use base64::Engine as _;
use std::path::Path;

/// The warnings of one file, each prefixed with its name, in the order they arise.
pub(super) struct Warnings {
    file: String,
    pub(super) list: Vec<String>,
}

impl Warnings {
    pub(super) fn new(file: &str) -> Warnings {
        Warnings {
            file: file.to_string(),
            list: Vec::new(),
        }
    }

    pub(super) fn warn(&mut self, s: String) {
        self.list.push(format!("{}: {s}", self.file));
    }
}

/// `asset.version` of a JSON glTF document, if it is JSON and says.
fn json_version(bytes: &[u8]) -> Option<String> {
    let v: ::gltf::json::Value = ::gltf::json::deserialize::from_slice(bytes).ok()?;
    Some(v.get("asset")?.get("version")?.as_str()?.to_string())
}

/// The content of glTF file `path` that cannot be used: `what` says why.
pub(super) fn malformed(path: &Path, what: String) -> LoadError {
    LoadError::Malformed {
        file: path.to_path_buf(),
        line: None,
        what,
    }
}

/// The extensions that give a texture an image in a format of their own (the extension's
/// `source`); the texture decoder says which it reads, and a material whose image it cannot read
/// keeps its factors, with a warning.
pub(super) const IMAGE_EXTENSIONS: &[&str] =
    &["KHR_texture_basisu", "EXT_texture_webp", "EXT_texture_avif"];

/// Reads and parses the file at `path`: the document and the GLB binary chunk, if any.
pub(super) fn read(path: &Path) -> Result<(::gltf::Document, Option<Vec<u8>>), LoadError> {
    let bytes = std::fs::read(path).map_err(|source| LoadError::Unreadable {
        file: path.to_path_buf(),
        source,
    })?;
    check_glb_header(&bytes).map_err(|e| malformed(path, e))?;
    let invalid =
        |e: &dyn std::fmt::Display| malformed(path, format!("not a valid glTF 2.0 file: {e}"));
    let ::gltf::Gltf { document, blob } = ::gltf::Gltf::from_slice_without_validation(&bytes)
        .map_err(|e| match json_version(&bytes) {
            // glTF 1.0 documents are JSON too, but of another schema: say so, not which field
            // failed to parse.
            Some(v) if !v.starts_with('2') => malformed(
                path,
                format!("glTF version {v}; only version 2 is supported"),
            ),
            _ => invalid(&e),
        })?;
    drop(bytes);
    let mut root = document.into_json();
    // Required image formats are read by the textures (or their materials keep their factors,
    // with a warning): not a reason to refuse the file.
    root.extensions_required
        .retain(|e| !IMAGE_EXTENSIONS.contains(&e.as_str()));
    check_attribute_indices(&root).map_err(|e| invalid(&e))?;
    let doc = ::gltf::Document::from_json(root).map_err(|e| invalid(&e))?;
    Ok((doc, blob))
}

/// Checks a binary glTF's header and chunk lengths against the file size, so that a truncated file
/// gets a clear message (and never reaches the parser with inconsistent lengths).
fn check_glb_header(bytes: &[u8]) -> Result<(), String> {
    if !bytes.starts_with(b"glTF") {
        return Ok(());
    }
    let u32_at = |o: usize| {
        bytes
            .get(o..o + 4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize)
    };
    let (Some(version), Some(length)) = (u32_at(4), u32_at(8)) else {
        return Err(format!(
            "truncated .glb: {} bytes, shorter than the 12-byte header",
            bytes.len()
        ));
    };
    if version != 2 {
        return Err(format!(
            "binary glTF version {version}; only version 2 is supported"
        ));
    }
    if length > bytes.len() {
        return Err(format!(
            "truncated .glb: the header declares {length} bytes, the file has {}",
            bytes.len()
        ));
    }
    let Some(json_len) = u32_at(12) else {
        return Err(format!(
            "truncated .glb: {} bytes, no JSON chunk header",
            bytes.len()
        ));
    };
    if 20 + json_len > length {
        return Err(format!(
            "truncated .glb: the JSON chunk of {json_len} bytes runs past the declared end ({length} bytes)"
        ));
    }
    let bin_at = 20 + json_len;
    if bin_at < length {
        let Some(bin_len) = u32_at(bin_at) else {
            return Err(format!(
                "truncated .glb: the chunk header at byte {bin_at} is cut off"
            ));
        };
        if bin_at + 8 + bin_len > length {
            return Err(format!(
                "truncated .glb: the binary chunk of {bin_len} bytes runs past the declared end ({length} bytes)"
            ));
        }
    }
    Ok(())
}

/// Checks that every primitive attribute names an existing accessor. The crate's validation looks
/// up the POSITION accessor before checking its index (and panics on a bad one), so this runs first.
fn check_attribute_indices(root: &::gltf::json::Root) -> Result<(), String> {
    for (i, mesh) in root.meshes.iter().enumerate() {
        for (j, prim) in mesh.primitives.iter().enumerate() {
            for index in prim.attributes.values() {
                if index.value() >= root.accessors.len() {
                    return Err(format!(
                        "meshes[{i}].primitives[{j}].attributes: accessor {} does not exist ({} accessors)",
                        index.value(),
                        root.accessors.len()
                    ));
                }
            }
        }
    }
    Ok(())
}

/// Reads every buffer: the GLB binary chunk, a base64 data URI, or a file relative to the glTF file.
pub(super) fn load_buffers(
    path: &Path,
    doc: &::gltf::Document,
    mut blob: Option<Vec<u8>>,
) -> Result<Vec<Vec<u8>>, LoadError> {
    let dir = path.parent().unwrap_or(Path::new(""));
    let mut out = Vec::new();
    for buffer in doc.buffers() {
        let label = named("buffer", buffer.index(), buffer.name());
        let mut data = match buffer.source() {
            ::gltf::buffer::Source::Bin => blob.take().ok_or_else(|| {
                malformed(
                    path,
                    format!(
                        "{label} has no URI and there is no (unused) GLB binary chunk to take its data from"
                    ),
                )
            })?,
            ::gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => {
                decode_data_uri(uri).map_err(|e| malformed(path, format!("{label}: {e}")))?
            }
            ::gltf::buffer::Source::Uri(uri) => {
                let target = dir.join(percent_decode(uri));
                // Only regular files: /dev/zero or a FIFO would never end.
                if target.exists() && !target.is_file() {
                    return Err(malformed(
                        path,
                        format!(
                            "{label}: '{uri}' ({}) is not a regular file",
                            target.display()
                        ),
                    ));
                }
                std::fs::read(&target).map_err(|source| LoadError::Referenced {
                    file: path.to_path_buf(),
                    what: format!("{label}: cannot read '{uri}' ({})", target.display()),
                    source,
                })?
            }
        };
        if data.len() < buffer.length() {
            return Err(malformed(
                path,
                format!(
                    "{label}: {} bytes of data, but the file declares a byteLength of {}",
                    data.len(),
                    buffer.length()
                ),
            ));
        }
        data.truncate(buffer.length());
        out.push(data);
    }
    Ok(out)
}

/// Decodes `data:[<media type>];base64,<data>`.
pub(super) fn decode_data_uri(uri: &str) -> Result<Vec<u8>, String> {
    let Some((header, payload)) = uri.split_once(',') else {
        return Err("malformed data URI (no ',')".into());
    };
    if !header.ends_with(";base64") {
        return Err("data URI is not base64-encoded".into());
    }
    base64::engine::general_purpose::STANDARD_PAD_INDIFFERENT
        .decode(payload.trim())
        .map_err(|e| format!("invalid base64 in data URI: {e}"))
}

/// `kind 'name'` when the object has a non-empty name, `kind #index` otherwise.
pub(super) fn named(kind: &str, index: usize, name: Option<&str>) -> String {
    match name {
        Some(n) if !n.is_empty() => format!("{kind} '{n}'"),
        _ => format!("{kind} #{index}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gltf_glb_header_checks() {
        assert!(check_glb_header(b"{\"asset\":{}}").is_ok());
        let e = check_glb_header(b"glTF\x02\x00\x00\x00").unwrap_err();
        assert!(e.contains("truncated"), "{e}");
        let mut glb = b"glTF".to_vec();
        glb.extend(2u32.to_le_bytes());
        glb.extend(100u32.to_le_bytes());
        let e = check_glb_header(&glb).unwrap_err();
        assert!(e.contains("declares 100 bytes"), "{e}");
    }
}
