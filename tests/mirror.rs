//! Lights seen through planar mirrors (virtual lights, `ftpd3d::transport::mirror`): the radiance
//! weighting that samples the lights' mirror images agrees with the plain reference estimator
//! (which finds an area light's image only by uniform directions that hit the mirror and then the
//! light, and a spot light's image by trying every mirror plane) on a scene where the light
//! reaches the points only through the mirror, also where a blocker hides the image; and in
//! flatland with the estimator that does not sample the images.

use crate::support::agrees_with_reference;
use crate::support::scene_path;
use ftpd3d::ftpd::moments::Moments;
use ftpd3d::ftpd::{Params, Weighting, sample_point};
use ftpd3d::kernel::Radiance3D;
use ftpd3d::math::Rgb;
use ftpd3d::rng::Sampler;
use ftpd3d::scene::material::Bsdf;
use ftpd3d::scene::{Light, Material, Scene};
use ftpd3d::transport::mirror::{connect_virtual, sample_virtual};
use glam::{DVec3, Vec3};

const LE: f64 = 20.0;
const KS: f64 = 0.9;

/// A floor (y = 0, x, z in [−1, 1]), a mirror in the plane x = 1 (y in [0, 1.6]), an area light
/// (0.3 × 0.3 at x = 0.5, facing +x: towards the mirror, away from every test point), a spot
/// light at x = 0.3 aimed at the mirror, and a blocker: a diffuse panel in the plane z = 0.35
/// between x = 0.55 and 0.95, which hides the mirror's image of the light from points on the +z
/// side.
fn mirror_room() -> Scene {
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    let mut tri_material = Vec::new();
    let mut quad = |c: [[f32; 3]; 4], m: u32| {
        let b = positions.len() as u32;
        positions.extend(c.iter().map(|p| Vec3::from_array(*p)));
        triangles.push([b, b + 1, b + 2]);
        triangles.push([b, b + 2, b + 3]);
        tri_material.extend([m, m]);
    };
    quad(
        [[-1., 0., -1.], [-1., 0., 1.], [1., 0., 1.], [1., 0., -1.]],
        0,
    );
    quad(
        [[1., 0., -1.], [1., 0., 1.], [1., 1.6, 1.], [1., 1.6, -1.]],
        1,
    );
    // Winding so that the light's front side faces +x.
    quad(
        [
            [0.5, 1.05, -0.15],
            [0.5, 1.35, -0.15],
            [0.5, 1.35, 0.15],
            [0.5, 1.05, 0.15],
        ],
        2,
    );
    quad(
        [
            [0.55, 0.0, 0.35],
            [1.0, 0.0, 0.35],
            [1.0, 1.6, 0.35],
            [0.55, 1.6, 0.35],
        ],
        0,
    );
    // A wall facing the mirror, where the pairs that start along the reflected light deflect.
    quad(
        [
            [-0.7, 0., -1.],
            [-0.7, 1.6, -1.],
            [-0.7, 1.6, 1.],
            [-0.7, 0., 1.],
        ],
        0,
    );
    let materials = vec![
        Material::diffuse("floor", Rgb::splat(0.6)),
        Material {
            name: "mirror".into(),
            bsdf: Bsdf::Mirror {
                kd: Rgb::ZERO,
                ks: Rgb::splat(KS),
            },
            emission: Rgb::ZERO,
            maps: Default::default(),
        },
        Material {
            name: "light".into(),
            bsdf: Bsdf::Black,
            emission: Rgb::splat(LE),
            maps: Default::default(),
        },
    ];
    let mut scene = crate::support::scene_of(
        "mirror_room.obj",
        positions,
        triangles,
        tri_material,
        materials,
    );
    scene.add_light(Light::Spot {
        position: DVec3::new(0.3, 0.9, -0.4),
        direction: DVec3::X,
        intensity: Rgb::splat(0.5),
        cos_inner: 20f64.to_radians().cos(),
        cos_outer: 35f64.to_radians().cos(),
    });
    scene
}

fn params() -> Params {
    crate::support::params(0.5, 1.5, 0.2, Weighting::Radiance, 8)
}

#[test]
fn the_mirror_is_found_as_one_plane() {
    let scene = mirror_room();
    assert!(scene.features.planar_mirrors);
    assert_eq!(scene.mirrors.planes.len(), 1);
    assert_eq!(scene.mirrors.triangles, 2);
    let p = scene.mirrors.planes[0];
    assert!((p.normal.x.abs() - 1.0).abs() < 1e-12);
    assert!((p.distance(DVec3::new(0.2, 0.7, 0.1)).abs() - 0.8).abs() < 1e-6);
    // A scene without a perfect mirror has none.
    let cornell = ftpd3d::scene::load::load_scene(&scene_path("stair_wall.obj")).unwrap();
    assert!(cornell.mirrors.is_empty() && !cornell.features.planar_mirrors);
}

/// Light that reaches the points only through the mirror: from the area light and the spot. The
/// points at z = 0.6 and 0.9 do not see the lights' images (the blocker hides them): their virtual
/// samples fail, and what they get comes by other paths, much of it light the mirror throws on the
/// floor, which the reference finds only by rare BSDF paths that hit the mirror and then the light.
/// Its batch errors are then too optimistic at 16 × 6000 samples (z up to 5.3 on σ, with MIS
/// above), while at 16 × 80000 all eight comparisons are within 1.3 standard errors: these two
/// points get the larger count.
#[test]
fn light_seen_only_through_a_mirror_matches_the_reference() {
    let scene = mirror_room();
    let open = [DVec3::new(-0.3, 0.8, -0.2)];
    agrees_with_reference(
        &scene,
        &open,
        &params(),
        6000,
        (300, 400),
        "mirror room, open",
    );
    let hidden = [DVec3::new(0.0, 1.2, 0.6), DVec3::new(0.2, 1.0, 0.9)];
    agrees_with_reference(
        &scene,
        &hidden,
        &params(),
        80000,
        (700, 800),
        "mirror room, hidden",
    );
}

/// The virtual sample from a point in the open sees the image of the light at the light's
/// radiance times the mirror's reflectance; from behind the blocker it is rejected.
#[test]
fn virtual_light_samples_pass_in_the_open_and_fail_behind_the_blocker() {
    let scene = mirror_room();
    let sp = &ftpd3d::kernel::Sphere;
    let count = |x: DVec3| {
        let (mut hits, mut tries) = (0, 0);
        for i in 0..400 {
            let u = ((i % 20) as f64 + 0.5) / 20.0;
            let v = ((i / 20) as f64 + 0.5) / 20.0;
            // u_light < light's share picks the area light (it has most of the power).
            for u_l in [0.01, 0.99] {
                let Some(vs) = sample_virtual(&scene, sp, x, 0.5, u_l, (u, v)) else {
                    continue;
                };
                tries += 1;
                let mut rays = 0;
                if let Some(li) = connect_virtual::<Radiance3D>(&scene, x, x, &vs, &mut rays) {
                    hits += 1;
                    if !vs.delta {
                        assert!((li.x - KS * LE).abs() < 1e-9, "{li:?}");
                    }
                }
            }
        }
        (hits, tries)
    };
    let (open_hits, open_tries) = count(DVec3::new(-0.3, 0.8, -0.2));
    assert!(
        open_tries > 0 && open_hits == open_tries,
        "{open_hits}/{open_tries}"
    );
    let (hidden_hits, hidden_tries) = count(DVec3::new(0.2, 1.0, 0.9));
    assert!(hidden_tries > 0, "no sample from behind the blocker");
    assert!(
        hidden_hits < hidden_tries / 4,
        "{hidden_hits}/{hidden_tries}"
    );
}

/// In flatland (the shipped two-mirror system), radiance weighting with the lights' mirror images
/// agrees with the same estimator without them (the scene's flatland mirrors cleared), which finds
/// the light through the mirrors only by uniform directions: m1, m2, σ and the fluence within 4
/// standard errors, each from the spread of 16 batches (so each z is close to Student's t with
/// about 30 degrees of freedom: a false failure with probability 4e-4 per comparison, 3e-3 for the
/// 8).
#[test]
fn flatland_mirror_images_agree_with_the_estimator_without_them() {
    let mut with = ftpd3d::scene::load::load_scene(&scene_path("flat_mirrors.obj")).unwrap();
    let plane = ftpd3d::kernel::Flatland::new(DVec3::ZERO, DVec3::X, DVec3::Y);
    with.prepare_flatland(plane, "z=0").unwrap();
    assert!(!with.flat().mirrors.is_empty());
    let mut without = ftpd3d::scene::load::load_scene(&scene_path("flat_mirrors.obj")).unwrap();
    without.prepare_flatland(plane, "z=0").unwrap();
    without.flat.as_mut().unwrap().mirrors = Default::default();
    let p = Params {
        t0: 0.5,
        t1: 3.0,
        theta_max: 0.1,
        weighting: Weighting::Radiance,
        max_bounces: 16,
        radiance_bounces: None,
        flat: Some(plane),
        design: ftpd3d::ftpd::Design::default_for(Weighting::Radiance),
        guide: false,
    };
    let lo = with.bounds.min;
    let hi = with.bounds.max;
    let points = [
        DVec3::new(lo.x + 0.3 * (hi.x - lo.x), lo.y + 0.6 * (hi.y - lo.y), 0.0),
        DVec3::new(lo.x + 0.7 * (hi.x - lo.x), lo.y + 0.4 * (hi.y - lo.y), 0.0),
    ];
    for (k, x) in points.iter().enumerate() {
        let run = |scene: &Scene, seed: u64| {
            let per: Vec<Moments> = (0..16)
                .map(|b| {
                    let mut s = Sampler::new(seed + k as u64, b, 0);
                    let mut m = Moments::default();
                    for _ in 0..4000 {
                        let smp = sample_point(scene, *x, &p, &mut s);
                        m.add_unit(smp.c, smp.cd, smp.cd2, smp.weight);
                    }
                    m
                })
                .collect();
            let stats = |f: &dyn Fn(&Moments) -> f64| {
                crate::support::mean_and_se_of(&per.iter().map(f).collect::<Vec<_>>())
            };
            [
                stats(&|m| m.s1 / m.s0),
                stats(&|m| m.s0 / m.n as f64),
                stats(&|m| m.sigma().unwrap_or(0.0)),
                stats(&|m| ftpd3d::math::luminance(m.fluence) / m.n as f64),
            ]
        };
        let (a, b) = (run(&with, 500), run(&without, 600));
        for (name, (a, b)) in ["m1", "mean c", "sigma", "fluence"]
            .iter()
            .zip(a.iter().zip(&b))
        {
            let z = (a.0 - b.0) / (a.1 * a.1 + b.1 * b.1).sqrt();
            eprintln!(
                "flat point {k} {name}: images {:.5} ± {:.5}, without {:.5} ± {:.5}, z = {z:.2}",
                a.0, a.1, b.0, b.1
            );
            assert!(z.abs() < 4.0, "point {k} {name}: z = {z:.2}");
        }
    }
}
