//! Alpha cut-outs: a quad with a checkerboard coverage texture against geometry of its opaque
//! squares only. The two scenes differ in triangles, BVH and the path every ray takes through
//! Embree (filter functions rejecting hits on one side, nothing to hit on the other), so agreement
//! of σ and fluence cell by cell, within a few of their standard errors and with independent seeds,
//! checks the walks, the radiance paths and their shadow rays alike; the ray and point queries are
//! also checked one by one where the answer is known exactly.

use ftpd3d::math::Rgb;
use ftpd3d::rng::Sampler;
use ftpd3d::scene::Scene;
use ftpd3d::scene::material::{Alpha, AlphaMode, Material, TextureRef};
use ftpd3d::scene::texture::{Texture, TextureSet, UvTransform, Wrap};
use glam::{DVec3, Vec2, Vec3};
use std::path::Path;
use std::sync::Arc;

/// Texels per side of the checkerboard.
const N: usize = 4;
/// Height of the cut-out quad over the floor.
const H: f32 = 1.0;

/// Texel (i, j) (column i from the left, row j from the top) is opaque when i + j is even.
fn opaque_texel(i: usize, j: usize) -> bool {
    (i + j).is_multiple_of(2)
}

/// A quad in z = `z` over [x0, x1] × [y0, y1], front side +z (two triangles), with per-vertex
/// texture coordinates u = x, v = y.
fn quad(
    pos: &mut Vec<Vec3>,
    uv: &mut Vec<Vec2>,
    tris: &mut Vec<[u32; 3]>,
    mats: &mut Vec<u32>,
    [x0, x1, y0, y1]: [f32; 4],
    z: f32,
    m: u32,
) {
    let b = pos.len() as u32;
    for (x, y) in [(x0, y0), (x1, y0), (x1, y1), (x0, y1)] {
        pos.push(Vec3::new(x, y, z));
        uv.push(Vec2::new(x, y));
    }
    tris.extend([[b, b + 1, b + 2], [b, b + 2, b + 3]]);
    mats.extend([m, m]);
}

/// The floor (z = 0, albedo 0.5) under the unit square at height `H` (albedo 0.8, two-sided
/// like every opaque surface), lit by a point light above: either one quad with the
/// checkerboard as its coverage (`mode`), or only the opaque squares as geometry (`None`).
fn scene(mode: Option<AlphaMode>) -> Scene {
    let (mut pos, mut uv, mut tris, mut mats) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    quad(
        &mut pos,
        &mut uv,
        &mut tris,
        &mut mats,
        [-2., 3., -2., 3.],
        0.0,
        0,
    );
    let mut leaf = Material::diffuse("leaf", Rgb::splat(0.8));
    let mut textures = TextureSet::default();
    match mode {
        Some(mode) => {
            quad(
                &mut pos,
                &mut uv,
                &mut tris,
                &mut mats,
                [0., 1., 0., 1.],
                H,
                1,
            );
            let texels = (0..N * N)
                .map(|k| {
                    let a = if opaque_texel(k % N, k / N) { 1.0 } else { 0.0 };
                    [0.8, 0.8, 0.8, a]
                })
                .collect();
            textures.textures.push(Arc::new(
                Texture::new(N, N, texels, "checkerboard").unwrap(),
            ));
            leaf.maps.alpha = Some(Alpha {
                factor: 1.0,
                map: Some(TextureRef {
                    texture: 0,
                    factor: Rgb::ONE,
                    wrap: (Wrap::ClampToEdge, Wrap::ClampToEdge),
                    transform: UvTransform::default(),
                }),
                channel: 3,
                mode,
            });
        }
        None => {
            let s = 1.0 / N as f32;
            for j in 0..N {
                for i in 0..N {
                    if opaque_texel(i, j) {
                        // Row j from the top spans v (= y) in [1 − (j+1)/N, 1 − j/N].
                        let (x0, y1) = (i as f32 * s, 1.0 - j as f32 * s);
                        let r = [x0, x0 + s, y1 - s, y1];
                        quad(&mut pos, &mut uv, &mut tris, &mut mats, r, H, 1);
                    }
                }
            }
        }
    }
    let floor = Material::diffuse("floor", Rgb::splat(0.5));
    let mut scene = crate::support::scene_of("cutout-test", pos, tris, mats, vec![floor, leaf]);
    scene.set_textures(uv, textures);
    scene.add_point_light(DVec3::new(0.4, 0.55, 3.0), Rgb::splat(20.0));
    scene
}

#[test]
fn cutout_rays_and_point_queries_pass_through_transparent_texels_only() {
    for mode in [AlphaMode::Mask { cutoff: 0.5 }, AlphaMode::Stochastic] {
        rays_and_point_queries(mode);
    }
}

/// Stochastic coverage is exact only where the bilinear α is 0 or 1, at the texel centres.
fn rays_and_point_queries(mode: AlphaMode) {
    let cut = scene(Some(mode));
    let points: &[(f64, f64)] = match mode {
        AlphaMode::Mask { .. } => &[(0.5, 0.5), (0.1, 0.1), (0.9, 0.9)],
        AlphaMode::Stochastic => &[(0.5, 0.5)],
    };
    assert!(cut.features.cutouts);
    assert!(!scene(None).features.cutouts);
    let s = 1.0 / N as f64;
    for j in 0..N {
        for i in 0..N {
            // The centre of texel (i, j) and a point a tenth of a texel inside its corner.
            for &(fx, fy) in points {
                let (x, y) = ((i as f64 + fx) * s, 1.0 - (j as f64 + fy) * s);
                let o = DVec3::new(x, y, 2.0);
                let hit = cut.intersect(o, -DVec3::Z, f64::INFINITY).unwrap();
                let z_expected = if opaque_texel(i, j) { H as f64 } else { 0.0 };
                assert!(
                    (hit.p.z - z_expected).abs() < 1e-6,
                    "texel ({i}, {j}) at ({x}, {y}): hit z = {}",
                    hit.p.z
                );
                // A shadow ray to a point just above the floor sees the same.
                let blocked = cut.occluded(o, -DVec3::Z, 1.9);
                assert_eq!(blocked, opaque_texel(i, j), "shadow ray at ({x}, {y})");
                // A point on the quad is moved off it only where the quad is there.
                let on = DVec3::new(x, y, H as f64);
                let moved = cut.off_surfaces(on) != on;
                assert_eq!(moved, opaque_texel(i, j), "point query at ({x}, {y})");
            }
        }
    }
}

/// σ (unweighted and radiance-weighted) and fluence on a grid of points in the plane y = 0.55
/// through the checkerboard, for the cut-out and for the geometry of the opaque squares, with
/// independent seeds: the difference of each pair over its combined standard error.
fn z_scores(mode: AlphaMode) -> Vec<(String, f64)> {
    let (cut, squares) = (scene(Some(mode)), scene(None));
    let points: Vec<DVec3> = (0..6)
        .flat_map(|ix| {
            (0..4).map(move |iz| DVec3::new(-0.25 + 0.3 * ix as f64, 0.55, 0.3 + 0.5 * iz as f64))
        })
        .collect();
    let params = |weighting| crate::support::params(0.3, 0.8, 0.15, weighting, 8);
    crate::support::z_scores_of_two_scenes([&cut, &squares], &points, params, 11, 3000)
}

#[test]
fn cutout_checkerboard_matches_the_opaque_squares_as_geometry() {
    crate::support::assert_consistent("mask", &z_scores(AlphaMode::Mask { cutoff: 0.5 }));
}

/// Stochastic coverage: at random points of the quad, a ray straight down passes with probability
/// 1 − α, α being the bilinear interpolation of the texels' coverage written out here (texel
/// centres at (i + ½)/N, clamped at the edges); the passes, summed over points and rays, agree
/// with the sum of 1 − α within their binomial standard errors (three counts judged together,
/// `support::z_limit`), for the closest-hit and the shadow query, and for a point query at the
/// same places.
#[test]
fn cutout_stochastic_coverage_passes_in_proportion_to_the_bilinear_alpha() {
    let cut = scene(Some(AlphaMode::Stochastic));
    let alpha_at = |x: f64, y: f64| {
        let at = |i: i64, j: i64| {
            let (i, j) = (i.clamp(0, N as i64 - 1), j.clamp(0, N as i64 - 1));
            if opaque_texel(i as usize, j as usize) {
                1.0
            } else {
                0.0
            }
        };
        let (fx, fy) = (x * N as f64 - 0.5, (1.0 - y) * N as f64 - 0.5);
        let (i, j) = (fx.floor(), fy.floor());
        let (tx, ty) = (fx - i, fy - j);
        let (i, j) = (i as i64, j as i64);
        (1.0 - ty) * ((1.0 - tx) * at(i, j) + tx * at(i + 1, j))
            + ty * ((1.0 - tx) * at(i, j + 1) + tx * at(i + 1, j + 1))
    };
    let mut s = Sampler::new(3, 0, 0);
    let (mut expected, mut var) = (0.0, 0.0);
    let mut passed = [0.0; 3];
    let n = 20_000;
    for _ in 0..n {
        let (x, y) = s.next_2d();
        let q = 1.0 - alpha_at(x, y);
        expected += q;
        var += q * (1.0 - q);
        // A fresh origin per ray: the decision is a hash of the ray.
        let o = DVec3::new(x, y, 1.5 + s.next_f64());
        let hit = cut.intersect(o, -DVec3::Z, f64::INFINITY).unwrap();
        passed[0] += (hit.p.z < 0.5) as u8 as f64;
        passed[1] += !cut.occluded(o, -DVec3::Z, o.z - 0.5) as u8 as f64;
        let on = DVec3::new(x, y, H as f64);
        passed[2] += (cut.off_surfaces(on) == on) as u8 as f64;
    }
    let se = var.sqrt();
    for (what, p) in ["closest hit", "shadow ray", "point query"]
        .iter()
        .zip(passed)
    {
        eprintln!("{what}: {p} passed, expected {expected:.1} ± {se:.1}");
        assert!(
            (p - expected).abs() <= crate::support::z_limit(3) * se,
            "{what}: {p} passed, expected {expected:.1} ± {se:.1}"
        );
    }
}

/// Writes `name`.obj and `name`.mtl in `dir`: the floor and the unit quad at height `H` with
/// texture coordinates, the quad's material given by `leaf` (MTL statements).
fn write_obj(dir: &Path, name: &str, leaf: &str) -> std::path::PathBuf {
    let obj = format!(
        "mtllib {name}.mtl\n\
         v -2 -2 0\nv 3 -2 0\nv 3 3 0\nv -2 3 0\n\
         v 0 0 {H}\nv 1 0 {H}\nv 1 1 {H}\nv 0 1 {H}\n\
         vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
         usemtl floor\nf 1 2 3\nf 1 3 4\n\
         usemtl leaf\nf 5/1 6/2 7/3\nf 5/1 7/3 8/4\n"
    );
    std::fs::write(dir.join(format!("{name}.obj")), obj).unwrap();
    std::fs::write(
        dir.join(format!("{name}.mtl")),
        format!("newmtl floor\nKd 0.5 0.5 0.5\n\nnewmtl leaf\nKd 0.8 0.8 0.8\n{leaf}\n"),
    )
    .unwrap();
    dir.join(format!("{name}.obj"))
}

/// MTL `d` alone: rays pass the quad with probability 1 − d (binomial, 4 standard errors), and a
/// dielectric ignores it.
#[test]
fn cutout_mtl_dissolve_passes_one_minus_d_of_the_rays() {
    let dir = crate::support::temp_dir("cutout", "dissolve");
    let d = 0.3;
    let scene = ftpd3d::scene::load::load_scene(&write_obj(&dir, "d", &format!("d {d}"))).unwrap();
    assert!(scene.features.cutouts);
    let mut s = Sampler::new(4, 0, 0);
    let n = 20_000;
    let mut passed = 0.0;
    for _ in 0..n {
        let (x, y) = s.next_2d();
        let o = DVec3::new(x, y, 1.5 + s.next_f64());
        passed += !scene.occluded(o, -DVec3::Z, o.z - 0.5) as u8 as f64;
    }
    let expected = n as f64 * (1.0 - d);
    let se = (n as f64 * d * (1.0 - d)).sqrt();
    assert!(
        (passed - expected).abs() <= 4.0 * se,
        "{passed} passed, expected {expected} ± {se}"
    );
    let glass = write_obj(&dir, "glass", "illum 7\nNi 1.5\nd 0.3");
    let scene = ftpd3d::scene::load::load_scene(&glass).unwrap();
    assert!(!scene.features.cutouts);
}

/// OBJ maps through `vt`: `map_Kd` of a 2 × 1 texture (sRGB 255 and 128) gives each half of the
/// quad its texel's albedo under a delta sun (ρ/π E, to rounding at the texel centres), and
/// `map_d` of a 2 × 1 RGBA mask (α 255 and 0) lets rays through the right half only.
#[test]
fn cutout_obj_map_kd_and_map_d_read_their_texels_at_the_vt_coordinates() {
    use ftpd3d::kernel::Radiance3D;
    use ftpd3d::scene::Light;
    use ftpd3d::transport::walk::{RadianceStats, radiance};
    let dir = crate::support::temp_dir("cutout", "obj_maps");
    image::RgbImage::from_raw(2, 1, vec![255, 255, 255, 128, 128, 128])
        .unwrap()
        .save(dir.join("kd.png"))
        .unwrap();
    image::RgbaImage::from_raw(2, 1, vec![255, 255, 255, 255, 255, 255, 255, 0])
        .unwrap()
        .save(dir.join("mask.png"))
        .unwrap();
    let mut scene = ftpd3d::scene::load::load_scene(&write_obj(
        &dir,
        "maps",
        "map_Kd -clamp on kd.png\nmap_d -clamp on mask.png",
    ))
    .unwrap();
    assert!(
        scene.report.warnings.is_empty(),
        "{:?}",
        scene.report.warnings
    );
    assert!(scene.features.textures && scene.features.cutouts);
    // The mask: the left half (u < ½) is there, the right half is not.
    for (x, present) in [(0.1, true), (0.25, true), (0.75, false), (0.9, false)] {
        let o = DVec3::new(x, 0.5, 2.0);
        let hit = scene.intersect(o, -DVec3::Z, f64::INFINITY).unwrap();
        assert_eq!((hit.p.z - H as f64).abs() < 1e-6, present, "x = {x}");
    }
    // The colour: at the left texel's centre and at the left edge (clamped) the albedo is 1.
    let e = 2.0;
    scene.add_light(Light::distant(DVec3::Z, Rgb::splat(e), 0.0));
    let mut s = Sampler::new(5, 0, 0);
    for x in [0.05, 0.25] {
        let q = DVec3::new(x, 0.5, H as f64);
        let eye = DVec3::new(0.25, 0.5, 2.0);
        let mut st = RadianceStats::default();
        let l =
            radiance::<Radiance3D>(&scene, eye, (q - eye).normalize(), 1, &mut s, &mut st).total();
        let expected = e / std::f64::consts::PI;
        assert!(
            (l.x - expected).abs() <= 1e-6 * expected,
            "x = {x}: {} vs {expected}",
            l.x
        );
    }
}
