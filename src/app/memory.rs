//! The memory a volume needs, checked against what the machine has before anything is allocated.

use super::report::human_bytes;
use crate::domain::VolumeRes;
use crate::domain::volume::Volume;
use crate::output;
use anyhow::bail;

/// Memory assumed when `/proc/meminfo` cannot be read: 8 GiB.
pub const FALLBACK_MEMORY_BYTES: u64 = 8 << 30;

/// Memory available to a new run: `MemAvailable` from `/proc/meminfo`, and whether it was read
/// (else [`FALLBACK_MEMORY_BYTES`]).
pub fn available_memory() -> (u64, bool) {
    let kb = std::fs::read_to_string("/proc/meminfo").ok().and_then(|s| {
        s.lines()
            .find_map(|l| l.strip_prefix("MemAvailable:"))
            .and_then(|r| r.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
    });
    match kb {
        Some(kb) => (kb.saturating_mul(1024), true),
        None => (FALLBACK_MEMORY_BYTES, false),
    }
}

/// Memory a volume of `dims` voxels needs ([`output::vti::bytes_per_voxel`] each), without
/// overflowing however large the request.
pub fn volume_bytes(dims: [usize; 3]) -> u128 {
    volume_bytes_at(dims, output::vti::bytes_per_voxel())
}

/// Bytes a voxel of a run needs: [`output::vti::bytes_per_voxel`], and in a gradient-domain run
/// (`gradient`) its replayed sums and reconstruction too
/// ([`crate::gradient_domain::bytes_per_cell`]).
pub fn bytes_per_voxel(gradient: bool) -> usize {
    output::vti::bytes_per_voxel()
        + if gradient {
            crate::gradient_domain::bytes_per_cell(3)
        } else {
            0
        }
}

/// Memory a volume of `dims` voxels of `per_voxel` bytes each needs, without overflowing however
/// large the request.
pub fn volume_bytes_at(dims: [usize; 3], per_voxel: usize) -> u128 {
    dims.iter()
        .fold(1u128, |a, &d| a.saturating_mul(d as u128))
        .saturating_mul(per_voxel as u128)
}

/// The voxel counts of `res` over a box of `size`, refused (naming `--volume` and the largest grid
/// of the same shape that would fit) when they need more than `available` bytes. Arithmetic only:
/// this runs before anything is allocated.
pub fn check_volume_memory(
    res: VolumeRes,
    size: glam::DVec3,
    available: u64,
    measured: bool,
) -> anyhow::Result<[usize; 3]> {
    check_volume_memory_at(
        res,
        size,
        available,
        measured,
        output::vti::bytes_per_voxel(),
    )
}

/// [`check_volume_memory`] for voxels of `per_voxel` bytes ([`bytes_per_voxel`]).
pub fn check_volume_memory_at(
    res: VolumeRes,
    size: glam::DVec3,
    available: u64,
    measured: bool,
    per_voxel: usize,
) -> anyhow::Result<[usize; 3]> {
    let dims = Volume::dims_for(res, size);
    let volume_bytes = |d: [usize; 3]| volume_bytes_at(d, per_voxel);
    let need = volume_bytes(dims);
    let fits = |d: [usize; 3]| volume_bytes(d) <= available as u128;
    if !fits(dims) {
        let suggestion = match res {
            VolumeRes::Longest(n) => {
                // Largest m < n whose grid fits (the count grows with m).
                let (mut lo, mut hi) = (0usize, n);
                while hi - lo > 1 {
                    let mid = lo + (hi - lo) / 2;
                    if fits(Volume::dims_for(VolumeRes::Longest(mid), size)) {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                (lo >= 1).then_some(VolumeRes::Longest(lo))
            }
            VolumeRes::Dims(d) => {
                let mut f = (available as f64 / need as f64).cbrt();
                let mut best = None;
                while f > 0.0 {
                    let e = d.map(|x| ((x as f64 * f).floor() as usize).clamp(1, x));
                    if fits(e) {
                        best = Some(VolumeRes::Dims(e));
                        break;
                    }
                    if e == [1, 1, 1] {
                        break;
                    }
                    f *= 0.99;
                }
                best
            }
        };
        let voxels = dims.iter().map(|&d| d as f64).product::<f64>();
        let have = format!(
            "this machine has {} available{}",
            human_bytes(available as f64),
            if measured {
                ""
            } else {
                " (assumed: /proc/meminfo could not be read)"
            }
        );
        let fit = match suggestion {
            Some(r) => format!("; --volume {r} would fit"),
            None => String::new(),
        };
        bail!(
            "--volume {res}: {}x{}x{} = {voxels:.1e} voxels need {} of memory ({} bytes each), \
             {have}{fit}",
            dims[0],
            dims[1],
            dims[2],
            human_bytes(need as f64),
            per_voxel
        );
    }
    if let Some(d) = dims.iter().find(|&&d| d > i32::MAX as usize) {
        bail!("--volume {res}: {d} voxels along one axis is more than a VTK image can index");
    }
    Ok(dims)
}
