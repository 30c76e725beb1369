//! The `.vti` reader: this tool's own volumes back, grid, exact sums, counts and metadata (not a
//! reader of every `.vti`).

use super::base64::{b64_decode, b64_len};
use super::{Vti, comment_unescape};
use crate::field::Field;
use crate::output::{EXACT, FileError};
use glam::DVec3;
use std::collections::BTreeMap;
use std::path::Path;

/// The value of `name="..."` in an XML tag.
fn attr<'a>(tag: &'a str, name: &str) -> Option<&'a str> {
    let key = format!(" {name}=\"");
    let start = tag.find(&key)? + key.len();
    let len = tag[start..].find('"')?;
    Some(&tag[start..start + len])
}

/// Reads a volume written by [`write_vti`](super::write_vti) back: grid, exact sums, sample and
/// batch counts, metadata. (A reader of this tool's own files, not of every `.vti`.)
pub fn read_vti(path: &Path) -> Result<Vti, FileError> {
    let bytes = std::fs::read(path).map_err(|source| FileError::read(path, source))?;
    let not_ours = |what: &str| FileError::format(path, format!("{what} (not an ftpd3d volume?)"));
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
    let data = &bytes[underscore + 1..];
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
    // Whole, non-negative extents, and no more voxels than the appended data could hold (every
    // voxel takes bytes in each array): a damaged header is refused before anything is allocated.
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
        .filter(|&n| n <= data.len())
        .ok_or_else(|| not_ours("more voxels than the appended data holds"))?;
    let mut field = Field::new(dims[0], dims[1], dims[2]);
    let mut offsets = BTreeMap::new();
    for l in head.lines() {
        let l = l.trim();
        if l.starts_with("<DataArray")
            && let (Some(name), Some(ty), Some(off)) =
                (attr(l, "Name"), attr(l, "type"), attr(l, "offset"))
        {
            let off: usize = off.parse().map_err(|_| not_ours("bad offset"))?;
            offsets.insert(name.to_string(), (ty.to_string(), off));
        } else if let Some(kv) = l
            .strip_prefix("<!-- ftpd3d ")
            .and_then(|r| r.strip_suffix(" -->"))
            && let Some((k, v)) = kv.split_once('=')
        {
            field.meta.insert(comment_unescape(k), comment_unescape(v));
        }
    }
    if offsets.contains_key("exact.batch.sigma") && !offsets.contains_key("exact.sum.w.w") {
        return Err(FileError::EarlierVersion {
            path: path.to_path_buf(),
        });
    }
    // Written before the standard error was taken over groups of samples: see `legacy_groups`.
    let legacy = !offsets.contains_key("groups");
    let block = |name: &str, ty: &str, size: usize| -> Result<Vec<u8>, FileError> {
        let (t, off) = offsets
            .get(name)
            .ok_or_else(|| not_ours(&format!("no array '{name}'")))?;
        if t != ty {
            return Err(not_ours(&format!("array '{name}' is {t}, expected {ty}")));
        }
        let chars = b64_len(8 + (n * size) as u64) as usize;
        let decoded = off
            .checked_add(chars)
            .and_then(|end| data.get(*off..end))
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
    };
    for (i, c) in block("samples", "UInt32", 4)?.chunks_exact(4).enumerate() {
        field.cells[i].n = u32::from_le_bytes(c.try_into().expect("4 bytes")) as u64;
    }
    for (i, c) in block("batches", "UInt32", 4)?.chunks_exact(4).enumerate() {
        field.cells[i].batches = u32::from_le_bytes(c.try_into().expect("4 bytes")) as u64;
    }
    if legacy {
        crate::output::legacy_groups(&mut field);
    } else {
        for (i, c) in block("groups", "UInt32", 4)?.chunks_exact(4).enumerate() {
            field.cells[i].groups = u32::from_le_bytes(c.try_into().expect("4 bytes")) as u64;
        }
    }
    for &(name, _, set) in EXACT {
        if legacy && crate::output::is_triple_sum(name) {
            continue;
        }
        let b = block(&format!("exact.{name}"), "Float64", 8)?;
        for (i, c) in b.chunks_exact(8).enumerate() {
            set(
                &mut field.cells[i],
                f64::from_le_bytes(c.try_into().expect("8 bytes")),
            );
        }
    }
    for (k, name) in ["sum.w.comp", "sum.wd.comp", "sum.wd2.comp"]
        .into_iter()
        .enumerate()
    {
        let b = block(&format!("exact.{name}"), "Float64", 8)?;
        for (i, c) in b.chunks_exact(8).enumerate() {
            field.cells[i].comp[k] = f64::from_le_bytes(c.try_into().expect("8 bytes"));
        }
    }
    let mut extra = BTreeMap::new();
    for (name, (ty, _)) in &offsets {
        if name.starts_with("pass.") && ty == "Float64" {
            let b = block(name, "Float64", 8)?;
            let v = b
                .chunks_exact(8)
                .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
                .collect();
            extra.insert(name.clone(), v);
        }
    }
    // Every attribute reads as what it should be, or the file is refused naming it.
    field.info(&path.display().to_string())?;
    Ok(Vti {
        field,
        origin: DVec3::new(o[0], o[1], o[2]),
        spacing: DVec3::new(s[0], s[1], s[2]),
        extra,
    })
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
