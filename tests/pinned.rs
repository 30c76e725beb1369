//! Exact sums pinned: a few cells of small runs of the shipped scenes, and a checksum over every
//! cell's sums, as computed by 8ae9f4f (the last version with 128 specialised kernels) from the
//! same command lines. A change that alters any sum of these runs by one bit fails here: refactors
//! of the kernel, the transport and the driver must keep results bit-identical, or say in their
//! commit why an operation order had to change (and update the values with that reason).
//! Deliberate changes of the estimator re-pinned since: Russian roulette from the fifth scattering
//! event on β·η² (radiance runs); Owen-scrambled Sobol' points for the first numbers of each
//! sample and the cone offset drawn before the start direction (every run); the lights' images in
//! planar mirrors sampled at the cell and at radiance-path vertices (radiance runs of scenes with
//! planar mirrors: the Cornell box and the flatland mirrors); the standard error's product sums
//! taken over groups of 8 samples (one scrambled Sobol' sequence each) with triple product sums
//! and group counts added to the checksum (every run; the pinned cells' sums unchanged).
//! Radiance-weighted samples' cell position drawn from the random stream instead of the first
//! two Sobol' dimensions (radiance runs; the unweighted and camera runs unchanged).
//! On a mismatch the test prints every actual pin and checksum.
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
        .chain(c.cube)
        {
            sum = sum.rotate_left(5) ^ v.to_bits();
        }
        sum = sum.rotate_left(5) ^ c.n ^ (c.batches << 32);
        sum = sum.rotate_left(5) ^ c.groups;
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
    let r = ftpd3d(&a);
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
                0x400e1259b15e7258,
                0x404d88ab964df38b,
                0x40933d5223a38ddb,
            ),
            (
                35,
                16,
                0x40399cae75614142,
                0x40405eda267b2da7,
                0x4072c3cf11c99d9c,
            ),
        ],
        0x4cf1e7968e5d2673,
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
                0x402cf0a3d70a3d71,
                0x4008abcc45856400,
                0x401dde614f3ad49d,
            ),
            (
                5,
                16,
                0x402a9b22d0e56041,
                0x4045a51e0bc4e3cf,
                0x4089e900ab2263d6,
            ),
        ],
        0xab2f63b72c7c3884,
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
            (32, 16, 0x40392459c77d48de, 0x0, 0x0),
            (47, 16, 0x4031a04cb44dc658, 0x0, 0x0),
        ],
        0x117caa466fcba592,
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
                0x4011dd3239546b72,
                0x401da63ee998a027,
                0x404a7102a6189fde,
            ),
            (
                87,
                8,
                0x4012d8864561f61c,
                0x402733abee8dea77,
                0x4056945dc065e5b1,
            ),
        ],
        0x754a4660bf2528b8,
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
                0x403f827c564c4e7c,
                0x4072c05c63830805,
                0x40b27f67a92ff07c,
            ),
            (
                106,
                8,
                0x402cbb93f6c9c770,
                0x4063e66eb52d4eaf,
                0x40a2662438c32499,
            ),
        ],
        0x8cb72a918e9dc55b,
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
            (48, 16, 0x0, 0x0, 0x0),
            (
                77,
                16,
                0x4070b2dc9c702b01,
                0x408c9af7bdaef4e8,
                0x40d9b012b6cec127,
            ),
        ],
        0x9a7abc90d506f61,
    );
}
