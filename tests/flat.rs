//! Flatland (`--flatland`): 2D light transport in scenes extruded along the slice normal, against
//! analytic 2D facts (angle measure, Jarosz et al. 2012).
//!
//! How tolerances are set (as in `bsdf.rs`): Monte Carlo means agree within k standard errors
//! computed from the sample variance, k = `support::z_limit(m)` for the m means a test judges (a
//! false failure with probability under 1e-4 whatever the seeds); integrals over the circle are composite Gauss–Legendre on
//! pieces split at every kink of the integrand, computed twice (coarse, and with panels and nodes
//! doubled), and allowed three times the coarse–fine difference; sampling is compared with the
//! density by Pearson's chi-square with the threshold at α = 1e-4 (`bsdf::chi2_test`); deterministic
//! quantities to a few ulps scaled by their magnitude. All random numbers come from fixed seeds.

use crate::support::{
    Run, chi2_test, extruded, flat_furnace, ftpd3d, gauss_legendre, mean_and_se, scene_path,
    translated, z_limit, z0,
};
use ftpd3d::domain::Plane;
use ftpd3d::ftpd::{Params, Weighting, radiance_direction, sample_at, visit_point};
use ftpd3d::kernel::{PlainFlat, RadianceFlat, Record};
use ftpd3d::math::{Rgb, luminance, reflect};
use ftpd3d::render::RenderOptions;
use ftpd3d::render::run_plane;
use ftpd3d::rng::Sampler;
use ftpd3d::scene::flat::{FlatBsdf, Flatland, PhongLobe, cos_power_integral};
use ftpd3d::scene::load::load_scene;
use ftpd3d::scene::{Material, Scene};
use ftpd3d::transport::bsdf::{Bsdf, Mode, fresnel_dielectric};
use ftpd3d::transport::walk::{RadianceStats, radiance, walk};
use glam::{DVec3, Vec3};
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// A plane through the origin with a normal along no axis, so that rounding is not exact.
fn tilted() -> Flatland {
    let n = DVec3::new(1.0, 2.0, 2.0) / 3.0;
    let e1 = DVec3::new(2.0, -1.0, 0.0).normalize();
    Flatland::new(DVec3::ZERO, e1, n.cross(e1))
}

fn in_plane_2d(pl: &Flatland, x: f64, y: f64) -> DVec3 {
    pl.e1 * x + pl.e2 * y
}

fn rect(x0: f64, y0: f64, x1: f64, y1: f64) -> Vec<(f64, f64)> {
    vec![(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
}

/// Every material kind, an area light (a segment) and a point light, extruded in the plane `pl`.
fn zoo(pl: &Flatland) -> Scene {
    let mat = |name: &str, bsdf: Bsdf, emission: Rgb| Material {
        name: name.into(),
        bsdf,
        emission,
        maps: Default::default(),
    };
    let materials = vec![
        Material::diffuse("floor", Rgb::splat(0.6)),
        mat(
            "glossy",
            Bsdf::Glossy {
                kd: Rgb::splat(0.2),
                ks: Rgb::splat(0.7),
                exponent: 30.0,
            },
            Rgb::ZERO,
        ),
        mat(
            "mirror",
            Bsdf::Mirror {
                kd: Rgb::splat(0.1),
                ks: Rgb::splat(0.85),
            },
            Rgb::ZERO,
        ),
        mat(
            "glass",
            Bsdf::Dielectric {
                ior: 1.5,
                tint: Rgb::ONE,
            },
            Rgb::ZERO,
        ),
        mat("light", Bsdf::Black, Rgb::new(6.0, 5.0, 4.0)),
    ];
    let (c, s) = (60f64.to_radians().cos(), 60f64.to_radians().sin());
    let slab = |cx: f64, cy: f64, l: f64, w: f64| {
        [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
            .iter()
            .map(|(a, b)| (cx + a * l * c - b * w * s, cy + a * l * s + b * w * c))
            .collect::<Vec<_>>()
    };
    let mut scene = extruded(
        pl,
        &[
            (rect(-3.0, -0.2, 3.0, 0.0), true, 0),
            (rect(-2.2, 0.0, -1.2, 0.6), true, 1),
            (slab(1.5, 1.0, 0.5, 0.025), true, 2),
            (vec![(-0.4, 0.3), (0.4, 0.3), (0.0, 1.0)], true, 3),
            (vec![(-0.8, 2.5), (0.8, 2.5)], false, 4),
        ],
        materials,
    );
    scene.add_point_light(in_plane_2d(pl, -1.5, 1.8), Rgb::splat(2.0));
    scene
}

fn params(weighting: Weighting, flat: Flatland) -> Params {
    Params {
        t0: 0.5,
        t1: 4.0,
        theta_max: 0.05,
        weighting,
        max_bounces: 32,
        radiance_bounces: None,
        flat: Some(flat),
        design: ftpd3d::ftpd::Design::default_for(weighting),
        guide: false,
    }
}

fn opts(spp: u32, seed: u64) -> RenderOptions {
    crate::support::render_opts(spp, seed)
}

// ------------------------------------------------------------------------------------------------
// Light: a point light over a diffuse plane

fn plane_with_point_light(light: DVec3, intensity: f64) -> Scene {
    let mut scene = load_scene(&scene_path("diffuse_plane.obj")).unwrap();
    scene.add_point_light(light, Rgb::splat(intensity));
    scene.prepare_flatland(z0(), "z=0").unwrap();
    scene
}

/// In flatland a point light of intensity I (per radian) gives irradiance I cos θ / d, and a
/// Lambertian surface of albedo ρ (f = ρ/2) reflects radiance ρ/2 · I cos θ / d. Paths that leave
/// the plane upwards escape, so every estimate (next-event estimation at the plane) is the same
/// number: it must equal the formula to rounding.
#[test]
fn point_light_over_a_diffuse_plane_reflects_rho_over_2_times_i_cos_over_d() {
    let (light, intensity, rho) = (DVec3::new(0.3, 1.0, 0.0), 3.0, 0.8);
    let scene = plane_with_point_light(light, intensity);
    let x = DVec3::new(-0.5, 0.6, 0.0);
    let mut s = Sampler::new(41, 0, 0);
    for qx in [-3.0, -1.0, -0.2, 0.3, 0.9, 2.5] {
        let q = DVec3::new(qx, 0.0, 0.0);
        let to_light = light - q;
        let d = to_light.length();
        let expected = rho / 2.0 * intensity * (to_light.y / d) / d;
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for _ in 0..500 {
            let mut st = RadianceStats::default();
            let r = radiance::<RadianceFlat>(&scene, x, (q - x).normalize(), 32, &mut s, &mut st);
            assert_eq!(r.direct, Rgb::ZERO);
            let l = r.total();
            assert!(l.x == l.y && l.y == l.z);
            lo = lo.min(l.x);
            hi = hi.max(l.x);
        }
        eprintln!("q = {qx}: L in [{lo:.15}, {hi:.15}], ρ/2·I cosθ/d = {expected:.15}");
        assert!(
            (lo - expected).abs() <= 1e-13 * expected && (hi - expected).abs() <= 1e-13 * expected,
            "q = {qx}: L in [{lo}, {hi}] vs {expected}"
        );
    }
}

/// Integral of `f` over [a, b] by `panels` × `m`-point Gauss–Legendre.
fn gl(f: &dyn Fn(f64) -> f64, a: f64, b: f64, panels: usize, m: usize) -> f64 {
    let nodes = gauss_legendre(m);
    let h = (b - a) / panels as f64;
    (0..panels)
        .map(|k| {
            let (lo, hi) = (a + k as f64 * h, a + (k + 1) as f64 * h);
            nodes
                .iter()
                .map(|(x, w)| w * f(0.5 * (lo + hi) + 0.5 * (hi - lo) * x))
                .sum::<f64>()
                * 0.5
                * (hi - lo)
        })
        .sum()
}

/// (value, error bound) of ∫ f over [a, b]: fine rule, and 3 × |coarse − fine|.
fn integral(f: &dyn Fn(f64) -> f64, a: f64, b: f64, panels: usize) -> (f64, f64) {
    let c = gl(f, a, b, panels, 8);
    let fine = gl(f, a, b, 2 * panels, 16);
    (fine, 3.0 * (c - fine).abs())
}

/// Fluence (∫ L dθ over the circle, 2π weights) above the lit plane: I/d from the light directly
/// plus the plane's reflected radiance integrated over the angles under which it is seen, the
/// latter by quadrature over the plane (dθ = h dq / |q − x|²). The estimator mixes uniform
/// directions and light sampling (one-sample MIS).
#[test]
fn point_light_fluence_is_i_over_d_plus_the_reflected_light() {
    let (light, intensity, rho) = (DVec3::new(0.3, 1.0, 0.0), 3.0, 0.8);
    let scene = plane_with_point_light(light, intensity);
    let x = DVec3::new(-0.5, 0.6, 0.0);
    let direct = intensity / (light - x).length();
    let reflected_at = |qx: f64| {
        let q = DVec3::new(qx, 0.0, 0.0);
        let tl = light - q;
        let d = tl.length();
        let l = rho / 2.0 * intensity * (tl.y / d) / d;
        l * x.y / (q - x).length_squared()
    };
    // The plane spans x in [−10, 10]; split at the points under x and under the light.
    let mut reflected = (0.0, 0.0);
    for (a, b) in [(-10.0, -0.5), (-0.5, 0.3), (0.3, 10.0)] {
        let (v, e) = integral(&reflected_at, a, b, 64);
        reflected = (reflected.0 + v, reflected.1 + e);
    }
    let expected = direct + reflected.0;
    let n = 200_000;
    let (mut sum, mut sum2) = (0.0, 0.0);
    let mut s = Sampler::new(42, 0, 0);
    let mut rays = 0;
    for _ in 0..n {
        let (omega, w) = radiance_direction::<RadianceFlat>(&scene, x, 32, &mut s, &mut rays);
        assert!(omega.z == 0.0 && (omega.length() - 1.0).abs() < 1e-15);
        sum += w.x;
        sum2 += w.x * w.x;
    }
    let (m, se) = mean_and_se(sum, sum2, n);
    eprintln!(
        "fluence {m:.5} ± {se:.5}; I/d = {direct:.5} + reflected {:.5} (± {:.1e}) = {expected:.5}",
        reflected.0, reflected.1
    );
    assert!(reflected.1 < 1e-9);
    assert!(
        (m - expected).abs() <= z_limit(1) * se + reflected.1,
        "{m} ± {se} vs {expected}"
    );
}

// ------------------------------------------------------------------------------------------------
// Empty space and the furnace

/// With the only geometry 10 km away no walk scatters: Δ = 0 and σ = 0 exactly, for both
/// weightings (radiance from a point light in the plane).
#[test]
fn empty_flatland_gives_exactly_zero() {
    let scene = load_scene(&scene_path("diffuse_plane.obj")).unwrap();
    let mut far = translated(&scene, Vec3::new(0.0, -1e4, 0.0));
    far.add_point_light(DVec3::new(0.1, 0.2, 0.0), Rgb::ONE);
    let plane = Plane::new(
        DVec3::new(-1.0, -1.0, 0.0),
        DVec3::X,
        DVec3::Y,
        (2.0, 2.0),
        12,
        "z=0".into(),
    )
    .unwrap();
    let fl = plane.flatland();
    assert_eq!(fl, z0());
    far.prepare_flatland(fl, "z=0").unwrap();
    for weighting in [Weighting::Unweighted, Weighting::Radiance] {
        let p = params(weighting, fl);
        let (field, stats) = run_plane(&far, &plane, &p, &opts(32, 3)).unwrap();
        assert!(field.meta["kernel"].contains("+flatland"));
        assert!(stats.rays > 0);
        for v in field.values() {
            assert!(v.valid, "{weighting}");
            assert_eq!(v.sigma, 0.0, "{weighting}");
            assert_eq!(v.stderr, 0.0, "{weighting}");
        }
    }
}

/// Inside the furnace L = Le + ∫ (a/2) L cos θ dθ = Le + a L, so L = Le/(1 − a) at every interior
/// point in every in-plane direction, and the fluence is 2π Le/(1 − a).
#[test]
fn flatland_furnace_radiance_and_fluence() {
    let (le, a) = (Rgb::new(1.0, 0.5, 0.25), 0.5);
    let scene = flat_furnace(le, a);
    assert_eq!(scene.flat().lights.lights.len(), 128);
    let expected = luminance(le) / (1.0 - a);
    let points = [
        DVec3::ZERO,
        DVec3::new(0.5, 0.2, 0.0),
        DVec3::new(-0.3, -0.7, 0.0),
    ];
    let mut s = Sampler::new(43, 0, 0);
    // 3 points × (4 directions + the fluence) judged together.
    let k = z_limit(15);
    for x in points {
        for phi in [0.0, 1.3, 2.9, 4.4] {
            let look = DVec3::new(f64::cos(phi), f64::sin(phi), 0.0);
            let n = 4000;
            let (mut sum, mut sum2) = (0.0, 0.0);
            for _ in 0..n {
                let mut st = RadianceStats::default();
                let l = luminance(
                    radiance::<RadianceFlat>(&scene, x, look, 1000, &mut s, &mut st).total(),
                );
                sum += l;
                sum2 += l * l;
            }
            let (m, se) = mean_and_se(sum, sum2, n);
            assert!(
                (m - expected).abs() <= k * se,
                "x = {x}, φ = {phi}: L = {m} ± {se}, expected {expected}"
            );
        }
        let n = 20_000;
        let (mut sum, mut sum2) = (0.0, 0.0);
        let mut rays = 0;
        for _ in 0..n {
            let (_, w) = radiance_direction::<RadianceFlat>(&scene, x, 1000, &mut s, &mut rays);
            let l = luminance(w);
            sum += l;
            sum2 += l * l;
        }
        let (m, se) = mean_and_se(sum, sum2, n);
        eprintln!(
            "x = {x}: fluence {m:.4} ± {se:.4}, 2π Le/(1−a) = {:.4}",
            TAU * expected
        );
        assert!(
            (m - TAU * expected).abs() <= k * se,
            "x = {x}: fluence {m} ± {se}, expected {}",
            TAU * expected
        );
    }
}

// ------------------------------------------------------------------------------------------------
// 2D BSDFs

/// Angle of the in-plane direction `w` in the plane's (e1, e2) coordinates, in [0, 2π).
fn angle_of(pl: &Flatland, w: DVec3) -> f64 {
    w.dot(pl.e2).atan2(w.dot(pl.e1)).rem_euclid(TAU)
}

fn dir_at(pl: &Flatland, phi: f64) -> DVec3 {
    pl.e1 * phi.cos() + pl.e2 * phi.sin()
}

struct BsdfCase {
    label: String,
    pl: Flatland,
    bsdf: Bsdf,
    wo: DVec3,
    ng: DVec3,
    ns: DVec3,
}

impl BsdfCase {
    /// `ng` at angle π/2 in the plane, `ns` turned from it by `tilt`, `wo` at `theta_o` from `ns`
    /// (on the back side when `back`).
    fn new(label: &str, pl: Flatland, bsdf: Bsdf, theta_o: f64, tilt: f64, back: bool) -> BsdfCase {
        let ng = dir_at(&pl, FRAC_PI_2);
        let ns = dir_at(&pl, FRAC_PI_2 + tilt);
        let mut wo = dir_at(&pl, FRAC_PI_2 + tilt + theta_o);
        if back {
            wo = -wo;
        }
        BsdfCase {
            label: label.into(),
            pl,
            bsdf,
            wo,
            ng,
            ns,
        }
    }

    /// Angles where the integrands may kink or jump: the geometric and shading horizons (both
    /// sides) and the edges of the Phong lobe's half circle.
    fn breaks(&self) -> Vec<f64> {
        let side = if self.wo.dot(self.ng) >= 0.0 {
            1.0
        } else {
            -1.0
        };
        let r = reflect(self.wo, self.ns * side);
        let mut b: Vec<f64> = [self.ng, self.ns, r]
            .iter()
            .flat_map(|v| {
                let a = angle_of(&self.pl, *v);
                [
                    (a + FRAC_PI_2).rem_euclid(TAU),
                    (a - FRAC_PI_2).rem_euclid(TAU),
                ]
            })
            .collect();
        b.extend([0.0, TAU]);
        b.sort_by(f64::total_cmp);
        b.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
        b
    }

    /// Integral of `f(wi)` over the circle (value, error bound), split at [`breaks`](Self::breaks)
    /// and at `extra` edges, with panels no wider than `h`.
    fn integrate(&self, f: &dyn Fn(DVec3) -> f64, lo: f64, hi: f64, h: f64) -> (f64, f64) {
        let mut edges: Vec<f64> = self
            .breaks()
            .into_iter()
            .filter(|b| *b > lo && *b < hi)
            .collect();
        edges.push(lo);
        edges.push(hi);
        edges.sort_by(f64::total_cmp);
        let mut total = (0.0, 0.0);
        for w in edges.windows(2) {
            // φ = a + (b − a) S(t) with S(t) = 3t² − 2t³ (S' = 0 at both ends): a density that
            // behaves like √(distance) at an end of its piece (cos^n α with n < 1 at the lobe's
            // edge) becomes smooth in t.
            let (a, b) = (w[0], w[1]);
            let g = |t: f64| {
                let phi = a + (b - a) * t * t * (3.0 - 2.0 * t);
                f(dir_at(&self.pl, phi)) * (b - a) * 6.0 * t * (1.0 - t)
            };
            let panels = ((b - a) / h).ceil().max(1.0) as usize;
            let (v, e) = integral(&g, 0.0, 1.0, panels);
            total = (total.0 + v, total.1 + e);
        }
        total
    }

    fn panel_width(&self) -> f64 {
        match &self.bsdf {
            Bsdf::Glossy { exponent, .. } => (0.5 / (exponent + 1.0).sqrt()).min(0.1),
            _ => 0.1,
        }
    }
}

/// The density integrates over the circle to the probability of producing a non-delta sample,
/// samples follow it (chi-square over angle bins plus "delta" and "rejected" categories), every
/// non-delta sample has weight eval/pdf and the pdf that `pdf` reports, and every direction stays
/// in the plane.
fn check_bsdf_sampling(case: &BsdfCase, seed: u64) -> (f64, f64) {
    let fb = FlatBsdf::new(&case.bsdf);
    let (pl, wo, ng, ns) = (case.pl, case.wo, case.ng, case.ns);
    let h = case.panel_width();
    // Bin edges: 72 uniform, plus fine ones around the lobe axis for narrow lobes, plus the
    // breaks (so each bin is smooth).
    let side = if wo.dot(ng) >= 0.0 { 1.0 } else { -1.0 };
    let r_angle = angle_of(&pl, reflect(wo, ns * side));
    let mut edges: Vec<f64> = (0..=72).map(|k| TAU * k as f64 / 72.0).collect();
    if let Bsdf::Glossy { exponent, .. } = &case.bsdf {
        let w = 1.0 / (exponent + 1.0).sqrt();
        for k in -24..=24 {
            let e = r_angle + k as f64 * w / 6.0;
            if (e - r_angle).abs() < PI {
                edges.push(e.rem_euclid(TAU));
            }
        }
    }
    edges.extend(case.breaks());
    edges.sort_by(f64::total_cmp);
    edges.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
    let bins = edges.len() - 1;
    let pdf = |wi: DVec3| fb.pdf(wo, wi, ng, ns);
    let mut expected = Vec::with_capacity(bins + 2);
    let mut err = Vec::with_capacity(bins + 2);
    let n = 200_000usize;
    let (mut p_total, mut p_err) = (0.0, 0.0);
    for w in edges.windows(2) {
        let (v, e) = case.integrate(&pdf, w[0], w[1], h);
        p_total += v;
        p_err += e;
        expected.push(v * n as f64);
        err.push(e * n as f64);
    }
    assert!(p_err < 1e-7, "{}: quadrature error {p_err}", case.label);
    // The delta lobe's probability.
    let p_delta = match &case.bsdf {
        Bsdf::Mirror { kd, ks } => {
            let (d, s) = (luminance(*kd), luminance(*ks));
            let pd = if d + s > 0.0 { d / (d + s) } else { 1.0 };
            if reflect(wo, ns * side).dot(ng * side) > 0.0 {
                1.0 - pd
            } else {
                0.0
            }
        }
        _ => 0.0,
    };
    let p_reject = 1.0 - p_total - p_delta;
    assert!(
        p_reject > -3.0 * p_err - 1e-12,
        "{}: pdf integrates to {p_total}",
        case.label
    );
    expected.push(p_delta * n as f64);
    err.push(0.0);
    expected.push(p_reject.max(0.0) * n as f64);
    err.push(p_err * n as f64);
    let mut observed = vec![0.0; bins + 2];
    let mut s = Sampler::new(seed, 7, 0);
    let (mut wsum, mut wsum2) = (0.0, 0.0);
    for _ in 0..n {
        let (u_lobe, u) = (s.next_f64(), s.next_2d());
        let Some(bs) = fb.sample(&pl, wo, ng, ns, u_lobe, u, &mut s, Mode::Importance) else {
            observed[bins + 1] += 1.0;
            continue;
        };
        assert!(
            bs.wi.dot(pl.normal).abs() < 1e-12 && (bs.wi.length() - 1.0).abs() < 1e-12,
            "{}: wi = {} leaves the plane",
            case.label,
            bs.wi
        );
        let w = luminance(bs.weight);
        wsum += w;
        wsum2 += w * w;
        if bs.delta {
            observed[bins] += 1.0;
            let r = reflect(wo, ns * side);
            assert!((bs.wi - r).length() < 1e-12, "{}", case.label);
            continue;
        }
        let p = fb.pdf(wo, bs.wi, ng, ns);
        assert!(
            (bs.pdf - p).abs() <= 1e-12 * p,
            "{}: sample pdf {} vs pdf {p}",
            case.label,
            bs.pdf
        );
        let f = fb.eval(wo, bs.wi, ng, ns, Mode::Importance);
        assert!(
            (bs.weight - f / p).abs().max_element() <= 1e-12 * (f / p).max_element(),
            "{}: weight {} vs eval/pdf {}",
            case.label,
            bs.weight,
            f / p
        );
        let phi = angle_of(&pl, bs.wi);
        let k = edges.partition_point(|e| *e <= phi).clamp(1, bins) - 1;
        observed[k] += 1.0;
    }
    chi2_test(&case.label, &observed, &expected, &err);
    mean_and_se(wsum, wsum2, n)
}

fn glossy(kd: f64, ks: f64, exponent: f64) -> Bsdf {
    Bsdf::Glossy {
        kd: Rgb::splat(kd),
        ks: Rgb::splat(ks),
        exponent,
    }
}

fn bsdf_cases() -> Vec<BsdfCase> {
    let mut v = Vec::new();
    for (pl, pn) in [(z0(), "z0"), (tilted(), "tilted")] {
        let diffuse = Bsdf::Diffuse {
            kd: Rgb::splat(0.8),
        };
        v.push(BsdfCase::new(
            &format!("diffuse {pn}"),
            pl,
            diffuse.clone(),
            0.3,
            0.0,
            false,
        ));
        v.push(BsdfCase::new(
            &format!("diffuse back {pn}"),
            pl,
            diffuse.clone(),
            -1.2,
            0.0,
            true,
        ));
        v.push(BsdfCase::new(
            &format!("diffuse ns tilt {pn}"),
            pl,
            diffuse,
            1.3,
            0.3,
            false,
        ));
        for n in [0.0, 0.5, 1.0, 10.0, 200.0, 1029.0, 20000.0] {
            for t in [0.0, 0.7, 1.45] {
                v.push(BsdfCase::new(
                    &format!("phong n={n} θo={t} {pn}"),
                    pl,
                    glossy(0.0, 0.9, n),
                    t,
                    0.0,
                    false,
                ));
            }
        }
        v.push(BsdfCase::new(
            &format!("phong mix tilt {pn}"),
            pl,
            glossy(0.3, 0.6, 20.0),
            -0.6,
            0.2,
            false,
        ));
        v.push(BsdfCase::new(
            &format!("mirror+diffuse {pn}"),
            pl,
            Bsdf::Mirror {
                kd: Rgb::splat(0.3),
                ks: Rgb::splat(0.6),
            },
            0.5,
            0.0,
            false,
        ));
        v.push(BsdfCase::new(
            &format!("mirror+diffuse tilt {pn}"),
            pl,
            Bsdf::Mirror {
                kd: Rgb::splat(0.3),
                ks: Rgb::splat(0.6),
            },
            1.3,
            -0.4,
            false,
        ));
    }
    v
}

#[test]
fn flat_bsdfs_pdf_integrates_and_matches_sampling() {
    for (i, case) in bsdf_cases().iter().enumerate() {
        check_bsdf_sampling(case, 100 + i as u64);
    }
}

/// Lambertian (f = ρ/2) and the Phong lobe at normal incidence reflect exactly their albedo; no
/// material with kd + ks = 1 reflects more than 1 at any incidence (quadrature), and the Monte
/// Carlo mean of the sample weights equals the quadrature albedo.
#[test]
fn flat_white_furnace() {
    let pl = z0();
    let albedo = |case: &BsdfCase| {
        let fb = FlatBsdf::new(&case.bsdf);
        let f = |wi: DVec3| luminance(fb.eval(case.wo, wi, case.ng, case.ns, Mode::Importance));
        let (mut v, e) = case.integrate(&f, 0.0, TAU, case.panel_width());
        if let Bsdf::Mirror { ks, .. } = &case.bsdf {
            v += luminance(*ks);
        }
        (v, e)
    };
    let white = Bsdf::Diffuse { kd: Rgb::ONE };
    for t in [0.0, 0.8, 1.5] {
        let (a, e) = albedo(&BsdfCase::new("white", pl, white.clone(), t, 0.0, false));
        assert!((a - 1.0).abs() <= e + 1e-13, "lambertian θo={t}: {a} ± {e}");
    }
    for n in [0.0, 1.0, 7.5, 100.0, 3000.0, 50000.0] {
        let case = BsdfCase::new("phong", pl, glossy(0.0, 1.0, n), 0.0, 0.0, false);
        let (a, e) = albedo(&case);
        assert!(
            (a - 1.0).abs() <= e + 1e-13,
            "phong n={n} at normal incidence: {a} ± {e}"
        );
    }
    let mut seed = 300;
    // 5 materials × 6 angles: 30 means judged together.
    let k = z_limit(30);
    for bsdf in [
        glossy(0.0, 1.0, 1.0),
        glossy(0.0, 1.0, 40.0),
        glossy(0.0, 1.0, 1029.0),
        glossy(0.4, 0.6, 5.0),
        Bsdf::Mirror {
            kd: Rgb::splat(0.5),
            ks: Rgb::splat(0.5),
        },
    ] {
        for t in [-1.5, -1.0, -0.4, 0.2, 0.9, 1.4] {
            let case = BsdfCase::new(&format!("{bsdf:?} θo={t}"), pl, bsdf.clone(), t, 0.0, false);
            let (a, e) = albedo(&case);
            assert!(a <= 1.0 + e + 1e-13, "{}: albedo {a} ± {e}", case.label);
            seed += 1;
            let (m, se) = check_bsdf_sampling(&case, seed);
            assert!(
                (m - a).abs() <= k * se + e + 1e-13,
                "{}: mean weight {m} ± {se} vs albedo {a}",
                case.label
            );
        }
    }
}

#[test]
fn phong_normalisation_is_the_cos_power_integral() {
    // I(n+1) normalises the BRDF: ∫ cos^n α cos α dα = I(n+1) at normal incidence.
    for n in [0.0, 1.0, 2.0, 37.0, 112.0, 1029.0] {
        let lobe = PhongLobe::new(n);
        assert!((lobe.inv_brdf_norm * cos_power_integral(n + 1.0) - 1.0).abs() < 1e-15);
        assert!((lobe.inv_pdf_norm * cos_power_integral(n) - 1.0).abs() < 1e-15);
    }
    // Closed forms for integers: I(0) = π, I(1) = 2, I(2) = π/2, I(3) = 4/3, I(4) = 3π/8.
    let known = [PI, 2.0, FRAC_PI_2, 4.0 / 3.0, 3.0 * PI / 8.0];
    for (m, v) in known.iter().enumerate() {
        assert!((cos_power_integral(m as f64) - v).abs() <= 4.0 * f64::EPSILON * v);
    }
}

/// Smooth dielectric in flatland: reflection with probability F (Fresnel, as in 3D), refraction by
/// Snell's law in the plane, weight 1 carrying importance and 1/η carrying radiance (not 1/η²).
#[test]
fn flat_dielectric_reflects_with_fresnel_and_scales_radiance_by_one_over_eta() {
    for pl in [z0(), tilted()] {
        for (theta, back) in [(0.2, false), (0.9, false), (0.3, true), (0.6, true)] {
            let case = BsdfCase::new(
                "glass",
                pl,
                Bsdf::Dielectric {
                    ior: 1.5,
                    tint: Rgb::ONE,
                },
                theta,
                0.0,
                back,
            );
            let fb = FlatBsdf::new(&case.bsdf);
            let eta = if back { 1.0 / 1.5 } else { 1.5 };
            let f = fresnel_dielectric(theta.cos(), eta);
            let n = 40_000;
            let mut s = Sampler::new(77, 0, 0);
            let mut reflected = 0.0;
            for _ in 0..n {
                let (ul, u) = (s.next_f64(), s.next_2d());
                for mode in [Mode::Importance, Mode::Radiance] {
                    let mut s2 = Sampler::new(1, 1, 1);
                    let bs = fb
                        .sample(&pl, case.wo, case.ng, case.ns, ul, u, &mut s2, mode)
                        .unwrap();
                    assert!(bs.delta && bs.wi.dot(pl.normal).abs() < 1e-12);
                    let cos_t = bs.wi.dot(case.ng).abs();
                    let same_side = bs.wi.dot(case.ng) * case.wo.dot(case.ng) > 0.0;
                    if same_side {
                        assert!((cos_t - theta.cos()).abs() < 1e-12);
                        assert_eq!(bs.weight, Rgb::ONE);
                        if mode == Mode::Importance {
                            reflected += 1.0;
                        }
                    } else {
                        // Snell: sin θt = sin θi / η.
                        let sin_t = (1.0 - cos_t * cos_t).sqrt();
                        assert!((sin_t - theta.sin() / eta).abs() < 1e-12);
                        let want = if mode == Mode::Radiance {
                            1.0 / eta
                        } else {
                            1.0
                        };
                        assert!((bs.weight - Rgb::splat(want)).abs().max_element() < 1e-15);
                    }
                }
            }
            let obs = [reflected, n as f64 - reflected];
            let exp = [f * n as f64, (1.0 - f) * n as f64];
            chi2_test("dielectric reflect/refract", &obs, &exp, &[0.0, 0.0]);
        }
    }
}

// ------------------------------------------------------------------------------------------------
// Validation

#[test]
fn non_extruded_geometry_is_refused_with_a_clear_error() {
    // The Cornell box's tall box is turned 15° about y: the slice z = −0.5 cuts its sides.
    let mut cornell = load_scene(&scene_path("cornell_mirror.obj")).unwrap();
    let pl = Flatland::new(DVec3::new(0.0, 0.0, -0.5), DVec3::X, DVec3::Y);
    // The library's words; the command line adds the flag (checked through the binary below).
    let e = cornell
        .prepare_flatland(pl, "z=-0.5")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("cornell_mirror.obj: flatland needs geometry extruded along the slice normal")
            && e.contains("(material 'white') crosses z=-0.5 with its normal 15° out of the plane"),
        "{e}"
    );
    // z = 0 misses both objects: the cross-section is the room with its light, all in-plane.
    cornell.prepare_flatland(z0(), "z=0").unwrap();
    assert_eq!(cornell.flat().lights.lights.len(), 2);

    // One triangle through z = 0, its normal 37° out of the plane.
    let (c, s) = (37f64.to_radians().cos(), 37f64.to_radians().sin());
    let t = DVec3::new(0.0, -s, c);
    let v = [-DVec3::X - t, DVec3::X - t, t];
    let mut scene = crate::support::scene_of(
        "scenes/x.obj",
        v.iter().map(|p| p.as_vec3()).collect(),
        vec![[0, 1, 2]],
        vec![0],
        vec![Material::diffuse("floor", Rgb::splat(0.5))],
    );
    let e = scene.prepare_flatland(z0(), "z=0").unwrap_err();
    assert_eq!(
        ftpd3d::cli::errors::message(&e),
        "scenes/x.obj: --flatland needs geometry extruded along the slice normal; triangle 0 \
         (material 'floor') crosses z=0 with its normal 37° out of the plane"
    );
    // Point lights must lie in the plane.
    let mut lit = load_scene(&scene_path("diffuse_plane.obj")).unwrap();
    lit.add_point_light(DVec3::new(0.0, 1.0, 0.25), Rgb::ONE);
    let e = lit.prepare_flatland(z0(), "z=0").unwrap_err().to_string();
    assert!(
        e.contains("point light at (0, 1, 0.25)") && e.contains("must lie in the plane"),
        "{e}"
    );
}

// ------------------------------------------------------------------------------------------------
// Directions stay in the plane

/// Every ray a flatland sample traces (walks, radiance paths, shadow rays) starts in the plane and
/// runs in it. On the plane z = 0 the rays are logged (f32) by the recording kernel: a component
/// along z below 1e-12 in f32 is one below ~1e-12 in f64. On a tilted plane (where f32 logs cannot
/// resolve 1e-12) the f64 end points of walks are checked instead.
#[test]
fn flatland_directions_stay_in_the_plane() {
    let pl = z0();
    let mut scene = zoo(&pl);
    scene.prepare_flatland(pl, "z=0").unwrap();
    assert_eq!(
        scene.flat().lights.lights.len(),
        3,
        "two triangles of the light + the point"
    );
    let mut s = Sampler::new(9, 0, 0);
    let _ = ftpd3d::transport::trace::take_ray_log();
    let mut logged = 0;
    for weighting in [Weighting::Radiance, Weighting::Unweighted] {
        let p = params(weighting, pl);
        for _ in 0..20_000 {
            let x = DVec3::new(-2.5 + 5.0 * s.next_f64(), 0.05 + 2.3 * s.next_f64(), 0.0);
            match weighting {
                Weighting::Radiance => sample_at::<Record<RadianceFlat>>(&scene, x, &p, &mut s),
                _ => sample_at::<Record<PlainFlat>>(&scene, x, &p, &mut s),
            };
            for r in ftpd3d::transport::trace::take_ray_log() {
                assert!(r.d.z.abs() < 1e-12 && r.o.z.abs() < 1e-12, "{r:?}");
                logged += 1;
            }
        }
    }
    assert!(logged > 100_000, "{logged} rays");

    let pl = tilted();
    let mut scene = zoo(&pl);
    scene.prepare_flatland(pl, "tilted").unwrap();
    let mut bounces = 0;
    for _ in 0..50_000 {
        let x = in_plane_2d(&pl, -2.5 + 5.0 * s.next_f64(), 0.05 + 2.3 * s.next_f64());
        let dir = pl.sample_circle(s.next_f64());
        if let Some(w) = walk::<RadianceFlat>(&scene, x, dir, 6.0, 32, &mut s) {
            assert!(
                pl.distance(w.end).abs() < 1e-12 * (1.0 + w.end.length()),
                "{}",
                w.end
            );
            bounces += w.bounces;
        }
    }
    assert!(bounces > 50_000, "{bounces} scattering events");
}

// ------------------------------------------------------------------------------------------------
// Kernels, the mirror, the command line

/// Flatland runs take the flatland kernels (with radiance estimates exactly when weighted by
/// radiance), and say so in their metadata; a flatland estimator on a scene prepared for another
/// plane is refused.
#[test]
fn flatland_runs_use_the_flatland_kernels() {
    let mut mirrors = load_scene(&scene_path("flat_mirrors.obj")).unwrap();
    let plane = Plane::axis_slice(&mirrors.bounds, "z=0".parse().unwrap(), None, 12).unwrap();
    let fl = plane.flatland();
    mirrors.prepare_flatland(fl, "z=0").unwrap();
    let mut zs = zoo(&z0());
    let zplane = Plane::axis_slice(&zs.bounds, "z=0".parse().unwrap(), None, 12).unwrap();
    zs.prepare_flatland(zplane.flatland(), "z=0").unwrap();
    for (scene, plane, weighting, kernel) in [
        (
            &mirrors,
            &plane,
            Weighting::Radiance,
            "kernel<+radiance +flatland>",
        ),
        (
            &zs,
            &zplane,
            Weighting::Radiance,
            "kernel<+radiance +flatland>",
        ),
        (
            &zs,
            &zplane,
            Weighting::Unweighted,
            "kernel<-radiance +flatland>",
        ),
    ] {
        let p = params(weighting, plane.flatland());
        let a = run_plane(scene, plane, &p, &opts(8, 2)).unwrap().0;
        assert_eq!(a.meta["flatland"], "true");
        assert_eq!(a.meta["kernel"], kernel);
        assert!(a.cells.iter().any(|c| c.n > 0));
    }
    // The mirrors' scene was prepared for z = 0: a flatland run in z = 0.1 is refused.
    let other = Plane::axis_slice(&mirrors.bounds, "z=0.1".parse().unwrap(), None, 12).unwrap();
    let p = params(Weighting::Radiance, other.flatland());
    let e = run_plane(&mirrors, &other, &p, &opts(1, 2)).unwrap_err();
    assert!(
        format!("{e:#}").contains("not prepared for this plane"),
        "{e:#}"
    );
}

/// A planar mirror is an isometry in flatland too: pairs whose walks both reflect (or both go
/// straight) have Δ = 0 to rounding.
#[test]
fn flatland_mirror_is_an_isometry() {
    let mut scene = load_scene(&scene_path("mirror_plane.obj")).unwrap();
    scene.prepare_flatland(z0(), "z=0").unwrap();
    let p = Params {
        t0: 1.0,
        t1: 1.0,
        theta_max: 5f64.to_radians(),
        weighting: Weighting::Unweighted,
        max_bounces: 32,
        radiance_bounces: None,
        flat: Some(z0()),
        design: ftpd3d::ftpd::Design::default_for(Weighting::Unweighted),
        guide: false,
    };
    let mut s = Sampler::new(11, 0, 0);
    let (mut both, mut worst) = (0, 0.0f64);
    for _ in 0..50_000 {
        visit_point(&scene, DVec3::new(0.0, 0.3, 0.0), &p, &mut s, &mut |pair| {
            if pair.bounces.0 == pair.bounces.1 {
                worst = worst.max(pair.delta.abs());
                both += (pair.bounces == (1, 1)) as u32;
            }
        });
    }
    assert!(both > 10_000, "{both}");
    assert!(worst < 1e-9, "{worst}");
}

#[test]
fn flatland_on_the_command_line() {
    let dir = crate::support::temp_dir("flat", "cli");
    let out = dir.join("s.exr");
    let stair = scene_path("flat_stair_wall.obj");
    let stair = stair.to_str().unwrap();
    let Run { ok, err, .. } = ftpd3d(&[
        "--scene",
        stair,
        "--slice",
        "z=0",
        "--flatland",
        "--res",
        "16",
        "--spp",
        "4",
        "--quiet",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{err}");
    let field = ftpd3d::output::exr::read_exr(&out).unwrap();
    assert_eq!(field.meta["flatland"], "true");
    assert!(
        field.meta["kernel"].contains("+flatland"),
        "{:?}",
        field.meta
    );
    assert!(field.values().iter().any(|v| v.valid && v.sigma > 0.0));
    let Run {
        ok, out: stdout, ..
    } = ftpd3d(&[
        "--scene",
        stair,
        "--slice",
        "z=0",
        "--flatland",
        "--explain",
    ]);
    assert!(
        ok && stdout.contains("+flatland") && stdout.contains("light cross-sections"),
        "{stdout}"
    );
    let Run {
        ok, out: stdout, ..
    } = ftpd3d(&["--scene", stair, "--slice", "z=0", "--explain"]);
    assert!(ok && stdout.contains("-flatland"), "{stdout}");
    let cornell = scene_path("cornell_mirror.obj");
    let Run { ok, err, .. } = ftpd3d(&[
        "--scene",
        cornell.to_str().unwrap(),
        "--slice",
        "z=-0.5",
        "--flatland",
        "--quiet",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(!ok);
    assert!(
        err.contains("--flatland needs geometry extruded along the slice normal; triangle")
            && err.contains("crosses z=-0.5 with its normal 15° out of the plane")
            && !err.contains("panicked"),
        "{err}"
    );
    // A slice that misses every light cannot be radiance-weighted in flatland.
    let Run { ok, err, .. } = ftpd3d(&[
        "--scene",
        stair,
        "--slice",
        "x=-0.8",
        "--flatland",
        "--quiet",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(!ok && err.contains("no light of"), "{err}");
}
