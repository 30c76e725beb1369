//! Numerically hard cases: points exactly on surfaces, edges and vertices, slices coincident with
//! walls, grazing and very thin geometry, extreme angles, run lengths and Phong exponents, total
//! internal reflection, scenes far from the origin, degenerate triangles, unlit regions, and long
//! accumulations. Every output must be finite and deterministic (same seed, same bits), and agree
//! within standard errors with the well-posed neighbouring case (the point moved off the surface by a
//! tiny fraction, a slightly larger angle, ...). Standard errors come from independent batches; no
//! tolerance is a tuned constant: two estimates agree within k combined standard errors, k =
//! `support::z_limit(m)` for the m comparisons a test makes (a false failure with probability
//! under 1e-4 whatever the seeds). Run with `--nocapture` to see the measured numbers.

use crate::support::{
    assert_consistent, cuboid, scene_of, scene_path, temp_dir, translated, z_limit,
};
use ftpd3d::domain::Plane;
use ftpd3d::ftpd::moments::{CellValue, Moments};
use ftpd3d::ftpd::{Params, Weighting, sample_point};
use ftpd3d::kernel::Plain3D;
use ftpd3d::math::{Rgb, is_finite3};
use ftpd3d::render::RenderOptions;
use ftpd3d::render::run_plane;
use ftpd3d::rng::Sampler;
use ftpd3d::scene::load::load_scene;
use ftpd3d::scene::{Material, Scene};
use ftpd3d::transport::bsdf::Bsdf;
use glam::{DVec3, Vec3};
use std::path::Path;

// ---------------------------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------------------------

/// Moments of one point over independent batches, with what the samples reported.
#[derive(Clone, Debug, PartialEq)]
struct PointRun {
    total: Moments,
    capped: u64,
    clamped: u64,
}

impl PointRun {
    fn value(&self) -> CellValue {
        self.total.finalize()
    }
}

/// `batches` × `per_batch` FTPD samples at `x`, each checked finite.
fn run_point(
    scene: &Scene,
    x: DVec3,
    p: &Params,
    seed: u64,
    batches: u64,
    per_batch: usize,
) -> PointRun {
    let mut run = PointRun {
        total: Moments::default(),
        capped: 0,
        clamped: 0,
    };
    for batch in 0..batches {
        let mut s = Sampler::new(seed, batch, 0);
        let mut b = Moments::default();
        for _ in 0..per_batch {
            let smp = sample_point(scene, x, p, &mut s);
            assert!(
                smp.c.is_finite()
                    && smp.c >= 0.0
                    && smp.cd.is_finite()
                    && smp.cd2.is_finite()
                    && is_finite3(smp.weight),
                "non-finite sample at {x}: {smp:?}"
            );
            run.capped += u64::from(smp.capped);
            run.clamped += smp.clamped as u64;
            b.add_unit(smp.c, smp.cd, smp.cd2, smp.weight);
        }
        run.total.add_batch(&b);
    }
    let v = run.value();
    assert!(
        v.sigma.is_finite() && v.stderr.is_finite() && v.mean.is_finite() && v.m2.is_finite(),
        "{v:?}"
    );
    run
}

/// Runs twice with the same seed: the same bits both times.
fn run_point_twice(
    scene: &Scene,
    x: DVec3,
    p: &Params,
    seed: u64,
    batches: u64,
    per_batch: usize,
) -> PointRun {
    let a = run_point(scene, x, p, seed, batches, per_batch);
    let b = run_point(scene, x, p, seed, batches, per_batch);
    assert_eq!(a, b, "same seed, same bits at {x}");
    a
}

/// Asserts that two estimates agree within `k` combined standard errors (both meaningful).
fn assert_agree(what: &str, a: &CellValue, b: &CellValue, k: f64) {
    let se = a.stderr.hypot(b.stderr);
    let z = (a.sigma - b.sigma) / se;
    println!(
        "{what}: σ {:.6} ± {:.1e} vs {:.6} ± {:.1e} ({z:+.2} se)",
        a.sigma, a.stderr, b.sigma, b.stderr
    );
    assert!(a.valid && b.valid, "{what}: {a:?} {b:?}");
    assert!(se > 0.0, "{what}: no spread to compare with");
    assert!(
        (a.sigma - b.sigma).abs() <= k * se,
        "{what}: σ {} ± {} and {} ± {} differ by {z:.2} standard errors (limit {k})",
        a.sigma,
        a.stderr,
        b.sigma,
        b.stderr
    );
}

fn params(weighting: Weighting, t0: f64, t1: f64, angle_deg: f64, max_bounces: u32) -> Params {
    crate::support::params(t0, t1, angle_deg.to_radians(), weighting, max_bounces)
}

/// Every channel of every part of an EXR file (f32 and u32 alike) holds finite values only.
fn assert_all_channels_finite(path: &Path) {
    let parts = crate::support::exr_parts(path);
    let channels: Vec<_> = parts.iter().flat_map(|l| &l.channel_data.list).collect();
    assert!(channels.len() > 20);
    for c in channels {
        let bad = c
            .sample_data
            .values_as_f32()
            .filter(|v| !v.is_finite())
            .count();
        assert_eq!(bad, 0, "channel {} has {bad} non-finite values", c.name);
    }
}

// ---------------------------------------------------------------------------------------------
// Points on surfaces, edges and vertices
// ---------------------------------------------------------------------------------------------

/// Points of the Cornell box exactly on the floor, on the floor/front-wall edge, on a corner and on
/// the light, against the same points moved into the room by 10⁻⁴ of the scene diagonal.
#[test]
fn stability_points_on_surfaces_edges_and_vertices_match_their_neighbours() {
    let scene = load_scene(&scene_path("cornell_mirror.obj")).unwrap();
    let d = scene.extent();
    // Far enough to be off the surface for the float error bound (2 × 64 ulps of the
    // coordinates), near enough that σ, which varies near walls, has not changed measurably.
    let off = 1e-5 * d;
    let cases = [
        (
            "floor",
            DVec3::new(0.3, 0.0, 0.5),
            DVec3::new(0.0, 1.0, 0.0),
        ),
        (
            "edge floor/front",
            DVec3::new(0.3, 0.0, 1.0),
            DVec3::new(0.0, 1.0, -1.0),
        ),
        (
            "corner",
            DVec3::new(1.0, 0.0, 1.0),
            DVec3::new(-1.0, 1.0, -1.0),
        ),
        (
            "back wall",
            DVec3::new(0.0, 1.5, -1.0),
            DVec3::new(0.0, 0.0, 1.0),
        ),
        (
            "light",
            DVec3::new(0.1, 1.98, 0.05),
            DVec3::new(0.0, -1.0, 0.0),
        ),
    ];
    let limit = z_limit(2 * cases.len());
    for weighting in [Weighting::Unweighted, Weighting::Radiance] {
        let p = params(weighting, 0.1 * d, 0.5 * d, 5.0, 32);
        for (k, (name, x, inward)) in cases.iter().enumerate() {
            let seed = 100 + k as u64;
            let on = run_point_twice(&scene, *x, &p, seed, 16, 2000);
            let near = run_point(
                &scene,
                *x + inward.normalize() * off,
                &p,
                seed + 50,
                16,
                2000,
            );
            assert_agree(
                &format!("{weighting} {name}: on the surface vs {off:.1e} inside"),
                &on.value(),
                &near.value(),
                limit,
            );
        }
    }
}

/// Slices coincident with walls of the Cornell box (the back wall z = −1, the floor y = 0; the
/// slice command accepts them, as planes on the bounds) against the slices moved into the room by
/// 10⁻⁵ of the diagonal, cell by cell.
#[test]
fn stability_slices_on_walls_match_their_neighbours() {
    let scene = load_scene(&scene_path("cornell_mirror.obj")).unwrap();
    let d = scene.extent();
    for (slice, moved, weighting) in [
        (
            "z=-1",
            format!("z={}", -1.0 + 1e-5 * d),
            Weighting::Radiance,
        ),
        ("y=0", format!("y={}", 1e-5 * d), Weighting::Unweighted),
    ] {
        let on = Plane::axis_slice(&scene.bounds, slice.parse().unwrap(), None, 4).unwrap();
        let near = Plane::axis_slice(&scene.bounds, moved.parse().unwrap(), None, 4).unwrap();
        assert!(scene.surface_in_plane(on.origin, on.normal()));
        assert!(!scene.surface_in_plane(near.origin, near.normal()));
        let p = params(weighting, 0.1 * d, 0.5 * d, 5.0, 32);
        let opts = |seed| RenderOptions {
            spp: 2048,
            batches: 16,
            seed,
            threads: 0,
            progress: false,
            ..Default::default()
        };
        let (a, _) = run_plane(&scene, &on, &p, &opts(1)).unwrap();
        let (a2, _) = run_plane(&scene, &on, &p, &opts(1)).unwrap();
        assert_eq!(a.cells, a2.cells, "{slice}: same seed, same bits");
        let (b, _) = run_plane(&scene, &near, &p, &opts(2)).unwrap();
        // Both slices' cells are judged together.
        let limit = z_limit(2 * a.cells.len());
        for (k, (x, y)) in a.values().iter().zip(b.values()).enumerate() {
            assert!(x.sigma.is_finite() && x.stderr.is_finite());
            assert_agree(&format!("{slice} {weighting} cell {k}"), x, &y, limit);
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Grazing walks and thin walls
// ---------------------------------------------------------------------------------------------

/// Walks along the walls of the closed Cornell box, within 10⁻⁶ rad of each wall's plane (towards
/// it and away from it), from points on the wall and 10⁻⁶ off it: however long the walk, it never
/// leaves the room, and everything it returns is finite.
#[test]
fn stability_grazing_walks_never_leave_a_closed_room() {
    use ftpd3d::transport::walk::walk;
    let scene = load_scene(&scene_path("cornell_mirror.obj")).unwrap();
    let (lo, hi) = (scene.bounds.min, scene.bounds.max);
    let tol = 1e-4;
    let walls = [
        (DVec3::new(0.2, 0.0, 0.3), DVec3::Y),
        (DVec3::new(0.2, 2.0, 0.6), -DVec3::Y),
        (DVec3::new(-1.0, 1.2, 0.1), DVec3::X),
        (DVec3::new(1.0, 0.7, 0.4), -DVec3::X),
        (DVec3::new(0.1, 1.1, -1.0), DVec3::Z),
        (DVec3::new(-0.3, 0.9, 1.0), -DVec3::Z),
    ];
    let mut s = Sampler::new(7, 0, 0);
    let mut walks = 0;
    for (on_wall, n) in walls {
        let frame = ftpd3d::math::Frame::from_z(n);
        for height in [0.0, 1e-6] {
            let x = scene.off_surfaces(on_wall + n * height);
            for k in 0..200 {
                let phi = std::f64::consts::TAU * k as f64 / 200.0;
                let along = frame.x * phi.cos() + frame.y * phi.sin();
                for a in [-1e-6f64, -1e-9, 0.0, 1e-9, 1e-6] {
                    let d = (along * a.cos() + n * a.sin()).normalize();
                    for t in [0.5, 3.0, 20.0] {
                        let Some(w) = walk::<Plain3D>(&scene, x, d, t, 64, &mut s) else {
                            continue;
                        };
                        walks += 1;
                        assert!(is_finite3(w.end) && is_finite3(w.beta), "{w:?}");
                        let e = w.end;
                        assert!(
                            e.cmpge(lo - tol).all() && e.cmple(hi + tol).all(),
                            "walk from {x} along {d} (T = {t}) left the room: {w:?}"
                        );
                    }
                }
            }
        }
    }
    assert!(walks > 30_000, "{walks}");
    // Walks from random points inside (and on the edges of the floor) in random directions.
    for k in 0..100_000 {
        let x = if k % 2 == 0 {
            DVec3::new(
                2.0 * s.next_f64() - 1.0,
                2.0 * s.next_f64(),
                2.0 * s.next_f64() - 1.0,
            )
        } else {
            let e = 2.0 * s.next_f64() - 1.0;
            let edges = [(e, 0.0, 1.0), (e, 0.0, -1.0), (1.0, 0.0, e), (-1.0, 0.0, e)];
            let (a, b, c) = edges[(k / 2) % 4];
            scene.off_surfaces(DVec3::new(a, b, c))
        };
        let d = ftpd3d::transport::sampling::sample_uniform_sphere(s.next_2d());
        if let Some(w) = walk::<Plain3D>(&scene, x, d, 20.0, 64, &mut s) {
            assert!(
                w.end.cmpge(lo - tol).all() && w.end.cmple(hi + tol).all(),
                "walk from {x} along {d} left the room: {w:?}"
            );
        }
    }
}

/// Pairs whose first direction grazes the Cornell floor (10⁻⁶ rad, from 10⁻⁶ above it, hitting it
/// 1 m away) against the same pairs at 10⁻⁴ rad from 10⁻⁴ above it; and on a perfect mirror, pairs
/// within 10⁻⁶ rad of each other grazing it at 10⁻⁶ rad are still an isometry.
#[test]
fn stability_grazing_pairs_match_their_neighbours() {
    use ftpd3d::ftpd::pair_from;
    let scene = load_scene(&scene_path("cornell_mirror.obj")).unwrap();
    let p = params(Weighting::Unweighted, 1.5, 1.5, 5.0, 32);
    let grazing = |a: f64, seed: u64| {
        let x = DVec3::new(-0.5, a, 0.5);
        let omega = DVec3::new(a.cos(), -a.sin(), 0.0);
        let mut total = Moments::default();
        for batch in 0..16 {
            let mut s = Sampler::new(seed, batch, 0);
            let mut b = Moments::default();
            for _ in 0..3000 {
                let smp =
                    pair_from::<Plain3D>(&scene, x, omega, 1.5, s.next_2d(), Rgb::ONE, &p, &mut s);
                assert!(smp.c.is_finite() && smp.delta.is_finite(), "{smp:?}");
                b.add_sample(smp.c, smp.delta, smp.weight);
            }
            total.add_batch(&b);
        }
        total
    };
    let (g, n) = (grazing(1e-6, 31), grazing(1e-4, 32));
    assert_eq!(g, grazing(1e-6, 31), "same seed, same bits");
    assert_agree(
        "pairs grazing the floor at 1e-6 vs 1e-4 rad",
        &g.finalize(),
        &n.finalize(),
        z_limit(1),
    );

    use ftpd3d::ftpd::pairwise_deviation;
    use ftpd3d::kernel::{Space, Sphere};
    use ftpd3d::transport::walk::walk;
    let mirror = load_scene(&scene_path("mirror_plane.obj")).unwrap();
    let theta_max: f64 = 1e-6;
    let (omc, thm) = (
        2.0 * (0.5 * theta_max).sin().powi(2),
        (0.5 * theta_max).tan(),
    );
    let mut s = Sampler::new(33, 0, 0);
    let (mut both, mut worst) = (0, 0.0f64);
    for _ in 0..20_000 {
        let a = 1e-6 + 1e-6 * s.next_f64();
        let x = DVec3::new(-5.0, a, 0.3);
        let omega = DVec3::new(a.cos(), -a.sin(), 0.0);
        let (omega2, chord, r) = Sphere.perturb(omega, theta_max, omc, thm, s.next_2d());
        let (Some(wa), Some(wb)) = (
            walk::<Plain3D>(&mirror, x, omega, 3.0, 8, &mut s),
            walk::<Plain3D>(&mirror, x, omega2, 3.0, 8, &mut s),
        ) else {
            panic!("a mirror walk was absorbed");
        };
        if (wa.bounces, wb.bounces) == (1, 1) {
            both += 1;
            let delta = pairwise_deviation((wa.end - wb.end).length(), 3.0, chord, r);
            worst = worst.max(delta.abs());
        }
    }
    println!("grazing mirror: {both} pairs reflect, largest |Δ| {worst:.2e}");
    assert!(both > 10_000, "{both}");
    assert!(
        worst < 1e-3,
        "grazing reflections are not an isometry: |Δ| up to {worst}"
    );
}

/// A 40 × 40 m diffuse slab whose two faces, facing away from each other, are one f32 ulp
/// (9.5e-7) apart at y = 10, far thinner than the ray offsets there: walks never cross it, and
/// FTPD above and below it equals that of a single two-sided plane.
#[test]
fn stability_thin_double_sided_wall_matches_a_single_plane() {
    use ftpd3d::transport::walk::walk;
    let y0 = 10.0f32;
    let y1 = f32::from_bits(y0.to_bits() + 1);
    let corners = |y: f32| {
        vec![
            Vec3::new(-20.0, y, -20.0),
            Vec3::new(-20.0, y, 20.0),
            Vec3::new(20.0, y, 20.0),
            Vec3::new(20.0, y, -20.0),
        ]
    };
    let mut pos = corners(y0);
    pos.extend(corners(y1));
    // Bottom face facing −y, top face facing +y.
    let slab = scene_of(
        "slab",
        pos,
        vec![[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7]],
        vec![0; 4],
        vec![Material::diffuse("wall", Rgb::splat(0.8))],
    );
    assert_eq!(slab.report.degenerate_dropped, 0);
    assert!(slab.eps_at(DVec3::splat(10.0)) > 10.0 * (y1 - y0) as f64);
    let single = scene_of(
        "plane",
        corners(y0),
        vec![[0, 1, 2], [0, 2, 3]],
        vec![0; 2],
        vec![Material::diffuse("wall", Rgb::splat(0.8))],
    );
    let p = params(Weighting::Unweighted, 0.5, 1.0, 5.0, 32);
    let limit = z_limit(4);
    for (k, h) in [0.3, -0.3, 0.01, -0.01].into_iter().enumerate() {
        let x = DVec3::new(0.2, 10.0 + h, -0.1);
        let a = run_point_twice(&slab, x, &p, 40 + k as u64, 16, 2000);
        let b = run_point(&single, x, &p, 50 + k as u64, 16, 2000);
        assert_agree(
            &format!("thin slab vs single plane at height {h:+}"),
            &a.value(),
            &b.value(),
            limit,
        );
    }
    // Walks stay on their side (the slab is opaque; its edges are out of reach).
    let mut s = Sampler::new(41, 0, 0);
    for h in [0.3, 1e-3, -1e-3, -0.3] {
        let x = DVec3::new(0.2, 10.0 + h, -0.1);
        for _ in 0..20_000 {
            let d = ftpd3d::transport::sampling::sample_uniform_sphere(s.next_2d());
            if let Some(w) = walk::<Plain3D>(&slab, x, d, 2.0, 32, &mut s) {
                let side = (w.end.y - 10.0) * h.signum();
                assert!(
                    side > -1e-4,
                    "walk from {x} along {d} crossed the slab: {w:?}"
                );
            }
        }
    }
    // A point between the two faces (on both, within the error bound): finite, reproducible.
    let inside = run_point_twice(&slab, DVec3::new(0.2, 10.0 + 0.5e-6, -0.1), &p, 49, 4, 500);
    assert!(inside.value().sigma.is_finite());
}

// ---------------------------------------------------------------------------------------------
// Extreme parameters
// ---------------------------------------------------------------------------------------------

/// Perturbation half-angles from 10⁻⁶ rad to 60°: finite and reproducible everywhere, and for small
/// angles θmax·σ converges (Δ of pairs that scatter apart grows like 1/θmax): θmax·σ at 10⁻⁶ rad
/// equals θmax·σ at 10⁻⁵ rad within standard errors.
#[test]
fn stability_perturbation_angles_from_1e_6_rad_to_60_degrees() {
    let scene = load_scene(&scene_path("cornell_mirror.obj")).unwrap();
    let d = scene.extent();
    let x = DVec3::new(0.1, 1.0, 0.2);
    let mut scaled = Vec::new();
    for (k, theta) in [
        1e-6,
        1e-5,
        1e-3,
        2f64.to_radians(),
        30f64.to_radians(),
        60f64.to_radians(),
    ]
    .into_iter()
    .enumerate()
    {
        let p = params(
            Weighting::Unweighted,
            0.1 * d,
            0.5 * d,
            theta.to_degrees(),
            32,
        );
        let r = run_point_twice(&scene, x, &p, 60 + k as u64, 16, 2000);
        let v = r.value();
        println!("θmax {theta:.1e} rad: σ {:.6e} ± {:.1e}", v.sigma, v.stderr);
        assert!(v.valid && v.sigma > 0.0, "{v:?}");
        scaled.push(CellValue {
            sigma: v.sigma * theta,
            stderr: v.stderr * theta,
            ..v
        });
    }
    assert_agree(
        "θmax·σ at 1e-6 vs 1e-5 rad",
        &scaled[0],
        &scaled[1],
        z_limit(1),
    );
}

/// Run lengths from 10⁻⁶ to 10³ scene diagonals D. In the closed Cornell box with T up to 10³ D,
/// walks reach the bounce cap: counted, and all finite. Above an open diffuse plane FTPD is scale
/// free (Δ is a ratio of lengths): σ at height 0.3 k with T = k is the same for k = 10⁻⁶ D as for
/// k = 1; and it converges as T grows: T = 10³ D and 2·10³ D agree.
#[test]
fn stability_run_lengths_from_1e_6_to_1e3_diagonals() {
    let cornell = load_scene(&scene_path("cornell_mirror.obj")).unwrap();
    let d = cornell.extent();
    for weighting in [Weighting::Unweighted, Weighting::Radiance] {
        let p = params(weighting, 1e-6 * d, 1e3 * d, 2.0, 32);
        let r = run_point_twice(&cornell, DVec3::new(0.1, 1.0, 0.2), &p, 70, 8, 500);
        println!(
            "{weighting}, T ∈ [1e-6 D, 1e3 D]: {:?}, {} capped",
            r.value(),
            r.capped
        );
        assert!(r.capped > 0 && r.value().valid);
    }
    let plane = load_scene(&scene_path("diffuse_plane.obj")).unwrap();
    let dp = plane.extent();
    let at_scale = |k: f64, seed: u64| {
        let p = params(Weighting::Unweighted, k, k, 5.0, 32);
        run_point_twice(&plane, DVec3::new(0.0, 0.3 * k, 0.0), &p, seed, 16, 2000).value()
    };
    assert_agree(
        "T = 1e-6 D at height 0.3 T vs T = 1",
        &at_scale(1e-6 * dp, 71),
        &at_scale(1.0, 72),
        z_limit(2),
    );
    let long = |t: f64, seed: u64| {
        let p = params(Weighting::Unweighted, t, t, 5.0, 32);
        run_point_twice(&plane, DVec3::new(0.0, 0.3, 0.0), &p, seed, 16, 2000).value()
    };
    assert_agree(
        "T = 1e3 D vs 2e3 D",
        &long(1e3 * dp, 73),
        &long(2e3 * dp, 74),
        z_limit(2),
    );
}

/// Unweighted FTPD above a large glossy plane (kd = 0, ks = 0.9) for Phong exponents 1 to 10⁶:
/// finite and reproducible, and at 10⁶ the glossy lobe is the perfect mirror's within standard
/// errors (the lobe tends to the mirror as the exponent grows).
#[test]
fn stability_phong_exponents_up_to_1e6_reach_the_mirror() {
    let ks = Rgb::splat(0.9);
    let plane = |bsdf: Bsdf| {
        let pos = vec![
            Vec3::new(-20.0, 0.0, -20.0),
            Vec3::new(-20.0, 0.0, 20.0),
            Vec3::new(20.0, 0.0, 20.0),
            Vec3::new(20.0, 0.0, -20.0),
        ];
        let m = Material {
            name: "plane".into(),
            bsdf,
            emission: Rgb::ZERO,
            maps: Default::default(),
        };
        scene_of(
            "plane",
            pos,
            vec![[0, 1, 2], [0, 2, 3]],
            vec![0, 0],
            vec![m],
        )
    };
    let p = params(Weighting::Unweighted, 1.0, 1.0, 30.0, 32);
    let x = DVec3::new(0.0, 0.3, 0.0);
    let mut last = None;
    for (k, exponent) in [1.0, 10.0, 100.0, 1e3, 1e4, 1e5, 1e6]
        .into_iter()
        .enumerate()
    {
        let scene = plane(Bsdf::Glossy {
            kd: Rgb::ZERO,
            ks,
            exponent,
        });
        let v = run_point_twice(&scene, x, &p, 80 + k as u64, 16, 4000).value();
        println!("Phong {exponent:e}: σ {:.6} ± {:.1e}", v.sigma, v.stderr);
        assert!(v.valid && v.sigma > 0.0);
        last = Some(v);
    }
    let mirror = plane(Bsdf::Mirror { kd: Rgb::ZERO, ks });
    let m = run_point(&mirror, x, &p, 90, 16, 4000).value();
    assert_agree("Phong 1e6 vs mirror", &last.unwrap(), &m, z_limit(1));
}

// ---------------------------------------------------------------------------------------------
// Total internal reflection
// ---------------------------------------------------------------------------------------------

/// Points inside the glass sphere with a low bounce cap: paths trapped by total internal reflection
/// reach the cap, the pairs are counted (per sample and in the run's statistics), and the field and
/// its EXR stay finite. A glass slab, where light past the critical angle is trapped for good, the
/// same.
#[test]
fn stability_total_internal_reflection_is_capped_and_counted() {
    let scene = load_scene(&scene_path("glass_sphere.obj")).unwrap();
    let d = scene.extent();
    for weighting in [Weighting::Unweighted, Weighting::Radiance] {
        let p = params(weighting, 0.1 * d, 0.5 * d, 2.0, 4);
        let r = run_point_twice(&scene, DVec3::new(0.35, 0.6, 0.0), &p, 100, 8, 1000);
        println!(
            "{weighting}: {:?}, {} of 8000 pairs capped",
            r.value(),
            r.capped
        );
        assert!(r.capped > 0 && r.value().valid);
    }
    // A plane through the sphere's centre, inside it.
    let plane = Plane::new(
        DVec3::new(-0.3, 0.3, 0.0),
        DVec3::X,
        DVec3::Y,
        (0.6, 0.6),
        6,
        "inside".into(),
    )
    .unwrap();
    let p = params(Weighting::Radiance, 0.1 * d, 0.5 * d, 2.0, 4);
    let opts = RenderOptions {
        spp: 64,
        batches: 8,
        seed: 3,
        threads: 0,
        progress: false,
        ..Default::default()
    };
    let (field, stats) = run_plane(&scene, &plane, &p, &opts).unwrap();
    println!("sphere plane: {stats:?}");
    assert!(stats.capped > 0);
    assert_eq!(stats.clamped, 0);
    let dir = temp_dir("stab", "tir");
    let out = dir.join("tir.exr");
    ftpd3d::output::write_outputs(&field, &out, true).unwrap();
    assert_all_channels_finite(&out);

    // A 20 × 20 × 0.1 m glass slab, outward faces; the point inside it.
    let (pos, tris) = cuboid(
        DVec3::new(-10.0, -0.05, -10.0),
        DVec3::new(10.0, 0.05, 10.0),
        false,
    );
    let n = tris.len();
    let glass = Material {
        name: "glass".into(),
        bsdf: Bsdf::Dielectric {
            ior: 1.5,
            tint: Rgb::ONE,
        },
        emission: Rgb::ZERO,
        maps: Default::default(),
    };
    let slab = scene_of("slab", pos, tris, vec![0; n], vec![glass]);
    let p = params(Weighting::Unweighted, 5.0, 10.0, 2.0, 16);
    let r = run_point_twice(&slab, DVec3::new(0.0, 0.0, 0.0), &p, 101, 8, 1000);
    println!("slab: {:?}, {} capped", r.value(), r.capped);
    assert!(r.capped > 1000, "{}", r.capped);
}

// ---------------------------------------------------------------------------------------------
// Far from the origin
// ---------------------------------------------------------------------------------------------

/// The Cornell box translated by 10⁴ in every axis (where the f32 spacing is 10⁻³ and ray offsets
/// are centimetres) against the original, on the slice through its middle, unweighted and
/// radiance-weighted: cell by cell (the z-scores as `support::assert_consistent` judges them) and
/// on average (the mean difference within its standard errors). And walks in the translated room
/// never leave it.
#[test]
fn stability_translated_by_1e4_equals_the_original() {
    use ftpd3d::transport::walk::walk;
    let scene = load_scene(&scene_path("cornell_mirror.obj")).unwrap();
    let offset = 1e4f32;
    let far = translated(&scene, Vec3::splat(offset));
    assert_eq!(far.report.degenerate_dropped, 0);
    let d = scene.extent();
    let res = 8;
    let near_plane = Plane::axis_slice(&scene.bounds, "z=0".parse().unwrap(), None, res).unwrap();
    let spec = format!("z={}", offset as f64).parse().unwrap();
    let far_plane = Plane::axis_slice(&far.bounds, spec, None, res).unwrap();
    assert_eq!(
        (near_plane.width, near_plane.height),
        (far_plane.width, far_plane.height)
    );
    for (weighting, spp) in [(Weighting::Unweighted, 2048), (Weighting::Radiance, 1024)] {
        let p = params(weighting, 0.1 * d, 0.5 * d, 2.0, 32);
        let opts = |seed| RenderOptions {
            spp,
            batches: 32,
            seed,
            threads: 0,
            progress: false,
            ..Default::default()
        };
        let (a, _) = run_plane(&scene, &near_plane, &p, &opts(1)).unwrap();
        let (b, _) = run_plane(&far, &far_plane, &p, &opts(2)).unwrap();
        let (b2, _) = run_plane(&far, &far_plane, &p, &opts(2)).unwrap();
        assert_eq!(b.cells, b2.cells, "same seed, same bits");
        let (va, vb) = (a.values(), b.values());
        let mut z = Vec::new();
        let (mut diff, mut var) = (0.0, 0.0);
        for (k, (x, y)) in va.iter().zip(&vb).enumerate() {
            assert!(x.valid && y.valid && y.sigma.is_finite() && y.stderr.is_finite());
            let se = x.stderr.hypot(y.stderr);
            z.push((format!("{weighting} cell {k}"), (x.sigma - y.sigma) / se));
            diff += y.sigma - x.sigma;
            var += se * se;
        }
        let n = z.len() as f64;
        let (mean, se_mean) = (diff / n, var.sqrt() / n);
        println!("{weighting}, translated by 1e4: mean difference {mean:.4} ± {se_mean:.4}");
        assert_consistent(&format!("{weighting}, translated by 1e4"), &z);
        // Both weightings' means judged together.
        assert!(
            mean.abs() <= z_limit(2) * se_mean,
            "{weighting}: mean difference {mean} ± {se_mean}"
        );
    }
    // Walks in a closed room translated by 1e4 never leave it, also where they hit its edges and
    // corners. (The empty room of cornell_point.gltf: the Cornell box's objects stand 1 mm above
    // its floor, one f32 ulp at 1e4 and far below the error bound there, a gap that geometry so far
    // from the origin does not resolve.)
    let room = load_scene(&scene_path("cornell_point.gltf")).unwrap();
    let far = translated(&room, Vec3::splat(offset));
    let (lo, hi) = (far.bounds.min, far.bounds.max);
    // End points of walks may lie up to the ray offsets (a few error bounds) beyond a surface.
    let tol = 4.0 * far.eps_at(hi);
    let mut s = Sampler::new(9, 0, 0);
    for _ in 0..50_000 {
        let u = DVec3::new(s.next_f64(), s.next_f64(), s.next_f64());
        let x = lo + (hi - lo) * u;
        let dir = ftpd3d::transport::sampling::sample_uniform_sphere(s.next_2d());
        if let Some(w) = walk::<Plain3D>(&far, far.off_surfaces(x), dir, 20.0, 64, &mut s) {
            assert!(
                w.end.cmpge(lo - tol).all() && w.end.cmple(hi + tol).all(),
                "walk from {x} along {dir} left the translated room: {w:?}"
            );
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Degenerate geometry and unlit regions
// ---------------------------------------------------------------------------------------------

/// Zero-area, repeated-vertex and non-finite triangles of an OBJ file are dropped at load and
/// counted; the rest of the scene is intact and traceable.
#[test]
fn stability_degenerate_triangles_are_dropped_and_counted() {
    let dir = temp_dir("stab", "degenerate");
    let obj = dir.join("degenerate.obj");
    std::fs::write(
        &obj,
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nv nan 0 0\nv inf 1 0\nv 1e39 0 1\nv 0.5 0.5 -inf\n\
         f 1 2 3\n\
         f 1 2 4\n\
         f 1 1 2\n\
         f 3 3 3\n\
         f 5 2 3\n\
         f 6 2 3\n\
         f 7 2 3\n\
         f 8 1 2\n",
    )
    .unwrap();
    let scene = load_scene(&obj).unwrap();
    assert_eq!(scene.report.triangles_read, 8);
    assert_eq!(scene.report.degenerate_dropped, 7);
    assert_eq!(scene.triangles[..], [[0, 1, 2]]);
    assert_eq!(scene.bounds.min, DVec3::ZERO);
    assert_eq!(scene.bounds.max, DVec3::new(1.0, 1.0, 0.0));
    assert!(scene.extent().is_finite());
    let h = scene
        .intersect(DVec3::new(0.25, 0.25, 1.0), -DVec3::Z, f64::INFINITY)
        .unwrap();
    assert_eq!(h.prim, 0);
    assert!(
        scene
            .intersect(DVec3::new(1.5, 0.1, 1.0), -DVec3::Z, f64::INFINITY)
            .is_none()
    );
}

/// A closed box with an area light next to a sealed box without one, radiance-weighted: no light
/// reaches the sealed box or the space between them, and those cells are invalid (σ = 0), never
/// NaN; every channel of the EXR is finite.
#[test]
fn stability_unlit_regions_are_invalid_never_nan() {
    let (mut pos, mut tris) = cuboid(DVec3::ZERO, DVec3::ONE, true);
    let (p2, t2) = cuboid(DVec3::new(2.0, 0.0, 0.0), DVec3::new(3.0, 1.0, 1.0), true);
    let base = pos.len() as u32;
    pos.extend(p2);
    tris.extend(t2.iter().map(|t| t.map(|i| i + base)));
    let mut mats = vec![0; tris.len()];
    let base = pos.len() as u32;
    pos.extend([
        Vec3::new(0.3, 0.98, 0.3),
        Vec3::new(0.7, 0.98, 0.3),
        Vec3::new(0.7, 0.98, 0.7),
        Vec3::new(0.3, 0.98, 0.7),
    ]);
    tris.extend([[base, base + 1, base + 2], [base, base + 2, base + 3]]);
    mats.extend([1, 1]);
    let light = Material {
        name: "light".into(),
        bsdf: Bsdf::Black,
        emission: Rgb::splat(10.0),
        maps: Default::default(),
    };
    let scene = scene_of(
        "two boxes",
        pos,
        tris,
        mats,
        vec![Material::diffuse("wall", Rgb::splat(0.7)), light],
    );
    assert!(!scene.lights.is_empty());
    let plane = Plane::axis_slice(&scene.bounds, "z=0.5".parse().unwrap(), None, 12).unwrap();
    let p = params(Weighting::Radiance, 0.5, 2.0, 2.0, 16);
    let opts = RenderOptions {
        spp: 32,
        batches: 4,
        seed: 5,
        threads: 0,
        progress: false,
        ..Default::default()
    };
    let (field, stats) = run_plane(&scene, &plane, &p, &opts).unwrap();
    assert_eq!(stats.clamped, 0);
    let (mut lit, mut dark) = (0, 0);
    for (k, v) in field.values().iter().enumerate() {
        let x = plane.point(k, (0.5, 0.5));
        assert!(v.sigma.is_finite() && v.stderr.is_finite() && v.weight.is_finite());
        if x.x > 1.05 {
            assert!(!v.valid && v.sigma == 0.0, "cell {k} at {x}: {v:?}");
            dark += 1;
        } else if x.x < 0.95 {
            assert!(v.valid, "cell {k} at {x}: {v:?}");
            lit += 1;
        }
    }
    assert!(lit > 0 && dark > 0);
    let dir = temp_dir("stab", "unlit");
    let out = dir.join("unlit.exr");
    ftpd3d::output::write_outputs(&field, &out, true).unwrap();
    assert_all_channels_finite(&out);
    let (_, _, valid) = ftpd3d::output::exr::read_channel(&out, "valid").unwrap();
    let invalid = field.values().iter().filter(|v| !v.valid).count();
    assert!(invalid >= dark);
    assert_eq!(valid.iter().filter(|v| **v == 0.0).count(), invalid);
}

// ---------------------------------------------------------------------------------------------
// Long accumulations
// ---------------------------------------------------------------------------------------------

/// 10⁸ samples in one cell, alternating (c, Δ) = (0.1, 1) and (0.3, 1.001): a cell where Δ barely
/// varies, so that σ's second term sqrt(m2 − m1²) comes from a difference of nearly equal moments.
/// σ must keep its 6th significant digit against the closed form (m1, m2 and the variance
/// c1 c2 (Δ1 − Δ2)² / (c1 + c2)² per pair, which involve no cancellation).
#[test]
fn stability_moments_over_1e8_samples_keep_six_digits() {
    let (c1, d1, c2, d2) = (0.1, 1.0, 0.3, 1.001);
    let pairs = 50_000_000u64;
    let started = std::time::Instant::now();
    let mut m = Moments::default();
    for _ in 0..pairs {
        m.add_sample(c1, d1, Rgb::ZERO);
        m.add_sample(c2, d2, Rgb::ZERO);
    }
    let elapsed = started.elapsed();
    let w = c1 + c2;
    let m1 = (c1 * d1 + c2 * d2) / w;
    let m2 = (c1 * d1 * d1 + c2 * d2 * d2) / w;
    let var = c1 * c2 * (d1 - d2) * (d1 - d2) / (w * w);
    let exact = m2.sqrt() + var.sqrt();
    let v = m.finalize();
    let rel = (v.sigma - exact).abs() / exact;
    println!(
        "10^8 samples in {elapsed:.2?}: σ {:.12} vs exact {exact:.12} (relative error {rel:.1e}); \
         m1 {:.3e} m2 {:.3e} relative errors",
        v.sigma,
        (v.mean - m1).abs() / m1,
        (v.m2 - m2).abs() / m2
    );
    assert_eq!(m.n, 2 * pairs);
    assert_eq!(format!("{:.5e}", v.sigma), format!("{exact:.5e}"));
    assert!(
        rel < 5e-8,
        "σ {} vs {exact}: relative error {rel:e}",
        v.sigma
    );
}
