//! Flatland: light transport confined to the slice plane, as in the paper's 2D figures (Zirr et al.
//! 2015, section 5.5 and 6, after Jarosz, Schönefeld, Kobbelt and Jensen, "Theory, analysis and
//! applications of 2D global illumination", ACM TOG 31(5), 2012).
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
//! Everything here is called from `if K::FLATLAND { .. }` branches of the sample kernel, so 3D
//! kernels do not contain it. [`FlatScene`](crate::scene::flat::FlatScene) (scene data, built
//! in `crate::scene::flat`) holds what a run needs per plane: the validated plane, the emitters'
//! cross-sections with it, and the 2D form of every material; this module samples and evaluates them.

use crate::math::{Rgb, reflect};
use crate::rng::Sampler;
use crate::scene::flat::{FlatBsdf, FlatLight, FlatLights, Flatland, PhongLobe};
use crate::transport::bsdf::{Bsdf, BsdfSample, Mode, sample_dielectric, sample_mirror_mixture};
use crate::transport::light::{LightSample, connect_emitter, connect_point, emitter_pdf};
use glam::DVec3;
use std::f64::consts::{FRAC_PI_2, PI, TAU};

impl Flatland {
    /// Uniform direction on the circle of in-plane directions (density 1/2π per radian).
    #[inline]
    pub fn sample_circle(&self, u: f64) -> DVec3 {
        let (s, c) = (TAU * u).sin_cos();
        self.e1 * c + self.e2 * s
    }
}

/// Density of [`Flatland::sample_circle`] per radian.
pub const PDF_CIRCLE: f64 = 1.0 / TAU;

/// The second direction of a deflection pair in flatland: ω turned by θ uniform in [−θmax, θmax].
/// Returns ω', the chord ‖ω − ω'‖ = 2 sin(|θ|/2) and `r = tan(|θ|/2) / tan(θmax/2)`.
#[inline]
pub fn perturb(
    pl: &Flatland,
    omega: DVec3,
    theta_max: f64,
    tan_half_max: f64,
    u: f64,
) -> (DVec3, f64, f64) {
    let theta = theta_max * (2.0 * u - 1.0);
    let (s, c) = theta.sin_cos();
    let half = 0.5 * theta.abs();
    (
        pl.rotate(omega, c, s),
        2.0 * half.sin(),
        half.tan() / tan_half_max,
    )
}

/// Cosine-weighted in-plane direction around the in-plane unit normal `n`: θ = asin(2u − 1), density
/// cos θ / 2 per radian.
#[inline]
pub fn sample_cosine(pl: &Flatland, n: DVec3, u: f64) -> DVec3 {
    let s = 2.0 * u - 1.0;
    let c = 2.0 * (u * (1.0 - u)).max(0.0).sqrt();
    pl.rotate(n, c, s)
}

/// Density of [`sample_cosine`] at a direction with cosine `cos_theta` to the normal.
#[inline]
pub fn pdf_cosine(cos_theta: f64) -> f64 {
    if cos_theta > 0.0 {
        0.5 * cos_theta
    } else {
        0.0
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
    pub fn sample(&self, u: (f64, f64), s: &mut Sampler) -> Option<(f64, f64)> {
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

impl FlatBsdf {
    /// Samples `wi` given `wo` (both in the plane, as are `ng`, `ns`). Conventions as
    /// [`Bsdf::sample`]; densities per radian. The Phong lobe's rejection sampler may draw more
    /// numbers from `s`.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn sample(
        &self,
        pl: &Flatland,
        wo: DVec3,
        ng: DVec3,
        ns: DVec3,
        u_lobe: f64,
        u: (f64, f64),
        s: &mut Sampler,
        mode: Mode,
    ) -> Option<BsdfSample> {
        let side = if wo.dot(ng) >= 0.0 { 1.0 } else { -1.0 };
        let (ngo, nso) = (ng * side, ns * side);
        match &self.bsdf {
            Bsdf::Black => None,
            Bsdf::Diffuse { kd } => {
                let wi = sample_cosine(pl, nso, u.0);
                if wi.dot(ngo) <= 0.0 {
                    return None;
                }
                Some(BsdfSample {
                    wi,
                    weight: *kd,
                    pdf: pdf_cosine(wi.dot(nso)),
                    delta: false,
                })
            }
            Bsdf::Glossy { kd, ks, .. } => {
                let pd = Bsdf::diffuse_probability(*kd, *ks);
                let wi = if u_lobe < pd {
                    sample_cosine(pl, nso, u.0)
                } else {
                    let r = reflect(wo, nso);
                    let (c, sn) = self.lobe.sample(u, s)?;
                    pl.rotate(r, c, sn)
                };
                if wi.dot(ngo) <= 0.0 || wi.dot(nso) <= 0.0 {
                    return None;
                }
                let pdf = self.pdf(wo, wi, ng, ns);
                if pdf <= 0.0 || !pdf.is_finite() {
                    return None;
                }
                Some(BsdfSample {
                    wi,
                    weight: self.eval(wo, wi, ng, ns, mode) / pdf,
                    pdf,
                    delta: false,
                })
            }
            Bsdf::Mirror { kd, ks } => {
                sample_mirror_mixture(wo, ngo, nso, *kd, *ks, u_lobe, || {
                    let wi = sample_cosine(pl, nso, u.0);
                    (wi, pdf_cosine(wi.dot(nso)))
                })
            }
            Bsdf::Dielectric { ior, tint } => {
                sample_dielectric(wo, ng, ngo, nso, *ior, *tint, u_lobe, mode, 2)
            }
        }
    }

    /// `f(wo, wi) |cos θi|` of the non-delta lobes (per radian).
    #[inline]
    pub fn eval(&self, wo: DVec3, wi: DVec3, ng: DVec3, ns: DVec3, _mode: Mode) -> Rgb {
        let side = if wo.dot(ng) >= 0.0 { 1.0 } else { -1.0 };
        let (ngo, nso) = (ng * side, ns * side);
        if wi.dot(ngo) <= 0.0 {
            return Rgb::ZERO;
        }
        let cos_i = wi.dot(nso);
        if cos_i <= 0.0 {
            return Rgb::ZERO;
        }
        match &self.bsdf {
            Bsdf::Black | Bsdf::Dielectric { .. } => Rgb::ZERO,
            Bsdf::Diffuse { kd } | Bsdf::Mirror { kd, .. } => *kd * (0.5 * cos_i),
            Bsdf::Glossy { kd, ks, .. } => {
                let cos_a = reflect(wo, nso).dot(wi);
                (*kd * 0.5 + *ks * self.lobe.brdf(cos_a)) * cos_i
            }
        }
    }

    /// Density per radian with which [`sample`](Self::sample) produces `wi` through its non-delta
    /// lobes.
    #[inline]
    pub fn pdf(&self, wo: DVec3, wi: DVec3, ng: DVec3, ns: DVec3) -> f64 {
        let side = if wo.dot(ng) >= 0.0 { 1.0 } else { -1.0 };
        let (ngo, nso) = (ng * side, ns * side);
        if wi.dot(ngo) <= 0.0 {
            return 0.0;
        }
        let cos_i = wi.dot(nso);
        if cos_i <= 0.0 {
            return 0.0;
        }
        match &self.bsdf {
            Bsdf::Black | Bsdf::Dielectric { .. } => 0.0,
            Bsdf::Diffuse { .. } => pdf_cosine(cos_i),
            Bsdf::Mirror { kd, ks } => Bsdf::diffuse_probability(*kd, *ks) * pdf_cosine(cos_i),
            Bsdf::Glossy { kd, ks, .. } => {
                let pd = Bsdf::diffuse_probability(*kd, *ks);
                let cos_a = reflect(wo, nso).dot(wi);
                pd * pdf_cosine(cos_i) + (1.0 - pd) * self.lobe.pdf(cos_a)
            }
        }
    }
}

impl FlatLights {
    /// Samples a light point as seen from `x` (in the plane). `pdf` is per radian (the choice
    /// probability for a point light), `li` the radiance arriving along `-wi`, or `I/d`.
    #[inline]
    pub fn sample(&self, x: DVec3, u_light: f64, u: f64) -> Option<LightSample> {
        let (i, p_choice) = self.choice.pick(u_light)?;
        match &self.lights[i] {
            FlatLight::Segment {
                a,
                b,
                normal,
                length,
                emission,
                ..
            } => connect_emitter(
                x,
                *a + (*b - *a) * u,
                *normal,
                p_choice,
                *length,
                *emission,
                2,
            ),
            FlatLight::Point {
                position,
                intensity,
            } => connect_point(x, *position, *intensity, p_choice, 2),
        }
    }

    /// Density per radian with which [`sample`](Self::sample) picks the point `y` of triangle
    /// `prim`'s cross-section as seen from `x`; 0 when `prim` has none.
    #[inline]
    pub fn pdf_hit(&self, x: DVec3, prim: u32, y: DVec3) -> f64 {
        let Some(&li) = self.light_of_prim.get(prim as usize) else {
            return 0.0;
        };
        if li == u32::MAX {
            return 0.0;
        }
        let FlatLight::Segment { normal, length, .. } = &self.lights[li as usize] else {
            return 0.0;
        };
        emitter_pdf(x, y, *normal, self.choice.prob(li as usize), *length, 2)
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
