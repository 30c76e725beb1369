//! File names as scenes give them: a path's extension, which picks a scene reader or an image
//! decoder, relative URIs (a glTF file's) read as paths, and the check that a named file is a
//! regular one before it is opened (a FIFO would block the open or the read forever, a device
//! never end, a directory fail obscurely). A leaf: it imports nothing of `crate::scene`.

use std::path::Path;

/// A path's extension in lower case.
pub fn extension(path: &Path) -> Option<String> {
    path.extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
}

/// Undoes `%XX` escapes of a relative URI (invalid escapes are kept as they are).
pub fn percent_decode(uri: &str) -> String {
    let b = uri.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = |c: u8| (c as char).to_digit(16);
        if b[i] == b'%'
            && i + 2 < b.len()
            && let (Some(h), Some(l)) = (hex(b[i + 1]), hex(b[i + 2]))
        {
            out.push((h * 16 + l) as u8);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// An OpenEXR image's texels: RGBA per texel, row-major from the top row.
pub struct ExrTexels {
    pub width: usize,
    pub height: usize,
    pub rgba: Vec<[f32; 4]>,
    /// The image's channels: 1 (luminance Y only), 3 (R, G, B) or 4 (with A).
    pub channels: u8,
}

/// Reads the first layer of an OpenEXR file: its R, G, B (and A) channels, or a luminance-only
/// image's Y channel as grey (alpha 1 where the file has none). Channels may carry a layer prefix
/// (`diffuse.R`).
pub fn read_exr(path: &Path) -> Result<ExrTexels, Box<dyn std::error::Error + Send + Sync>> {
    let image = exr::prelude::read_first_flat_layer_from_file(path)?;
    let layer = image.layer_data;
    let (width, height) = (layer.size.width(), layer.size.height());
    let channels = &layer.channel_data.list;
    let find = |name: &str| {
        channels.iter().find(|c| {
            let full = c.name.to_string();
            full == name || full.ends_with(&format!(".{name}"))
        })
    };
    let values = |c: &exr::prelude::AnyChannel<exr::prelude::FlatSamples>| {
        let v: Vec<f32> = c.sample_data.values_as_f32().collect();
        if v.len() == width * height {
            Ok(v)
        } else {
            Err(format!(
                "channel {} is subsampled; only full-resolution channels are read",
                c.name
            ))
        }
    };
    let (rgb, count) = match (find("R"), find("G"), find("B"), find("Y")) {
        (Some(r), Some(g), Some(b), _) => ([values(r)?, values(g)?, values(b)?], 3),
        (_, _, _, Some(y)) => {
            let y = values(y)?;
            ([y.clone(), y.clone(), y], 1)
        }
        _ => {
            let names: Vec<String> = channels.iter().map(|c| c.name.to_string()).collect();
            return Err(format!(
                "no R, G, B or Y channel (the channels are {})",
                names.join(", ")
            )
            .into());
        }
    };
    let alpha = match find("A") {
        Some(a) => Some(values(a)?),
        None => None,
    };
    let rgba = (0..width * height)
        .map(|i| {
            let a = alpha.as_ref().map_or(1.0, |a| a[i]);
            [rgb[0][i], rgb[1][i], rgb[2][i], a]
        })
        .collect();
    Ok(ExrTexels {
        width,
        height,
        rgba,
        channels: if alpha.is_some() { count + 1 } else { count },
    })
}

/// What is at `path` if it exists and is not a regular file (after following links): "a
/// directory", "a FIFO (named pipe)", ...; `None` for a regular file or nothing at all (opening it
/// then reports what is wrong). Asks for the metadata only, which never blocks.
pub fn not_regular(path: &Path) -> Option<&'static str> {
    let kind = std::fs::metadata(path).ok()?.file_type();
    if kind.is_file() {
        return None;
    }
    if kind.is_dir() {
        return Some("a directory");
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if kind.is_fifo() {
            return Some("a FIFO (named pipe)");
        }
        if kind.is_char_device() {
            return Some("a character device");
        }
        if kind.is_block_device() {
            return Some("a block device");
        }
        if kind.is_socket() {
            return Some("a socket");
        }
    }
    Some("not a regular file")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn extensions_are_lower_case() {
        assert_eq!(extension(Path::new("a/B.GLB")).as_deref(), Some("glb"));
        assert_eq!(extension(Path::new("a/b")), None);
    }

    #[test]
    fn only_regular_files_pass() {
        assert_eq!(not_regular(Path::new("/definitely/not/here")), None);
        assert_eq!(not_regular(Path::new("/")), Some("a directory"));
        #[cfg(unix)]
        assert_eq!(
            not_regular(Path::new("/dev/null")),
            Some("a character device")
        );
    }

    #[test]
    fn percent_decoding() {
        assert_eq!(percent_decode("a%20b.bin"), "a b.bin");
        assert_eq!(percent_decode("100%"), "100%");
        assert_eq!(percent_decode("x%zz"), "x%zz");
    }
}
