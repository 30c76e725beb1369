//! VTK XML ImageData (`.vti`) output of volumes: one file, every array in one appended block,
//! opening in ParaView as it is. Each array is a UInt64 byte count followed by its little-endian
//! values, base64-encoded (`<AppendedData encoding="base64">`, offsets in characters).
//!
//! Why base64 and not raw bytes: raw appended data is arbitrary bytes inside an XML document, which
//! VTK's own reader accepts but streaming XML parsers do not (the independent `vtkio` crate, with
//! which the tests read the files back, stops at the first byte that looks like `<`). Base64 costs a
//! third more disk and is read by every VTK XML reader; the layout (appended, offsets, UInt64
//! headers) is the same.
//!
//! Point data sit at voxel centres: the image's `Origin` is the centre of voxel (0, 0, 0) and its
//! `WholeExtent` is `0 nx-1 0 ny-1 0 nz-1`, so each point holds exactly one voxel's estimate (see
//! `domain::volume`). Point `i + nx·(j + ny·k)` is voxel (i, j, k).
//!
//! | array                          | type          | meaning                                         |
//! |--------------------------------|---------------|-------------------------------------------------|
//! | `ftpd` (the active scalars)    | Float32       | σ (eq. 14); 0 where `valid` = 0                 |
//! | `ftpd.stderr`, `ftpd.relerr`   | Float32       | standard error of σ (delta method over independent groups of samples, skewness-corrected), and /σ |
//! | `ftpd.mean`, `ftpd.m2`         | Float32       | weighted mean and second moment of Δ            |
//! | `weight`                       | Float32       | mean contribution weight ΣP / samples           |
//! | `fluence`                      | Float32 × 3   | incident radiance integrated over the sphere (RGB); zeros unless radiance-weighted |
//! | `grad.mag`                     | Float32       | ‖∇σ‖ in σ per scene unit (central differences, one-sided at borders and next to invalid voxels; 0 at invalid voxels) |
//! | `valid`                        | UInt8         | 1 where σ is defined (ΣP > 0)                   |
//! | `samples`, `batches`, `groups` | UInt32        | samples taken; batches (passes) that sampled it; independent groups of samples (for the standard error) |
//! | `exact.<sum>`                  | Float64       | the raw f64 sums, bit for bit: `exact.sum.w`, `exact.sum.wd`, `exact.sum.wd2`, `exact.sum.fluence.R/G/B`, the product sums over groups `exact.sum.w.w` … `exact.sum.wd2.wd2`, the triple product sums `exact.sum3.w.w.w` … `exact.sum3.wd2.wd2.wd2` |
//!
//! With `samples`, `batches` and `groups`, the `exact.*` arrays are each voxel's whole accumulator, so
//! [`read_vti`] gives back the field exactly and volumes merge by addition like EXR fields.
//!
//! The run's description (`field.meta`, the attributes of [`crate::run_info::RunInfo`]) is kept as
//! XML comments `<!-- ftpd3d key=value -->`
//! between `<VTKFile>` and `<ImageData>`, one per key; `%`, control characters and the second `-`
//! of `--` (which a comment may not contain) are percent-encoded. Comments are invisible to
//! ParaView and to every VTK reader, and readable with `head`: string arrays in `<FieldData>` would
//! show in ParaView's information panel, but VTK writes them as lists of character codes, which are
//! neither readable nor portable between VTK readers.

use crate::field::Field;
use crate::ftpd::Weighting;
use crate::ftpd::moments::{CellValue, Moments};
use crate::output::{EXACT, f32_of, write_atomically};
use anyhow::{Context, bail};
use glam::DVec3;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::Path;

/// A volume file's grid and contents.
#[derive(Clone, Debug, PartialEq)]
pub struct Vti {
    pub field: Field,
    /// Position of the first point (the centre of voxel (0, 0, 0)).
    pub origin: DVec3,
    pub spacing: DVec3,
    /// Arrays of a run's progress, by name (`pass.done`, `pass.units`: see [`write_vti_with`]),
    /// empty for a finished run.
    pub extra: BTreeMap<String, Vec<f64>>,
}

/// Bytes of memory a volume run needs per voxel, besides the scene: its accumulator while it runs,
/// then the finalised values and the gradient magnitude the writer holds (every other array is
/// streamed to the file cell by cell).
pub const fn bytes_per_voxel() -> usize {
    size_of::<Moments>() + size_of::<CellValue>() + size_of::<f32>()
}

/// Magnitude of the gradient of σ in σ per scene unit: along each axis the central difference over
/// twice the spacing where both neighbours are valid, a one-sided difference with the voxel itself
/// where only one is, 0 along axes with neither (and on axes one voxel thick). Invalid voxels get
/// 0. Never NaN: overflow is clamped to `f32::MAX`.
pub fn gradient_magnitude(vals: &[CellValue], dims: [usize; 3], spacing: DVec3) -> Vec<f32> {
    let [nx, ny, nz] = dims;
    let n = nx * ny * nz;
    assert_eq!(vals.len(), n, "one value per voxel");
    let ok = |i: usize| vals[i].valid && vals[i].sigma.is_finite();
    let strides = [1, nx, nx * ny];
    let (size, h) = (dims, [spacing.x, spacing.y, spacing.z]);
    let mut out = vec![0.0f32; n];
    for (idx, g) in out.iter_mut().enumerate() {
        if !ok(idx) {
            continue;
        }
        let c = [idx % nx, (idx / nx) % ny, idx / (nx * ny)];
        let centre = vals[idx].sigma;
        let mut sq = 0.0;
        for a in 0..3 {
            let prev = (c[a] > 0 && ok(idx - strides[a])).then(|| vals[idx - strides[a]].sigma);
            let next =
                (c[a] + 1 < size[a] && ok(idx + strides[a])).then(|| vals[idx + strides[a]].sigma);
            let d = match (prev, next) {
                (Some(p), Some(q)) => (q - p) / (2.0 * h[a]),
                (None, Some(q)) => (q - centre) / h[a],
                (Some(p), None) => (centre - p) / h[a],
                (None, None) => 0.0,
            };
            sq += d * d;
        }
        *g = f32_of(sq.sqrt());
    }
    out
}

/// Appends the little-endian bytes of one cell's value(s).
type PutCell<'a> = Box<dyn Fn(usize, &mut Vec<u8>) + 'a>;

/// One array of the file: name, VTK type, components, bytes per component, and the bytes of a cell.
struct Array<'a> {
    name: String,
    ty: &'static str,
    comps: usize,
    size: usize,
    put: PutCell<'a>,
}

impl Array<'_> {
    fn bytes(&self, cells: usize) -> u64 {
        (cells * self.comps * self.size) as u64
    }
}

fn f32_array<'a>(name: &str, f: impl Fn(usize) -> f64 + 'a) -> Array<'a> {
    Array {
        name: name.into(),
        ty: "Float32",
        comps: 1,
        size: 4,
        put: Box::new(move |i, b| b.extend_from_slice(&f32_of(f(i)).to_le_bytes())),
    }
}

/// Percent-encodes what an XML comment may not hold (`--`, control characters) and `%` itself.
fn comment_escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for ch in s.chars() {
        if ch == '%' || ch.is_control() || (ch == '-' && out.ends_with('-')) {
            let mut buf = [0u8; 4];
            for b in ch.encode_utf8(&mut buf).bytes() {
                let _ = write!(out, "%{b:02X}");
            }
        } else {
            out.push(ch);
        }
    }
    out
}

fn comment_unescape(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%'
            && i + 2 < b.len()
            && let Some(v) = std::str::from_utf8(&b[i + 1..i + 3])
                .ok()
                .and_then(|h| u8::from_str_radix(h, 16).ok())
        {
            out.push(v);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

const B64: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

/// Base64 characters for `bytes` bytes.
fn b64_len(bytes: u64) -> u64 {
    bytes.div_ceil(3) * 4
}

/// Streaming base64 encoder (standard alphabet, `=` padding) into a byte buffer.
#[derive(Default)]
struct B64 {
    pending: [u8; 3],
    len: usize,
}

impl B64 {
    fn push(&mut self, bytes: &[u8], out: &mut Vec<u8>) {
        for &b in bytes {
            self.pending[self.len] = b;
            self.len += 1;
            if self.len == 3 {
                Self::group(self.pending, 3, out);
                self.len = 0;
            }
        }
    }
    fn finish(&mut self, out: &mut Vec<u8>) {
        if self.len > 0 {
            let mut g = [0u8; 3];
            g[..self.len].copy_from_slice(&self.pending[..self.len]);
            Self::group(g, self.len, out);
            self.len = 0;
        }
    }
    fn group(g: [u8; 3], n: usize, out: &mut Vec<u8>) {
        let v = (g[0] as u32) << 16 | (g[1] as u32) << 8 | g[2] as u32;
        for k in 0..4 {
            out.push(if k <= n {
                B64[(v >> (18 - 6 * k)) as usize & 63]
            } else {
                b'='
            });
        }
    }
}

/// Decodes standard base64 (with `=` padding); `None` on anything else.
fn b64_decode(s: &[u8]) -> Option<Vec<u8>> {
    if !s.len().is_multiple_of(4) {
        return None;
    }
    let val = |c: u8| -> Option<u32> {
        Some(match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' => 62,
            b'/' => 63,
            _ => return None,
        } as u32)
    };
    let mut out = Vec::with_capacity(s.len() / 4 * 3);
    for (q, g) in s.chunks_exact(4).enumerate() {
        let last = q + 1 == s.len() / 4;
        let pad = g.iter().rev().take_while(|&&c| c == b'=').count();
        if pad > 2 || (pad > 0 && !last) {
            return None;
        }
        let mut v = 0u32;
        for &c in &g[..4 - pad] {
            v = v << 6 | val(c)?;
        }
        v <<= 6 * pad as u32;
        out.extend_from_slice(&v.to_be_bytes()[1..4 - pad]);
    }
    Some(out)
}

/// `x y z` with the shortest decimal that reads back as the same f64.
fn triple(v: DVec3) -> String {
    format!("{} {} {}", v.x, v.y, v.z)
}

/// Writes a volume (`field.depth` ≥ 1 layers of `width` × `height` voxels) with the first point at
/// `origin` (the centre of voxel (0, 0, 0)) and `spacing` between points. Written to a temporary
/// name, then renamed.
pub fn write_vti(path: &Path, field: &Field, origin: DVec3, spacing: DVec3) -> anyhow::Result<()> {
    write_vti_with(path, field, origin, spacing, &[])
}

/// [`write_vti`] with extra Float64 arrays (one value per voxel, field order), read back exactly
/// into [`Vti::extra`]: a partial run's `pass.done` and `pass.units`, which a resumed run needs.
pub fn write_vti_with(
    path: &Path,
    field: &Field,
    origin: DVec3,
    spacing: DVec3,
    extra: &[(&str, Vec<f64>)],
) -> anyhow::Result<()> {
    let dims = [field.width, field.height, field.depth];
    let n = dims.iter().product::<usize>();
    if n == 0 || n != field.cells.len() {
        bail!(
            "{}: a {}x{}x{} volume with {} cells",
            path.display(),
            dims[0],
            dims[1],
            dims[2],
            field.cells.len()
        );
    }
    if !(origin.is_finite() && spacing.is_finite() && spacing.min_element() > 0.0) {
        bail!(
            "{}: origin {origin} and spacing {spacing} must be finite, spacing > 0",
            path.display()
        );
    }
    if let Some(c) = field.cells.iter().find(|c| c.n > u32::MAX as u64) {
        bail!(
            "{}: a voxel holds {} samples, more than the UInt32 'samples' array can count",
            path.display(),
            c.n
        );
    }
    let vals = field.values();
    let grad = gradient_magnitude(&vals, dims, spacing);
    let radiance = field.info(&path.display().to_string())?.weighting == Some(Weighting::Radiance);
    let cells = &field.cells;
    let v = &vals;
    let mut arrays = vec![
        f32_array("ftpd", |i| v[i].sigma),
        f32_array("ftpd.stderr", |i| v[i].stderr),
        f32_array("ftpd.relerr", |i| {
            if v[i].valid && v[i].sigma > 0.0 {
                v[i].stderr / v[i].sigma
            } else {
                0.0
            }
        }),
        f32_array("ftpd.mean", |i| v[i].mean),
        f32_array("ftpd.m2", |i| v[i].m2),
        f32_array("weight", |i| v[i].weight),
        Array {
            name: "fluence".into(),
            ty: "Float32",
            comps: 3,
            size: 4,
            put: Box::new(move |i, b| {
                let f = if radiance {
                    cells[i].fluence()
                } else {
                    DVec3::ZERO
                };
                for x in f.to_array() {
                    b.extend_from_slice(&f32_of(x).to_le_bytes());
                }
            }),
        },
        Array {
            name: "grad.mag".into(),
            ty: "Float32",
            comps: 1,
            size: 4,
            put: Box::new(|i, b| b.extend_from_slice(&grad[i].to_le_bytes())),
        },
        Array {
            name: "valid".into(),
            ty: "UInt8",
            comps: 1,
            size: 1,
            put: Box::new(|i, b| b.push(v[i].valid as u8)),
        },
        Array {
            name: "samples".into(),
            ty: "UInt32",
            comps: 1,
            size: 4,
            put: Box::new(|i, b| b.extend_from_slice(&(cells[i].n as u32).to_le_bytes())),
        },
        Array {
            name: "batches".into(),
            ty: "UInt32",
            comps: 1,
            size: 4,
            put: Box::new(|i, b| {
                b.extend_from_slice(&(cells[i].batches.min(u32::MAX as u64) as u32).to_le_bytes())
            }),
        },
        Array {
            name: "groups".into(),
            ty: "UInt32",
            comps: 1,
            size: 4,
            put: Box::new(|i, b| b.extend_from_slice(&(cells[i].groups as u32).to_le_bytes())),
        },
    ];
    for &(name, get, _) in EXACT {
        arrays.push(Array {
            name: format!("exact.{name}"),
            ty: "Float64",
            comps: 1,
            size: 8,
            put: Box::new(move |i, b| b.extend_from_slice(&get(&cells[i]).to_le_bytes())),
        });
    }
    // The compensations of the weighted sums, so that volumes merge and resume exactly too.
    for (k, name) in ["sum.w.comp", "sum.wd.comp", "sum.wd2.comp"]
        .into_iter()
        .enumerate()
    {
        arrays.push(Array {
            name: format!("exact.{name}"),
            ty: "Float64",
            comps: 1,
            size: 8,
            put: Box::new(move |i, b| b.extend_from_slice(&cells[i].comp[k].to_le_bytes())),
        });
    }
    for (name, values) in extra {
        if values.len() != n {
            bail!(
                "{}: array '{name}' has {} values for {n} voxels",
                path.display(),
                values.len()
            );
        }
        arrays.push(Array {
            name: (*name).to_string(),
            ty: "Float64",
            comps: 1,
            size: 8,
            put: Box::new(move |i, b| b.extend_from_slice(&values[i].to_le_bytes())),
        });
    }

    let header = header(dims, origin, spacing, &field.meta, &arrays, n);
    write_atomically(path, |tmp| {
        let file = std::fs::File::create(tmp)
            .with_context(|| format!("{}: cannot create", tmp.display()))?;
        let mut w = std::io::BufWriter::with_capacity(1 << 20, file);
        w.write_all(header.as_bytes())?;
        let (mut raw, mut text) = (Vec::with_capacity(1 << 16), Vec::with_capacity(1 << 17));
        for a in &arrays {
            let mut enc = B64::default();
            enc.push(&a.bytes(n).to_le_bytes(), &mut text);
            for i in 0..n {
                (a.put)(i, &mut raw);
                if raw.len() >= 1 << 16 {
                    enc.push(&raw, &mut text);
                    raw.clear();
                    w.write_all(&text)?;
                    text.clear();
                }
            }
            enc.push(&raw, &mut text);
            raw.clear();
            enc.finish(&mut text);
            w.write_all(&text)?;
            text.clear();
        }
        w.write_all(b"\n  </AppendedData>\n</VTKFile>\n")?;
        w.into_inner()
            .map_err(|e| e.into_error())?
            .sync_all()
            .with_context(|| format!("{}: cannot flush", tmp.display()))?;
        Ok(())
    })
}

/// Everything before the first appended byte, ending in `_`.
fn header(
    dims: [usize; 3],
    origin: DVec3,
    spacing: DVec3,
    meta: &BTreeMap<String, String>,
    arrays: &[Array],
    cells: usize,
) -> String {
    let extent = format!("0 {} 0 {} 0 {}", dims[0] - 1, dims[1] - 1, dims[2] - 1);
    let mut h = String::new();
    h.push_str("<?xml version=\"1.0\"?>\n");
    h.push_str(
        "<VTKFile type=\"ImageData\" version=\"1.0\" byte_order=\"LittleEndian\" \
         header_type=\"UInt64\">\n",
    );
    for (k, v) in meta {
        let _ = writeln!(
            h,
            "  <!-- ftpd3d {}={} -->",
            comment_escape(k),
            comment_escape(v)
        );
    }
    let _ = writeln!(
        h,
        "  <ImageData WholeExtent=\"{extent}\" Origin=\"{}\" Spacing=\"{}\">",
        triple(origin),
        triple(spacing)
    );
    let _ = writeln!(h, "    <Piece Extent=\"{extent}\">");
    h.push_str("      <PointData Scalars=\"ftpd\">\n");
    let mut offset = 0u64;
    for a in arrays {
        let comps = if a.comps > 1 {
            format!(" NumberOfComponents=\"{}\"", a.comps)
        } else {
            String::new()
        };
        let _ = writeln!(
            h,
            "        <DataArray type=\"{}\" Name=\"{}\"{comps} format=\"appended\" offset=\"{offset}\">\
             </DataArray>",
            a.ty, a.name
        );
        offset += b64_len(8 + a.bytes(cells));
    }
    h.push_str("      </PointData>\n    </Piece>\n  </ImageData>\n");
    h.push_str("  <AppendedData encoding=\"base64\">\n   _");
    h
}

/// The value of `name="..."` in an XML tag.
fn attr<'a>(tag: &'a str, name: &str) -> Option<&'a str> {
    let key = format!(" {name}=\"");
    let start = tag.find(&key)? + key.len();
    let len = tag[start..].find('"')?;
    Some(&tag[start..start + len])
}

/// Reads a volume written by [`write_vti`] back: grid, exact sums, sample and batch counts,
/// metadata. (A reader of this tool's own files, not of every `.vti`.)
pub fn read_vti(path: &Path) -> anyhow::Result<Vti> {
    let bytes = std::fs::read(path).with_context(|| format!("{}: cannot read", path.display()))?;
    let not_ours =
        |what: &str| anyhow::anyhow!("{}: {what} (not an ftpd3d volume?)", path.display());
    if !bytes.trim_ascii_end().ends_with(b"</VTKFile>") {
        bail!(not_ours("truncated: no closing </VTKFile>"));
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
        bail!(not_ours(
            "expected byte_order LittleEndian and header_type UInt64"
        ));
    }
    if !bytes[at..underscore].starts_with(b"<AppendedData encoding=\"base64\"") {
        bail!(not_ours("appended data is not base64"));
    }
    let data = &bytes[underscore + 1..];
    let image = head
        .lines()
        .find(|l| l.trim_start().starts_with("<ImageData"))
        .ok_or_else(|| not_ours("no <ImageData>"))?;
    let nums = |name: &str| -> anyhow::Result<Vec<f64>> {
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
        bail!(not_ours("unexpected WholeExtent, Origin or Spacing"));
    }
    // Whole, non-negative extents, and no more voxels than the appended data could hold (every
    // voxel takes bytes in each array): a damaged header is refused before anything is allocated.
    if [ext[1], ext[3], ext[5]]
        .iter()
        .any(|&e| !(0.0..=1e15).contains(&e) || e.fract() != 0.0)
    {
        bail!(not_ours("unexpected WholeExtent"));
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
        bail!(
            "{}: written by an earlier ftpd3d, whose standard error came from batch σ sums; the \
             per-sample product sums the error needs now are not in it, so it cannot be merged: \
             run it again",
            path.display()
        );
    }
    // Written before the standard error was taken over groups of samples: see `legacy_groups`.
    let legacy = !offsets.contains_key("groups");
    let block = |name: &str, ty: &str, size: usize| -> anyhow::Result<Vec<u8>> {
        let (t, off) = offsets
            .get(name)
            .ok_or_else(|| not_ours(&format!("no array '{name}'")))?;
        if t != ty {
            bail!(not_ours(&format!("array '{name}' is {t}, expected {ty}")));
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
            bail!(not_ours(&format!(
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
    use super::*;

    fn cell(sigma: f64) -> CellValue {
        CellValue {
            sigma,
            valid: true,
            ..CellValue::default()
        }
    }

    #[test]
    fn gradient_of_a_ramp_is_exact_at_borders_and_next_to_holes() {
        // σ = 2x + 3y - z on a 5x4x3 grid with spacing (0.5, 0.25, 2).
        let (dims, h) = ([5, 4, 3], DVec3::new(0.5, 0.25, 2.0));
        let mut vals: Vec<CellValue> = (0..60)
            .map(|i| {
                let (x, y, z) = ((i % 5) as f64, ((i / 5) % 4) as f64, (i / 20) as f64);
                cell(2.0 * x * h.x + 3.0 * y * h.y - z * h.z + 10.0)
            })
            .collect();
        let hole = 2 + 5 * (1 + 4);
        vals[hole] = CellValue::default();
        let g = gradient_magnitude(&vals, dims, h);
        // Per axis the ramp's slope (2, 3, -1) exactly, wherever a neighbour along that axis is
        // usable; next to the hole with a border on the other side there is none (slope 0).
        let usable = |i: isize, a: usize, d: isize| -> bool {
            let c = [i % 5, (i / 5) % 4, i / 20];
            let size = [5, 4, 3];
            let stride = [1, 5, 20];
            let k = c[a] + d;
            k >= 0 && k < size[a] && i + d * stride[a] != hole as isize
        };
        for (i, &x) in g.iter().enumerate() {
            if i == hole {
                assert_eq!(x, 0.0);
                continue;
            }
            let mut want = 0.0f64;
            for (a, slope) in [2.0f64, 3.0, -1.0].into_iter().enumerate() {
                if usable(i as isize, a, -1) || usable(i as isize, a, 1) {
                    want += slope * slope;
                }
            }
            let want = want.sqrt() as f32;
            assert!((x - want).abs() < 1e-5, "voxel {i}: {x} vs {want}");
        }
        // Isolated and one-voxel-thick: 0, never NaN.
        let one = gradient_magnitude(&[cell(f64::MAX)], [1, 1, 1], DVec3::ONE);
        assert_eq!(one, vec![0.0]);
        let big = gradient_magnitude(&[cell(-f64::MAX), cell(f64::MAX)], [2, 1, 1], DVec3::ONE);
        assert!(big.iter().all(|x| x.is_finite()), "{big:?}");
    }

    #[test]
    fn base64_matches_rfc4648_vectors_and_round_trips() {
        for (plain, coded) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            let mut out = Vec::new();
            let mut e = B64::default();
            // Fed in pieces, as the writer does.
            for b in plain.as_bytes() {
                e.push(&[*b], &mut out);
            }
            e.finish(&mut out);
            assert_eq!(out, coded.as_bytes());
            assert_eq!(b64_len(plain.len() as u64), coded.len() as u64);
            assert_eq!(b64_decode(coded.as_bytes()).unwrap(), plain.as_bytes());
        }
        let all: Vec<u8> = (0..=255).collect();
        let mut out = Vec::new();
        let mut e = B64::default();
        e.push(&all, &mut out);
        e.finish(&mut out);
        assert_eq!(b64_decode(&out).unwrap(), all);
        assert!(b64_decode(b"Zg=").is_none() && b64_decode(b"Z===").is_none());
    }

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

    #[test]
    fn comments_escape_and_unescape() {
        for s in [
            "plain",
            "a--b",
            "-",
            "--",
            "x-",
            "50% of\nlines",
            "ü--ö",
            "%2D",
        ] {
            let e = comment_escape(s);
            assert!(!e.contains("--") && !e.contains('\n'), "{s:?} → {e:?}");
            assert_eq!(comment_unescape(&e), s);
        }
    }
}
