//! Independent references for the transport and the FTPD estimator.
//!
//! Every reference here is computed without the code under test: closed forms (the furnace, a point
//! light over a plane, Lambert's polygon formula) or deterministic quadrature written from the
//! geometry. Every Monte Carlo comparison uses fixed seeds and a tolerance of k standard errors that
//! the test computes from its own samples (sample variance, or the spread of independent batches);
//! no tolerance is a tuned constant. Run with `--nocapture` to see the measured numbers.

use ftpd3d::ftpd::radiance_direction;
use ftpd3d::math::Rgb;
use ftpd3d::rng::Sampler;
use ftpd3d::scene::{Features, Material, Scene};
use ftpd3d::transport::bsdf::Bsdf;
use ftpd3d::transport::walk::{RadianceStats, radiance};
use glam::{DVec3, Vec3};
use std::collections::HashMap;
use std::f64::consts::{FRAC_1_PI, PI, TAU};
use std::path::Path;

// ---------------------------------------------------------------------------------------------
// Statistics and quadrature helpers
// ---------------------------------------------------------------------------------------------

/// Running mean and variance (Welford).
#[derive(Clone, Copy, Debug, Default)]
struct Acc {
    n: f64,
    mean: f64,
    m2: f64,
}

impl Acc {
    fn add(&mut self, v: f64) {
        self.n += 1.0;
        let d = v - self.mean;
        self.mean += d / self.n;
        self.m2 += d * (v - self.mean);
    }
    /// Standard error of the mean from the sample variance.
    fn stderr(&self) -> f64 {
        (self.m2 / (self.n - 1.0) / self.n).sqrt()
    }
}

/// Asserts `|est − reference| ≤ k·se` and that the comparison is meaningful (`se` positive and at
/// most `max_rel_se` of the reference), printing the numbers.
fn check(what: &str, est: f64, se: f64, reference: f64, k: f64, max_rel_se: f64) {
    let z = (est - reference) / se;
    println!("{what}: {est:.6} ± {se:.2e} vs reference {reference:.6} ({z:+.2} se)");
    assert!(
        se > 0.0 && se <= max_rel_se * reference.abs(),
        "{what}: standard error {se:.3e} too large for a meaningful test of {reference}"
    );
    assert!(
        (est - reference).abs() <= k * se,
        "{what}: {est} ± {se} differs from {reference} by {z:.2} standard errors (limit {k})"
    );
}

/// Gauss–Legendre nodes and weights on [−1, 1]: Newton iteration on P_n (three-term recurrence)
/// from Tricomi's initial guess, to rounding.
fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    (0..n)
        .map(|i| {
            let mut x = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut dp = 1.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=n {
                    let k = k as f64;
                    let p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
                    p0 = p1;
                    p1 = p2;
                }
                dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / dp;
                x -= dx;
                if dx.abs() < 1e-16 {
                    break;
                }
            }
            (x, 2.0 / ((1.0 - x * x) * dp * dp))
        })
        .collect()
}

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

fn build(
    name: &str,
    positions: Vec<Vec3>,
    tris: Vec<[u32; 3]>,
    mats: Vec<u32>,
    materials: Vec<Material>,
) -> Scene {
    let scene = Scene::build(
        Path::new(name),
        positions,
        Vec::new(),
        tris,
        mats,
        materials,
        Default::default(),
    )
    .unwrap();
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

/// A 40 × 40 m plane at y = 0 facing +y.
fn big_plane(material: Material) -> Scene {
    let (p, t) = square(20.0, 0.0, false, 0);
    let scene = build("plane", p, t, vec![0, 0], vec![material]);
    assert!(scene.tri_normals.iter().all(|n| *n == DVec3::Y));
    scene
}

/// Icosphere of unit radius with `subdiv` midpoint subdivisions (20·4^subdiv triangles), vertices
/// shared by index, every triangle wound to face the centre.
fn inward_icosphere(subdiv: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let g = (1.0 + 5f64.sqrt()) / 2.0;
    let mut v: Vec<DVec3> = [
        (-1.0, g, 0.0),
        (1.0, g, 0.0),
        (-1.0, -g, 0.0),
        (1.0, -g, 0.0),
        (0.0, -1.0, g),
        (0.0, 1.0, g),
        (0.0, -1.0, -g),
        (0.0, 1.0, -g),
        (g, 0.0, -1.0),
        (g, 0.0, 1.0),
        (-g, 0.0, -1.0),
        (-g, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| DVec3::new(x, y, z).normalize())
    .collect();
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdiv {
        let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
        let mut m = |a: u32, b: u32, v: &mut Vec<DVec3>| {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                v.push((v[a as usize] + v[b as usize]).normalize());
                v.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(4 * f.len());
        for [a, b, c] in f {
            let (ab, bc, ca) = (m(a, b, &mut v), m(b, c, &mut v), m(c, a, &mut v));
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        f = next;
    }
    for t in &mut f {
        let [a, b, c] = t.map(|i| v[i as usize]);
        if (b - a).cross(c - a).dot(a + b + c) > 0.0 {
            t.swap(1, 2);
        }
    }
    (v.iter().map(|p| p.as_vec3()).collect(), f)
}

/// The furnace: a closed inward-facing icosphere (1280 triangles) of diffuse albedo `a` whose walls
/// emit `le` towards the inside.
fn furnace(a: f64, le: f64) -> Scene {
    let (p, t) = inward_icosphere(3);
    // Exactly closed: every directed edge appears once, and its reverse once.
    let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
    for &[a, b, c] in &t {
        for e in [(a, b), (b, c), (c, a)] {
            *edges.entry(e).or_default() += 1;
        }
    }
    assert!(
        edges
            .iter()
            .all(|(&(a, b), &k)| k == 1 && edges.get(&(b, a)) == Some(&1))
    );
    let n = t.len();
    let wall = Material {
        name: "wall".into(),
        bsdf: Bsdf::Diffuse { kd: Rgb::splat(a) },
        emission: Rgb::splat(le),
    };
    let scene = build("furnace", p, t, vec![0; n], vec![wall]);
    assert!(scene.triangles.len() >= 1000);
    // Inward: every front side faces the centre.
    for (tri, ng) in scene.triangles.iter().zip(&scene.tri_normals) {
        let c: DVec3 = tri
            .iter()
            .map(|&i| scene.positions[i as usize].as_dvec3())
            .sum();
        assert!(ng.dot(c) < 0.0);
    }
    assert_eq!(scene.lights.lights.len(), n);
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
                let mut acc = Acc::default();
                for _ in 0..n {
                    let l = radiance(&scene, x, dir, DEEP, &mut s, &mut st).total();
                    assert_eq!(l.x, l.z);
                    acc.add(l.x);
                }
                check(
                    &format!("furnace a = {a}, point {pi}, direction {di}: L"),
                    acc.mean,
                    acc.stderr(),
                    reference,
                    4.0,
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
    for (ai, a) in [0.5, 0.8].into_iter().enumerate() {
        let scene = furnace(a, le);
        let reference = 4.0 * PI * le / (1.0 - a);
        for (pi, x) in [DVec3::ZERO, 0.93 * DVec3::new(-0.2, 0.9, 0.3).normalize()]
            .into_iter()
            .enumerate()
        {
            let mut s = Sampler::new(1002, ai as u64, pi as u64);
            let mut acc = Acc::default();
            let mut rays = 0;
            for _ in 0..n {
                acc.add(radiance_direction(&scene, x, DEEP, &mut s, &mut rays).1.x);
            }
            check(
                &format!("furnace a = {a}, point {pi}: fluence"),
                acc.mean,
                acc.stderr(),
                reference,
                4.0,
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
    scene.lights.add_point(PL_LIGHT, Rgb::splat(PL_I));
    scene.features = Features::of(&scene.materials, &scene.tri_material, &scene.lights);
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
            let l = radiance(&scene, x, look, DEEP, &mut s, &mut st).total().x;
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
    let mut acc = Acc::default();
    let mut rays = 0;
    for _ in 0..n {
        acc.add(radiance_direction(&scene, x, DEEP, &mut s, &mut rays).1.x);
    }
    // The quadrature error must be negligible against the statistical tolerance.
    assert!((fine - coarse).abs() < 1e-3 * acc.stderr());
    check(
        "point light fluence",
        acc.mean,
        acc.stderr(),
        reference,
        4.0,
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
    let emitter = Material {
        name: "light".into(),
        bsdf: Bsdf::Black,
        emission: Rgb::splat(le),
    };
    let scene = build(
        "area",
        p,
        t,
        vec![0, 0, 1, 1],
        vec![diffuse("plane", rho), emitter],
    );
    assert!(scene.tri_normals[2] == -DVec3::Y && scene.tri_normals[3] == -DVec3::Y);
    assert_eq!(scene.lights.lights.len(), 2);
    let v: Vec<DVec3> = scene.positions[4..8].iter().map(|q| q.as_dvec3()).collect();
    let em = (v[0], v[1] - v[0], v[3] - v[0], scene.tri_normals[2]);
    let n = 40_000;
    // Straight below the emitter, oblique, and far out (light seen at 67° from its normal).
    let ys = [
        DVec3::ZERO,
        DVec3::new(1.25, 0.0, 0.5),
        DVec3::new(3.0, 0.0, -2.0),
    ];
    for (k, y) in ys.into_iter().enumerate() {
        let lambert = lambert_polygon(le, y, DVec3::Y, &v);
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
        let mut acc = Acc::default();
        for _ in 0..n {
            acc.add(radiance(&scene, x, look, DEEP, &mut s, &mut st).total().x);
        }
        check(
            &format!("area light, y = {y}: reflected radiance"),
            acc.mean,
            acc.stderr(),
            reference,
            4.0,
            0.01,
        );
    }
}
