//! `--radiance-bounces N`: radiance paths of at most N scattering events (N + 1 segments from the
//! point to the light), walks capped by `--max-bounces` alone (the paper's Fig. 5 limits its
//! radiance paths to 6 segments, not its FTPD walks).
//!
//! References that are not the code under test: in a closed enclosure whose walls all emit Le and
//! reflect diffusely with albedo ρ, the light that reached a point after exactly i scattering events
//! has radiance Le·ρ^i in every direction (each wall point sees only walls of the previous order's
//! uniform radiance), so paths of at most k events carry Le·Σ_{i≤k} ρ^i, in 3D and in flatland
//! (the 2D Lambertian f = ρ/2 reflects ρ of a uniform field too). A point light in a closed box
//! checks the light sampled at the last vertex the cap allows: one scattering event adds the
//! box's once-reflected light, a surface integral computed here by quadrature from the geometry.
//! Monte Carlo tolerances are k standard errors computed from the samples, k = `z_limit(m)` for the
//! m estimates a test judges (a false failure with probability under 1e-4 whatever the seeds);
//! consecutive caps differ by far more than 2k standard errors, so a cap off by one fails.

use crate::support::{
    Mean, extruded, flat_furnace, ftpd3d, ftpd3d_in, furnace, gauss_legendre, temp_dir, z_limit, z0,
};
use ftpd3d::ftpd::{Params, Start, Weighting, sample, sample_point, visit_point};
use ftpd3d::kernel::Radiance3D;
use ftpd3d::math::{Rgb, luminance};
use ftpd3d::rng::Sampler;
use ftpd3d::scene::{Material, Scene};
use glam::{DVec3, Vec3};
use std::f64::consts::{PI, TAU};

/// Walks capped far above any radiance cap tested, short run lengths (the walks are not what is
/// checked here), and radiance paths capped at `cap`.
fn params(weighting: Weighting, cap: Option<u32>, flat: bool) -> Params {
    Params {
        t0: 0.05,
        t1: 0.2,
        theta_max: 0.05,
        weighting,
        max_bounces: 32,
        radiance_bounces: cap,
        flat: flat.then(z0),
        design: ftpd3d::ftpd::Design::default_for(weighting),
        guide: false,
    }
}

/// Le·Σ_{i=0..k} ρ^i.
fn truncated(le: f64, rho: f64, k: u32) -> f64 {
    (0..=k).map(|i| le * rho.powi(i as i32)).sum()
}

/// Mean and standard error of `n` draws of `f`.
fn estimate(n: usize, f: impl FnMut() -> f64) -> (f64, f64) {
    Mean::of(n, f).estimate()
}

/// `m ± se` within `k` standard errors of `expected`; an estimate without variance (the camera's
/// beauty with cap 0 sees the emission of the first wall only) must equal it to rounding.
fn check(what: &str, (m, se): (f64, f64), expected: f64, k: f64) {
    if se == 0.0 {
        eprintln!("{what}: {m} (no variance), expected {expected}");
        assert!(
            (m - expected).abs() <= 1e-12 * expected,
            "{what}: {m} vs {expected}"
        );
        return;
    }
    let z = (m - expected) / se;
    eprintln!("{what}: {m:.5} ± {se:.1e}, expected {expected:.5} ({z:+.2} se, limit {k:.2})");
    assert!(
        se > 0.0 && se < 0.02 * expected,
        "{what}: standard error {se} too large for a meaningful test"
    );
    assert!(
        (m - expected).abs() <= k * se,
        "{what}: {m} ± {se} differs from {expected} by {z:.2} standard errors"
    );
}

/// The fluence (radiance weighting: the direction weight w/p, whose mean is ∫ L dω) and the
/// camera's beauty image (the radiance along the pixel ray) in the 3D furnace, for caps 0-3.
/// Consecutive caps differ by 4π·Le·ρ^k, tens of standard errors: a cap off by one fails.
#[test]
fn furnace_3d_fluence_and_beauty_keep_k_scattering_events() {
    let (rho, le) = (0.5, 1.5);
    let scene = furnace(rho, le);
    let x = 0.6 * DVec3::new(0.3, -0.5, 0.8).normalize();
    let limit = z_limit(8);
    for k in 0..=3 {
        let p = params(Weighting::Radiance, Some(k), false);
        let mut s = Sampler::new(77, k as u64, 0);
        let fluence = estimate(20_000, || sample_point(&scene, x, &p, &mut s).weight.x);
        check(
            &format!("3D furnace, cap {k}: fluence"),
            fluence,
            4.0 * PI * truncated(le, rho, k),
            limit,
        );
        let p = params(Weighting::Importance, Some(k), false);
        let dir = DVec3::new(0.2, 0.9, -0.4).normalize();
        let mut s = Sampler::new(78, k as u64, 0);
        let beauty = estimate(20_000, || {
            let start = Start::Eye { eye: x, dir };
            sample::<Radiance3D>(&scene, start, &p, &mut s).weight.x
        });
        check(
            &format!("3D furnace, cap {k}: beauty"),
            beauty,
            truncated(le, rho, k),
            limit,
        );
    }
}

/// The same in flatland (a 64-gon extruded): the fluence ∫ L dθ = 2π·Le·Σ ρ^i.
#[test]
fn furnace_flatland_fluence_keeps_k_scattering_events() {
    let (rho, le) = (0.5, 1.5);
    let scene = flat_furnace(Rgb::splat(le), rho);
    let x = DVec3::new(0.3, -0.4, 0.0);
    let limit = z_limit(4);
    for k in 0..=3 {
        let p = params(Weighting::Radiance, Some(k), true);
        let mut s = Sampler::new(79, k as u64, 0);
        let fluence = estimate(20_000, || {
            luminance(sample_point(&scene, x, &p, &mut s).weight)
        });
        check(
            &format!("flatland furnace, cap {k}: fluence"),
            fluence,
            TAU * truncated(le, rho, k),
            limit,
        );
    }
}

/// The radiance cap leaves the walks alone: with radiance paths capped at 0, walks in the closed
/// furnace still scatter up to `max_bounces` times.
#[test]
fn the_walks_keep_max_bounces() {
    let scene = furnace(0.9, 1.0);
    let p = Params {
        t0: 6.0,
        t1: 6.0,
        ..params(Weighting::Radiance, Some(0), false)
    };
    let mut s = Sampler::new(80, 0, 0);
    let most = (0..500)
        .map(|_| {
            let mut most = 0;
            visit_point(&scene, DVec3::ZERO, &p, &mut s, &mut |pair| {
                most = most.max(pair.bounces.0.max(pair.bounces.1));
            });
            most
        })
        .max()
        .unwrap();
    // A walk of length 6 in the unit sphere crosses it at least 3 times.
    assert!(most >= 3, "walks scattered at most {most} times");
}

/// The closed cube [−1, 1]³, every wall facing inward, diffuse albedo `rho`, no emission.
fn closed_cube(rho: f64) -> Scene {
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for axis in 0..3 {
        for side in [-1.0f64, 1.0] {
            // Corners of the face at coordinate `side` along `axis`.
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let base = positions.len() as u32;
            for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                let mut p = [0.0f64; 3];
                p[axis] = side;
                p[u] = a;
                p[v] = b;
                positions.push(DVec3::from(p));
            }
            let mut tris = [[base, base + 1, base + 2], [base, base + 2, base + 3]];
            for t in &mut tris {
                let [a, b, c] = t.map(|i| positions[i as usize]);
                // Facing the centre: the normal points against the face's position.
                if (b - a).cross(c - a).dot(a + b + c) > 0.0 {
                    t.swap(1, 2);
                }
            }
            triangles.extend(tris);
        }
    }
    let n = triangles.len();
    let positions: Vec<Vec3> = positions.iter().map(|p| p.as_vec3()).collect();
    let wall = Material::diffuse("wall", Rgb::splat(rho));
    crate::support::scene_of("closed-cube", positions, triangles, vec![0; n], vec![wall])
}

/// ∫ over the square [−1, 1]² of `f` by `panels`² tiles of an m×m Gauss–Legendre rule.
fn square_rule(f: &dyn Fn(f64, f64) -> f64, panels: usize, m: usize) -> f64 {
    let nodes = gauss_legendre(m);
    let h = 2.0 / panels as f64;
    let mut sum = 0.0;
    for i in 0..panels {
        for j in 0..panels {
            let (cu, cv) = (-1.0 + (i as f64 + 0.5) * h, -1.0 + (j as f64 + 0.5) * h);
            for (a, wa) in &nodes {
                for (b, wb) in &nodes {
                    sum += wa * wb * f(cu + 0.5 * h * a, cv + 0.5 * h * b);
                }
            }
        }
    }
    sum * 0.25 * h * h
}

/// A point light inside the closed cube, seen from `x`: with at most one scattering event the
/// fluence is I/d² (the light itself) plus the walls' once-reflected light,
/// (ρ/π)·I·∫ cosθ_c cosθ_x / (|y − c|² |y − x|²) dA over the six walls (radiance of a wall point
/// y is ρ/π times its irradiance I cosθ_c/|y − c|², seen under the solid angle
/// cosθ_x dA/|y − x|²). A point light is reached only by sampling it, so the reflected part is
/// exactly the light sampled at the first (and, with the cap 1, last) vertex. With the cap 0 only
/// I/d² is left.
#[test]
fn point_light_in_a_closed_cube_is_sampled_at_the_last_vertex() {
    let (rho, intensity) = (0.7, 2.0);
    let c = DVec3::new(0.2, 0.1, -0.15);
    let x = DVec3::new(-0.3, -0.2, 0.25);
    let mut scene = closed_cube(rho);
    scene.add_point_light(c, Rgb::splat(intensity));
    let direct = intensity / (c - x).length_squared();
    let reflected = |panels: usize, m: usize| -> f64 {
        let mut sum = 0.0;
        for axis in 0..3 {
            for side in [-1.0f64, 1.0] {
                let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                let mut n = [0.0; 3];
                n[axis] = -side;
                let n = DVec3::from(n);
                let f = |a: f64, b: f64| {
                    let mut y = [0.0; 3];
                    y[axis] = side;
                    y[u] = a;
                    y[v] = b;
                    let y = DVec3::from(y);
                    let (tc, tx) = (c - y, x - y);
                    let (dc2, dx2) = (tc.length_squared(), tx.length_squared());
                    let cos_c = n.dot(tc) / dc2.sqrt();
                    let cos_x = n.dot(tx) / dx2.sqrt();
                    cos_c * cos_x / (dc2 * dx2)
                };
                sum += square_rule(&f, panels, m);
            }
        }
        rho / PI * intensity * sum
    };
    let (coarse, fine) = (reflected(4, 8), reflected(8, 16));
    assert!((coarse - fine).abs() < 1e-9 * fine, "{coarse} vs {fine}");
    fluence_by_cap(
        "point light in a cube",
        &scene,
        x,
        false,
        81,
        [(0, direct), (1, direct + fine)],
    );
}

/// The fluence at `x` (40 000 samples, stream `seed`) with each radiance cap k against its
/// expected value (two estimates judged together).
fn fluence_by_cap(
    label: &str,
    scene: &Scene,
    x: DVec3,
    flat: bool,
    seed: u64,
    cases: [(u32, f64); 2],
) {
    for (k, expected) in cases {
        let p = params(Weighting::Radiance, Some(k), flat);
        let mut s = Sampler::new(seed, k as u64, 0);
        let fluence = estimate(40_000, || sample_point(scene, x, &p, &mut s).weight.x);
        check(
            &format!("{label}, cap {k}: fluence"),
            fluence,
            expected,
            z_limit(cases.len()),
        );
    }
}

/// The same in flatland: the square [−1, 1]² extruded, a point light in the plane; the fluence
/// (∫ L dθ) with at most one scattering event is I/d plus
/// (ρ/2)·I·∫ cosθ_c cosθ_x / (|y − c| |y − x|) ds over the four walls (the 2D Lambertian f = ρ/2,
/// irradiance I cosθ_c/|y − c|, dθ = cosθ_x ds/|y − x|).
#[test]
fn point_light_in_a_flatland_box_is_sampled_at_the_last_vertex() {
    let (rho, intensity) = (0.7, 2.0);
    let c = DVec3::new(0.2, 0.1, 0.0);
    let x = DVec3::new(-0.3, -0.45, 0.0);
    // Clockwise, so that the walls face inward.
    let square = vec![(-1.0, -1.0), (-1.0, 1.0), (1.0, 1.0), (1.0, -1.0)];
    let wall = Material::diffuse("wall", Rgb::splat(rho));
    let mut scene = extruded(&z0(), &[(square, true, 0)], vec![wall]);
    scene.add_point_light(c, Rgb::splat(intensity));
    scene.prepare_flatland(z0(), "z=0").unwrap();
    let direct = intensity / (c - x).length();
    let nodes = gauss_legendre(32);
    let mut edges = 0.0;
    // Each wall: points y(t) for t in [−1, 1], inward normal n.
    for (n, y) in [
        (
            DVec3::X,
            (|t: f64| DVec3::new(-1.0, t, 0.0)) as fn(f64) -> DVec3,
        ),
        (-DVec3::X, |t| DVec3::new(1.0, t, 0.0)),
        (DVec3::Y, |t| DVec3::new(t, -1.0, 0.0)),
        (-DVec3::Y, |t| DVec3::new(t, 1.0, 0.0)),
    ] {
        let panels = 8;
        let h = 2.0 / panels as f64;
        for i in 0..panels {
            let mid = -1.0 + (i as f64 + 0.5) * h;
            for (a, w) in &nodes {
                let p = y(mid + 0.5 * h * a);
                let (tc, tx) = (c - p, x - p);
                let (dc, dx) = (tc.length(), tx.length());
                edges += w * 0.5 * h * (n.dot(tc) / dc) * (n.dot(tx) / dx) / (dc * dx);
            }
        }
    }
    let reflected = rho / 2.0 * intensity * edges;
    fluence_by_cap(
        "point light in a flatland box",
        &scene,
        x,
        true,
        82,
        [(0, direct), (1, direct + reflected)],
    );
}

fn attr(path: &std::path::Path, key: &str) -> Option<String> {
    crate::support::ftpd3d_attribute(&crate::support::exr_parts(path)[0], key)
}

/// On the command line: the cap is recorded beside `max_bounces`, merges of runs with other caps
/// are refused naming it, a cap equal to the default changes no bit, and bad values are refused
/// naming the flag.
#[test]
fn radiance_bounces_on_the_command_line() {
    let dir = temp_dir("radiance_cap", "cli");
    let run = |name: &str, extra: &[&str]| {
        let out = dir.join(name);
        let mut args = vec![
            "--scene",
            "scenes/cornell_mirror.obj",
            "--slice",
            "z=0",
            "--res",
            "6",
            "--spp",
            "4",
            "--quiet",
            "--no-png",
            "-o",
            out.to_str().unwrap(),
        ];
        args.extend(extra);
        let r = ftpd3d_in(std::path::Path::new(env!("CARGO_MANIFEST_DIR")), &args);
        assert!(r.ok, "{name}: {}", r.err);
        out
    };
    let plain = run("plain.exr", &[]);
    let same = run("same.exr", &["--radiance-bounces", "32"]);
    let capped = run("capped.exr", &["--radiance-bounces", "3", "--seed", "2"]);
    let capped2 = run("capped2.exr", &["--radiance-bounces", "3", "--seed", "3"]);
    assert_eq!(attr(&plain, "radiance_bounces").as_deref(), Some("32"));
    assert_eq!(attr(&capped, "radiance_bounces").as_deref(), Some("3"));
    assert_eq!(attr(&capped, "max_bounces").as_deref(), Some("32"));
    let read = |p: &std::path::Path| ftpd3d::output::exr::read_exr(p).unwrap();
    assert_eq!(
        read(&plain).cells,
        read(&same).cells,
        "the default cap, given"
    );
    assert_ne!(read(&plain).cells, read(&capped).cells);

    let merged = dir.join("merged.exr");
    let m = merged.to_str().unwrap();
    let merge = |a: &std::path::Path, b: &std::path::Path| {
        let (a, b) = (a.to_str().unwrap(), b.to_str().unwrap());
        ftpd3d(&["merge", a, b, "-o", m, "--no-png"])
    };
    let r = merge(&capped, &capped2);
    assert!(r.ok, "{}", r.err);
    assert_eq!(attr(&merged, "radiance_bounces").as_deref(), Some("3"));
    let r = merge(&capped, &plain);
    assert!(!r.ok);
    assert!(
        r.err.contains("radiance_bounces = 32 differs from") && r.err.contains("'s 3"),
        "{}",
        r.err
    );

    for (bad, says) in [
        (&["--radiance-bounces", "-1"][..], "--radiance-bounces"),
        (&["--radiance-bounces", "five"][..], "--radiance-bounces"),
        (
            &["--radiance-bounces", "2", "--weight", "unweighted"][..],
            "--radiance-bounces 2: caps the radiance paths",
        ),
    ] {
        let mut args = vec![
            "--scene",
            "scenes/cornell_mirror.obj",
            "--slice",
            "z=0",
            "--res",
            "4",
            "--spp",
            "1",
            "-o",
            m,
        ];
        args.extend(bad);
        let r = ftpd3d_in(std::path::Path::new(env!("CARGO_MANIFEST_DIR")), &args);
        assert!(!r.ok, "{bad:?} was accepted");
        assert!(r.err.contains(says), "{bad:?}: {}", r.err);
    }
}
