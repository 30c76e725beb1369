//! Guided radiance ([`ftpd3d::transport::guide`]): the guide's density is a density and its
//! sampler draws it; guided radiance paths estimate what unguided ones do; guided runs are
//! bit-identical on 1 and 2 threads, across tiles and when resumed; the flag is refused where it
//! cannot act.

use crate::support::{
    Mean, Run, assert_resume_keeps, chi2_test, cuboid, gauss_legendre, material,
    run_on_1_and_2_threads, scene_of, scene_path, small_slice, temp_dir, z_limit,
};
use ftpd3d::kernel::Radiance3D;
use ftpd3d::math::Rgb;
use ftpd3d::output::exr::read_exr;
use ftpd3d::rng::Sampler;
use ftpd3d::scene::load::load_scene;
use ftpd3d::scene::{Material, Scene};
use ftpd3d::transport::bsdf::Bsdf;
use ftpd3d::transport::guide::{BINS_PHI, BINS_Z, Guide};
use ftpd3d::transport::training::train;
use ftpd3d::transport::walk::{Guiding, RadianceStats, StartMis, radiance, radiance_guided};
use glam::DVec3;
use std::f64::consts::PI;

const CAP: u32 = 8;

fn cornell() -> (Scene, Guide) {
    let scene = load_scene(&scene_path("cornell_mirror.obj")).unwrap();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let guide = train::<Radiance3D>(&scene, CAP, 7, &pool);
    (scene, guide)
}

/// Guide training is a function of the scene, the cap and the seed: the same on 1 and 2 threads.
#[test]
fn training_is_the_same_on_any_thread_count() {
    let scene = load_scene(&scene_path("cornell_mirror.obj")).unwrap();
    let on = |n| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .unwrap();
        train::<Radiance3D>(&scene, CAP, 7, &pool)
    };
    let one = on(1);
    assert!(
        one.guided_cells() > 50,
        "{} cells guide",
        one.guided_cells()
    );
    assert_eq!(one, on(2));
}

/// A point near the floor of the Cornell box, where the guide has a histogram.
const FLOOR: DVec3 = DVec3::new(0.1, 0.02, 0.3);

/// The guide's density integrates to 1 over the sphere (quadrature in (cos θ, φ), exact for a
/// density constant on equal-area bins up to rounding), and so does its mixture with a Lambertian
/// BSDF (Gauss-Legendre in cos θ per hemisphere, where the cosine density is smooth); the sampler
/// draws the density (chi-square over bins that halve the guide's in both coordinates, whose
/// expected counts are exact).
#[test]
fn guide_density_integrates_to_one_and_its_sampler_draws_it() {
    let (_, guide) = cornell();
    let g = guide.at(FLOOR).expect("the floor's cell guides");
    let dir = |z: f64, phi: f64| {
        let r = (1.0 - z * z).max(0.0).sqrt();
        DVec3::new(r * phi.cos(), r * phi.sin(), z)
    };
    let (nz, nphi) = (4 * BINS_Z, 4 * BINS_PHI);
    let cell = 4.0 * PI / (nz * nphi) as f64;
    let mut total = 0.0;
    for i in 0..nz {
        for j in 0..nphi {
            let z = -1.0 + 2.0 * (i as f64 + 0.5) / nz as f64;
            let phi = -PI + 2.0 * PI * (j as f64 + 0.5) / nphi as f64;
            total += g.pdf(dir(z, phi)) * cell;
        }
    }
    assert!((total - 1.0).abs() < 1e-12, "∫ p_guide = {total}");

    // The mixture with the floor's Lambertian BSDF (normal +y): per hemisphere of y, Gauss-Legendre
    // in y, midpoint in the azimuth around y; the guide's bins cut these cells, so the rule is
    // not exact for it, and the tolerance is the quadrature's.
    let bsdf = Bsdf::Diffuse {
        kd: ftpd3d::math::Rgb::splat(0.5),
    };
    let (n, wo) = (DVec3::Y, DVec3::new(0.3, 0.8, 0.1).normalize());
    let gl = gauss_legendre(64);
    let naz = 2048;
    let mut mix = 0.0;
    for sign in [1.0, -1.0] {
        for &(x, w) in &gl {
            let y = sign * 0.5 * (x + 1.0);
            let r = (1.0 - y * y).sqrt();
            for k in 0..naz {
                let a = 2.0 * PI * (k as f64 + 0.5) / naz as f64;
                let wi = DVec3::new(r * a.cos(), y, r * a.sin());
                let p = g.mixture(g.pdf(wi), bsdf.pdf(wo, wi, n, n));
                mix += p * 0.5 * w * (2.0 * PI / naz as f64);
            }
        }
    }
    assert!((mix - 1.0).abs() < 2e-3, "∫ mixture = {mix}");

    let (bz, bp) = (2 * BINS_Z, 2 * BINS_PHI);
    let bin = |d: DVec3| {
        let iz = (((d.z + 1.0) * 0.5 * bz as f64) as usize).min(bz - 1);
        let t = (d.y.atan2(d.x) + PI) / (2.0 * PI);
        iz * bp + ((t * bp as f64) as usize).min(bp - 1)
    };
    let draws = 200_000;
    let mut observed = vec![0.0; bz * bp];
    let mut s = Sampler::new(11, 0, 0);
    for _ in 0..draws {
        let d = g.sample(s.next_2d());
        assert!((d.length() - 1.0).abs() < 1e-12);
        observed[bin(d)] += 1.0;
    }
    // Each test bin lies in one guide bin: its expectation is the density at its centre × area.
    let area = 4.0 * PI / (bz * bp) as f64;
    let expected: Vec<f64> = (0..bz * bp)
        .map(|b| {
            let z = -1.0 + 2.0 * ((b / bp) as f64 + 0.5) / bz as f64;
            let phi = -PI + 2.0 * PI * ((b % bp) as f64 + 0.5) / bp as f64;
            draws as f64 * g.pdf(dir(z, phi)) * area
        })
        .collect();
    let err = vec![1e-9 * draws as f64; bz * bp];
    chi2_test("guide sampler", &observed, &expected, &err);
}

/// A room lit only by a lamp that shines up at the ceiling from just below it: every point of the
/// room below the lamp sees light only after a bounce off a small bright patch of the ceiling, which
/// light sampling cannot reach and BSDF sampling finds rarely (the case guiding is for).
fn uplit_room() -> Scene {
    let (mut pos, mut tris) = cuboid(DVec3::new(-1.0, 0.0, -1.0), DVec3::new(1.0, 2.0, 1.0), true);
    let mut mats = vec![0; tris.len()];
    let (s, h) = (0.1f32, 1.9f32);
    let base = pos.len() as u32;
    pos.extend([
        glam::Vec3::new(-s, h, -s),
        glam::Vec3::new(-s, h, s),
        glam::Vec3::new(s, h, s),
        glam::Vec3::new(s, h, -s),
    ]);
    // Counter-clockwise seen from above: the lamp's front side, the one that emits, faces +y.
    tris.extend([[base, base + 1, base + 2], [base, base + 2, base + 3]]);
    mats.extend([1, 1]);
    let lamp = Material {
        emission: Rgb::splat(40.0),
        ..material("lamp", Bsdf::Black)
    };
    let wall = material(
        "wall",
        Bsdf::Diffuse {
            kd: Rgb::splat(0.7),
        },
    );
    scene_of("uplit_room", pos, tris, mats, vec![wall, lamp])
}

/// Guided and unguided radiance paths estimate the same radiance, where much or all of it is
/// indirect light: inside the Cornell box (looking at walls, the floor and the shadowed corners)
/// and in the up-lit room (all of it). Each of the 10 differences is judged within `z_limit(10)`
/// standard errors of the difference, computed from the paths' own variance: a correct code fails
/// with probability ≤ 1e-4 over the seeds. Prints the ratio of the standard errors.
#[test]
fn guided_radiance_agrees_with_unguided() {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let (cornell, cornell_guide) = cornell();
    let room = uplit_room();
    let room_guide = train::<Radiance3D>(&room, CAP, 7, &pool);
    let cases = [
        (
            &cornell,
            &cornell_guide,
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::new(0.0, -1.0, 0.0),
        ),
        (
            &cornell,
            &cornell_guide,
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::new(-1.0, 0.0, 0.0),
        ),
        (
            &cornell,
            &cornell_guide,
            DVec3::new(0.5, 0.5, 0.5),
            DVec3::new(1.0, -0.2, -1.0),
        ),
        (
            &cornell,
            &cornell_guide,
            DVec3::new(-0.5, 0.3, 0.6),
            DVec3::new(-1.0, -1.0, -1.0),
        ),
        (
            &cornell,
            &cornell_guide,
            DVec3::new(0.2, 1.5, 0.0),
            DVec3::new(0.0, 0.0, -1.0),
        ),
        (
            &cornell,
            &cornell_guide,
            DVec3::new(0.3, 0.6, 0.5),
            DVec3::new(-0.3, -1.0, -0.9),
        ),
        (
            &room,
            &room_guide,
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::new(0.0, -1.0, 0.0),
        ),
        (
            &room,
            &room_guide,
            DVec3::new(0.3, 0.5, 0.2),
            DVec3::new(1.0, -0.3, 0.2),
        ),
        (
            &room,
            &room_guide,
            DVec3::new(-0.5, 1.0, 0.5),
            DVec3::new(-1.0, 0.5, 1.0),
        ),
        (
            &room,
            &room_guide,
            DVec3::new(0.5, 0.2, -0.5),
            DVec3::new(0.2, -1.0, -0.6),
        ),
    ];
    let n = 20_000;
    let k = z_limit(cases.len());
    let mut guided_vertices = 0;
    for (i, &(scene, guide, x, look)) in cases.iter().enumerate() {
        let look = look.normalize();
        let mut st = RadianceStats::default();
        let mut s = Sampler::new(21, i as u64, 0);
        let plain = Mean::of(n, || {
            ftpd3d::math::luminance(
                radiance::<Radiance3D>(scene, x, look, CAP, &mut s, &mut st).total(),
            )
        });
        let mut s = Sampler::new(22, i as u64, 0);
        let mut visits = Vec::new();
        let guided = Mean::of(n, || {
            let g = Guiding {
                guide: Some(guide),
                visits: Some(&mut visits),
            };
            let r = radiance_guided::<Radiance3D>(
                scene,
                x,
                look,
                CAP,
                StartMis::default(),
                g,
                &mut s,
                &mut st,
            );
            ftpd3d::math::luminance(r.total())
        });
        guided_vertices += visits.iter().filter(|v| guide.at(v.p).is_some()).count();
        let (a, sa) = plain.estimate();
        let (b, sb) = guided.estimate();
        assert!(a > 0.0 && sa > 0.0, "case {i}: light reaches the point");
        let z = (b - a) / (sa * sa + sb * sb).sqrt();
        assert!(
            z.abs() <= k,
            "case {i}: guided {b:.5} ± {sb:.5}, unguided {a:.5} ± {sa:.5}: z = {z:.2} > {k:.2}"
        );
        eprintln!(
            "case {i}: L {a:.5}, standard error guided / unguided {:.3}",
            sb / sa
        );
    }
    assert!(guided_vertices > n, "the paths met the guide");
}

/// The command line's `--guide on`: recorded in the file, bit-identical on 1 and 2 threads, tiles
/// of the full run's cells, a resumed run equal to the same run in one go, a resume with another
/// setting refused naming the flag, and refused for runs it cannot act on.
#[test]
fn guide_flag_runs_resumes_and_refuses() {
    let dir = temp_dir("guide", "flag");
    let scene = scene_path("cornell_mirror.obj");
    let out = |name: &str| dir.join(name).to_str().unwrap().to_string();
    let run = |extra: &[&str]| -> Run { small_slice(&scene, extra) };
    let cells = |name: &str| read_exr(&dir.join(name)).unwrap();
    run_on_1_and_2_threads(run, &["--guide", "on"], [&out("t1.exr"), &out("t2.exr")]);
    let (t1, t2) = (cells("t1.exr"), cells("t2.exr"));
    assert_eq!(t1.cells, t2.cells, "bit-identical on 1 and 2 threads");
    assert_eq!(t1.meta["guide"], "on");
    let r = run(&["--spp", "8", "-o", &out("plain.exr")]);
    assert!(r.ok, "{}", r.err);
    assert!(!cells("plain.exr").meta.contains_key("guide"));
    assert_ne!(cells("plain.exr").cells, t1.cells);
    // Tiles: each the full run's cells in its rows.
    for (i, rows) in [(0, 0..4), (1, 4..8)] {
        let tile = format!("{i}/2");
        let name = format!("tile{i}.exr");
        let r = run(&[
            "--guide",
            "on",
            "--spp",
            "8",
            "--tile",
            &tile,
            "--threads",
            "1",
            "-o",
            &out(&name),
        ]);
        assert!(r.ok, "{}", r.err);
        let t = cells(&name);
        for (k, (c, f)) in t.cells.iter().zip(&t1.cells).enumerate() {
            if rows.contains(&(k / 8)) {
                assert_eq!(c.bit_pattern(), f.bit_pattern(), "tile {i}, cell {k}");
            }
        }
    }
    // 4 samples, resumed to 8: the 8-sample run, bit for bit.
    let resumed = out("resumed.exr");
    let read = || cells("resumed.exr").cells;
    assert_resume_keeps(run, &["--guide", "on"], "guide", &resumed, read, &t1.cells);
    // Nothing to guide: refused, naming the flag.
    for extra in [&["--weight", "unweighted"][..], &["--flatland"][..]] {
        let mut a = vec!["--guide", "on", "--spp", "1", "-o"];
        let bad = out("bad.exr");
        a.push(&bad);
        a.extend_from_slice(extra);
        let r = run(&a);
        assert!(
            !r.ok && r.err.contains("--guide on"),
            "{extra:?}: {}",
            r.err
        );
        assert!(!r.err.contains("panicked"), "{}", r.err);
    }
}
