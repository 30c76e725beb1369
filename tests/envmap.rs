//! Environment maps: Mitsuba 3's lat-long convention, the bilinear lookup, importance sampling
//! that matches it (a chi-square test of the sampled directions against the density), and the
//! files a map may come in (a luminance-only EXR, negative texels, a FIFO).

use crate::support::{chi2_test, temp_dir};
use ftpd3d::math::Rgb;
use ftpd3d::rng::Sampler;
use ftpd3d::scene::env::EnvMap;
use glam::DVec3;
use std::f64::consts::PI;

/// A 10 × 5 map: grey 0.2 everywhere, the top row 0.7, the bottom row 0.1, and a bright texel
/// 50 at column 2, row 2, whose centre is u = 2.5/10 = ¼, v = 2/4 = ½.
fn marked_map(rotation_deg: f64) -> EnvMap {
    let (w, h) = (10, 5);
    let texels = (0..w * h)
        .map(|k| {
            let (i, j) = (k % w, k / w);
            Rgb::splat(match (i, j) {
                (_, 0) => 0.7,
                (_, 4) => 0.1,
                (2, 2) => 50.0,
                _ => 0.2,
            })
        })
        .collect();
    EnvMap::new(w, h, texels, 1.0, rotation_deg, "marked").unwrap()
}

fn close(a: DVec3, b: DVec3) -> bool {
    (a - b).length() < 1e-12
}

/// Mitsuba 3's convention: u = ¼ looks along +x, u = ½ along +z, u = 0 along −z, the top row is
/// the zenith (+y); a rotation of 90° turns +x to +z. The texel at u = ¼, v = ½ is what a camera
/// looking along +x sees.
#[test]
fn env_map_follows_mitsubas_lat_long_convention() {
    let map = marked_map(0.0);
    assert!(close(map.direction(0.25, 0.5), DVec3::X));
    assert!(close(map.direction(0.5, 0.5), DVec3::Z));
    assert!(close(map.direction(0.0, 0.5), -DVec3::Z));
    assert!(close(map.direction(0.75, 0.5), -DVec3::X));
    assert!(close(map.direction(0.3, 0.0), DVec3::Y));
    assert!(close(map.direction(0.3, 1.0), -DVec3::Y));
    for (u, v) in [(0.1, 0.2), (0.25, 0.5), (0.9, 0.7), (0.6, 0.01)] {
        let (a, b) = map.uv(map.direction(u, v));
        assert!((a - u).abs() < 1e-12 && (b - v).abs() < 1e-12, "({u}, {v})");
    }
    assert_eq!(map.radiance(DVec3::X), Rgb::splat(50.0));
    assert_eq!(map.radiance(DVec3::Y), Rgb::splat(0.7));
    assert_eq!(map.radiance(-DVec3::Y), Rgb::splat(0.1));
    assert_eq!(map.radiance(DVec3::Z), Rgb::splat(0.2));
    // Turned by 90°: the patch moves from +x to +z.
    let turned = marked_map(90.0);
    assert_eq!(turned.radiance(DVec3::Z), Rgb::splat(50.0));
    assert!(close(turned.direction(0.25, 0.5), DVec3::Z));
}

/// Bilinear between texel centres: half-way between two columns the mean, half-way between two
/// rows the mean, and φ wraps around (u = 0 lies half-way between the last column and the first).
#[test]
fn env_map_lookup_is_bilinear_between_texel_centres() {
    let (w, h) = (4, 3);
    let texels: Vec<Rgb> = (0..w * h).map(|k| Rgb::splat(k as f64 + 1.0)).collect();
    let map = EnvMap::new(w, h, texels.clone(), 1.0, 0.0, "ramp").unwrap();
    let at = |i: usize, j: usize| texels[j * w + i].x;
    // Centres: u = (i + ½)/4, v = j/2.
    assert_eq!(map.radiance_at(0.375, 0.5).x, at(1, 1));
    assert!((map.radiance_at(0.5, 0.5).x - 0.5 * (at(1, 1) + at(2, 1))).abs() < 1e-12);
    assert!((map.radiance_at(0.375, 0.25).x - 0.5 * (at(1, 0) + at(1, 1))).abs() < 1e-12);
    assert!((map.radiance_at(0.0, 1.0).x - 0.5 * (at(3, 2) + at(0, 2))).abs() < 1e-12);
    let (fx, fy) = (0.3, 0.6);
    let (u, v) = ((1.5 + fx) / 4.0, (0.0 + fy) / 2.0);
    let want = (1.0 - fy) * ((1.0 - fx) * at(1, 0) + fx * at(2, 0))
        + fy * ((1.0 - fx) * at(1, 1) + fx * at(2, 1));
    assert!((map.radiance_at(u, v).x - want).abs() < 1e-12);
}

/// The sampled directions follow the density the map reports: 400,000 samples counted in the
/// cells between texel centres (where the density × sin θ is bilinear in (u, v)) against the
/// density's integral over each cell (2 × 2 midpoint rule: exact for a bilinear function), by
/// Pearson's chi-square at the suite's significance. A map with black texels, a bright one and
/// a gradient, turned by 25°.
#[test]
fn env_map_samples_follow_the_bilinear_density() {
    let (w, h) = (16, 9);
    let texels: Vec<Rgb> = (0..w * h)
        .map(|k| {
            let (i, j) = (k % w, k / w);
            if (3..5).contains(&i) {
                Rgb::ZERO
            } else if (i, j) == (11, 3) {
                Rgb::new(30.0, 20.0, 5.0)
            } else {
                Rgb::new(0.3 + 0.1 * i as f64, 0.5, 1.0 - 0.1 * j as f64)
            }
        })
        .collect();
    let map = EnvMap::new(w, h, texels, 2.0, 25.0, "gradient").unwrap();
    let cell_of = |d: DVec3| {
        let (u, v) = map.uv(d);
        let x = (u * w as f64 - 0.5).rem_euclid(w as f64);
        let i = (x as usize).min(w - 1);
        let j = ((v * (h - 1) as f64) as usize).min(h - 2);
        j * w + i
    };
    let n = 400_000;
    let mut counts = vec![0.0; w * (h - 1)];
    let mut s = Sampler::new(47, 0, 0);
    for _ in 0..n {
        let (d, pdf) = map.sample_sphere(s.next_2d()).unwrap();
        assert!(pdf > 0.0 && pdf.is_finite());
        counts[cell_of(d)] += 1.0;
    }
    let mut expected = vec![0.0; w * (h - 1)];
    let (du, dv) = (1.0 / w as f64, 1.0 / (h - 1) as f64);
    for j in 0..h - 1 {
        for i in 0..w {
            let mut mass = 0.0;
            for (a, b) in [(0.25, 0.25), (0.75, 0.25), (0.25, 0.75), (0.75, 0.75)] {
                let u = ((i as f64 + 0.5 + a) * du).rem_euclid(1.0);
                let v = (j as f64 + b) * dv;
                let jac = 2.0 * PI * PI * (PI * v).sin();
                mass += map.pdf_sphere(map.direction(u, v)) * jac * du * dv / 4.0;
            }
            expected[j * w + i] = n as f64 * mass;
        }
    }
    let err: Vec<f64> = expected.iter().map(|e| 1e-9 * e + 1e-9).collect();
    chi2_test("env map samples", &counts, &expected, &err);
}

/// A luminance-only (Y) OpenEXR map is read as grey; negative and non-finite texels become 0 with
/// a note that names the file and counts them.
#[test]
fn env_map_reads_luminance_exr_and_clears_negative_texels() {
    use exr::prelude::*;
    let dir = temp_dir("envmap", "luminance");
    let path = dir.join("y.exr");
    let (w, h) = (4usize, 3usize);
    let mut y: Vec<f32> = (0..w * h).map(|k| 0.5 + k as f32).collect();
    y[5] = -2.0;
    y[7] = f32::NAN;
    let channels = AnyChannels::sort(SmallVec::from_vec(vec![AnyChannel::new(
        "Y",
        FlatSamples::F32(y.clone()),
    )]));
    Image::from_channels((w, h), channels)
        .write()
        .to_file(&path)
        .unwrap();
    let map = EnvMap::load(&path, 1.0, 0.0).unwrap();
    assert_eq!((map.width, map.height), (w, h));
    assert_eq!(map.texels[0], Rgb::splat(0.5));
    assert_eq!(map.texels[5], Rgb::ZERO);
    assert_eq!(map.texels[7], Rgb::ZERO);
    assert!(map.texels.iter().all(|c| c.min_element() >= 0.0));
    assert_eq!(map.notes.len(), 1, "{:?}", map.notes);
    assert!(
        map.notes[0].contains("y.exr") && map.notes[0].contains("2 of 12 texels"),
        "{}",
        map.notes[0]
    );
}

/// A FIFO named as an environment map is refused at once, naming it (opening it would block).
#[cfg(unix)]
#[test]
fn env_map_fifo_is_refused_at_once() {
    let dir = temp_dir("envmap", "fifo");
    let path = dir.join("sky.exr");
    let status = std::process::Command::new("mkfifo")
        .arg(&path)
        .status()
        .unwrap();
    assert!(status.success());
    let e = EnvMap::load(&path, 1.0, 0.0).unwrap_err();
    let msg = format!("{e:#}");
    assert!(msg.contains("sky.exr") && msg.contains("FIFO"), "{msg}");
    let e = EnvMap::load(&dir, 1.0, 0.0).unwrap_err();
    assert!(format!("{e:#}").contains("directory"), "{e:#}");
}
