//! Exact sums pinned: a few cells of small runs of the shipped scenes, and a checksum over every
//! cell's sums, as computed by 8ae9f4f (the last version with 128 specialised kernels) from the
//! same command lines. A change that alters any sum of these runs by one bit fails here: refactors
//! of the kernel, the transport and the driver must keep results bit-identical, or say in their
//! commit why an operation order had to change (and update the values with that reason).
//! Deliberate changes of the estimator re-pinned since: Russian roulette from the fifth scattering
//! event on β·η² (radiance runs). On a mismatch the test prints every actual pin and checksum.
//!
//! The runs cover each kernel (3D and flatland, with and without radiance estimates), the domains
//! (slice, camera, volume), every material kind the shipped scenes have (diffuse, mirror,
//! dielectric) and both kinds of light (area, point).

use crate::support::{ftpd3d, temp_dir};
use ftpd3d::field::Field;
use std::path::Path;

/// (cell, samples, Σc, ΣcΔ, ΣcΔ² as f64 bits).
type Pin = (usize, u64, u64, u64, u64);

fn read(path: &Path) -> Field {
    if path.extension().is_some_and(|e| e == "vti") {
        ftpd3d::output::vti::read_vti(path).unwrap().field
    } else {
        ftpd3d::output::exr::read_exr(path).unwrap()
    }
}

/// Every exact sum of every cell folded into one word (order-sensitive).
fn checksum(f: &Field) -> u64 {
    let mut sum: u64 = 0;
    for c in &f.cells {
        for v in [
            c.s0,
            c.s1,
            c.s2,
            c.comp[0],
            c.comp[1],
            c.comp[2],
            c.fluence.x,
            c.fluence.y,
            c.fluence.z,
        ]
        .into_iter()
        .chain(c.cross)
        {
            sum = sum.rotate_left(5) ^ v.to_bits();
        }
        sum = sum.rotate_left(5) ^ c.n ^ (c.batches << 32);
    }
    sum
}

fn check(name: &str, args: &[&str], pins: &[Pin], sum: u64) {
    let dir = temp_dir("pinned", name);
    let out = dir.join(if args.contains(&"--volume") {
        "f.vti"
    } else {
        "f.exr"
    });
    let mut a = args.to_vec();
    let o = out.to_str().unwrap();
    a.extend(["--quiet", "--no-png", "-o", o]);
    let r = ftpd3d(None, &a);
    assert!(r.ok, "{name}: {}", r.err);
    let f = read(&out);
    let actual: Vec<Pin> = pins
        .iter()
        .map(|&(k, ..)| {
            let c = &f.cells[k];
            (k, c.n, c.s0.to_bits(), c.s1.to_bits(), c.s2.to_bits())
        })
        .collect();
    if actual != pins || checksum(&f) != sum {
        // Everything a deliberate change of the estimator needs to re-pin, in one run.
        eprintln!("{name}: actual pins");
        for (k, n, s0, s1, s2) in &actual {
            eprintln!("            ({k}, {n}, {s0:#x}, {s1:#x}, {s2:#x}),");
        }
        eprintln!("{name}: actual checksum {:#x}", checksum(&f));
    }
    for &(k, n, s0, s1, s2) in pins {
        let c = &f.cells[k];
        assert_eq!(
            (c.n, c.s0.to_bits(), c.s1.to_bits(), c.s2.to_bits()),
            (n, s0, s1, s2),
            "{name}: cell {k} ({} {} {})",
            c.s0,
            c.s1,
            c.s2
        );
    }
    assert_eq!(checksum(&f), sum, "{name}: checksum over every cell");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn slice_radiance_cornell_box_with_mirror() {
    check(
        "cornell",
        &[
            "--scene",
            "scenes/cornell_mirror.obj",
            "--slice",
            "z=0",
            "--res",
            "12",
            "--spp",
            "16",
        ],
        &[
            (
                48,
                16,
                0x402001938dd47a69,
                0x404e2bb559c93d61,
                0x40944d45edc43fe4,
            ),
            (
                35,
                16,
                0x40486454f5e278e5,
                0x4093b16e0da3a802,
                0x40e08706591e7413,
            ),
        ],
        0x7fde24c7563ae517,
    );
}

#[test]
fn slice_unweighted_glass_sphere() {
    check(
        "glass",
        &[
            "--scene",
            "scenes/glass_sphere.obj",
            "--slice",
            "z=0",
            "--res",
            "12",
            "--spp",
            "16",
            "--weight",
            "unweighted",
        ],
        &[
            (
                20,
                16,
                0x4028dc28f5c28f5b,
                0x40445d91cde0381b,
                0x40844645f26d5799,
            ),
            (
                5,
                16,
                0x4025ed0e56041893,
                0x40612af458dc085b,
                0x40ab5b0c85119d82,
            ),
        ],
        0x8aa785babae5e61d,
    );
}

#[test]
fn flatland_radiance_two_mirrors() {
    check(
        "flat",
        &[
            "--scene",
            "scenes/flat_mirrors.obj",
            "--slice",
            "z=0",
            "--flatland",
            "--res",
            "12",
            "--spp",
            "16",
        ],
        &[
            (32, 16, 0x401ba6e843fc4b06, 0x0, 0x0),
            (
                47,
                16,
                0x404d53160e43603a,
                0x409346ffec82e297,
                0x40ddcda098103f49,
            ),
        ],
        0x67407e2b405f2776,
    );
}

#[test]
fn camera_importance_with_point_light() {
    check(
        "camera",
        &[
            "--scene",
            "scenes/cornell_point.gltf",
            "--camera",
            "--size",
            "12,12",
            "--spp",
            "8",
            "--t0",
            "1",
            "--t1",
            "6",
        ],
        &[
            (
                48,
                8,
                0x3ff4e7d4116ef495,
                0x40051cd0d3cc9146,
                0x403775cf5eb748f7,
            ),
            (
                87,
                8,
                0x400a7757b1236f49,
                0x4032cd0a61ae9566,
                0x40692a1bf54e1bf8,
            ),
        ],
        0x36007b0c424bea29,
    );
}

#[test]
fn volume_radiance_cornell_box() {
    check(
        "volume",
        &[
            "--scene",
            "scenes/cornell_mirror.obj",
            "--volume",
            "5",
            "--spp",
            "8",
        ],
        &[
            (
                41,
                8,
                0x403c01bf300a826f,
                0x4052f95c8109cfd4,
                0x408a8e800d3db956,
            ),
            (
                106,
                8,
                0x402f75a99954d296,
                0x40684ee80a560dc4,
                0x40b6deebc0c968af,
            ),
        ],
        0xfda4a5b7834ad209,
    );
}

#[test]
fn slice_radiance_point_light() {
    check(
        "point",
        &[
            "--scene",
            "scenes/plane_point.toml",
            "--slice",
            "z=0",
            "--res",
            "12",
            "--spp",
            "16",
        ],
        &[
            (48, 16, 0, 0, 0),
            (
                77,
                16,
                0x40714379021e6d6d,
                0x409433c9b24548d3,
                0x40dc3d566e219b3e,
            ),
        ],
        0xc885d610bb52f603,
    );
}
