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
//! | `exact.shift.rNN.<sum>`        | Float64       | gradient-domain runs only (`gradient.alpha` in the description): per replicate `r00` … `r15` the samples (`n`), their sums (`w`, `wd`, `wd2`) and those of their replays at the upper neighbour along `x`, `y` and `z` (`x.w` … `z.wd2`), bit for bit ([`crate::gradient_domain::Shift`]) |
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
//!
//! The writer (`write`) streams every array to the file cell by cell; the reader (`read`) reads
//! this tool's own files back, exactly. Both encode the appended data as base64 (`base64`).

mod base64;
mod read;
mod write;

pub use read::read_vti;
pub use write::{VtiArray, vti_arrays, write_vti, write_vti_with};

use crate::field::Field;
use crate::ftpd::moments::{CellValue, Moments};
use crate::output::f32_of;
use glam::DVec3;
use std::collections::BTreeMap;
use std::fmt::Write as _;

/// A volume file's grid and contents.
#[derive(Clone, Debug, PartialEq)]
pub struct Vti {
    pub field: Field,
    /// Position of the first point (the centre of voxel (0, 0, 0)).
    pub origin: DVec3,
    pub spacing: DVec3,
    /// The Float64 arrays besides the exact sums, by name: a run's progress (`pass.done`,
    /// `pass.units`: see [`write_vti_with`]) and the separatrices' arrays; empty for a finished
    /// run without separatrices.
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
