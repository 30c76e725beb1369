//! The `.vti` reader: this tool's own volumes back, grid, exact sums, counts and metadata (not a
//! reader of every `.vti`).

use super::base64::{b64_decode, b64_len};
use super::{Vti, comment_unescape};
use crate::field::Field;
use crate::output::FileError;
use crate::output::exact::{ExactArrays, read_exact, read_shift};
use glam::DVec3;
use std::collections::BTreeMap;
use std::path::Path;

/// Reads a volume written by [`write_vti`](super::write_vti) back: grid, exact sums, sample and
/// batch counts, metadata. (A reader of this tool's own files, not of every `.vti`.)
pub fn read_vti(path: &Path) -> Result<Vti, FileError> {
    let bytes = std::fs::read(path).map_err(|source| FileError::read(path, source))?;
    let (head, data) = split(path, &bytes)?;
    let grid = grid(path, head, data.len())?;
    let (arrays, meta) = arrays_and_comments(path, head)?;
    if arrays.contains_key("exact.batch.sigma") && !arrays.contains_key("exact.sum.w.w") {
        return Err(FileError::EarlierVersion {
            path: path.to_path_buf(),
        });
    }
    let file = Appended {
        path,
        data,
        arrays,
        n: grid.n,
    };
    let [nx, ny, nz] = grid.dims;
    let mut field = Field::new(nx, ny, nz);
    field.meta = meta;
    read_exact(&mut field, &file)?;
    let mut extra = BTreeMap::new();
    for (name, (ty, _)) in &file.arrays {
        if !name.starts_with("exact.") && ty == "Float64" {
            extra.insert(name.clone(), file.float64s(name)?);
        }
    }
    // Every attribute reads as what it should be, or the file is refused naming it.
    field.info(&path.display().to_string())?;
    read_shift(path, &mut field, &file)?;
    Ok(Vti {
        field,
        origin: grid.origin,
        spacing: grid.spacing,
        extra,
    })
}

/// The error for a file that is not one of this tool's volumes, or is damaged.
fn not_ours(path: &Path, what: &str) -> FileError {
    FileError::format(path, format!("{what} (not an ftpd3d volume?)"))
}

/// The XML header (everything before `<AppendedData`) and the base64 appended data (after its
/// `_`), once the file is whole and of the layout the writer gives.
fn split<'a>(path: &Path, bytes: &'a [u8]) -> Result<(&'a str, &'a [u8]), FileError> {
    let not_ours = |what: &str| not_ours(path, what);
    if !bytes.trim_ascii_end().ends_with(b"</VTKFile>") {
        return Err(not_ours("truncated: no closing </VTKFile>"));
    }
    let tag = b"<AppendedData";
    let at = bytes
        .windows(tag.len())
        .position(|w| w == tag)
        .ok_or_else(|| not_ours("no <AppendedData>"))?;
    let underscore = at
        + bytes[at..]
            .iter()
            .position(|&b| b == b'_')
            .ok_or_else(|| not_ours("no '_' starting the appended data"))?;
    let head = std::str::from_utf8(&bytes[..at]).map_err(|_| not_ours("header is not UTF-8"))?;
    if !head.contains("byte_order=\"LittleEndian\"") || !head.contains("header_type=\"UInt64\"") {
        return Err(not_ours(
            "expected byte_order LittleEndian and header_type UInt64",
        ));
    }
    if !bytes[at..underscore].starts_with(b"<AppendedData encoding=\"base64\"") {
        return Err(not_ours("appended data is not base64"));
    }
    Ok((head, &bytes[underscore + 1..]))
}

/// The image's grid: points per axis, their count, the first point and the spacing.
struct Grid {
    dims: [usize; 3],
    n: usize,
    origin: DVec3,
    spacing: DVec3,
}

/// The grid of the `<ImageData>` tag of `head`, refused when damaged: whole, non-negative extents
/// from 0, and no more voxels than `data_len` bytes of appended data could hold (every voxel takes
/// bytes in each array), so that nothing is allocated for a damaged header.
fn grid(path: &Path, head: &str, data_len: usize) -> Result<Grid, FileError> {
    let not_ours = |what: &str| not_ours(path, what);
    let image = head
        .lines()
        .find(|l| l.trim_start().starts_with("<ImageData"))
        .ok_or_else(|| not_ours("no <ImageData>"))?;
    let nums = |name: &str| -> Result<Vec<f64>, FileError> {
        attr(image, name)
            .ok_or_else(|| not_ours(&format!("no {name}")))?
            .split_whitespace()
            .map(|t| {
                t.parse::<f64>()
                    .map_err(|_| not_ours(&format!("bad {name}")))
            })
            .collect()
    };
    let (ext, o, s) = (nums("WholeExtent")?, nums("Origin")?, nums("Spacing")?);
    if ext.len() != 6
        || o.len() != 3
        || s.len() != 3
        || ext[0] != 0.0
        || ext[2] != 0.0
        || ext[4] != 0.0
    {
        return Err(not_ours("unexpected WholeExtent, Origin or Spacing"));
    }
    if [ext[1], ext[3], ext[5]]
        .iter()
        .any(|&e| !(0.0..=1e15).contains(&e) || e.fract() != 0.0)
    {
        return Err(not_ours("unexpected WholeExtent"));
    }
    let dims = [ext[1], ext[3], ext[5]].map(|e| e as usize + 1);
    let n = dims
        .iter()
        .try_fold(1usize, |a, &d| a.checked_mul(d))
        .filter(|&n| n <= data_len)
        .ok_or_else(|| not_ours("more voxels than the appended data holds"))?;
    Ok(Grid {
        dims,
        n,
        origin: DVec3::new(o[0], o[1], o[2]),
        spacing: DVec3::new(s[0], s[1], s[2]),
    })
}

/// The arrays the header lists (name → type and offset into the appended data) and the run's
/// description from its comments.
type ArrayIndex = BTreeMap<String, (String, usize)>;

fn arrays_and_comments(
    path: &Path,
    head: &str,
) -> Result<(ArrayIndex, BTreeMap<String, String>), FileError> {
    let mut arrays = BTreeMap::new();
    let mut meta = BTreeMap::new();
    for l in head.lines() {
        let l = l.trim();
        if l.starts_with("<DataArray")
            && let (Some(name), Some(ty), Some(off)) =
                (attr(l, "Name"), attr(l, "type"), attr(l, "offset"))
        {
            let off: usize = off.parse().map_err(|_| not_ours(path, "bad offset"))?;
            arrays.insert(name.to_string(), (ty.to_string(), off));
        } else if let Some(kv) = l
            .strip_prefix("<!-- ftpd3d ")
            .and_then(|r| r.strip_suffix(" -->"))
            && let Some((k, v)) = kv.split_once('=')
        {
            meta.insert(comment_unescape(k), comment_unescape(v));
        }
    }
    Ok((arrays, meta))
}

/// The value of `name="..."` in an XML tag.
fn attr<'a>(tag: &'a str, name: &str) -> Option<&'a str> {
    let key = format!(" {name}=\"");
    let start = tag.find(&key)? + key.len();
    let len = tag[start..].find('"')?;
    Some(&tag[start..start + len])
}

/// The appended data of a file and the arrays in it, `n` values each.
struct Appended<'a> {
    path: &'a Path,
    data: &'a [u8],
    arrays: ArrayIndex,
    n: usize,
}

impl Appended<'_> {
    /// The bytes of array `name`, which must be of VTK type `ty` with `size` bytes a value.
    fn block(&self, name: &str, ty: &str, size: usize) -> Result<Vec<u8>, FileError> {
        let not_ours = |what: &str| not_ours(self.path, what);
        let n = self.n;
        let (t, off) = self
            .arrays
            .get(name)
            .ok_or_else(|| not_ours(&format!("no array '{name}'")))?;
        if t != ty {
            return Err(not_ours(&format!("array '{name}' is {t}, expected {ty}")));
        }
        let chars = b64_len(8 + (n * size) as u64) as usize;
        let decoded = off
            .checked_add(chars)
            .and_then(|end| self.data.get(*off..end))
            .and_then(b64_decode)
            .filter(|d| d.len() == 8 + n * size)
            .ok_or_else(|| not_ours(&format!("array '{name}' is truncated or not base64")))?;
        let len = u64::from_le_bytes(decoded[..8].try_into().expect("8 bytes"));
        if len != (n * size) as u64 {
            return Err(not_ours(&format!(
                "array '{name}' has {len} bytes, expected {}",
                n * size
            )));
        }
        Ok(decoded[8..].to_vec())
    }

    /// The Float64 array `name`.
    fn float64s(&self, name: &str) -> Result<Vec<f64>, FileError> {
        Ok(self
            .block(name, "Float64", 8)?
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
            .collect())
    }
}

impl ExactArrays for Appended<'_> {
    fn has_groups(&self) -> bool {
        self.arrays.contains_key("groups")
    }

    fn counts(&self, name: &str) -> Result<Vec<u64>, FileError> {
        Ok(self
            .block(name, "UInt32", 4)?
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes(c.try_into().expect("4 bytes")) as u64)
            .collect())
    }

    fn sums(&self, name: &str) -> Result<Vec<f64>, FileError> {
        self.float64s(&format!("exact.{name}"))
    }

    /// Required: a volume without the compensations is refused.
    fn compensation(&self, name: &str) -> Result<Option<Vec<f64>>, FileError> {
        self.sums(name).map(Some)
    }
}

#[cfg(test)]
mod tests {
    use super::super::write_vti;
    use super::*;

    #[test]
    fn damaged_files_are_refused_without_panicking() {
        let dir = std::env::temp_dir().join(format!("ftpd3d-vti-unit-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut field = Field::new(3, 2, 2);
        for (i, c) in field.cells.iter_mut().enumerate() {
            for k in 0..=i {
                c.add_sample(0.25 * k as f64, 0.1 + i as f64, DVec3::splat(0.5));
            }
            c.batches = 1;
        }
        field.meta.insert("seed".into(), "3".into());
        let good = dir.join("good.vti");
        write_vti(
            &good,
            &field,
            DVec3::new(0.5, 1.0, -2.0),
            DVec3::splat(0.25),
        )
        .unwrap();
        let back = read_vti(&good).unwrap();
        assert_eq!(back.field, field);
        assert_eq!(back.spacing, DVec3::splat(0.25));
        let text = std::fs::read_to_string(&good).unwrap();
        let bad = dir.join("bad.vti");
        let mut variants: Vec<String> = (0..text.len())
            .step_by(97)
            .map(|k| text[..k].to_string())
            .collect();
        for (from, to) in [
            (
                "WholeExtent=\"0 2 0 1 0 1\"",
                "WholeExtent=\"0 1e300 0 1 0 1\"",
            ),
            (
                "WholeExtent=\"0 2 0 1 0 1\"",
                "WholeExtent=\"0 -4 0 1 0 1\"",
            ),
            (
                "WholeExtent=\"0 2 0 1 0 1\"",
                "WholeExtent=\"0 2.5 0 1 0 1\"",
            ),
            (
                "WholeExtent=\"0 2 0 1 0 1\"",
                "WholeExtent=\"0 99999999 0 99999999 0 99999999\"",
            ),
            ("_", "_AAAAAAAAAA=="),
            ("encoding=\"base64\"", "encoding=\"raw\""),
        ] {
            assert!(text.contains(from), "{from}");
            variants.push(text.replacen(from, to, 1));
        }
        // An offset at the end of the address space, on an array the reader uses.
        let at = text.find("Name=\"samples\"").unwrap();
        let (a, b) = text.split_at(at);
        let q = b.find("offset=\"").unwrap() + 8;
        let r = q + b[q..].find('"').unwrap();
        variants.push(format!("{a}{}18446744073709551615{}", &b[..q], &b[r..]));
        for v in variants {
            std::fs::write(&bad, &v).unwrap();
            let Err(e) = read_vti(&bad) else {
                panic!("damaged file accepted: {v}")
            };
            assert!(e.to_string().contains("bad.vti"), "{e}");
        }
        std::fs::remove_dir_all(&dir).ok();
    }
}
