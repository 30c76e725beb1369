//! Lights of the outdoors: the sun (a Dirac delta, or a disc of uniform radiance), a uniform sky and
//! spot lights, in 3D and in flatland, against closed forms that do not come from the code:
//! - a Lambertian surface of albedo ρ under irradiance E reflects radiance ρ E / π (3D) or ρ E / 2
//!   (flatland, where f = ρ/2); the sun at angle θ to the normal gives E cos θ, also with a disc
//!   (∫ L cos over a cone about s is L (n·s) π sin²α, or L (n·s) 2 sin α in flatland, as long as
//!   the disc is above the horizon);
//! - a sky of radiance L gives irradiance π L (3D) or 2 L (flatland), so the plane reflects ρ L;
//!   inside a closed box no sky light arrives;
//! - a spot light follows glTF's `KHR_lights_punctual` falloff, written out here from the
//!   specification.
//!
//! Monte Carlo checks use fixed seeds and a tolerance of k standard errors computed from the same
//! samples, k = `support::z_limit(m)` for the m estimates a test judges (a false failure with
//! probability under 1e-4 whatever the seeds); estimates whose every sample is the same number
//! (next-event estimation of a delta light) are checked to rounding.

use crate::support::{mean_and_se, scene_path, z_limit};
use ftpd3d::kernel::{Radiance3D, RadianceFlat};
use ftpd3d::math::Rgb;
use ftpd3d::rng::Sampler;
use ftpd3d::scene::flat::Flatland;
use ftpd3d::scene::load::load_scene;
use ftpd3d::scene::{Light, Material, Scene};
use ftpd3d::transport::walk::{RadianceStats, radiance};
use glam::{DVec3, Vec3};
use std::f64::consts::PI;

/// The shipped 20 × 20 plane at y = 0 (albedo 0.8) with `light` added; flatland on z = 0 when
/// `flat`.
fn plane_with(light: Light, flat: bool) -> Scene {
    let mut scene = load_scene(&scene_path("diffuse_plane.obj")).unwrap();
    scene.add_light(light);
    if flat {
        let pl = Flatland::new(DVec3::ZERO, DVec3::X, DVec3::Y);
        scene.prepare_flatland(pl, "z=0").unwrap();
    }
    scene
}

const RHO: f64 = 0.8;

/// Mean and standard error of the radiance (luminance of grey = any channel) arriving at `x`
/// from the plane point `q`.
fn radiance_at(scene: &Scene, x: DVec3, q: DVec3, flat: bool, n: usize, seed: u64) -> (f64, f64) {
    let (mean, se, _, _) = radiance_stats(scene, x, q, flat, n, seed);
    (mean, se)
}

/// [`radiance_at`] with the smallest and largest sample.
fn radiance_stats(
    scene: &Scene,
    x: DVec3,
    q: DVec3,
    flat: bool,
    n: usize,
    seed: u64,
) -> (f64, f64, f64, f64) {
    let mut s = Sampler::new(seed, 0, 0);
    let (mut sum, mut sum2) = (0.0, 0.0);
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for _ in 0..n {
        let mut st = RadianceStats::default();
        let look = (q - x).normalize();
        let r = if flat {
            radiance::<RadianceFlat>(scene, x, look, 16, &mut s, &mut st)
        } else {
            radiance::<Radiance3D>(scene, x, look, 16, &mut s, &mut st)
        };
        let l = r.total();
        assert!(l.x == l.y && l.y == l.z && l.x.is_finite());
        sum += l.x;
        sum2 += l.x * l.x;
        lo = lo.min(l.x);
        hi = hi.max(l.x);
    }
    let (mean, se) = mean_and_se(sum, sum2, n);
    (mean, se, lo, hi)
}

/// Every sample equals `expected` to rounding.
fn all_equal(lo: f64, hi: f64, expected: f64) -> bool {
    let tol = 1e-13 * expected.abs().max(1e-300);
    (lo - expected).abs() <= tol && (hi - expected).abs() <= tol
}

/// A delta sun: every estimate is next-event estimation of one direction, so each sample is
/// ρ/π · E cos θ (ρ/2 · E cos θ in flatland) to rounding.
#[test]
fn delta_sun_over_a_diffuse_plane_gives_e_cos_theta() {
    let e = 2.5;
    for flat in [false, true] {
        for theta_deg in [0.0f64, 30.0, 75.0] {
            let t = theta_deg.to_radians();
            let dir = DVec3::new(t.sin(), t.cos(), 0.0);
            let scene = plane_with(Light::distant(dir, Rgb::splat(e), 0.0), flat);
            let brdf = if flat { RHO / 2.0 } else { RHO / PI };
            let expected = brdf * e * t.cos();
            let x = DVec3::new(0.2, 1.0, 0.0);
            for qx in [-2.0, 0.0, 3.0] {
                let q = DVec3::new(qx, 0.0, 0.0);
                let (_, _, lo, hi) = radiance_stats(&scene, x, q, flat, 64, 5);
                assert!(
                    all_equal(lo, hi, expected),
                    "flat {flat}, θ {theta_deg}°: samples in [{lo}, {hi}] vs {expected}"
                );
            }
        }
    }
}

/// A sun with a disc (here 10°, wide enough for the disc to matter): light sampling over the cone
/// and BSDF samples that reach the disc, weighted by MIS, give E cos θ on average.
#[test]
fn sun_with_a_disc_gives_e_cos_theta_within_its_standard_errors() {
    let e = 2.0;
    let k = z_limit(4);
    for flat in [false, true] {
        for theta_deg in [0.0f64, 50.0] {
            let t = theta_deg.to_radians();
            let dir = DVec3::new(t.sin(), t.cos(), 0.0);
            let half = 5.0f64.to_radians();
            let scene = plane_with(Light::distant(dir, Rgb::splat(e), half), flat);
            let brdf = if flat { RHO / 2.0 } else { RHO / PI };
            let expected = brdf * e * t.cos();
            let x = DVec3::new(0.0, 1.0, 0.0);
            let (mean, se) = radiance_at(&scene, x, DVec3::new(0.5, 0.0, 0.0), flat, 40_000, 7);
            eprintln!("flat {flat}, θ {theta_deg}°: {mean:.6} ± {se:.6} vs {expected:.6}");
            assert!(se > 0.0, "a disc is sampled, not a delta");
            assert!(
                (mean - expected).abs() <= k * se,
                "flat {flat}, θ {theta_deg}°: {mean} ± {se} vs {expected}"
            );
        }
    }
}

/// Rays that leave the scene see the disc exactly within its angular radius: the radiance seen
/// looking straight at the sun is E / (π sin²α) (3D) or E / (2 sin α) (flatland), and none just
/// outside it.
#[test]
fn looking_at_the_sun_disc_sees_its_radiance_and_nothing_beside_it() {
    let (e, half) = (3.0, 2.0f64.to_radians());
    for flat in [false, true] {
        let dir = DVec3::new(0.6, 0.8, 0.0);
        let scene = plane_with(Light::distant(dir, Rgb::splat(e), half), flat);
        let expected = if flat {
            e / (2.0 * half.sin())
        } else {
            e / (PI * half.sin().powi(2))
        };
        let x = DVec3::new(0.0, 1.0, 0.0);
        let mut s = Sampler::new(3, 0, 0);
        let mut st = RadianceStats::default();
        let hit = if flat {
            radiance::<RadianceFlat>(&scene, x, dir, 4, &mut s, &mut st)
        } else {
            radiance::<Radiance3D>(&scene, x, dir, 4, &mut s, &mut st)
        };
        assert!(hit.escaped);
        assert!(
            (hit.direct.x - expected).abs() <= 1e-12 * expected,
            "{hit:?}"
        );
        // 1.1 α away, in the plane z = 0 (so also in flatland's plane).
        let a = 1.1 * half;
        let beside = DVec3::new(
            dir.x * a.cos() - dir.y * a.sin(),
            dir.x * a.sin() + dir.y * a.cos(),
            0.0,
        );
        let miss = if flat {
            radiance::<RadianceFlat>(&scene, x, beside, 4, &mut s, &mut st)
        } else {
            radiance::<Radiance3D>(&scene, x, beside, 4, &mut s, &mut st)
        };
        assert_eq!(miss.total(), Rgb::ZERO, "flat {flat}");
    }
}

/// A uniform sky over the plane: irradiance π L (3D) or 2 L (flatland), so the plane reflects
/// ρ L in both.
#[test]
fn sky_over_a_diffuse_plane_gives_rho_times_its_radiance() {
    let l = 1.5;
    let k = z_limit(2);
    for flat in [false, true] {
        let scene = plane_with(
            Light::Sky {
                radiance: Rgb::splat(l),
            },
            flat,
        );
        let x = DVec3::new(0.0, 1.0, 0.0);
        let (mean, se) = radiance_at(&scene, x, DVec3::new(-0.7, 0.0, 0.0), flat, 40_000, 11);
        let expected = RHO * l;
        eprintln!("flat {flat}: {mean:.6} ± {se:.6} vs {expected:.6}");
        assert!(se > 0.0);
        assert!(
            (mean - expected).abs() <= k * se,
            "flat {flat}: {mean} ± {se} vs {expected}"
        );
        // Looking up: the sky itself.
        let mut s = Sampler::new(2, 0, 0);
        let mut st = RadianceStats::default();
        let up = if flat {
            radiance::<RadianceFlat>(&scene, x, DVec3::Y, 4, &mut s, &mut st)
        } else {
            radiance::<Radiance3D>(&scene, x, DVec3::Y, 4, &mut s, &mut st)
        };
        assert_eq!(up.total(), Rgb::splat(l));
    }
}

/// A closed cube (faces towards the inside) under a sky and a sun: no light gets in.
#[test]
fn no_sky_or_sun_light_reaches_the_inside_of_a_closed_box() {
    let (positions, triangles) = crate::support::cuboid(-DVec3::ONE, DVec3::ONE, true);
    let n = triangles.len();
    let mut scene = crate::support::scene_of(
        "closed-box",
        positions,
        triangles,
        vec![0; n],
        vec![Material::diffuse("wall", Rgb::splat(0.9))],
    );
    scene.add_light(Light::Sky { radiance: Rgb::ONE });
    scene.add_light(Light::distant(DVec3::Y, Rgb::splat(5.0), 0.01));
    let mut s = Sampler::new(13, 0, 0);
    for _ in 0..5000 {
        let look = ftpd3d::transport::sampling::sample_uniform_sphere(s.next_2d());
        let mut st = RadianceStats::default();
        let r = radiance::<Radiance3D>(
            &scene,
            DVec3::new(0.1, -0.2, 0.3),
            look,
            16,
            &mut s,
            &mut st,
        );
        assert_eq!(r.total(), Rgb::ZERO);
    }
}

/// glTF's spot falloff, from the `KHR_lights_punctual` specification.
fn gltf_spot(cd: f64, inner: f64, outer: f64) -> f64 {
    let scale = 1.0 / f64::max(0.001, inner.cos() - outer.cos());
    let offset = -outer.cos() * scale;
    let a = (cd * scale + offset).clamp(0.0, 1.0);
    a * a
}

/// A spot light pointing down at the plane: ρ/π · I · falloff · cos θ / d² inside its cone, in
/// its smooth edge and outside (0).
#[test]
fn spot_light_follows_the_gltf_falloff() {
    let (inner, outer) = (20.0f64.to_radians(), 35.0f64.to_radians());
    let (pos, i) = (DVec3::new(0.0, 2.0, 0.0), 4.0);
    let dir = DVec3::new(0.0, -1.0, 0.0);
    let scene = plane_with(
        Light::Spot {
            position: pos,
            direction: dir,
            intensity: Rgb::splat(i),
            cos_inner: inner.cos(),
            cos_outer: outer.cos(),
        },
        false,
    );
    let x = DVec3::new(0.0, 1.0, 0.5);
    let mut seen = [false; 3];
    for qx in [0.3, 0.8, 1.0, 1.2, 2.0] {
        let q = DVec3::new(qx, 0.0, 0.0);
        let to = pos - q;
        let d = to.length();
        let cd = (-to / d).dot(dir);
        let f = gltf_spot(cd, inner, outer);
        seen[if f == 1.0 {
            0
        } else if f > 0.0 {
            1
        } else {
            2
        }] = true;
        let expected = RHO / PI * i * f * (to.y / d) / (d * d);
        let (_, _, lo, hi) = radiance_stats(&scene, x, q, false, 32, 17);
        assert!(
            all_equal(lo, hi, expected),
            "q {qx}: samples in [{lo}, {hi}] vs {expected}"
        );
    }
    assert!(
        seen.iter().all(|s| *s),
        "inside, edge and outside all checked"
    );
}

/// The radiance-weighted FTPD estimator's direction weights average to the fluence ∫ L dω. Under
/// a sky of radiance L and a sun with a disc, at height h = 1 over the centre of the 20 × 20 plane,
/// which covers the solid angle Ω_p = 4 asin(a² / (a² + h²)) (a = 10): the sky's L over the
/// 4π − Ω_p that miss the plane (the sky surrounds the scene, also below a finite plane's
/// horizon), L_sun Ω_sun from the disc, and the plane's radiance ρ L + ρ/π E cos θ over Ω_p. In
/// flatland: L (2π − θ_p), L_sun 2α and ρ L + ρ/2 E cos θ over θ_p = 2 atan(a / h). Uniform directions and light sampling are
/// combined by MIS, including for directions that leave the scene.
#[test]
fn fluence_under_sky_and_sun_matches_the_closed_form() {
    use ftpd3d::ftpd::{Params, Weighting, sample_point};
    let (l, e, half, theta) = (0.7, 2.0, 4.0f64.to_radians(), 30.0f64.to_radians());
    let (a, h) = (10.0f64, 1.0f64);
    let k = z_limit(2);
    for flat in [false, true] {
        let mut scene = plane_with(
            Light::Sky {
                radiance: Rgb::splat(l),
            },
            false,
        );
        let dir = DVec3::new(theta.sin(), theta.cos(), 0.0);
        scene.add_light(Light::distant(dir, Rgb::splat(e), half));
        let pl = Flatland::new(DVec3::ZERO, DVec3::X, DVec3::Y);
        if flat {
            scene.prepare_flatland(pl, "z=0").unwrap();
        }
        let expected = if flat {
            let l_sun = e / (2.0 * half.sin());
            let theta_plane = 2.0 * (a / h).atan();
            l * (2.0 * PI - theta_plane)
                + l_sun * 2.0 * half
                + (RHO * l + RHO / 2.0 * e * theta.cos()) * theta_plane
        } else {
            let l_sun = e / (PI * half.sin().powi(2));
            let omega_sun = 2.0 * PI * (1.0 - half.cos());
            let omega_plane = 4.0 * (a * a / (a * a + h * h)).asin();
            l * (4.0 * PI - omega_plane)
                + l_sun * omega_sun
                + (RHO * l + RHO / PI * e * theta.cos()) * omega_plane
        };
        let p = Params {
            t0: 0.5,
            t1: 1.0,
            theta_max: 0.1,
            weighting: Weighting::Radiance,
            max_bounces: 16,
            radiance_bounces: None,
            flat: flat.then_some(pl),
            design: ftpd3d::ftpd::Design::default_for(Weighting::Radiance),
            guide: false,
        };
        let mut s = Sampler::new(19, 0, 0);
        let n = 200_000;
        let (mut sum, mut sum2) = (0.0, 0.0);
        for _ in 0..n {
            let w = sample_point(&scene, DVec3::new(0.0, h, 0.0), &p, &mut s)
                .weight
                .x;
            sum += w;
            sum2 += w * w;
        }
        let (mean, se) = mean_and_se(sum, sum2, n);
        eprintln!("flat {flat}: fluence {mean:.5} ± {se:.5} vs {expected:.5}");
        assert!(
            (mean - expected).abs() <= k * se,
            "flat {flat}: {mean} ± {se} vs {expected}"
        );
    }
}

// ------------------------------------------------------------------------------------------------
// Environment maps

use ftpd3d::scene::env::{EnvMap, Environment};

/// A 32 × 16 map: a smooth gradient, a black band and a bright texel above the horizon.
fn test_map(rotation_deg: f64) -> EnvMap {
    let (w, h) = (32, 16);
    let mut texels = Vec::new();
    for j in 0..h {
        for i in 0..w {
            let base = 0.2 + 0.8 * (i as f64 / w as f64) * (1.0 - j as f64 / h as f64);
            let v = if (5..7).contains(&i) {
                0.0
            } else if (i, j) == (20, 4) {
                40.0
            } else {
                base
            };
            texels.push(Rgb::new(v, 0.5 * v, 0.25 * v));
        }
    }
    EnvMap::new(w, h, texels, 1.5, rotation_deg, "test-map").unwrap()
}

/// The sampling density integrates to 1 over the sphere (midpoint rule on a grid 4× finer than
/// the cells between texel centres and aligned with them: the density × sin θ is bilinear in
/// (u, v) on each cell, which the rule integrates exactly, to rounding), and the density a sample
/// reports is the density at its direction (the density is continuous, so every sample agrees).
#[test]
fn env_map_density_integrates_to_one_and_matches_its_samples() {
    use ftpd3d::kernel::{Space, Sphere};
    for rot in [0.0, 37.0] {
        let map = test_map(rot);
        let (w, h) = (map.width, map.height);
        let sub = 4;
        let mut total = 0.0;
        for j in 0..(h - 1) * sub {
            let v = (j as f64 + 0.5) / ((h - 1) * sub) as f64;
            for i in 0..w * sub {
                let u = (0.5 + (i as f64 + 0.5) / sub as f64) / w as f64;
                let d = map.direction(u.rem_euclid(1.0), v);
                let dw = 2.0 * PI * PI * (PI * v).sin() / ((h - 1) * sub * w * sub) as f64;
                total += map.pdf_sphere(d) * dw;
            }
        }
        assert!(
            (total - 1.0).abs() < 1e-12,
            "rotation {rot}: ∫ pdf = {total}"
        );
        let env = Environment::new(map.clone());
        let mut s = Sampler::new(23, 0, 0);
        for k in 0..10_000 {
            let (d, pdf) = Sphere::env_sample(&env, s.next_2d()).unwrap();
            assert!((d.length() - 1.0).abs() < 1e-12);
            let back = Sphere::env_pdf(&env, d);
            assert!(
                (back - pdf).abs() <= 1e-9 * pdf,
                "rotation {rot}, sample {k}: {back} vs {pdf}"
            );
            assert!(
                map.radiance(d) != Rgb::ZERO,
                "black texels are never sampled"
            );
        }
    }
    // Flatland: the density over the plane's circle integrates to 1 per radian.
    let pl = Flatland::new(DVec3::ZERO, DVec3::X, DVec3::Y);
    let env = Environment::new(test_map(10.0)).in_plane(pl.e1, pl.e2);
    // A whole number of points per bin of the circle's table (4 per texel column: 128 bins), so
    // that the midpoint rule is exact for its piecewise-constant density.
    let n = 128_000;
    let total: f64 = (0..n)
        .map(|k| {
            let phi = 2.0 * PI * (k as f64 + 0.5) / n as f64;
            let d = pl.e1 * phi.cos() + pl.e2 * phi.sin();
            <Flatland as ftpd3d::kernel::Space>::env_pdf(&env, d) * 2.0 * PI / n as f64
        })
        .sum();
    assert!((total - 1.0).abs() < 1e-9, "flatland ∫ pdf = {total}");
}

/// Irradiance on a surface facing +y, by quadrature of the bilinear map: over u each row's
/// piecewise-linear radiance integrates to its mean, so E = 2π² ∫₀^½ Σ_j tent_j(v) mean_j
/// cos(π v) sin(π v) dv, integrated by Gauss–Legendre on each interval between rows (split at the
/// horizon), exact to rounding for this smooth integrand.
fn exact_irradiance_up(map: &EnvMap) -> f64 {
    let (w, h) = (map.width, map.height);
    let mean: Vec<f64> = (0..h)
        .map(|j| (0..w).map(|i| map.texels[j * w + i].x).sum::<f64>() / w as f64)
        .collect();
    let gl = crate::support::gauss_legendre(24);
    let d = 1.0 / (h - 1) as f64;
    let mut e = 0.0;
    for j in 0..h - 1 {
        let (v0, v1) = (j as f64 * d, ((j + 1) as f64 * d).min(0.5));
        if v1 <= v0 {
            break;
        }
        for &(x, wt) in &gl {
            let v = v0 + (v1 - v0) * (x + 1.0) / 2.0;
            let t = (v - j as f64 * d) / d;
            let l = (1.0 - t) * mean[j] + t * mean[j + 1];
            e += wt * (v1 - v0) / 2.0 * l * (PI * v).cos() * (PI * v).sin();
        }
    }
    2.0 * PI * PI * e
}

/// The irradiance of the map on a horizontal surface, estimated by importance sampling the map
/// and by uniform directions over the hemisphere: both agree with the closed form and with each
/// other within their standard errors (three estimates judged together).
#[test]
fn env_map_importance_and_uniform_estimates_agree() {
    use ftpd3d::kernel::{Space, Sphere};
    let map = test_map(25.0);
    let exact = exact_irradiance_up(&map);
    let env = Environment::new(map.clone());
    let n = 200_000;
    let mut s = Sampler::new(29, 0, 0);
    let (mut a, mut a2, mut b, mut b2) = (0.0, 0.0, 0.0, 0.0);
    for _ in 0..n {
        let (d, pdf) = Sphere::env_sample(&env, s.next_2d()).unwrap();
        let f = map.radiance(d).x * d.y.max(0.0) / pdf;
        a += f;
        a2 += f * f;
        let u = s.next_2d();
        // Uniform on the upper hemisphere: cos θ = u, density 1/2π.
        let (ct, phi) = (u.0, 2.0 * PI * u.1);
        let st = (1.0 - ct * ct).sqrt();
        let d = DVec3::new(st * phi.cos(), ct, st * phi.sin());
        let g = map.radiance(d).x * ct * 2.0 * PI;
        b += g;
        b2 += g * g;
    }
    let (ma, sa) = mean_and_se(a, a2, n);
    let (mb, sb) = mean_and_se(b, b2, n);
    eprintln!("importance {ma:.5} ± {sa:.5}, uniform {mb:.5} ± {sb:.5}, exact {exact:.5}");
    let k = z_limit(3);
    assert!((ma - mb).abs() <= k * (sa * sa + sb * sb).sqrt());
    assert!((ma - exact).abs() <= k * sa && (mb - exact).abs() <= k * sb);
    assert!(sa < sb, "importance sampling has the smaller error here");
}

/// The radiance estimator on the diffuse plane under the map (next-event estimation from the map's
/// tables, BSDF samples that leave the scene, MIS between them): ρ/π times the closed-form
/// irradiance, within 4 standard errors.
#[test]
fn env_map_over_a_diffuse_plane_reflects_rho_over_pi_times_its_irradiance() {
    let map = test_map(-40.0);
    let expected = RHO / PI * exact_irradiance_up(&map);
    let mut scene = load_scene(&scene_path("diffuse_plane.obj")).unwrap();
    scene.add_light(Light::Env(Environment::new(map)));
    let x = DVec3::new(0.0, 1.0, 0.0);
    let mut s = Sampler::new(31, 0, 0);
    let n = 40_000;
    let (mut sum, mut sum2) = (0.0, 0.0);
    for _ in 0..n {
        let mut st = RadianceStats::default();
        let look = (DVec3::new(0.3, 0.0, -0.2) - x).normalize();
        let l = radiance::<Radiance3D>(&scene, x, look, 16, &mut s, &mut st)
            .total()
            .x;
        sum += l;
        sum2 += l * l;
    }
    let (mean, se) = mean_and_se(sum, sum2, n);
    eprintln!("env over plane: {mean:.5} ± {se:.5} vs {expected:.5}");
    assert!(
        (mean - expected).abs() <= z_limit(1) * se,
        "{mean} ± {se} vs {expected}"
    );
}

/// A map with one bright texel (its radiance spread bilinearly over the neighbouring texel
/// centres) lights a plane as the quadrature of the map says: the estimator's next-event
/// estimation from the map's tables and its BSDF samples find the small bright patch.
#[test]
fn one_bright_texel_lights_a_plane_as_the_quadrature_says() {
    let (w, h, l) = (512, 256, 5000.0);
    let (ti, tj) = (100, 57);
    let mut texels = vec![Rgb::ZERO; w * h];
    texels[tj * w + ti] = Rgb::splat(l);
    let map = EnvMap::new(w, h, texels, 1.0, 0.0, "one-texel").unwrap();
    let closed = RHO / PI * exact_irradiance_up(&map);
    let mut scene = load_scene(&scene_path("diffuse_plane.obj")).unwrap();
    scene.add_light(Light::Env(Environment::new(map)));
    let x = DVec3::new(0.0, 1.0, 0.0);
    let mut s = Sampler::new(37, 0, 0);
    let n = 20_000;
    let (mut sum, mut sum2) = (0.0, 0.0);
    for _ in 0..n {
        let mut st = RadianceStats::default();
        let l = radiance::<Radiance3D>(&scene, x, -DVec3::Y, 16, &mut s, &mut st)
            .total()
            .x;
        sum += l;
        sum2 += l * l;
    }
    let (a, sa) = mean_and_se(sum, sum2, n);
    eprintln!("texel {a:.5} ± {sa:.5}, quadrature {closed:.5}");
    assert!(closed > 0.0);
    assert!(
        (a - closed).abs() <= z_limit(1) * sa,
        "{a} ± {sa} vs {closed}"
    );
}

/// In flatland a constant map is a uniform sky: the plane reflects ρ L.
#[test]
fn constant_env_map_in_flatland_is_a_uniform_sky() {
    let l = 0.9;
    let map = EnvMap::new(8, 4, vec![Rgb::splat(l); 32], 1.0, 15.0, "constant").unwrap();
    let scene = plane_with(Light::Env(Environment::new(map)), true);
    let x = DVec3::new(0.0, 1.0, 0.0);
    let (mean, se) = radiance_at(&scene, x, DVec3::new(0.4, 0.0, 0.0), true, 40_000, 43);
    let expected = RHO * l;
    eprintln!("flatland constant map: {mean:.5} ± {se:.5} vs {expected:.5}");
    assert!((mean - expected).abs() <= z_limit(1) * se);
}

/// `--env FILE:SCALE:ROT` reads a lat-long EXR from the command line, `--explain` lists the sky
/// it makes, a run records it in the field's metadata, and a missing or wrong file is an error
/// that names it.
#[test]
fn env_flag_reads_an_exr_map() {
    use exr::prelude::*;
    let dir = crate::support::temp_dir("outdoor", "env_flag");
    let path = dir.join("sky.exr");
    let (w, h) = (16, 8);
    write_rgb_file(&path, w, h, |x, y| {
        (0.5 + x as f32 / w as f32, 0.4f32, 1.0 - y as f32 / h as f32)
    })
    .unwrap();
    let plane = scene_path("diffuse_plane.obj");
    let plane = plane.to_str().unwrap();
    let env = format!("{}:2:90", path.display());
    let r = crate::support::ftpd3d_in(&dir, &["--scene", plane, "--env", &env, "--explain"]);
    assert!(r.ok, "{}", r.err);
    assert!(r.out.contains("1 skies and environment maps"), "{}", r.out);
    assert!(
        r.out
            .lines()
            .any(|l| l.starts_with("simulates") && l.contains(" sky")),
        "{}",
        r.out
    );
    let r = crate::support::ftpd3d_in(
        &dir,
        &[
            "--scene", plane, "--env", &env, "--slice", "z=0", "--res", "6", "--spp", "2",
            "--quiet", "--no-png", "-o", "f.exr",
        ],
    );
    assert!(r.ok, "{}", r.err);
    let f = ftpd3d::output::exr::read_exr(&dir.join("f.exr")).unwrap();
    assert_eq!(f.meta["sky"], format!("{}:2:90", path.display()));
    let missing = dir.join("missing.hdr");
    let m = format!("{}", missing.display());
    let r = crate::support::ftpd3d_in(&dir, &["--scene", plane, "--env", &m, "--explain"]);
    assert!(!r.ok && r.err.contains(&m), "{}", r.err);
    let txt = dir.join("sky.txt");
    std::fs::write(&txt, "not an image").unwrap();
    let t = format!("{}", txt.display());
    let r = crate::support::ftpd3d_in(&dir, &["--scene", plane, "--env", &t, "--explain"]);
    assert!(!r.ok && r.err.contains("must be .exr or .hdr"), "{}", r.err);
}

/// The penumbra of a sun disc behind a straight edge: a black plate at height d = 1 covers x ≤ 0
/// above the ground, the sun stands overhead with a 10° diameter. Across the shadow's edge the
/// ground's radiance follows ρ/π times the visible part of the disc's irradiance, computed here by
/// quadrature over the cone; the penumbra spans d·tan(diameter) (to within 1 %, the difference
/// between 2 tan α and tan 2α): points more than half of it inside the shadow are exactly black,
/// points more than half of it outside are fully lit.
#[test]
fn sun_disc_penumbra_behind_an_edge() {
    let (e, half, d) = (3.0, 5.0f64.to_radians(), 1.0);
    let positions: Vec<Vec3> = [
        [-10.0, 0.0, -10.0],
        [-10.0, 0.0, 10.0],
        [10.0, 0.0, 10.0],
        [10.0, 0.0, -10.0],
        [-10.0, d, -10.0],
        [0.0, d, -10.0],
        [0.0, d, 10.0],
        [-10.0, d, 10.0],
    ]
    .iter()
    .map(|p| Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32))
    .collect();
    let triangles = vec![[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]];
    let mut scene = crate::support::scene_of(
        "penumbra",
        positions,
        triangles,
        vec![0, 0, 1, 1],
        vec![
            Material::diffuse("ground", Rgb::splat(RHO)),
            Material::diffuse("plate", Rgb::ZERO),
        ],
    );
    scene.add_light(Light::distant(DVec3::Y, Rgb::splat(e), half));
    let l_sun = e / (PI * half.sin().powi(2));
    // Irradiance from the visible part of the disc at ground point x (midpoint rule over the cone).
    let visible_irradiance = |x: f64| {
        let (nt, np) = (400, 800);
        let mut sum = 0.0;
        for i in 0..nt {
            let t = half * (i as f64 + 0.5) / nt as f64;
            for j in 0..np {
                let p = 2.0 * PI * (j as f64 + 0.5) / np as f64;
                let x_hit = x + d * t.tan() * p.cos();
                if x_hit > 0.0 {
                    sum += t.cos() * t.sin();
                }
            }
        }
        l_sun * sum * (half / nt as f64) * (2.0 * PI / np as f64)
    };
    let w = d * (2.0 * half).tan();
    let eye = DVec3::new(0.0, 0.5, 2.0);
    // At most 17 estimates judged; 2e-3 of the lit radiance bounds the quadrature's error.
    let limit = z_limit(17);
    for k in -8..=8 {
        let x = 0.75 * w * k as f64 / 4.0;
        let q = DVec3::new(x, 0.0, 0.0);
        let (mean, se, lo, hi) = radiance_stats(&scene, eye, q, false, 4000, (60 + k) as u64);
        let expected = RHO / PI * visible_irradiance(x);
        eprintln!("x = {x:+.4}: {mean:.5} ± {se:.5} vs {expected:.5}");
        if x < -0.5 * w * 1.01 {
            assert!(
                lo == 0.0 && hi == 0.0,
                "x = {x}: in the umbra, but [{lo}, {hi}]"
            );
        } else {
            assert!(
                (mean - expected).abs() <= limit * se + 2e-3 * RHO / PI * e,
                "x = {x}: {mean} ± {se} vs {expected}"
            );
        }
        if x > 0.5 * w * 1.01 {
            assert!(
                (expected / (RHO / PI * e) - 1.0).abs() < 2e-3,
                "fully lit at {x}"
            );
        }
    }
}

/// The scene file's light tables: `[[spot_light]]`, `[[sun]]`, `[sky]` and `[environment]` (a map
/// relative to the file) load with their values; bad values are refused naming the file and the
/// table.
#[test]
fn scene_file_light_tables_load_and_bad_ones_are_refused() {
    use exr::prelude::*;
    let dir = crate::support::temp_dir("outdoor", "sidecar_lights");
    std::fs::copy(scene_path("diffuse_plane.obj"), dir.join("plane.obj")).unwrap();
    std::fs::copy(
        scene_path("diffuse_plane.mtl"),
        dir.join("diffuse_plane.mtl"),
    )
    .unwrap();
    write_rgb_file(dir.join("sky.exr"), 8, 4, |_, _| (0.5f32, 0.5f32, 0.5f32)).unwrap();
    let good = r#"mesh = "plane.obj"

[[spot_light]]
position = [0.0, 2.0, 0.0]
direction = [0.0, -2.0, 0.0]
intensity = [4.0, 4.0, 4.0]
inner_deg = 20.0
outer_deg = 35.0

[[sun]]
direction = [0.0, 3.0, 4.0]
irradiance = [2.0, 2.0, 2.0]

[sky]
radiance = [0.1, 0.2, 0.3]

[environment]
file = "sky.exr"
scale = 2.0
rotation_deg = 30.0
"#;
    let path = dir.join("lit.toml");
    std::fs::write(&path, good).unwrap();
    let scene = load_scene(&path).unwrap();
    let f = scene.features;
    assert!(f.spot_lights && f.sun && f.sky && !f.point_lights);
    let mut kinds = [0; 4];
    for l in &scene.lights.lights {
        match l {
            Light::Spot {
                direction,
                cos_inner,
                cos_outer,
                ..
            } => {
                kinds[0] += 1;
                assert_eq!(*direction, -DVec3::Y);
                assert!((cos_inner - 20f64.to_radians().cos()).abs() < 1e-15);
                assert!((cos_outer - 35f64.to_radians().cos()).abs() < 1e-15);
            }
            Light::Distant {
                direction,
                half_angle,
                ..
            } => {
                kinds[1] += 1;
                assert!((*direction - DVec3::new(0.0, 0.6, 0.8)).length() < 1e-15);
                assert!((half_angle - 0.265f64.to_radians()).abs() < 1e-15);
            }
            Light::Sky { radiance } => {
                kinds[2] += 1;
                assert_eq!(*radiance, Rgb::new(0.1, 0.2, 0.3));
            }
            Light::Env(env) => {
                kinds[3] += 1;
                assert_eq!(env.map.texels[0], Rgb::splat(1.0));
                assert!((env.map.rotation - 30f64.to_radians()).abs() < 1e-15);
            }
            _ => {}
        }
    }
    assert_eq!(kinds, [1, 1, 1, 1]);
    let bad = [
        (
            "[[sun]]\ndirection = [0.0, 0.0, 0.0]\nirradiance = [1.0, 1.0, 1.0]\n",
            "sun #1: direction must be finite and not zero",
        ),
        (
            "[[spot_light]]\nposition = [0.0, 1.0, 0.0]\ndirection = [0.0, -1.0, 0.0]\n\
             intensity = [1.0, 1.0, 1.0]\ninner_deg = 40.0\nouter_deg = 30.0\n",
            "spot_light #1: position must be finite",
        ),
        (
            "[sky]\nradiance = [-1.0, 0.0, 0.0]\n",
            "sky: radiance must be finite and ≥ 0",
        ),
        ("[environment]\nfile = \"missing.hdr\"\n", "[environment]"),
    ];
    for (table, want) in bad {
        let p = dir.join("bad.toml");
        std::fs::write(&p, format!("mesh = \"plane.obj\"\n\n{table}")).unwrap();
        let Err(e) = load_scene(&p) else {
            panic!("{table} should be refused")
        };
        let e = format!("{e:#}");
        assert!(
            e.contains(&p.display().to_string()) && e.contains(want),
            "{e}"
        );
    }
}

/// In flatland a sun must shine within the slice plane, and a spot light must stand in it; both are
/// refused otherwise, naming the light.
#[test]
fn flatland_refuses_suns_and_spots_out_of_the_plane() {
    let pl = Flatland::new(DVec3::ZERO, DVec3::X, DVec3::Y);
    let mut scene = load_scene(&scene_path("diffuse_plane.obj")).unwrap();
    scene.add_light(Light::distant(
        DVec3::new(0.0, 1.0, 0.5).normalize(),
        Rgb::ONE,
        0.0,
    ));
    let e = format!("{:#}", scene.prepare_flatland(pl, "z=0").unwrap_err());
    assert!(
        e.contains("sun direction") && e.contains("not in the slice plane z=0"),
        "{e}"
    );
    let mut scene = load_scene(&scene_path("diffuse_plane.obj")).unwrap();
    scene.add_light(Light::Spot {
        position: DVec3::new(0.0, 1.0, 0.3),
        direction: -DVec3::Y,
        intensity: Rgb::ONE,
        cos_inner: 0.9,
        cos_outer: 0.8,
    });
    let e = format!("{:#}", scene.prepare_flatland(pl, "z=0").unwrap_err());
    assert!(
        e.contains("spot light at (0, 1, 0.3)") && e.contains("must lie in the plane"),
        "{e}"
    );
    // In the plane, both are accepted.
    let mut scene = load_scene(&scene_path("diffuse_plane.obj")).unwrap();
    scene.add_light(Light::distant(DVec3::new(0.6, 0.8, 0.0), Rgb::ONE, 0.01));
    scene.prepare_flatland(pl, "z=0").unwrap();
    assert_eq!(scene.flat().lights.lights.len(), 1);
}
