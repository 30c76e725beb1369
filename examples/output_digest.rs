//! One line per output, channel and header attribute of every file in a folder, for comparing the
//! outputs of two builds (`scripts/same-outputs.sh`). EXR files are read with the `exr` crate, not
//! with ftpd3d's own reader, so a change of that reader cannot hide a change of the files. Values
//! that measure the run rather than the field (wall-clock times) are left out; everything else is
//! compared exactly, as the bits of every sample.
//!
//! ```sh
//! cargo run --release --example output_digest -- DIR > digest.txt
//! ```

use anyhow::{Context, bail};
use std::fmt::Write as _;
use std::path::Path;

/// Attributes that change from one run to the next without the field changing.
fn volatile(key: &str) -> bool {
    key.ends_with("elapsed") || key.ends_with("remaining.time")
}

/// The same attributes as they appear in text files (`<!-- ftpd3d elapsed=... -->`).
const VOLATILE_TEXT: [&str; 2] = [" elapsed=", " remaining.time="];

fn contains(haystack: &[u8], needle: &[u8]) -> bool {
    haystack.windows(needle.len()).any(|w| w == needle)
}

/// FNV-1a: a fingerprint to compare, not a cryptographic hash.
fn fnv(bytes: impl IntoIterator<Item = u8>) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

fn exr_lines(path: &Path, name: &str, out: &mut String) -> anyhow::Result<()> {
    use exr::prelude::*;
    let image = read_all_flat_layers_from_file(path)
        .with_context(|| format!("{}: not readable as OpenEXR", path.display()))?;
    for (i, layer) in image.layer_data.iter().enumerate() {
        let mut attrs: Vec<String> = layer
            .attributes
            .other
            .iter()
            .filter(|(k, _)| !volatile(&k.to_string()))
            .map(|(k, v)| format!("{name} part{i} attr {k} = {v:?}"))
            .collect();
        attrs.push(format!(
            "{name} part{i} size {}x{} name {:?}",
            layer.size.0, layer.size.1, layer.attributes.layer_name
        ));
        attrs.sort();
        for a in attrs {
            writeln!(out, "{a}")?;
        }
        for ch in &layer.channel_data.list {
            let bytes: Vec<u8> = match &ch.sample_data {
                FlatSamples::F16(v) => v.iter().flat_map(|x| x.to_bits().to_le_bytes()).collect(),
                FlatSamples::F32(v) => v.iter().flat_map(|x| x.to_bits().to_le_bytes()).collect(),
                FlatSamples::U32(v) => v.iter().flat_map(|x| x.to_le_bytes()).collect(),
            };
            writeln!(
                out,
                "{name} part{i} channel {} {:016x}",
                ch.name,
                fnv(bytes)
            )?;
        }
    }
    Ok(())
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [dir] = args.as_slice() else {
        bail!("usage: output_digest DIR");
    };
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .with_context(|| format!("{dir}: not a readable folder"))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    let mut out = String::new();
    for path in &files {
        let name = path.file_name().unwrap_or_default().to_string_lossy();
        if path.extension().is_some_and(|e| e == "exr") {
            exr_lines(path, &name, &mut out)?;
            continue;
        }
        let bytes = std::fs::read(path).with_context(|| format!("{}", path.display()))?;
        // Text outputs (VTI and VTP headers, SVG, CSV) without the lines that carry wall-clock
        // times; a VTI's appended binary data is compared as it is.
        let kept = bytes
            .split_inclusive(|&b| b == b'\n')
            .filter(|line| !VOLATILE_TEXT.iter().any(|k| contains(line, k.as_bytes())))
            .flatten()
            .copied();
        let digest = fnv(kept);
        writeln!(out, "{name} {digest:016x}")?;
    }
    print!("{out}");
    Ok(())
}
