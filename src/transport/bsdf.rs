//! Scattering models: Lambertian, normalised (energy-conserving) Phong, perfect mirror, smooth
//! dielectric with exact Fresnel, and their mixtures. Closed-set dispatch: one enum, no trait objects.
//!
//! Conventions (as in pbrt): `wo` points from the surface towards where the path came from, `wi`
//! towards where it goes; both unit. `ng` is the unit geometric normal (orientation from the triangle's
//! winding, front side = counter-clockwise), `ns` the unit shading normal on the same side as `ng`.
//! `eval` returns `f(wo, wi) |cos θi|`; `sample` returns the weight `f |cos θi| / pdf`, which already
//! includes the probability of the lobe chosen.

use crate::math::{Frame, Rgb, luminance, reflect, safe_sqrt};
// The enum is scene data; its sampling and evaluation are the `impl Bsdf` blocks below.
pub use crate::scene::material::Bsdf;
use crate::transport::sampling::*;
use glam::DVec3;
use std::f64::consts::{FRAC_1_PI, TAU};

/// What a path carries: radiance (traced from the sensor) or importance/light (traced along the
/// direction light travels). Only refraction differs: radiance is scaled by 1/η² across it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    Radiance,
    Importance,
}

/// One sampled direction.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    pub wi: DVec3,
    /// `f |cos θi| / pdf`.
    pub weight: Rgb,
    /// Solid-angle density of the non-delta part (0 for a delta lobe).
    pub pdf: f64,
    /// The direction came from a Dirac lobe (mirror, refraction): no light sampling can reach it.
    pub delta: bool,
}

impl Bsdf {
    /// True when every lobe is a Dirac delta, so light sampling at this surface is useless.
    pub fn is_delta(&self) -> bool {
        match self {
            Bsdf::Black => true,
            Bsdf::Dielectric { .. } => true,
            Bsdf::Mirror { kd, .. } => *kd == Rgb::ZERO,
            Bsdf::Diffuse { .. } | Bsdf::Glossy { .. } => false,
        }
    }

    /// Probability of choosing the diffuse lobe of a two-lobe mixture.
    pub(crate) fn diffuse_probability(kd: Rgb, ks: Rgb) -> f64 {
        let (d, s) = (luminance(kd).max(0.0), luminance(ks).max(0.0));
        if d + s > 0.0 { d / (d + s) } else { 1.0 }
    }

    /// Sample `wi` given `wo`. `None` when the path is absorbed or the sample falls on the wrong side.
    #[inline(always)]
    pub fn sample(
        &self,
        wo: DVec3,
        ng: DVec3,
        ns: DVec3,
        u_lobe: f64,
        u: (f64, f64),
        mode: Mode,
    ) -> Option<BsdfSample> {
        // Orient both normals towards wo: opaque surfaces are two-sided.
        let side = if wo.dot(ng) >= 0.0 { 1.0 } else { -1.0 };
        let (ngo, nso) = (ng * side, ns * side);
        match self {
            Bsdf::Black => None,
            Bsdf::Diffuse { kd } => Self::sample_diffuse(*kd, ngo, nso, u),
            Bsdf::Glossy { kd, ks, exponent } => {
                let pd = Self::diffuse_probability(*kd, *ks);
                let wi = if u_lobe < pd {
                    Frame::from_z(nso).to_world(sample_cosine_hemisphere(u))
                } else {
                    let r = reflect(wo, nso);
                    Frame::from_z(r).to_world(sample_phong_lobe(u, *exponent))
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
                    let wi = Frame::from_z(nso).to_world(sample_cosine_hemisphere(u));
                    (wi, pdf_cosine_hemisphere(wi.dot(nso)))
                })
            }
            Bsdf::Dielectric { ior, tint } => {
                sample_dielectric(wo, ng, ngo, nso, *ior, *tint, u_lobe, mode, 3)
            }
        }
    }

    /// `f(wo, wi) |cos θi|` of the non-delta lobes (delta lobes evaluate to zero).
    #[inline(always)]
    pub fn eval(&self, wo: DVec3, wi: DVec3, ng: DVec3, ns: DVec3, _mode: Mode) -> Rgb {
        let Some((nso, cos_i)) = Self::cos_i(wo, wi, ng, ns) else {
            return Rgb::ZERO;
        };
        match self {
            Bsdf::Black | Bsdf::Dielectric { .. } => Rgb::ZERO,
            Bsdf::Diffuse { kd } | Bsdf::Mirror { kd, .. } => *kd * (FRAC_1_PI * cos_i),
            Bsdf::Glossy { kd, ks, exponent } => {
                let cos_a = reflect(wo, nso).dot(wi);
                // Phong lobe divided by max(cos θi, cos θo) (cos θi > 0 here, so no division by
                // zero): symmetric in wo and wi, albedo ≤ ks, and f cos θi / pdf = ks cos θi /
                // max(cos θi, cos θo) → ks as the exponent grows, i.e. the lobe tends to the
                // perfect mirror of reflectance ks (the paper's Fig. 4c/d).
                let spec = if cos_a > 0.0 {
                    (exponent + 1.0) / TAU * cos_a.powf(*exponent) / cos_i.max(wo.dot(nso))
                } else {
                    0.0
                };
                (*kd * FRAC_1_PI + *ks * spec) * cos_i
            }
        }
    }

    /// Solid-angle density with which `sample` produces `wi` through its non-delta lobes.
    #[inline(always)]
    pub fn pdf(&self, wo: DVec3, wi: DVec3, ng: DVec3, ns: DVec3) -> f64 {
        // `sample` rejects directions below the shading horizon, so none has density there
        // (the Phong lobe around the mirror direction may reach below it when ns ≠ ng).
        let Some((nso, cos_i)) = Self::cos_i(wo, wi, ng, ns) else {
            return 0.0;
        };
        match self {
            Bsdf::Black | Bsdf::Dielectric { .. } => 0.0,
            Bsdf::Diffuse { .. } => pdf_cosine_hemisphere(cos_i),
            Bsdf::Mirror { kd, ks } => {
                Self::diffuse_probability(*kd, *ks) * pdf_cosine_hemisphere(cos_i)
            }
            Bsdf::Glossy { kd, ks, exponent } => {
                let pd = Self::diffuse_probability(*kd, *ks);
                let cos_a = reflect(wo, nso).dot(wi);
                pd * pdf_cosine_hemisphere(cos_i) + (1.0 - pd) * pdf_phong_lobe(cos_a, *exponent)
            }
        }
    }
}

/// The Lambertian lobe.
impl Bsdf {
    /// `sample` of `Diffuse { kd }`, with the normals already oriented towards `wo`.
    #[inline(always)]
    fn sample_diffuse(kd: Rgb, ngo: DVec3, nso: DVec3, u: (f64, f64)) -> Option<BsdfSample> {
        let wi = Frame::from_z(nso).to_world(sample_cosine_hemisphere(u));
        if wi.dot(ngo) <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wi,
            weight: kd,
            pdf: pdf_cosine_hemisphere(wi.dot(nso)),
            delta: false,
        })
    }

    /// The side of `wo` (±1) and the cosine of `wi` to the shading normal on that side, or `None`
    /// where `eval` and `pdf` of every lobe are zero (wi below the geometric or shading horizon).
    #[inline(always)]
    fn cos_i(wo: DVec3, wi: DVec3, ng: DVec3, ns: DVec3) -> Option<(DVec3, f64)> {
        let side = if wo.dot(ng) >= 0.0 { 1.0 } else { -1.0 };
        let (ngo, nso) = (ng * side, ns * side);
        if wi.dot(ngo) <= 0.0 {
            return None;
        }
        let cos_i = wi.dot(nso);
        if cos_i <= 0.0 {
            return None;
        }
        Some((nso, cos_i))
    }
}

/// Samples the `kd` Lambertian plus `ks` perfect-mirror mixture, choosing the lobe by albedo:
/// `diffuse` draws the Lambertian direction and gives its density (per solid angle in 3D, per
/// radian in flatland). `ngo` and `nso` are the normals turned towards `wo`.
#[inline]
pub(crate) fn sample_mirror_mixture(
    wo: DVec3,
    ngo: DVec3,
    nso: DVec3,
    kd: Rgb,
    ks: Rgb,
    u_lobe: f64,
    diffuse: impl FnOnce() -> (DVec3, f64),
) -> Option<BsdfSample> {
    let pd = Bsdf::diffuse_probability(kd, ks);
    let sample = if u_lobe < pd {
        let (wi, pdf) = diffuse();
        BsdfSample {
            wi,
            weight: kd / pd,
            pdf: pd * pdf,
            delta: false,
        }
    } else {
        BsdfSample {
            wi: reflect(wo, nso),
            weight: ks / (1.0 - pd),
            pdf: 0.0,
            delta: true,
        }
    };
    (sample.wi.dot(ngo) > 0.0).then_some(sample)
}

/// Samples a smooth dielectric of relative index `ior` (inside over outside) in `dims` dimensions:
/// reflection with the Fresnel probability, else refraction (entering when `wo` is on the front side
/// of `ng`). Radiance, measured per (area × solid angle) in 3D and per (length × angle) in
/// flatland, changes by 1/η^(dims−1) across the interface; importance does not. `ngo` and `nso`
/// are the normals turned towards `wo`.
#[allow(clippy::too_many_arguments)]
#[inline]
pub(crate) fn sample_dielectric(
    wo: DVec3,
    ng: DVec3,
    ngo: DVec3,
    nso: DVec3,
    ior: f64,
    tint: Rgb,
    u_lobe: f64,
    mode: Mode,
    dims: i32,
) -> Option<BsdfSample> {
    let entering = wo.dot(ng) > 0.0;
    let eta = if entering { ior } else { 1.0 / ior }; // eta_t / eta_i
    let cos_i = wo.dot(nso).clamp(-1.0, 1.0).abs();
    if u_lobe < fresnel_dielectric(cos_i, eta) {
        let wi = reflect(wo, nso);
        if wi.dot(ngo) <= 0.0 {
            return None;
        }
        return Some(BsdfSample {
            wi,
            weight: Rgb::ONE,
            pdf: 0.0,
            delta: true,
        });
    }
    let wi = refract(wo, nso, eta)?;
    if wi.dot(ngo) >= 0.0 {
        return None;
    }
    let scale = if mode == Mode::Radiance {
        1.0 / eta.powi(dims - 1)
    } else {
        1.0
    };
    Some(BsdfSample {
        wi,
        weight: tint * scale,
        pdf: 0.0,
        delta: true,
    })
}

/// Unpolarised Fresnel reflectance of a smooth dielectric interface.
/// `cos_i` is the cosine of the incident angle (≥ 0), `eta` = η_transmitted / η_incident.
/// Returns 1 past the critical angle (total internal reflection).
pub fn fresnel_dielectric(cos_i: f64, eta: f64) -> f64 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = safe_sqrt(1.0 - sin2_t);
    let r_par = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (r_par * r_par + r_perp * r_perp)
}

/// Refraction of `wo` (pointing away from the surface, on the side of `n`) through an interface with
/// relative index `eta` = η_t/η_i. `None` on total internal reflection.
pub fn refract(wo: DVec3, n: DVec3, eta: f64) -> Option<DVec3> {
    let cos_i = wo.dot(n);
    let sin2_i = (1.0 - cos_i * cos_i).max(0.0);
    let sin2_t = sin2_i / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = safe_sqrt(1.0 - sin2_t);
    Some((-wo / eta + (cos_i / eta - cos_t) * n).normalize())
}
