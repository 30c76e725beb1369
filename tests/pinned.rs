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
//! Samples of several deflection pairs (`ftpd::Design`, 2,2,1,2 by default), each walk from a
//! random stream of its own, and the Sobol' dimensions given to the cell position and the
//! direction first, the run lengths' and cone directions' offsets after them (every run).
//! Start directions in scenes with planar mirrors drawn uniformly, towards the lights and towards
//! their mirror images with probabilities 0.5, 0.35, 0.15 instead of 0.4, 0.3, 0.3 (radiance runs
//! of the Cornell box and the flatland mirrors).
//! Radiance-weighted samples take two cone directions (the design 2,2,2,2; every radiance run).
//! Shadow rays towards an area light's point ending off the emitter along its normal instead of
//! short along the ray (radiance runs of the Cornell box: the checksums; the pinned cells unchanged).
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
                0x401053d548feb01d,
                0x404881727175387a,
                0x40918bbe231bc9b1,
            ),
            (
                35,
                16,
                0x4032fa9aaae3c458,
                0x4061db1900d00072,
                0x40ac94ce67c850f0,
            ),
        ],
        0x3979e9c7cd47c631,
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
                0x402beb851eb851ec,
                0x404264671bce6eff,
                0x4086db79b2960777,
            ),
            (
                5,
                16,
                0x402a733333333333,
                0x4053c6ec0917d794,
                0x409d198796717229,
            ),
        ],
        0x5f56c0bedeb35d00,
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
            (32, 16, 0x40411399ba769f19, 0x0, 0x0),
            (47, 16, 0x403b65498d850a87, 0x0, 0x0),
        ],
        0x5fc505ac7695aa85,
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
                0x400ddd53c36bfdae,
                0x4007cabf410aa076,
                0x40344d9c7b82a76d,
            ),
            (
                87,
                8,
                0x400c5be2bfe088ad,
                0x401d27f581ef2bfb,
                0x404fb22e7f31c0d6,
            ),
        ],
        0x2549f5f390424a5,
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
                0x403abd2d96173317,
                0x4062dc0c85574b1a,
                0x40aef0af5b5de356,
            ),
            (
                106,
                8,
                0x4023f6cc5954f332,
                0x404d9b61c7a5c408,
                0x4096f40038bb0f41,
            ),
        ],
        0x926c990fa93dae69,
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
                0x409583b9af678182,
                0x40d04a09921b4edd,
                0x411c5d580d1c8e10,
            ),
        ],
        0x7066131fc9097900,
    );
}
