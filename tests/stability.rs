//! Numerically hard cases: points exactly on surfaces, edges and vertices, slices coincident with
//! walls, grazing and very thin geometry, extreme angles, run lengths and Phong exponents, total
//! internal reflection, scenes far from the origin, degenerate triangles, unlit regions, and long
//! accumulations. Every output must be finite and deterministic (same seed, same bits), and agree
//! within standard errors with the well-posed neighbouring case (the point moved off the surface by a
//! tiny fraction, a slightly larger angle, ...). Standard errors come from independent batches; no
//! tolerance is a tuned constant. Run with `--nocapture` to see the measured numbers.

use crate::geometry::scene_path;
use ftpd3d::app::{load_scene, run_plane};
use ftpd3d::domain::Plane;
use ftpd3d::ftpd::moments::{CellValue, Moments};
use ftpd3d::ftpd::{Params, Weighting, sample_at};
use ftpd3d::math::{Rgb, is_finite3};
use ftpd3d::render::RenderOptions;
use ftpd3d::rng::Sampler;
use ftpd3d::scene::Scene;
use glam::DVec3;

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
            let smp = sample_at(scene, x, p, &mut s);
            assert!(
                smp.c.is_finite()
                    && smp.c >= 0.0
                    && smp.delta.is_finite()
                    && is_finite3(smp.weight),
                "non-finite sample at {x}: {smp:?}"
            );
            run.capped += smp.capped as u64;
            run.clamped += smp.clamped as u64;
            b.add_sample(smp.c, smp.delta, smp.weight);
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
    Params {
        t0,
        t1,
        theta_max: angle_deg.to_radians(),
        weighting,
        max_bounces,
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
                4.0,
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
        };
        let (a, _) = run_plane(&scene, &on, &p, &opts(1)).unwrap();
        let (a2, _) = run_plane(&scene, &on, &p, &opts(1)).unwrap();
        assert_eq!(a.cells, a2.cells, "{slice}: same seed, same bits");
        let (b, _) = run_plane(&scene, &near, &p, &opts(2)).unwrap();
        for (k, (x, y)) in a.values().iter().zip(b.values()).enumerate() {
            assert!(x.sigma.is_finite() && x.stderr.is_finite());
            assert_agree(&format!("{slice} {weighting} cell {k}"), x, &y, 4.0);
        }
    }
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
