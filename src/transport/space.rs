//! The space of directions, 3D or flatland: the dimension policy of light transport.
//!
//! Flatland is light transport confined to the slice plane, as in the paper's 2D figures (its
//! sections 5.5 and 6, after "Theory, analysis and applications of 2D global illumination", ACM TOG
//! 31(5), 2012).
//!
//! A flatland scene is a 3D scene extruded along the normal of the slice plane; every direction lies
//! in the plane, so rays never leave it and the extruded geometry acts as its 2D cross-section.
//! Measures are 2D: directions are measured by plane angle (radians) instead of solid angle, surfaces
//! by length. Concretely, with θ the angle to the (in-plane) surface normal:
//!
//! | quantity | 3D | flatland |
//! |---|---|---|
//! | uniform direction | 1/4π per sr | 1/2π per rad |
//! | Lambertian BRDF | ρ/π | ρ/2 (∫ cos θ dθ over the half circle is 2) |
//! | cosine sampling | cos θ/π | cos θ/2, θ = asin(2u − 1) |
//! | normalised Phong lobe | ks (n+2)/2π cosⁿα | ks cosⁿα / I(n+1) (see [`PhongLobe`]) |
//! | area light, seen from x | p_A d²/cos | p_L d/cos (uniform along the cross-section) |
//! | geometry term | cos cos/d² | cos cos/d |
//! | point light | I/d² (I per sr) | I/d (I per radian) |
//! | radiance across refraction | ×1/η² | ×1/η |
//! | fluence | ∫ L dω over the sphere | ∫ L dθ over the circle |
//!
//! Mirror reflection and Fresnel refraction are the 3D formulas: with the normal in the plane, the
//! reflected and refracted directions stay in it.
//!
//! The two columns are the two implementations of [`Space`] below: [`Sphere`] and [`Flatland`] (the
//! slice plane). Walks, the radiance estimate, the BSDFs and the lights are written once over a
//! `Space`, so a kernel for one space contains nothing of the other.
//! [`FlatScene`](crate::scene::flat::FlatScene) (scene data, built in `crate::scene::flat`) holds
//! what a flatland run needs per plane: the validated plane, the emitters' cross-sections with it,
//! and the Phong normalisations of every material.

use crate::kernel::{Flatland, Space, Sphere};
use crate::math::Frame;
use crate::rng::Uniform;
use crate::scene::env::Environment;
use crate::scene::flat::PhongLobe;
use crate::scene::light::{Lights, Segment, Triangle};
use crate::scene::material::Bsdf;
use crate::scene::{Hit, Scene};
use crate::transport::sampling::{
    pdf_cosine_hemisphere, pdf_phong_lobe, sample_cosine_hemisphere, sample_phong_lobe,
    sample_uniform_cone_1mc, sample_uniform_sphere, sample_uniform_triangle,
};
use glam::DVec3;
use std::f64::consts::{FRAC_1_PI, FRAC_PI_2, PI, TAU};

impl Space for Sphere {
    const DIMS: i32 = 3;
    const PDF_UNIFORM: f64 = 1.0 / (4.0 * PI);
    const LAMBERT: f64 = FRAC_1_PI;
    type Shape = Triangle;
    /// The 3D lobe's normalisation (n+1)/2π is computed from the exponent where it is needed.
    type Lobe = ();

    #[inline(always)]
    fn of(_: &Scene) -> &Sphere {
        &Sphere
    }

    #[inline(always)]
    fn lights(scene: &Scene) -> &Lights<Triangle> {
        &scene.lights
    }

    #[inline(always)]
    fn mirrors(scene: &Scene) -> &crate::scene::mirror::Mirrors {
        &scene.mirrors
    }

    #[inline(always)]
    fn scatter(scene: &Scene, m: u32) -> (&Bsdf, &()) {
        (&scene.materials[m as usize].bsdf, &())
    }

    #[inline(always)]
    fn textured_lobe(_: &Bsdf, _: &()) {}

    #[inline(always)]
    fn intersect(scene: &Scene, o: DVec3, d: DVec3, tmax: f64) -> Option<Hit> {
        scene.intersect(o, d, tmax)
    }

    #[inline(always)]
    fn uniform(&self, u: (f64, f64)) -> DVec3 {
        sample_uniform_sphere(u)
    }

    /// ω' uniform in the cone (density 1/(2π(1 − cos θmax)) per steradian); θ is read off the
    /// local coordinates, which is exact for tiny angles.
    #[inline(always)]
    fn perturb(
        &self,
        omega: DVec3,
        _theta_max: f64,
        one_minus_cos_max: f64,
        tan_half_max: f64,
        u: (f64, f64),
    ) -> (DVec3, f64, f64) {
        let local = sample_uniform_cone_1mc(u, one_minus_cos_max);
        let omega2 = Frame::from_z(omega).to_world(local);
        let sin_t = (local.x * local.x + local.y * local.y).sqrt(); // unit vector: no overflow
        let cos_t = local.z;
        let tan_half = sin_t / (1.0 + cos_t);
        let chord = 2.0 * tan_half / (1.0 + tan_half * tan_half).sqrt(); // 2 sin(θ/2)
        (omega2, chord, tan_half / tan_half_max)
    }

    #[inline(always)]
    fn cone(&self, axis: DVec3, alpha: f64, u: (f64, f64)) -> DVec3 {
        let h = (0.5 * alpha).sin();
        Frame::from_z(axis).to_world(sample_uniform_cone_1mc(u, 2.0 * h * h))
    }

    #[inline(always)]
    fn cosine(&self, n: DVec3, u: (f64, f64)) -> DVec3 {
        Frame::from_z(n).to_world(sample_cosine_hemisphere(u))
    }

    #[inline(always)]
    fn pdf_cosine(cos_theta: f64) -> f64 {
        pdf_cosine_hemisphere(cos_theta)
    }

    #[inline(always)]
    fn phong(
        &self,
        _: &(),
        exponent: f64,
        r: DVec3,
        u: (f64, f64),
        _: &mut impl Uniform,
    ) -> Option<DVec3> {
        Some(Frame::from_z(r).to_world(sample_phong_lobe(u, exponent)))
    }

    #[inline(always)]
    fn phong_pdf(_: &(), exponent: f64, cos_a: f64) -> f64 {
        pdf_phong_lobe(cos_a, exponent)
    }

    /// The lobe divided by max(cos θi, cos θo) (cos θi > 0 where it is called, so no division by
    /// zero): symmetric in wo and wi, albedo ≤ ks, and f cos θi / pdf = ks cos θi / max(cos θi,
    /// cos θo) → ks as the exponent grows, i.e. the lobe tends to the perfect mirror of
    /// reflectance ks (the paper's Fig. 4c/d).
    #[inline(always)]
    fn phong_brdf(_: &(), exponent: f64, cos_a: f64, cos_i: f64, cos_o: f64) -> f64 {
        if cos_a > 0.0 {
            (exponent + 1.0) / TAU * cos_a.powf(exponent) / cos_i.max(cos_o)
        } else {
            0.0
        }
    }

    fn env_sample(env: &Environment, u: (f64, f64)) -> Option<(DVec3, f64)> {
        env.map.sample_sphere(u)
    }

    fn env_pdf(env: &Environment, d: DVec3) -> f64 {
        env.map.pdf_sphere(d)
    }

    #[inline(always)]
    fn point_on(shape: &Triangle, u: (f64, f64)) -> DVec3 {
        let v = &shape.0;
        let (b0, b1, b2) = sample_uniform_triangle(u);
        b0 * v[0] + b1 * v[1] + b2 * v[2]
    }
}

impl Space for Flatland {
    const DIMS: i32 = 2;
    const PDF_UNIFORM: f64 = 1.0 / TAU;
    const LAMBERT: f64 = 0.5;
    type Shape = Segment;
    type Lobe = PhongLobe;

    #[inline(always)]
    fn of(scene: &Scene) -> &Flatland {
        &scene.flat().plane
    }

    #[inline(always)]
    fn lights(scene: &Scene) -> &Lights<Segment> {
        &scene.flat().lights
    }

    #[inline(always)]
    fn mirrors(scene: &Scene) -> &crate::scene::mirror::Mirrors {
        &scene.flat().mirrors
    }

    #[inline(always)]
    fn scatter(scene: &Scene, m: u32) -> (&Bsdf, &PhongLobe) {
        let fb = &scene.flat().bsdfs[m as usize];
        (&fb.bsdf, &fb.lobe)
    }

    /// The normalisations for a texel's exponent, in closed form ([`PhongLobe::at`]).
    #[inline]
    fn textured_lobe(bsdf: &Bsdf, own: &PhongLobe) -> PhongLobe {
        match bsdf {
            Bsdf::Glossy { exponent, .. } if *exponent != own.exponent => PhongLobe::at(*exponent),
            _ => *own,
        }
    }

    #[inline(always)]
    fn intersect(scene: &Scene, o: DVec3, d: DVec3, tmax: f64) -> Option<Hit> {
        scene.intersect_in_plane(o, d, tmax)
    }

    /// Uniform on the circle of in-plane directions.
    #[inline(always)]
    fn uniform(&self, u: (f64, f64)) -> DVec3 {
        self.sample_circle(u.0)
    }

    /// ω turned by θ uniform in [−θmax, θmax] (density 1/2θmax per radian).
    #[inline(always)]
    fn perturb(
        &self,
        omega: DVec3,
        theta_max: f64,
        _one_minus_cos_max: f64,
        tan_half_max: f64,
        u: (f64, f64),
    ) -> (DVec3, f64, f64) {
        let theta = theta_max * (2.0 * u.0 - 1.0);
        let (s, c) = theta.sin_cos();
        let half = 0.5 * theta.abs();
        (
            self.rotate(omega, c, s),
            2.0 * half.sin(),
            half.tan() / tan_half_max,
        )
    }

    #[inline(always)]
    fn cone(&self, axis: DVec3, alpha: f64, u: (f64, f64)) -> DVec3 {
        let (s, c) = (alpha * (2.0 * u.0 - 1.0)).sin_cos();
        self.rotate(axis, c, s)
    }

    /// θ = asin(2u − 1) from the normal: density cos θ / 2 per radian.
    #[inline(always)]
    fn cosine(&self, n: DVec3, u: (f64, f64)) -> DVec3 {
        let u = u.0;
        let s = 2.0 * u - 1.0;
        let c = 2.0 * (u * (1.0 - u)).max(0.0).sqrt();
        self.rotate(n, c, s)
    }

    #[inline(always)]
    fn pdf_cosine(cos_theta: f64) -> f64 {
        if cos_theta > 0.0 {
            0.5 * cos_theta
        } else {
            0.0
        }
    }

    #[inline(always)]
    fn phong(
        &self,
        lobe: &PhongLobe,
        _exponent: f64,
        r: DVec3,
        u: (f64, f64),
        s: &mut impl Uniform,
    ) -> Option<DVec3> {
        let (c, sn) = lobe.sample(u, s)?;
        Some(self.rotate(r, c, sn))
    }

    #[inline(always)]
    fn phong_pdf(lobe: &PhongLobe, _exponent: f64, cos_a: f64) -> f64 {
        lobe.pdf(cos_a)
    }

    #[inline(always)]
    fn phong_brdf(lobe: &PhongLobe, _exponent: f64, cos_a: f64, _cos_i: f64, _cos_o: f64) -> f64 {
        lobe.brdf(cos_a)
    }

    fn env_sample(env: &Environment, u: (f64, f64)) -> Option<(DVec3, f64)> {
        let (e1, e2, dist) = env.circle.as_ref()?;
        let (x, i) = dist.sample(u.0)?;
        let (s, c) = (TAU * x).sin_cos();
        Some((*e1 * c + *e2 * s, dist.density(i) / TAU))
    }

    fn env_pdf(env: &Environment, d: DVec3) -> f64 {
        let Some((e1, e2, dist)) = env.circle.as_ref() else {
            return 0.0;
        };
        let phi = d.dot(*e2).atan2(d.dot(*e1)).rem_euclid(TAU);
        let i = ((phi / TAU * dist.len() as f64) as usize).min(dist.len() - 1);
        dist.density(i) / TAU
    }

    #[inline(always)]
    fn point_on(shape: &Segment, u: (f64, f64)) -> DVec3 {
        shape.a + (shape.b - shape.a) * u.0
    }
}

impl Flatland {
    /// Uniform direction on the circle of in-plane directions (density 1/2π per radian).
    #[inline]
    pub fn sample_circle(&self, u: f64) -> DVec3 {
        let (s, c) = (TAU * u).sin_cos();
        self.e1 * c + self.e2 * s
    }
}

/// Proposals tried by the rejection samplers of [`PhongLobe`] before giving up (the acceptance
/// rate is at least 0.63, so giving up has probability below 1e-27).
const MAX_TRIES: usize = 64;

impl PhongLobe {
    /// `cosⁿα / I(n+1)` (times ks, the BRDF), 0 outside the lobe's half circle.
    #[inline]
    pub fn brdf(&self, cos_a: f64) -> f64 {
        if cos_a > 0.0 {
            cos_a.powf(self.exponent) * self.inv_brdf_norm
        } else {
            0.0
        }
    }

    /// Density per radian of [`sample`](Self::sample) at angle α to the lobe axis.
    #[inline]
    pub fn pdf(&self, cos_a: f64) -> f64 {
        if cos_a > 0.0 {
            cos_a.powf(self.exponent) * self.inv_pdf_norm
        } else {
            0.0
        }
    }

    /// An angle α with density ∝ cosⁿα on (−π/2, π/2), as (cos α, sin α). The first proposal uses
    /// `u`; further ones draw from `s`.
    pub fn sample(&self, u: (f64, f64), s: &mut impl Uniform) -> Option<(f64, f64)> {
        let n = self.exponent;
        if n < 1.0 {
            let (mut a, mut b) = u;
            for _ in 0..MAX_TRIES {
                let alpha = PI * (a - 0.5);
                let c = alpha.cos();
                if n == 0.0 || b < c.powf(n) {
                    return Some((c, alpha.sin()));
                }
                (a, b) = s.next_2d();
            }
            return None;
        }
        let sigma = 1.0 / n.sqrt();
        let mut uu = u;
        for _ in 0..MAX_TRIES {
            // Box–Muller: two independent standard normal proposals per pair of uniforms.
            let r = (-2.0 * (1.0 - uu.0).ln()).sqrt();
            let (zs, zc) = (TAU * uu.1).sin_cos();
            for z in [r * zc, r * zs] {
                let alpha = z * sigma;
                if alpha.abs() < FRAC_PI_2 {
                    // ln cos α + α²/2 ≤ 0, written without cancellation for small α.
                    let h = (0.5 * alpha).sin();
                    let log_ratio = (-2.0 * h * h).ln_1p() + 0.5 * alpha * alpha;
                    if s.next_f64() < (n * log_ratio).exp() {
                        return Some((alpha.cos(), alpha.sin()));
                    }
                }
            }
            uu = s.next_2d();
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::flat::cos_power_integral;

    #[test]
    fn cos_power_integral_matches_closed_forms_and_quadrature() {
        assert_eq!(cos_power_integral(0.0), PI);
        assert_eq!(cos_power_integral(1.0), 2.0);
        assert!((cos_power_integral(2.0) - FRAC_PI_2).abs() < 1e-15);
        assert!((cos_power_integral(3.0) - 4.0 / 3.0).abs() < 1e-15);
        // √π Γ((m+1)/2)/Γ(m/2+1) for fractional m (Python's math.lgamma).
        for (m, v) in [(0.5, 2.396280469471182), (1.5, 1.7480383695280806)] {
            assert!((cos_power_integral(m) / v - 1.0).abs() < 1e-14, "m = {m}");
        }
        // Midpoint rule with many points (the integrand vanishes smoothly at ±π/2 for m ≥ 1):
        // relative error ≪ 1e-9.
        for m in [1.5, 7.3, 37.0, 200.0, 1029.0] {
            let k = 200_000;
            let h = PI / k as f64;
            let q: f64 = (0..k)
                .map(|i| (-FRAC_PI_2 + (i as f64 + 0.5) * h).cos().powf(m) * h)
                .sum();
            let c = cos_power_integral(m);
            assert!((q / c - 1.0).abs() < 1e-9, "m = {m}: {q} vs {c}");
        }
        // Both sides of the switch to the asymptotic series: one ulp apart in m, I changes by
        // ~1e-16 relative (d ln I/dm ≈ −1/2m).
        let m = 4096.0f64;
        let (a, b) = (
            cos_power_integral(m),
            cos_power_integral(f64::from_bits(m.to_bits() + 1)),
        );
        assert!((a / b - 1.0).abs() < 1e-14, "{a} {b}");
        // Exact value of I(4096) = π ∏ (2k−1)/(2k), k = 1..2048 (40-digit decimal arithmetic).
        assert!((a / 0.039_163_676_357_077_836 - 1.0).abs() < 1e-14, "{a}");
        let r = cos_power_integral(10000.0) / cos_power_integral(9998.0);
        assert!((r - 9999.0 / 10000.0).abs() < 1e-14, "{r}");
    }
}
