//! Sampling warps, each paired with its density (`sample_x` next to `pdf_x`). Densities are with
//! respect to solid angle on the unit sphere (3D) or plane angle on the unit circle (flatland), or
//! to area for points on triangles. Inputs `u` are uniform in [0, 1).

use glam::DVec3;
use std::f64::consts::{FRAC_1_PI, PI, TAU};

/// `(sin 2πu, cos 2πu)` for a turn fraction `u` (|u| < 2⁴⁸; samplers pass [0, 1)), to about
/// one ulp: the reduction to a quarter turn is exact (4u minus the nearest integer), the remaining
/// angle, at most π/4, goes through Taylor polynomials whose truncation error is below 1e-17. Several
/// times cheaper than `(TAU * u).sin_cos()`, which every sampled direction needs.
#[inline]
pub fn sin_cos_turns(u: f64) -> (f64, f64) {
    // Nearest integer to x (ties to even) by the 1.5·2⁵² trick: exact for |x| < 2⁵¹, and inline
    // (`f64::round` is a libm call on targets without SSE4.1).
    const ROUND: f64 = 6_755_399_441_055_744.0;
    let x = 4.0 * u;
    let k = (x + ROUND) - ROUND;
    let a = (x - k) * std::f64::consts::FRAC_PI_2;
    let a2 = a * a;
    let sin_a = a + a
        * a2
        * (-0.16666666666666666
            + a2 * (0.008333333333333333
                + a2 * (-0.0001984126984126984
                    + a2 * (2.7557319223985893e-6
                        + a2 * (-2.505210838544172e-8
                            + a2 * (1.6059043836821613e-10 + a2 * -7.647163731819816e-13))))));
    let cos_a = 1.0
        + a2 * (-0.5
            + a2 * (0.041666666666666664
                + a2 * (-0.001388888888888889
                    + a2 * (2.48015873015873e-5
                        + a2 * (-2.755731922398589e-7
                            + a2 * (2.08767569878681e-9
                                + a2 * (-1.1470745597729725e-11 + a2 * 4.779477332387385e-14)))))));
    // 2πu = k π/2 + a.
    let q = k as i64;
    let (s, c) = if q & 1 == 0 {
        (sin_a, cos_a)
    } else {
        (cos_a, -sin_a)
    };
    if q & 2 == 0 { (s, c) } else { (-s, -c) }
}

/// Uniform direction on the unit sphere.
pub fn sample_uniform_sphere(u: (f64, f64)) -> DVec3 {
    let z = 1.0 - 2.0 * u.0;
    let r = crate::math::safe_sqrt(1.0 - z * z);
    let (sin_phi, cos_phi) = sin_cos_turns(u.1);
    DVec3::new(r * cos_phi, r * sin_phi, z)
}

pub fn pdf_uniform_sphere() -> f64 {
    1.0 / (4.0 * PI)
}

/// Cosine-weighted direction on the hemisphere around +z (Malley's method).
pub fn sample_cosine_hemisphere(u: (f64, f64)) -> DVec3 {
    let r = u.0.sqrt();
    let (sin_phi, cos_phi) = sin_cos_turns(u.1);
    let (x, y) = (r * cos_phi, r * sin_phi);
    DVec3::new(x, y, crate::math::safe_sqrt(1.0 - x * x - y * y))
}

/// Density of [`sample_cosine_hemisphere`] for a local direction with cosine `cos_theta` to +z.
pub fn pdf_cosine_hemisphere(cos_theta: f64) -> f64 {
    if cos_theta > 0.0 {
        cos_theta * FRAC_1_PI
    } else {
        0.0
    }
}

/// Uniform direction inside the cone of half-angle acos(`cos_max`) around +z.
pub fn sample_uniform_cone(u: (f64, f64), cos_max: f64) -> DVec3 {
    // Written with 1 - cos so that tiny cones (1e-6 rad) keep their precision.
    let one_minus_cos_max = one_minus_cos_from_cos(cos_max);
    sample_uniform_cone_1mc(u, one_minus_cos_max)
}

/// As [`sample_uniform_cone`], with the cone given by `1 - cos(θmax)` (exact for tiny angles:
/// pass `2 sin²(θmax/2)`).
pub fn sample_uniform_cone_1mc(u: (f64, f64), one_minus_cos_max: f64) -> DVec3 {
    let omc = u.0 * one_minus_cos_max; // 1 - cos θ, uniform in [0, 1 - cos θmax]
    let cos_t = 1.0 - omc;
    let sin_t = crate::math::safe_sqrt(omc * (2.0 - omc));
    let (sin_phi, cos_phi) = sin_cos_turns(u.1);
    DVec3::new(sin_t * cos_phi, sin_t * sin_phi, cos_t)
}

pub fn pdf_uniform_cone(one_minus_cos_max: f64) -> f64 {
    1.0 / (TAU * one_minus_cos_max)
}

fn one_minus_cos_from_cos(c: f64) -> f64 {
    (1.0 - c).max(0.0)
}

/// Direction around +z with density proportional to `cos^n` of its angle to +z (a Phong lobe),
/// restricted to the hemisphere around +z.
pub fn sample_phong_lobe(u: (f64, f64), n: f64) -> DVec3 {
    let cos_t = u.0.powf(1.0 / (n + 1.0));
    let sin_t = crate::math::safe_sqrt(1.0 - cos_t * cos_t);
    let (sin_phi, cos_phi) = sin_cos_turns(u.1);
    DVec3::new(sin_t * cos_phi, sin_t * sin_phi, cos_t)
}

/// Density of [`sample_phong_lobe`] at a direction with cosine `cos_alpha` to +z.
pub fn pdf_phong_lobe(cos_alpha: f64, n: f64) -> f64 {
    if cos_alpha > 0.0 {
        (n + 1.0) / TAU * cos_alpha.powf(n)
    } else {
        0.0
    }
}

/// Uniform point on a triangle as barycentrics (b0, b1, b2) (the square-root warp).
pub fn sample_uniform_triangle(u: (f64, f64)) -> (f64, f64, f64) {
    let su = u.0.sqrt();
    let b0 = 1.0 - su;
    let b1 = u.1 * su;
    (b0, b1, 1.0 - b0 - b1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samples_are_unit_and_in_their_domain() {
        let mut s = crate::rng::Sampler::new(3, 0, 0);
        for _ in 0..10_000 {
            let u = s.next_2d();
            assert!((sample_uniform_sphere(u).length() - 1.0).abs() < 1e-12);
            let c = sample_cosine_hemisphere(u);
            assert!((c.length() - 1.0).abs() < 1e-12 && c.z >= 0.0);
            let k = sample_uniform_cone(u, 0.9);
            assert!(k.z >= 0.9 - 1e-12);
            let p = sample_phong_lobe(u, 50.0);
            assert!((p.length() - 1.0).abs() < 1e-12 && p.z >= 0.0);
            let (b0, b1, b2) = sample_uniform_triangle(u);
            assert!(b0 >= 0.0 && b1 >= 0.0 && b2 >= -1e-15);
        }
    }

    #[test]
    fn sin_cos_turns_matches_libm() {
        let mut s = crate::rng::Sampler::new(5, 0, 0);
        let edges = [
            0.0,
            0.125,
            0.25,
            0.375,
            0.5,
            0.625,
            0.75,
            0.875,
            1.0 - 1e-16,
            1e-300,
        ];
        let random = (0..200_000).map(|_| s.next_f64());
        for u in edges.into_iter().chain(random) {
            let (sn, cs) = sin_cos_turns(u);
            let (sr, cr) = (TAU * u).sin_cos();
            // TAU * u itself is rounded: allow for its error (≤ 2πu · 2⁻⁵³) plus a few ulps.
            let tol = 8.0 * f64::EPSILON;
            assert!((sn - sr).abs() <= tol && (cs - cr).abs() <= tol, "u = {u}");
            assert!((sn * sn + cs * cs - 1.0).abs() <= 4.0 * f64::EPSILON);
        }
        assert_eq!(sin_cos_turns(0.0), (0.0, 1.0));
        assert_eq!(sin_cos_turns(0.25).0, 1.0);
        assert_eq!(sin_cos_turns(0.5).1, -1.0);
    }

    #[test]
    fn tiny_cone_keeps_precision() {
        let theta: f64 = 1e-6;
        let omc = 2.0 * (theta / 2.0).sin().powi(2);
        let d = sample_uniform_cone_1mc((1.0 - 1e-16, 0.25), omc);
        let angle = d.x.hypot(d.y).atan2(d.z);
        assert!(
            (angle - theta).abs() < 1e-12 * theta.max(1.0) + 1e-15,
            "{angle}"
        );
    }
}
