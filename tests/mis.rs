//! The production radiance weighting (uniform and light-directed directions with MIS) converges to
//! the same moments as the plain reference estimator, on a scene with area lights, a point light,
//! diffuse walls and a mirror, and on one lit by a sky, two suns and a spot light.

use crate::support::{agrees_with_reference, scene_path};
use ftpd3d::ftpd::Weighting;
use ftpd3d::scene::Scene;
use glam::DVec3;

fn cornell_with_point_light() -> Scene {
    let mut scene = ftpd3d::scene::load::load_scene(&scene_path("cornell_mirror.obj")).unwrap();
    scene.add_point_light(DVec3::new(0.5, 1.2, 0.3), DVec3::splat(2.0));
    scene
}

#[test]
fn mis_radiance_weighting_matches_the_reference() {
    let scene = cornell_with_point_light();
    let p = crate::support::params(0.3, 1.2, 0.2, Weighting::Radiance, 12);
    let points = [
        DVec3::new(0.2, 1.0, 0.0),
        DVec3::new(-0.6, 0.4, 0.5),
        DVec3::new(0.5, 1.6, -0.4),
    ];
    agrees_with_reference(&scene, &points, &p, 8000, (100, 200), "point");
}

/// The same comparison under the lights of the outdoors: a sky, a sun with a disc, a sun without
/// one and a spot light, added to the shipped stair wall (with its own area light), whose open
/// sides let the sky and the suns in. The reference finds the sky and the disc only by leaving the
/// scene, the delta sun and the spot only by connections.
#[test]
fn mis_radiance_weighting_matches_the_reference_under_sky_sun_and_spot() {
    use ftpd3d::math::Rgb;
    use ftpd3d::scene::Light;
    let mut scene = ftpd3d::scene::load::load_scene(&scene_path("stair_wall.obj")).unwrap();
    scene.add_light(Light::Sky {
        radiance: Rgb::new(0.2, 0.25, 0.3),
    });
    scene.add_light(Light::distant(
        DVec3::new(0.3, 1.0, 0.4).normalize(),
        Rgb::splat(1.5),
        3f64.to_radians(),
    ));
    scene.add_light(Light::distant(
        DVec3::new(-0.5, 1.0, 0.1).normalize(),
        Rgb::splat(0.8),
        0.0,
    ));
    scene.add_light(Light::Spot {
        position: DVec3::new(0.0, 1.5, 0.5),
        direction: DVec3::new(0.0, -1.0, -0.3).normalize(),
        intensity: Rgb::splat(1.0),
        cos_inner: 25f64.to_radians().cos(),
        cos_outer: 40f64.to_radians().cos(),
    });
    let lo = scene.bounds.min;
    let hi = scene.bounds.max;
    let at = |a: f64, b: f64, c: f64| lo + (hi - lo) * DVec3::new(a, b, c);
    let p = crate::support::params(
        0.1 * scene.extent(),
        0.5 * scene.extent(),
        0.2,
        Weighting::Radiance,
        12,
    );
    let points = [at(0.3, 0.5, 0.5), at(0.6, 0.8, 0.3)].map(|x| scene.off_surfaces(x));
    agrees_with_reference(&scene, &points, &p, 24000, (500, 600), "outdoor point");
}

/// An emitter whose radiance comes from a texture (`map_Ke`, a 2 × 1 map of sRGB 255 and 64, times
/// `Ke` 3) over a floor: light sampling draws points by the constant `Ke` and reads the texel
/// there, hits read it too, and the reference estimator (emission only where paths hit it)
/// agrees.
#[test]
fn mis_emission_texture_agrees_with_the_reference() {
    let dir = crate::support::temp_dir("mis", "emission_texture");
    image::RgbImage::from_raw(2, 1, vec![255, 255, 255, 64, 64, 64])
        .unwrap()
        .save(dir.join("glow.png"))
        .unwrap();
    let obj = "mtllib e.mtl\n\
               v -2 -2 0\nv 2 -2 0\nv 2 2 0\nv -2 2 0\n\
               v 0 0 1\nv 0 1 1\nv 1 1 1\nv 1 0 1\n\
               vt 0 0\nvt 0 1\nvt 1 1\nvt 1 0\n\
               usemtl floor\nf 1 2 3\nf 1 3 4\n\
               usemtl glow\nf 5/1 6/2 7/3\nf 5/1 7/3 8/4\n";
    std::fs::write(dir.join("e.obj"), obj).unwrap();
    std::fs::write(
        dir.join("e.mtl"),
        "newmtl floor\nKd 0.6 0.6 0.6\n\nnewmtl glow\nKd 0 0 0\nKe 3 3 3\nmap_Ke -clamp on glow.png\n",
    )
    .unwrap();
    let scene = ftpd3d::scene::load::load_scene(&dir.join("e.obj")).unwrap();
    assert!(
        scene.report.warnings.is_empty(),
        "{:?}",
        scene.report.warnings
    );
    assert!(scene.features.emission_textures);
    let p = crate::support::params(0.2, 0.6, 0.1, Weighting::Radiance, 4);
    let points = [
        DVec3::new(0.25, 0.5, 0.5),
        DVec3::new(0.75, 0.5, 0.5),
        DVec3::new(1.5, 0.5, 0.3),
    ];
    agrees_with_reference(&scene, &points, &p, 8000, (700, 800), "emission texture");
}
