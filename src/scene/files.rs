//! File names as scenes give them: a path's extension, which picks a scene reader or an image
//! decoder, relative URIs (a glTF file's) read as paths, where they may lead ([`Reach`]: inside
//! the scene file's folder unless the load opts out), and the check that a named file is a
//! regular one before it is opened (a FIFO would block the open or the read forever, a device
//! never end, a directory fail obscurely). A leaf: it imports nothing of `crate::scene`.

use std::path::{Path, PathBuf};

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

/// Where the files a scene file names (buffers, images, material libraries, maps, a sidecar's mesh
/// and environment map) may lie. A scene file may come from anywhere, so by default it reads only
/// inside its own folder and the folders below it: a name that is absolute, a `file:` URI, a
/// Windows drive or UNC path, one that climbs out with `..` (after percent-decoding; `/` and `\`
/// both separate) or one that resolves through a symbolic link to a place outside the folder is
/// refused. Opting in ([`Reach::Anywhere`]) reads names as paths relative to the scene's folder,
/// wherever they lead (a `file:` URI as its path).
#[derive(Clone, Debug)]
pub enum Reach {
    /// Inside `folder` (as the scene file's path gives it) or below; `real` is its canonical path,
    /// against which resolved links are checked.
    Folder {
        folder: PathBuf,
        real: Option<PathBuf>,
    },
    /// Anywhere (opted in).
    Anywhere,
}

/// A name that lies outside the folder a scene may read: the folder and why.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Outside {
    pub folder: PathBuf,
    pub why: String,
}

impl Reach {
    /// The reach of the scene file at `scene`: its own folder, or anywhere when `anywhere`.
    pub fn of(scene: &Path, anywhere: bool) -> Reach {
        if anywhere {
            return Reach::Anywhere;
        }
        let folder = match scene.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let real = std::fs::canonicalize(&folder).ok();
        Reach::Folder { folder, real }
    }

    /// The path to open for `name` (a path relative to folder `base`, which lies inside this
    /// reach; percent-decoded where it comes from a URI), or why it may not be read. A name that
    /// does not exist passes when it stays inside lexically: reading it reports it missing.
    pub fn resolve(&self, base: &Path, name: &str) -> Result<PathBuf, Outside> {
        let (folder, real) = match self {
            Reach::Anywhere => return Ok(base.join(file_uri_path(name).unwrap_or(name))),
            Reach::Folder { folder, real } => (folder, real),
        };
        let outside = |why: String| Outside {
            folder: folder.clone(),
            why,
        };
        let b = name.as_bytes();
        if b.len() >= 5 && b[..5].eq_ignore_ascii_case(b"file:") {
            return Err(outside("a file: URI names an absolute path".into()));
        }
        if b.len() >= 2 && b[0].is_ascii_alphabetic() && b[1] == b':' {
            return Err(outside("a Windows drive path".into()));
        }
        if name.starts_with('/') || name.starts_with('\\') {
            return Err(outside("an absolute path".into()));
        }
        let target = base.join(name);
        // Lexically, from the folder: `..` may not climb above it.
        let below = base.strip_prefix(folder).unwrap_or(Path::new(""));
        let mut depth = 0usize;
        let rest = below.to_string_lossy().into_owned() + "/" + name;
        for part in rest.split(['/', '\\']) {
            match part {
                "" | "." => {}
                ".." if depth == 0 => {
                    return Err(outside("'..' climbs out of the folder".into()));
                }
                ".." => depth -= 1,
                _ => depth += 1,
            }
        }
        // Symbolic links: where it really is.
        if let (Some(root), Ok(to)) = (real, std::fs::canonicalize(&target))
            && !to.starts_with(root)
        {
            return Err(outside(format!(
                "it resolves through a symbolic link to {}",
                to.display()
            )));
        }
        Ok(target)
    }
}

/// The path of a `file:` URI (`file:///p`, `file://localhost/p`, `file:/p`), if `name` is one.
fn file_uri_path(name: &str) -> Option<&str> {
    let rest = name
        .get(..5)?
        .eq_ignore_ascii_case("file:")
        .then(|| &name[5..])?;
    match rest.strip_prefix("//") {
        Some(r) => r
            .strip_prefix("localhost")
            .or(Some(r))
            .filter(|p| p.starts_with('/')),
        None => Some(rest),
    }
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
    fn names_outside_the_folder_are_refused() {
        let dir = std::env::temp_dir().join(format!("ftpd3d-reach-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("sub")).unwrap();
        std::fs::write(dir.join("sub/in.bin"), b"x").unwrap();
        let scene = dir.join("s.gltf");
        let reach = Reach::of(&scene, false);
        for bad in [
            "../outside.bin",
            "/etc/passwd",
            "/proc/self/environ",
            "sub/../../x.bin",
            "file:///etc/passwd",
            "C:\\Windows\\x.bin",
            "..\\x.bin",
            "\\\\server\\share\\x.bin",
        ] {
            assert!(reach.resolve(&dir, bad).is_err(), "{bad}");
        }
        for good in [
            "sub/in.bin",
            "sub/../sub/in.bin",
            "./missing.bin",
            "a%2Fb",
            "é",
        ] {
            assert!(reach.resolve(&dir, good).is_ok(), "{good}");
        }
        // From a subfolder (a material library's), `..` may come back up to the folder.
        assert!(reach.resolve(&dir.join("sub"), "../x.png").is_ok());
        assert!(reach.resolve(&dir.join("sub"), "../../x.png").is_err());
        #[cfg(unix)]
        {
            let link = dir.join("link.bin");
            let _ = std::fs::remove_file(&link);
            std::os::unix::fs::symlink("/etc/hostname", &link).unwrap();
            let e = reach.resolve(&dir, "link.bin").unwrap_err();
            assert!(e.why.contains("symbolic link"), "{e:?}");
        }
        let anywhere = Reach::of(&scene, true);
        assert_eq!(
            anywhere.resolve(&dir, "file:///etc/passwd").unwrap(),
            Path::new("/etc/passwd")
        );
        assert_eq!(
            anywhere.resolve(&dir, "../x.bin").unwrap(),
            dir.join("../x.bin")
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn percent_decoding() {
        assert_eq!(percent_decode("a%20b.bin"), "a b.bin");
        assert_eq!(percent_decode("100%"), "100%");
        assert_eq!(percent_decode("x%zz"), "x%zz");
    }
}
