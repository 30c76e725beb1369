//! Independent references for the transport and the FTPD estimator.
//!
//! Every reference here is computed without the code under test: closed forms (the furnace, a point
//! light over a plane, Lambert's polygon formula) or deterministic quadrature written from the
//! geometry. Every Monte Carlo comparison uses fixed seeds and a tolerance of k standard errors that
//! the test computes from its own samples (sample variance, or the spread of independent batches);
//! no tolerance is a tuned constant. k is `support::z_limit(m)` for the m quantities a test judges
//! (`t_limit` where the standard errors come from the spread of 32 batches), so that each test
//! fails a correct code with probability at most 1e-4 whatever its seeds. Run with `--nocapture` to
//! see the measured numbers.

use crate::support::{Mean, assert_within, furnace, gauss_legendre, scene_path, t_limit, z_limit};
use ftpd3d::ftpd::moments::{Moments, sigma_from};
use ftpd3d::ftpd::{Design, Params, Weighting, radiance_direction, sample_point};
use ftpd3d::kernel::Radiance3D;
use ftpd3d::math::Rgb;
use ftpd3d::rng::Sampler;
use ftpd3d::scene::load::load_scene;
use ftpd3d::scene::{Material, Scene};
use ftpd3d::transport::bsdf::Bsdf;
use ftpd3d::transport::walk::{RadianceStats, radiance};
use glam::{DVec3, Vec3};
use std::f64::consts::{FRAC_1_PI, PI, TAU};

// ---------------------------------------------------------------------------------------------
// Quadrature
// ---------------------------------------------------------------------------------------------

/// An `n`-point Gauss–Legendre rule on [a, b]. With `cluster`, through the substitution
/// x = a + (b − a)(3t² − 2t³), whose Jacobian vanishes at both ends: integrands with square-root
/// behaviour at an end (where a domain boundary moves like a square root) become smooth in t.
fn rule(a: f64, b: f64, n: usize, cluster: bool) -> Vec<(f64, f64)> {
    gauss_legendre(n)
        .into_iter()
        .map(|(x, w)| {
            let t = 0.5 * (x + 1.0);
            let wt = 0.5 * w;
            if cluster {
                (
                    a + (b - a) * t * t * (3.0 - 2.0 * t),
                    wt * (b - a) * 6.0 * t * (1.0 - t),
                )
            } else {
                (a + (b - a) * t, wt * (b - a))
            }
        })
        .collect()
}

#[test]
fn valid_gauss_legendre_is_exact_for_polynomials() {
    for n in [1, 2, 5, 8, 16, 24] {
        let r = gauss_legendre(n);
        for p in 0..2 * n {
            let q: f64 = r.iter().map(|(x, w)| w * x.powi(p as i32)).sum();
            let exact = if p % 2 == 1 {
                0.0
            } else {
                2.0 / (p as f64 + 1.0)
            };
            assert!((q - exact).abs() < 1e-14, "n = {n}, x^{p}: {q} vs {exact}");
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Scenes built in code
// ---------------------------------------------------------------------------------------------

/// [`crate::support::scene_of`], asserting that no triangle was dropped as degenerate.
fn build(
    name: &str,
    positions: Vec<Vec3>,
    tris: Vec<[u32; 3]>,
    mats: Vec<u32>,
    materials: Vec<Material>,
) -> Scene {
    let scene = crate::support::scene_of(name, positions, tris, mats, materials);
    assert_eq!(scene.report.degenerate_dropped, 0);
    scene
}

/// The square [−half, half]² at height `y`, two triangles facing +y (or −y with `down`).
fn square(half: f32, y: f32, down: bool, base: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let p = vec![
        Vec3::new(-half, y, -half),
        Vec3::new(-half, y, half),
        Vec3::new(half, y, half),
        Vec3::new(half, y, -half),
    ];
    let t = if down {
        vec![[base, base + 2, base + 1], [base, base + 3, base + 2]]
    } else {
        vec![[base, base + 1, base + 2], [base, base + 2, base + 3]]
    };
    (p, t)
}

fn diffuse(name: &str, albedo: f64) -> Material {
    Material::diffuse(name, Rgb::splat(albedo))
}

/// A black emitter of radiance `le` (the area lamps of the tests below).
fn emitter(le: f64) -> Material {
    Material {
        name: "light".into(),
        bsdf: Bsdf::Black,
        emission: Rgb::splat(le),
        maps: Default::default(),
    }
}

/// A 40 × 40 m plane at y = 0 facing +y.
fn big_plane(material: Material) -> Scene {
    let (p, t) = square(20.0, 0.0, false, 0);
    let scene = build("plane", p, t, vec![0, 0], vec![material]);
    assert!(scene.tri_normals().all(|n| n == DVec3::Y));
    scene
}

// ---------------------------------------------------------------------------------------------
// 1. Furnace
// ---------------------------------------------------------------------------------------------

/// Paths of at most this many scattering events. In the furnace the truncation removes
/// Le·Σ_{k>200} a^k = reference·a^201 ≤ 3.5e-20·reference (a ≤ 0.8), some 16 orders of magnitude
/// below the standard errors (~1e-3 relative): the expected value is the untruncated one.
const DEEP: u32 = 200;

#[test]
fn valid_furnace_radiance_is_le_over_one_minus_albedo() {
    // The furnace argument holds for any closed surface of uniform albedo and emission, so the
    // tessellated (exactly closed) sphere has the analytic value exactly: L = Le + a·L everywhere.
    let le = 1.5;
    let points = [
        DVec3::ZERO,
        0.93 * DVec3::new(0.3, -0.5, 0.8).normalize(), // near the wall (faces are ≥ 0.99 from 0)
        0.5 * DVec3::new(-0.7, 0.2, 0.1).normalize(),
    ];
    let n = 20_000;
    // 2 albedos × 3 points × 3 directions judged together.
    let k = z_limit(18);
    for (ai, a) in [0.5, 0.8].into_iter().enumerate() {
        let scene = furnace(a, le);
        let reference = le / (1.0 - a);
        for (pi, &x) in points.iter().enumerate() {
            let out = if x == DVec3::ZERO {
                DVec3::X
            } else {
                x.normalize()
            };
            // Towards the nearest wall, away from it, and along it.
            let dirs = [out, -out, out.cross(DVec3::new(0.1, 1.0, 0.2)).normalize()];
            for (di, &dir) in dirs.iter().enumerate() {
                let mut s = Sampler::new(1001, ai as u64, (pi * 3 + di) as u64);
                let mut st = RadianceStats::default();
                let mut acc = Mean::default();
                for _ in 0..n {
                    let l = radiance::<Radiance3D>(&scene, x, dir, DEEP, &mut s, &mut st).total();
                    assert_eq!(l.x, l.z);
                    acc.add(l.x);
                }
                assert_within(
                    &format!("furnace a = {a}, point {pi}, direction {di}: L"),
                    (acc.mean(), acc.stderr()),
                    reference,
                    k,
                    0.02,
                );
            }
        }
    }
}

#[test]
fn valid_furnace_fluence_is_four_pi_le_over_one_minus_albedo() {
    // radiance_direction returns the direction weight w/p; its mean is ∫ L dω = 4π Le / (1 − a).
    let le = 1.5;
    let n = 40_000;
    let k = z_limit(4);
    for (ai, a) in [0.5, 0.8].into_iter().enumerate() {
        let scene = furnace(a, le);
        let reference = 4.0 * PI * le / (1.0 - a);
        for (pi, x) in [DVec3::ZERO, 0.93 * DVec3::new(-0.2, 0.9, 0.3).normalize()]
            .into_iter()
            .enumerate()
        {
            let mut s = Sampler::new(1002, ai as u64, pi as u64);
            let mut acc = Mean::default();
            let mut rays = 0;
            for _ in 0..n {
                acc.add(
                    radiance_direction::<Radiance3D>(&scene, x, DEEP, &mut s, &mut rays)
                        .1
                        .x,
                );
            }
            assert_within(
                &format!("furnace a = {a}, point {pi}: fluence"),
                (acc.mean(), acc.stderr()),
                reference,
                k,
                0.02,
            );
        }
    }
}

// ---------------------------------------------------------------------------------------------
// 2. Point light over a diffuse plane
// ---------------------------------------------------------------------------------------------

const PL_RHO: f64 = 0.6;
const PL_I: f64 = 5.0;
const PL_LIGHT: DVec3 = DVec3::new(0.3, 1.2, -0.2);

fn point_lit_plane() -> Scene {
    let mut scene = big_plane(diffuse("plane", PL_RHO));
    scene.add_point_light(PL_LIGHT, Rgb::splat(PL_I));
    assert!(scene.features.point_lights && !scene.features.area_lights);
    scene
}

/// Radiance leaving the plane point `y` (any direction, Lambertian): ρ/π · I cosθ / d².
fn point_lit_radiance(y: DVec3) -> f64 {
    let to = PL_LIGHT - y;
    let d = to.length();
    PL_RHO * FRAC_1_PI * PL_I * (to.y / d) / (d * d)
}

#[test]
fn valid_point_light_on_plane_radiance_is_exact() {
    // The path tracer sees the plane point y, connects to the point light (the only light: its
    // contribution is deterministic) and its continuation leaves upwards to infinity (nothing else
    // exists). So every sample must equal ρ/π · I cosθ/d², up to rounding.
    let scene = point_lit_plane();
    let ys = [
        DVec3::new(0.3, 0.0, -0.2), // straight below the light
        DVec3::new(1.5, 0.0, 0.8),
        DVec3::new(-3.0, 0.0, 2.0),
        DVec3::new(7.0, 0.0, -6.0), // grazing
    ];
    let mut s = Sampler::new(2001, 0, 0);
    let mut st = RadianceStats::default();
    for y in ys {
        let x = y + DVec3::new(0.2, 0.9, 0.4);
        let look = (y - x).normalize();
        let reference = point_lit_radiance(y);
        let mut worst: f64 = 0.0;
        for _ in 0..256 {
            let l = radiance::<Radiance3D>(&scene, x, look, DEEP, &mut s, &mut st)
                .total()
                .x;
            worst = worst.max((l / reference - 1.0).abs());
        }
        println!("point light, y = {y}: L = {reference:.9}, worst relative error {worst:.1e}");
        assert!(worst < 1e-12, "y = {y}: relative error {worst}");
    }
}

/// ∫ g(u, v) du dv over the square [−half, half]² in polar coordinates about (cx, cz) (inside it):
/// the angle split at the corners (so the exit radius R(φ) is smooth on each piece), the radius split
/// geometrically at 1/8, 1/4, … so that a peak near the centre and the slow tail are both resolved;
/// `n`-point Gauss–Legendre on each piece.
fn square_polar(half: f64, cx: f64, cz: f64, n: usize, g: impl Fn(f64, f64) -> f64) -> f64 {
    let mut corners: Vec<f64> = [(-1.0, -1.0), (-1.0, 1.0), (1.0, 1.0), (1.0, -1.0)]
        .iter()
        .map(|&(a, b): &(f64, f64)| (b * half - cz).atan2(a * half - cx))
        .collect();
    corners.sort_by(f64::total_cmp);
    corners.push(corners[0] + TAU);
    let exit = |phi: f64| {
        let (c, s) = (phi.cos(), phi.sin());
        let rx = if c > 0.0 {
            (half - cx) / c
        } else {
            (-half - cx) / c
        };
        let rz = if s > 0.0 {
            (half - cz) / s
        } else {
            (-half - cz) / s
        };
        rx.min(rz)
    };
    let mut total = 0.0;
    for w in corners.windows(2) {
        for (phi, wp) in rule(w[0], w[1], n, false) {
            let r_max = exit(phi);
            let (c, s) = (phi.cos(), phi.sin());
            let mut a = 0.0;
            let mut b: f64 = 0.125;
            while a < r_max {
                let hi = b.min(r_max);
                for (r, wr) in rule(a, hi, n, false) {
                    total += wp * wr * r * g(cx + r * c, cz + r * s);
                }
                a = hi;
                b *= 2.0;
            }
        }
    }
    total
}

#[test]
fn valid_point_light_on_plane_fluence_matches_quadrature() {
    // Fluence ∫ L dω at x: the light seen directly, I/d², plus the plane's reflected radiance
    // L(y) = ρ/π · I cosθ_y / d_y² over the solid angle the 40 × 40 m plane subtends:
    // dω = cos(angle at y between the normal and y→x) dA / r² = (x_y / r) dA / r².
    let scene = point_lit_plane();
    let x = DVec3::new(-0.4, 0.5, 0.6);
    let refl = |n: usize| {
        square_polar(20.0, x.x, x.z, n, |u, v| {
            let y = DVec3::new(u, 0.0, v);
            let r = (x - y).length();
            point_lit_radiance(y) * (x.y / r) / (r * r)
        })
    };
    // The integrand is analytic on each polar piece (its nearest singularities lie off the plane,
    // at x_y = 0.5 and the light's height 1.2, and each radial piece is at most as long as its
    // distance from the centre), so Gauss–Legendre converges geometrically: 12 and 24 points agree
    // to 4.3e-14 (reflected part 1.265493031231), 1e-12 of the standard error (1.0e-2).
    let (coarse, fine) = (refl(12), refl(24));
    let direct = PL_I / (PL_LIGHT - x).length_squared();
    let reference = direct + fine;
    println!(
        "point light fluence: direct {direct:.9}, reflected {fine:.12} (12-point rule: {coarse:.12}, \
         difference {:.1e})",
        (fine - coarse).abs()
    );
    let n = 100_000;
    let mut s = Sampler::new(2002, 0, 0);
    let mut acc = Mean::default();
    let mut rays = 0;
    for _ in 0..n {
        acc.add(
            radiance_direction::<Radiance3D>(&scene, x, DEEP, &mut s, &mut rays)
                .1
                .x,
        );
    }
    // The quadrature error must be negligible against the statistical tolerance.
    assert!((fine - coarse).abs() < 1e-3 * acc.stderr());
    assert_within(
        "point light fluence",
        (acc.mean(), acc.stderr()),
        reference,
        z_limit(1),
        0.01,
    );
}

// ---------------------------------------------------------------------------------------------
// 3. Square area light over a diffuse plane
// ---------------------------------------------------------------------------------------------

/// Lambert's polygon formula (Lambert 1760; e.g. Arvo, "Irradiance tensors", SIGGRAPH 1995, eq. 1):
/// the irradiance at `y` (unit normal `n`) from a uniform Lambertian polygon of radiance `le`, fully
/// above y's horizon, is E = le/2 · |Σ_i β_i (n · γ_i)|, with r_i = v_i − y, β_i the angle between
/// r_i and r_{i+1} and γ_i the unit normal of the plane through y, v_i, v_{i+1}.
fn lambert_polygon(le: f64, y: DVec3, n: DVec3, v: &[DVec3]) -> f64 {
    let mut sum = 0.0;
    for i in 0..v.len() {
        let (a, b) = (v[i] - y, v[(i + 1) % v.len()] - y);
        let beta = a.cross(b).length().atan2(a.dot(b));
        sum += beta * n.dot(a.cross(b).normalize());
    }
    0.5 * le * sum.abs()
}

/// The same irradiance by tensor Gauss–Legendre quadrature over the emitter (a parallelogram
/// `o + s e1 + t e2` with unit front normal `nl`): E = ∫ le cosθ_y cosθ_l / r² dA.
fn emitter_quadrature(
    le: f64,
    y: DVec3,
    n: DVec3,
    em: (DVec3, DVec3, DVec3, DVec3),
    k: usize,
) -> f64 {
    let (o, e1, e2, nl) = em;
    let area = e1.cross(e2).length();
    let mut e = 0.0;
    for (s, ws) in rule(0.0, 1.0, k, false) {
        for (t, wt) in rule(0.0, 1.0, k, false) {
            let p = o + s * e1 + t * e2;
            let d = p - y;
            let r2 = d.length_squared();
            let cos_y = n.dot(d) / r2.sqrt();
            let cos_l = -nl.dot(d) / r2.sqrt();
            e += ws * wt * area * le * cos_y * cos_l / r2;
        }
    }
    e
}

#[test]
fn valid_area_light_on_plane_matches_lambert_and_quadrature() {
    let (rho, le) = (0.7, 4.0);
    // Plane 40 × 40 m at y = 0; a 0.5 × 0.5 m emitter at height 1.5 facing down (dyadic
    // coordinates: exact in f32, so the references use the geometry the estimator sees).
    let (mut p, mut t) = square(20.0, 0.0, false, 0);
    let (pe, te) = square(0.25, 1.5, true, 4);
    p.extend(pe);
    t.extend(te);
    let emitter = emitter(le);
    let scene = build(
        "area",
        p,
        t,
        vec![0, 0, 1, 1],
        vec![diffuse("plane", rho), emitter],
    );
    assert!(scene.tri_normal(2) == -DVec3::Y && scene.tri_normal(3) == -DVec3::Y);
    assert_eq!(scene.lights.lights.len(), 2);
    let v: Vec<DVec3> = scene.positions[4..8].iter().map(|q| q.as_dvec3()).collect();
    let em = (v[0], v[1] - v[0], v[3] - v[0], scene.tri_normal(2));
    let n = 40_000;
    // Straight below the emitter, oblique, and far out (light seen at 67° from its normal).
    let ys = [
        DVec3::ZERO,
        DVec3::new(1.25, 0.0, 0.5),
        DVec3::new(3.0, 0.0, -2.0),
    ];
    let limit = z_limit(ys.len());
    for (k, y) in ys.into_iter().enumerate() {
        let lambert = lambert_polygon(le, y, DVec3::Y, &v);
        // Smooth integrand (y is 1.5 below the emitter): 8×8 and 16×16 points and Lambert's
        // formula agree to 12 digits.
        let (q8, q16) = (
            emitter_quadrature(le, y, DVec3::Y, em, 8),
            emitter_quadrature(le, y, DVec3::Y, em, 16),
        );
        println!(
            "area light, y = {y}: E Lambert {lambert:.12}, quadrature {q16:.12} (8×8: {q8:.12})"
        );
        assert!(
            (lambert - q16).abs() < 1e-12 * lambert,
            "two references disagree"
        );
        let reference = rho * FRAC_1_PI * lambert;
        let x = y + DVec3::new(0.25, 0.5, 0.375);
        let look = (y - x).normalize();
        let mut s = Sampler::new(3001, k as u64, 0);
        let mut st = RadianceStats::default();
        let mut acc = Mean::default();
        for _ in 0..n {
            acc.add(
                radiance::<Radiance3D>(&scene, x, look, DEEP, &mut s, &mut st)
                    .total()
                    .x,
            );
        }
        assert_within(
            &format!("area light, y = {y}: reflected radiance"),
            (acc.mean(), acc.stderr()),
            reference,
            limit,
            0.01,
        );
    }
}

/// The same emitter seen from a wall at grazing angles: the wall x = −1 (facing +x) stands beside
/// the emitter (x ∈ [−0.25, 0.25] at height 1.5, facing down), and its points just below the
/// emitter's height see it from 0.15° to 8° above its plane, as the back wall of the Cornell box
/// sees its lamp where the two meet. The shadow ray towards a point sampled on the emitter must
/// end off the emitter at every angle: ending a fixed distance short along the ray leaves less
/// than the f32 rounding of the ray between its end and the emitter's plane at grazing angles, and
/// the emitter then hid its own samples: here all of them at 0.25° and 98 % at 0.5° (whether a
/// sample hides depends on how the ray's origin rounds to f32, so the share varies along a wall).
#[test]
fn valid_area_light_at_grazing_angles_matches_lambert_and_quadrature() {
    let (rho, le) = (0.7, 4.0);
    let mut p = vec![
        Vec3::new(-1.0, 0.0, -2.0),
        Vec3::new(-1.0, 3.0, -2.0),
        Vec3::new(-1.0, 3.0, 2.0),
        Vec3::new(-1.0, 0.0, 2.0),
    ];
    let mut t = vec![[0, 1, 2], [0, 2, 3]];
    let (pe, te) = square(0.25, 1.5, true, 4);
    p.extend(pe);
    t.extend(te);
    let emitter = emitter(le);
    let scene = build(
        "grazing",
        p,
        t,
        vec![0, 0, 1, 1],
        vec![diffuse("wall", rho), emitter],
    );
    assert!(scene.tri_normal(0) == DVec3::X && scene.tri_normal(2) == -DVec3::Y);
    let v: Vec<DVec3> = scene.positions[4..8].iter().map(|q| q.as_dvec3()).collect();
    let em = (v[0], v[1] - v[0], v[3] - v[0], scene.tri_normal(2));
    let n = 40_000;
    // The emitter's centre, 1 m from the wall, at these angles above its plane (its near and
    // far edges at 1.33 and 0.8 times them).
    let angles = [0.25f64, 0.5, 1.0, 2.0, 5.0];
    let limit = z_limit(angles.len());
    for (k, deg) in angles.into_iter().enumerate() {
        let y = DVec3::new(-1.0, 1.5 - deg.to_radians().tan(), 0.0);
        let lambert = lambert_polygon(le, y, DVec3::X, &v);
        let q16 = emitter_quadrature(le, y, DVec3::X, em, 16);
        println!("grazing {deg}°, y = {y}: E Lambert {lambert:.12}, quadrature {q16:.12}");
        assert!(
            (lambert - q16).abs() < 1e-9 * lambert,
            "two references disagree"
        );
        let reference = rho * FRAC_1_PI * lambert;
        let x = y + DVec3::new(0.5, -0.5, 0.25);
        let look = (y - x).normalize();
        let mut s = Sampler::new(3002, k as u64, 0);
        let mut st = RadianceStats::default();
        let mut acc = Mean::default();
        for _ in 0..n {
            acc.add(
                radiance::<Radiance3D>(&scene, x, look, DEEP, &mut s, &mut st)
                    .total()
                    .x,
            );
        }
        assert_within(
            &format!("area light seen at {deg}° from its plane: reflected radiance"),
            (acc.mean(), acc.stderr()),
            reference,
            limit,
            0.01,
        );
    }
}

// ---------------------------------------------------------------------------------------------
// 4. Unweighted FTPD in front of a diffuse plane, by deterministic quadrature
// ---------------------------------------------------------------------------------------------

/// The point x = (0, h, 0) in front of the plane y = 0 (normal +y, Lambertian albedo ρ, unbounded as
/// far as walks of length T can tell), run length T, cone half-angle θmax.
///
/// The reference is written from the geometry alone: a walk from x along a unit w meets the plane
/// iff μ = −w_y satisfies μT > h, at p = x + (h/μ) w, and then (one diffuse bounce, throughput ρ)
/// leaves upwards for the remaining l = T − h/μ and never comes back: its end is p + l·d with d
/// cosine-distributed about +y. Otherwise it ends at x + T w with throughput 1.
#[derive(Clone, Copy)]
struct PlaneSetup {
    h: f64,
    t: f64,
    theta_max: f64,
    rho: f64,
}

/// Nodes and weights for E[f(d)], d cosine-distributed about +y (density cos θ/π): Gauss–Legendre
/// in the polar angle, the trapezoidal rule (spectrally accurate for periodic integrands) in the
/// azimuth.
fn cosine_hemisphere_nodes(n_theta: usize, n_phi: usize) -> Vec<(DVec3, f64)> {
    let mut out = Vec::with_capacity(n_theta * n_phi);
    for (th, w) in rule(0.0, 0.5 * PI, n_theta, false) {
        let (st, ct) = th.sin_cos();
        for j in 0..n_phi {
            let (sp, cp) = (TAU * (j as f64 + 0.5) / n_phi as f64).sin_cos();
            out.push((
                DVec3::new(st * cp, ct, st * sp),
                w * ct * st * FRAC_1_PI * TAU / n_phi as f64,
            ));
        }
    }
    // The rule reproduces the distribution's mass and mean (0, 2/3, 0) (to 5e-13 with 8 points).
    let mass: f64 = out.iter().map(|(_, w)| w).sum();
    let mean: DVec3 = out.iter().map(|(d, w)| *d * *w).sum();
    assert!(
        (mass - 1.0).abs() < 1e-10 && (mean - DVec3::new(0.0, 2.0 / 3.0, 0.0)).length() < 1e-10
    );
    out
}

impl PlaneSetup {
    fn x(&self) -> DVec3 {
        DVec3::new(0.0, self.h, 0.0)
    }

    /// Where a walk along unit `w` meets the plane within T, and the length left after it.
    fn hit(&self, w: DVec3) -> Option<(DVec3, f64)> {
        let mu = -w.y;
        (mu * self.t > self.h).then(|| {
            let th = self.h / mu;
            (self.x() + th * w, self.t - th)
        })
    }

    /// ω at angle `alpha` from −n (in the x-y plane; by symmetry about the normal only this angle
    /// matters) and ω' at angle `theta` from ω and azimuth `phi` about it, measured from the
    /// direction towards −n; with the regulariser s(r) and k = 1/(T‖ω − ω'‖).
    fn pair_geometry(&self, alpha: f64, theta: f64, phi: f64) -> (DVec3, DVec3, f64, f64) {
        let (sa, ca) = alpha.sin_cos();
        let w = DVec3::new(sa, -ca, 0.0);
        let towards_down = DVec3::new(-ca, -sa, 0.0); // ⟂ ω, in the plane of ω and −n
        let (st, ct) = theta.sin_cos();
        let (sp, cp) = phi.sin_cos();
        let w2 = ct * w + st * (cp * towards_down + sp * DVec3::Z);
        let chord = 2.0 * (0.5 * theta).sin();
        let r = (0.5 * theta).tan() / (0.5 * self.theta_max).tan();
        (w, w2, r * r * (3.0 - 2.0 * r), 1.0 / (self.t * chord))
    }

    /// E[(c, cΔ, cΔ²)] over the two diffuse directions, for the pair of directions of
    /// [`pair_geometry`](Self::pair_geometry), on a Lambertian plane of albedo ρ.
    ///
    /// E‖a − b‖ is integrated with `nodes`; E‖a − b‖² is exact: with E[d] = (0, 2/3, 0) and the
    /// horizontal offsets of two hit points, E‖D + l_A d_A − l_B d_B‖² = |D|² + l_A² + l_B² − (8/9) l_A l_B
    /// and E‖q + l d‖² = |q|² + l² + (4/3) l q_y.
    fn diffuse_pair(&self, alpha: f64, theta: f64, phi: f64, nodes: &[(DVec3, f64)]) -> [f64; 3] {
        let (w, w2, s, k) = self.pair_geometry(alpha, theta, phi);
        // E[Δ] = s(k E‖a−b‖ − 1), E[Δ²] = s²(k² E‖a−b‖² − 2k E‖a−b‖ + 1).
        let moments = |m1: f64, m2: f64, c: f64| {
            [
                c,
                c * s * (k * m1 - 1.0),
                c * s * s * (k * k * m2 - 2.0 * k * m1 + 1.0),
            ]
        };
        match (self.hit(w), self.hit(w2)) {
            (None, None) => [1.0, 0.0, 0.0], // two straight walks: Δ = 0
            (Some((p, l)), None) | (None, Some((p, l))) => {
                let straight = if self.hit(w).is_some() { w2 } else { w };
                let q = p - (self.x() + self.t * straight);
                let m1: f64 = nodes.iter().map(|(d, wd)| wd * (q + l * *d).length()).sum();
                let m2 = q.length_squared() + l * l + 4.0 / 3.0 * l * q.y;
                moments(m1, m2, self.rho)
            }
            (Some((pa, la)), Some((pb, lb))) => {
                let dd = pa - pb;
                let mut m1 = 0.0;
                for (da, wa) in nodes {
                    let q = dd + la * *da;
                    let inner: f64 = nodes
                        .iter()
                        .map(|(db, wb)| wb * (q - lb * *db).length())
                        .sum();
                    m1 += wa * inner;
                }
                let m2 = dd.length_squared() + la * la + lb * lb - 8.0 / 9.0 * la * lb;
                moments(m1, m2, self.rho * self.rho)
            }
        }
    }

    /// (c, cΔ, cΔ²) for the pair of directions of [`pair_geometry`](Self::pair_geometry) on a
    /// perfect mirror: a walk that meets the plane ends at the mirror image of x + Tω (the mirror
    /// is an isometry) and carries `throughput(μ)`, μ the cosine of its angle with the normal.
    fn mirror_pair(
        &self,
        alpha: f64,
        theta: f64,
        phi: f64,
        throughput: impl Fn(f64) -> f64,
    ) -> [f64; 3] {
        let (w, w2, s, k) = self.pair_geometry(alpha, theta, phi);
        let end = |w: DVec3| {
            let e = self.x() + self.t * w;
            match self.hit(w) {
                Some(_) => (DVec3::new(e.x, -e.y, e.z), throughput(-w.y)),
                None => (e, 1.0),
            }
        };
        let ((a, ca), (b, cb)) = (end(w), end(w2));
        let delta = s * (k * (a - b).length() - 1.0);
        let c = ca * cb;
        [c, c * delta, c * delta * delta]
    }

    /// (E[c], E[cΔ], E[cΔ²]) over ω uniform on the sphere and ω' uniform in the cone, by product
    /// Gauss–Legendre rules of `n` points on pieces where the integrand is smooth.
    ///
    /// Walk A (along ω) hits iff α < α_c = acos(h/T). Walk B (along ω') hits iff
    /// μ' = cos θ' cos α + sin θ' sin α cos φ' > h/T; over φ' its maximum is cos(θ' − α) and its
    /// minimum cos(θ' + α), so B's hit status depends on φ' only for θ' beyond |α − α_c|, and there
    /// B hits exactly for φ' < φ* = acos((h/T − cos θ' cos α)/(sin θ' sin α)). So α is split at
    /// α_c and α_c ± θmax, θ' at |α − α_c|, φ' at φ*. Where a boundary moves like a square root
    /// (φ* near ±1, and what that does to the θ' and α integrals), the clustered rule makes the
    /// integrand smooth again.
    fn moments(&self, n: usize, pair: impl Fn(f64, f64, f64) -> [f64; 3]) -> [f64; 3] {
        let ac = (self.h / self.t).acos();
        let tm = self.theta_max;
        assert!(ac - tm > 0.0 && ac + tm < PI);
        let mu_c = self.h / self.t;
        let cone = 1.0 / (1.0 - tm.cos()); // density of θ' is sin θ' / (1 − cos θmax)
        let mut acc = [0.0; 3];
        for a in [[0.0, ac - tm], [ac - tm, ac], [ac, ac + tm], [ac + tm, PI]] {
            for (alpha, wa) in rule(a[0], a[1], n, true) {
                let wa = wa * 0.5 * alpha.sin(); // μ = cos α is uniform on [−1, 1]
                let tb = (alpha - ac).abs();
                let thetas: &[[f64; 2]] = if tb < tm {
                    &[[0.0, tb], [tb, tm]]
                } else {
                    &[[0.0, tm]]
                };
                for t in thetas {
                    for (theta, wt) in rule(t[0], t[1], n, true) {
                        let wt = wt * theta.sin() * cone;
                        let kk = (mu_c - theta.cos() * alpha.cos()) / (theta.sin() * alpha.sin());
                        let phis: &[[f64; 2]] = if kk.abs() < 1.0 {
                            &[[0.0, kk.acos()], [kk.acos(), PI]]
                        } else {
                            &[[0.0, PI]]
                        };
                        // φ' is uniform on [0, 2π); the integrand is even in φ': use [0, π].
                        for p in phis {
                            for (phi, wp) in rule(p[0], p[1], n, false) {
                                let v = pair(alpha, theta, phi);
                                let w = wa * wt * wp * FRAC_1_PI;
                                for i in 0..3 {
                                    acc[i] += w * v[i];
                                }
                            }
                        }
                    }
                }
            }
        }
        acc
    }
}

/// Batch statistics of the FTPD estimator at `x`: pooled moments and the spread of the batches'
/// m1 = S1/S0, m2 = S2/S0, σ and of the per-sample c.
struct FtpdRun {
    total: Moments,
    m1: Mean,
    m2: Mean,
    sigma: Mean,
    c: Mean,
}

impl FtpdRun {
    fn m1(&self) -> f64 {
        self.total.s1 / self.total.s0
    }
    fn m2(&self) -> f64 {
        self.total.s2 / self.total.s0
    }
}

fn run_ftpd(
    scene: &Scene,
    x: DVec3,
    p: &Params,
    seed: u64,
    batches: u64,
    per_batch: usize,
) -> FtpdRun {
    let mut run = FtpdRun {
        total: Moments::default(),
        m1: Mean::default(),
        m2: Mean::default(),
        sigma: Mean::default(),
        c: Mean::default(),
    };
    for batch in 0..batches {
        let mut s = Sampler::new(seed, batch, 0);
        let mut b = Moments::default();
        for _ in 0..per_batch {
            let smp = sample_point(scene, x, p, &mut s);
            b.add_unit(smp.c, smp.cd, smp.cd2, smp.weight);
            run.c.add(smp.c);
        }
        run.m1.add(b.s1 / b.s0);
        run.m2.add(b.s2 / b.s0);
        run.sigma.add(b.sigma().unwrap());
        run.total.add_batch(&b);
    }
    run
}

#[test]
fn valid_unweighted_ftpd_at_a_diffuse_plane_matches_quadrature() {
    plane_ftpd_matches_quadrature(Design::SINGLE, 4001, 32, 100_000);
}

/// The same with all pairs of 2 walks along ω and 3 cone directions with 2 walks each, read at 4
/// run lengths (all equal here: t0 = t1): the average over a sample's 48 pairs has the single
/// pair's expectations.
#[test]
fn valid_all_pairs_ftpd_at_a_diffuse_plane_matches_quadrature() {
    plane_ftpd_matches_quadrature(Design::new(2, 2, 3, 4), 4002, 16, 40_000);
}

/// Unweighted FTPD of `design` above the diffuse plane, from `batches` × `per_batch` samples,
/// against the quadrature of [`PlaneSetup::diffuse_pair`].
fn plane_ftpd_matches_quadrature(design: Design, seed: u64, batches: u64, per_batch: usize) {
    let scene = load_scene(&scene_path("diffuse_plane.obj")).unwrap();
    let Bsdf::Diffuse { kd } = scene.materials[0].bsdf else {
        panic!("diffuse_plane.obj is Lambertian");
    };
    let setup = PlaneSetup {
        h: 0.3,
        t: 1.0,
        theta_max: 30f64.to_radians(),
        rho: ftpd3d::math::luminance(kd),
    };
    let started = std::time::Instant::now();
    let moments = |n: usize, inner: (usize, usize)| {
        let nodes = cosine_hemisphere_nodes(inner.0, inner.1);
        setup.moments(n, |a, t, p| setup.diffuse_pair(a, t, p, &nodes))
    };
    // Two resolutions: n points per piece in α, θ', φ' and (n_θ × n_φ) per diffuse direction.
    //                      E[c]            m1              m2              σ
    //   8, (8 × 16):       0.871891366659  0.107760460711  0.109938488171  0.645139775558
    //   12, (12 × 24):     0.871891369293  0.107763011487  0.109938272983  0.645138231329
    //   16, (16 × 32):     0.871891369292  0.107763087818  0.109938101040  0.645137671637
    // (the last row once, offline: 13 s). The coarse–fine difference (m1 2.6e-6, m2 2.2e-7,
    // σ 1.5e-6) bounds the fine rule's error (its own change to 16 points is 30× smaller) and is
    // 1/60 or less of the Monte Carlo standard errors (m1 1.7e-4, m2 1.9e-4, σ 5.5e-4).
    let (coarse, fine) = (moments(8, (8, 16)), moments(12, (12, 24)));
    let quad = started.elapsed();
    let (c_ref, m1_ref, m2_ref) = (fine[0], fine[1] / fine[0], fine[2] / fine[0]);
    let sigma_ref = sigma_from(m1_ref, m2_ref);
    let (m1_c, m2_c) = (coarse[1] / coarse[0], coarse[2] / coarse[0]);
    println!(
        "plane FTPD quadrature ({quad:.2?}): E[c] {c_ref:.10} (coarse {:.10}), m1 {m1_ref:.10} \
         (coarse {m1_c:.10}), m2 {m2_ref:.10} (coarse {m2_c:.10}), σ {sigma_ref:.10} (coarse {:.10})",
        coarse[0],
        sigma_from(m1_c, m2_c)
    );
    let p = Params {
        t0: 1.0,
        t1: 1.0,
        theta_max: setup.theta_max,
        weighting: Weighting::Unweighted,
        max_bounces: 64, // walks bounce at most once here: the cap is never reached
        radiance_bounces: None,
        flat: None,
        design,
        guide: false,
    };
    let started = std::time::Instant::now();
    let run = run_ftpd(&scene, setup.x(), &p, seed, batches, per_batch);
    // Four quantities judged together; m1 and m2 with standard errors from the batches.
    let (k, k_batches) = (z_limit(4), t_limit(4, (batches - 1) as f64));
    println!("plane FTPD Monte Carlo: {:.2?}", started.elapsed());
    // The quadrature error (bounded by the difference of the two resolutions) must be negligible
    // against the statistical tolerance.
    for (q, c, se) in [
        (m1_ref, m1_c, run.m1.stderr()),
        (m2_ref, m2_c, run.m2.stderr()),
        (c_ref, coarse[0], run.c.stderr()),
    ] {
        assert!(
            (q - c).abs() < 0.1 * se,
            "quadrature error {} vs se {se}",
            (q - c).abs()
        );
    }
    assert_within(
        "plane FTPD E[c]",
        (run.c.mean(), run.c.stderr()),
        c_ref,
        k,
        0.01,
    );
    assert_within(
        "plane FTPD m1",
        (run.m1(), run.m1.stderr()),
        m1_ref,
        k_batches,
        0.05,
    );
    assert_within(
        "plane FTPD m2",
        (run.m2(), run.m2.stderr()),
        m2_ref,
        k_batches,
        0.05,
    );
    let v = run.total.finalize();
    assert_within("plane FTPD σ", (v.sigma, v.stderr), sigma_ref, k, 0.05);
}

// ---------------------------------------------------------------------------------------------
// 5. The glossy limit (paper Fig. 4c/d)
// ---------------------------------------------------------------------------------------------

/// Unweighted FTPD above a large plane of glossy Phong material (kd = 0, ks = 0.9) for growing
/// exponents, and above a perfect mirror (ks = 0.9): σ falls strictly with the exponent and tends to
/// the mirror's σ, which matches the quadrature of [`PlaneSetup::mirror_pair`]. (The Phong lobe is
/// divided by max(cos θi, cos θo), so its sampling weight ks cos θi / max(cos θi, cos θo) tends to
/// ks: the limit is the mirror itself. A lobe normalised by (n+2)/2π alone would tend to a mirror of
/// reflectance ks cos θ instead, whose σ here is 0.1264, about 70 standard errors away.)
#[test]
fn valid_glossy_sigma_falls_with_the_exponent_towards_its_mirror_limit() {
    let ks = 0.9;
    let setup = PlaneSetup {
        h: 0.3,
        t: 1.0,
        theta_max: 30f64.to_radians(),
        rho: 0.0, // unused: mirror pairs only
    };
    let sigma_of = |n: usize, throughput: &dyn Fn(f64) -> f64| {
        let m = setup.moments(n, |a, t, p| setup.mirror_pair(a, t, p, throughput));
        (
            m[1] / m[0],
            m[2] / m[0],
            sigma_from(m[1] / m[0], m[2] / m[0]),
        )
    };
    // Quadrature error: 16 against 24 points per piece and dimension: mirror σ 0.163443278 against
    // 0.163442837 (4.4e-7, 1/1000 of the standard error).
    let mirror = |_: f64| ks;
    let (mirror_c, mirror_f) = (sigma_of(16, &mirror), sigma_of(24, &mirror));
    println!(
        "mirror quadrature: m1 {:.9} m2 {:.9} σ {:.9} (16 points: σ {:.9})",
        mirror_f.0, mirror_f.1, mirror_f.2, mirror_c.2
    );
    let p = crate::support::params(setup.t, setup.t, setup.theta_max, Weighting::Unweighted, 64);
    let run = |bsdf: Bsdf, seed: u64, per_batch: usize| {
        let scene = big_plane(crate::support::material("plane", bsdf));
        run_ftpd(&scene, setup.x(), &p, seed, 32, per_batch)
    };
    let m = run(
        Bsdf::Mirror {
            kd: Rgb::ZERO,
            ks: Rgb::splat(ks),
        },
        5000,
        20_000,
    );
    let mv = m.total.finalize();
    assert!((mirror_f.2 - mirror_c.2).abs() < 0.01 * mv.stderr);
    // Four quantities judged against references (m1, m2 with standard errors from 32 batches):
    // the mirror's three moments here, and the glossy σ at 10⁴ below.
    let (k, k_batches) = (z_limit(4), t_limit(4, 31.0));
    assert_within(
        "mirror m1",
        (m.m1(), m.m1.stderr()),
        mirror_f.0,
        k_batches,
        0.1,
    );
    assert_within(
        "mirror m2",
        (m.m2(), m.m2.stderr()),
        mirror_f.1,
        k_batches,
        0.1,
    );
    assert_within("mirror σ", (mv.sigma, mv.stderr), mirror_f.2, k, 0.05);

    // The last two exponents with twice the samples: their σ differ by about 8 combined standard
    // errors then (5.7 with equal counts, which the 3-standard-error step below would miss once in
    // a few hundred seeds).
    let exponents = [
        (37.0, 20_000),
        (112.0, 20_000),
        (1029.0, 40_000),
        (1e4, 40_000),
    ];
    let glossy: Vec<_> = exponents
        .iter()
        .enumerate()
        .map(|(i, &(exponent, per_batch))| {
            let v = run(
                Bsdf::Glossy {
                    kd: Rgb::ZERO,
                    ks: Rgb::splat(ks),
                    exponent,
                },
                5001 + i as u64,
                per_batch,
            )
            .total
            .finalize();
            println!(
                "glossy exponent {exponent}: σ {:.6} ± {:.1e}",
                v.sigma, v.stderr
            );
            v
        })
        .collect();
    for (k, w) in glossy.windows(2).enumerate() {
        let se = w[0].stderr.hypot(w[1].stderr);
        println!(
            "σ({}) − σ({}) = {:.2} standard errors",
            exponents[k].0,
            exponents[k + 1].0,
            (w[0].sigma - w[1].sigma) / se
        );
        assert!(
            w[0].sigma - w[1].sigma > 3.0 * se,
            "σ({}) = {} ± {} is not above σ({}) = {} ± {} by 3 standard errors",
            exponents[k].0,
            w[0].sigma,
            w[0].stderr,
            exponents[k + 1].0,
            w[1].sigma,
            w[1].stderr
        );
    }
    let (s1029, s1e4) = (glossy[2].sigma, glossy[3].sigma);
    println!(
        "distance to the mirror: σ(1029) {:.6}, σ(1e4) {:.6}",
        s1029 - mirror_f.2,
        s1e4 - mirror_f.2
    );
    // Approaching the mirror: the step from 1029 to 10⁴ closes the distance by more than 3 combined
    // standard errors, and at 10⁴ the glossy σ is within 3 standard errors of the mirror's.
    let se = glossy[2].stderr.hypot(glossy[3].stderr);
    println!(
        "the step from 1029 to 10⁴ closes {:.2} standard errors",
        ((s1029 - mirror_f.2).abs() - (s1e4 - mirror_f.2).abs()) / se
    );
    assert!((s1029 - mirror_f.2).abs() - (s1e4 - mirror_f.2).abs() > 3.0 * se);
    assert!((s1e4 - mirror_f.2).abs() < k * glossy[3].stderr.hypot(mv.stderr));
}
