//! Reading a glTF file: the document (JSON or binary), checked where the `gltf` crate's own
//! validation would panic or say too little; its buffers (the GLB binary chunk, data URIs, files
//! next to it); and the names messages give its objects.

use crate::scene::error::LoadError;
use crate::scene::files::{Outside, Reach, percent_decode};
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

/// The URI `uri` of `what` (a buffer, an image) in glTF file `path` lies outside the folder the
/// file may read.
pub(super) fn outside(path: &Path, what: &str, uri: &str, o: Outside) -> LoadError {
    LoadError::Outside {
        file: path.to_path_buf(),
        what: format!("{what}: URI"),
        name: uri.to_string(),
        folder: o.folder,
        why: o.why,
    }
}

/// The extensions this reader implements: a file that requires one of them loads, one that
/// requires any other is refused, naming it. Extensions a file only uses and this list lacks are
/// ignored with one warning. The image-format extensions (KTX2, WebP, AVIF) are accepted: the
/// textures name such an image in a warning and its materials keep their factors.
pub(super) const SUPPORTED_EXTENSIONS: &[&str] = &[
    "EXT_mesh_gpu_instancing",
    "EXT_meshopt_compression",
    "EXT_texture_avif",
    "EXT_texture_webp",
    "KHR_draco_mesh_compression",
    "KHR_lights_punctual",
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_transmission",
    "KHR_mesh_quantization",
    "KHR_meshopt_compression",
    "KHR_texture_basisu",
    "KHR_texture_transform",
];

/// The extensions that give a texture an image in a format of their own (the extension's
/// `source`); the texture decoder says which it reads, and a material whose image it cannot read
/// keeps its factors, with a warning.
pub(super) const IMAGE_EXTENSIONS: &[&str] =
    &["KHR_texture_basisu", "EXT_texture_webp", "EXT_texture_avif"];

/// Validation problems a message lists before it says how many more there are.
const SHOWN_PROBLEMS: usize = 3;

/// A parsed document, its GLB binary chunk, and the extensions it uses that this reader ignores.
pub(super) struct Read {
    pub(super) doc: ::gltf::Document,
    pub(super) blob: Option<Vec<u8>>,
    pub(super) ignored_extensions: Vec<String>,
}

/// Reads and parses the file at `path`: the document and the GLB binary chunk, if any. A required
/// extension this reader lacks is refused by name; the rest is checked by the `gltf` crate's
/// validation, except what the supported extensions allow (Draco-compressed attributes have no
/// buffer view).
pub(super) fn read(path: &Path) -> Result<Read, LoadError> {
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
    check_attribute_indices(&root).map_err(|e| invalid(&e))?;
    check_required(&root).map_err(|e| malformed(path, e))?;
    let ignored_extensions = root
        .extensions_used
        .iter()
        .filter(|e| !SUPPORTED_EXTENSIONS.contains(&e.as_str()))
        .cloned()
        .collect();
    // Checked above: the crate's own check knows only the extensions it implements itself.
    let required = std::mem::take(&mut root.extensions_required);
    validate(&root).map_err(|e| invalid(&e))?;
    root.extensions_required = required;
    Ok(Read {
        doc: ::gltf::Document::from_json_without_validation(root),
        blob,
        ignored_extensions,
    })
}

/// Refuses a document that requires an extension this reader does not implement, naming each.
fn check_required(root: &::gltf::json::Root) -> Result<(), String> {
    let missing: Vec<&str> = root
        .extensions_required
        .iter()
        .map(String::as_str)
        .filter(|e| !SUPPORTED_EXTENSIONS.contains(e))
        .collect();
    match missing.as_slice() {
        [] => Ok(()),
        [one] => Err(format!(
            "requires the glTF extension {one}, which is not supported"
        )),
        more => Err(format!(
            "requires the glTF extensions {}, which are not supported",
            more.join(", ")
        )),
    }
}

/// The `gltf` crate's validation, less what supported extensions allow, in one short line: the
/// first few problems and how many more there are.
fn validate(root: &::gltf::json::Root) -> Result<(), String> {
    use ::gltf::json::validation::{Error, Validate};
    let draco = draco_accessors(root);
    let mut problems = Vec::new();
    root.validate(
        root,
        ::gltf::json::Path::new,
        &mut |path: &dyn Fn() -> ::gltf::json::Path, error| {
            let path = path().0;
            // The accessors of Draco-compressed attributes describe the decoded data and have no
            // buffer view (KHR_draco_mesh_compression).
            let allowed = matches!(error, Error::Missing)
                && path
                    .strip_prefix("accessors[")
                    .and_then(|r| r.strip_suffix("].bufferView"))
                    .and_then(|i| i.parse::<usize>().ok())
                    .is_some_and(|i| draco.contains(&i));
            if !allowed {
                problems.push(format!("{path}: {error}"));
            }
        },
    );
    if problems.is_empty() {
        return Ok(());
    }
    let n = problems.len();
    problems.truncate(SHOWN_PROBLEMS);
    let mut text = problems.join("; ");
    if n > SHOWN_PROBLEMS {
        text += &format!("; and {} more", n - SHOWN_PROBLEMS);
    }
    Err(text)
}

/// The accessors that primitives compressed with KHR_draco_mesh_compression name (attributes and
/// indices): their data comes from the compressed stream.
fn draco_accessors(root: &::gltf::json::Root) -> std::collections::HashSet<usize> {
    let mut out = std::collections::HashSet::new();
    for prim in root.meshes.iter().flat_map(|m| &m.primitives) {
        let draco = prim
            .extensions
            .as_ref()
            .is_some_and(|e| e.others.contains_key(DRACO));
        if draco {
            out.extend(prim.attributes.values().map(|i| i.value()));
            out.extend(prim.indices.map(|i| i.value()));
        }
    }
    out
}

/// The name of the Draco extension.
pub(super) const DRACO: &str = "KHR_draco_mesh_compression";

/// The name of the quantization extension.
pub(super) const QUANTIZATION: &str = "KHR_mesh_quantization";

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

/// The names of the meshopt extension: the vendor one and the ratified one, which reads the same
/// bitstream and adds attribute codec version 1 and the COLOR filter (not decoded here: refused
/// by name, [`super::meshopt`]).
const MESHOPT: [&str; 2] = ["EXT_meshopt_compression", "KHR_meshopt_compression"];

/// True when `buffer` is a placeholder of a meshopt extension: marked as the fallback of
/// compressed views, or without data of its own (no URI and no GLB chunk left for it) in a file
/// that uses the extension. Its views are decoded from their compressed data, so it is never read
/// (and a marked one never loaded).
fn is_placeholder(buffer: &::gltf::Buffer, uses_meshopt: bool, blob_left: bool) -> bool {
    let marked = MESHOPT.iter().any(|name| {
        buffer
            .extension_value(name)
            .and_then(|e| e.get("fallback"))
            .and_then(|f| f.as_bool())
            .unwrap_or(false)
    });
    marked || (uses_meshopt && !blob_left && matches!(buffer.source(), ::gltf::buffer::Source::Bin))
}

/// Reads every buffer: the GLB binary chunk, a base64 data URI, or a file relative to the glTF file
/// within `reach` (a placeholder of compressed views is left empty: [`is_placeholder`]).
pub(super) fn load_buffers(
    path: &Path,
    doc: &::gltf::Document,
    mut blob: Option<Vec<u8>>,
    reach: &Reach,
) -> Result<Vec<Vec<u8>>, LoadError> {
    let dir = path.parent().unwrap_or(Path::new(""));
    let uses_meshopt = doc.extensions_used().any(|e| MESHOPT.contains(&e));
    let mut out = Vec::new();
    for buffer in doc.buffers() {
        let label = named("buffer", buffer.index(), buffer.name());
        if is_placeholder(&buffer, uses_meshopt, blob.is_some()) {
            out.push(Vec::new());
            continue;
        }
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
                let target = reach
                    .resolve(dir, &percent_decode(uri))
                    .map_err(|o| outside(path, &label, uri, o))?;
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

/// Decodes the buffer views compressed with EXT_meshopt_compression or KHR_meshopt_compression
/// (the same bitstream, of the versions [`super::meshopt`] reads): each one's decoded bytes
/// become a buffer of their own (appended to `buffers`) that the view then names, so accessors
/// (and images) read them as any other view.
pub(super) fn decode_compressed_views(
    path: &Path,
    doc: ::gltf::Document,
    buffers: &mut Vec<Vec<u8>>,
) -> Result<::gltf::Document, LoadError> {
    let mut root = doc.into_json();
    for (i, view) in root.buffer_views.iter_mut().enumerate() {
        let Some((name, ext)) = view.extensions.as_ref().and_then(|e| {
            MESHOPT
                .iter()
                .find_map(|name| Some((*name, e.others.get(*name)?)))
        }) else {
            continue;
        };
        let label = format!("buffer view #{i} ({name})");
        let fail = |e: String| malformed(path, format!("{label}: {e}"));
        let field = |k: &str| ext.get(k).and_then(|v| v.as_u64()).map(|v| v as usize);
        let (Some(source), Some(length), Some(stride), Some(count)) = (
            field("buffer"),
            field("byteLength"),
            field("byteStride"),
            field("count"),
        ) else {
            return Err(fail(
                "buffer, byteLength, byteStride and count are required".into(),
            ));
        };
        let offset = field("byteOffset").unwrap_or(0);
        let word =
            |k: &str, default: &'static str| ext.get(k).map_or(Some(default), |v| v.as_str());
        let mode = word("mode", "").and_then(super::meshopt::Mode::parse);
        let filter = word("filter", "NONE").and_then(super::meshopt::Filter::parse);
        if name == MESHOPT[1] && word("filter", "NONE") == Some("COLOR") {
            return Err(fail(
                "filter COLOR (of KHR_meshopt_compression) is not decoded by this reader".into(),
            ));
        }
        let (Some(mode), Some(filter)) = (mode, filter) else {
            return Err(fail(format!(
                "mode {} or filter {} is not one the extension defines",
                ext.get("mode").unwrap_or(&::gltf::json::Value::Null),
                ext.get("filter").unwrap_or(&::gltf::json::Value::Null)
            )));
        };
        let data = buffers
            .get(source)
            .and_then(|b| b.get(offset..offset.checked_add(length)?))
            .ok_or_else(|| {
                fail(format!(
                    "bytes {offset}..{} of buffer #{source} do not exist",
                    offset as u128 + length as u128
                ))
            })?;
        let decoded = super::meshopt::decode(data, count, stride, mode, filter).map_err(fail)?;
        if decoded.len() != view.byte_length.0 as usize {
            return Err(fail(format!(
                "{count} elements of {stride} bytes, but the view's byteLength is {}",
                view.byte_length.0
            )));
        }
        view.buffer = ::gltf::json::Index::new(buffers.len() as u32);
        view.byte_offset = Some(0u64.into());
        root.buffers.push(::gltf::json::Buffer {
            byte_length: decoded.len().into(),
            name: None,
            uri: None,
            extensions: None,
            extras: Default::default(),
        });
        buffers.push(decoded);
    }
    Ok(::gltf::Document::from_json_without_validation(root))
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
