//! Scattering models: Lambertian, normalised (energy-conserving) Phong, perfect mirror, smooth
//! dielectric with exact Fresnel, and their mixtures. Closed-set dispatch: one enum, no trait objects.
//!
//! Conventions (as in pbrt): `wo` points from the surface towards where the path came from, `wi`
//! towards where it goes; both unit. `ng` is the unit geometric normal (orientation from the triangle's
//! winding, front side = counter-clockwise), `ns` the unit shading normal on the same side as `ng`.
//! `eval` returns `f(wo, wi) |cos θi|`; `sample` returns the weight `f |cos θi| / pdf`, which already
//! includes the probability of the lobe chosen.

use crate::kernel::{Flatland, Space, Sphere};
use crate::math::{Rgb, luminance, reflect, safe_sqrt};
use crate::rng::{Sampler, Uniform};
// The enum is scene data; its sampling and evaluation are the `impl Bsdf` blocks below.
use crate::scene::flat::FlatBsdf;
pub use crate::scene::material::Bsdf;
use glam::DVec3;

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
    /// Relative index of refraction η_t/η_i crossed by a refraction, 1 for every other event:
    /// in radiance mode `weight` holds the factor 1/etap^(d−1), which Russian roulette takes
    /// out again ([`crate::transport::walk::survives`]).
    pub etap: f64,
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

    /// Samples `wi` given `wo` in 3D ([`sample_in`](Self::sample_in) on the [`Sphere`]). `None`
    /// when the path is absorbed or the sample falls on the wrong side.
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
        // The 3D lobes draw no numbers beyond `u`: this sampler is never read.
        let mut unused = Sampler::new(0, 0, 0);
        self.sample_in(&Sphere, &(), wo, ng, ns, u_lobe, u, &mut unused, mode)
    }

    /// `f(wo, wi) |cos θi|` of the non-delta lobes in 3D (delta lobes evaluate to zero).
    #[inline(always)]
    pub fn eval(&self, wo: DVec3, wi: DVec3, ng: DVec3, ns: DVec3, mode: Mode) -> Rgb {
        self.eval_in::<Sphere>(&(), wo, wi, ng, ns, mode)
    }

    /// Solid-angle density with which [`sample`](Self::sample) produces `wi` through its non-delta
    /// lobes.
    #[inline(always)]
    pub fn pdf(&self, wo: DVec3, wi: DVec3, ng: DVec3, ns: DVec3) -> f64 {
        self.pdf_in::<Sphere>(&(), wo, wi, ng, ns)
    }

    /// Samples `wi` given `wo` in the space `sp` (3D or flatland), with `lobe` the Phong lobe's
    /// constants there ([`Space::scatter`]); densities per steradian or per radian. `None` when
    /// the path is absorbed or the sample falls on the wrong side. The flatland Phong lobe's
    /// rejection sampler may draw more numbers from `s`.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub fn sample_in<D: Space>(
        &self,
        sp: &D,
        lobe: &D::Lobe,
        wo: DVec3,
        ng: DVec3,
        ns: DVec3,
        u_lobe: f64,
        u: (f64, f64),
        s: &mut impl Uniform,
        mode: Mode,
    ) -> Option<BsdfSample> {
        // Orient both normals towards wo: opaque surfaces are two-sided.
        let side = if wo.dot(ng) >= 0.0 { 1.0 } else { -1.0 };
        let (ngo, nso) = (ng * side, ns * side);
        match self {
            Bsdf::Black => None,
            Bsdf::Diffuse { kd } => {
                let wi = sp.cosine(nso, u);
                if wi.dot(ngo) <= 0.0 {
                    return None;
                }
                Some(BsdfSample {
                    wi,
                    weight: *kd,
                    pdf: D::pdf_cosine(wi.dot(nso)),
                    delta: false,
                    etap: 1.0,
                })
            }
            Bsdf::Glossy { kd, ks, exponent } => {
                let pd = Self::diffuse_probability(*kd, *ks);
                let wi = if u_lobe < pd {
                    sp.cosine(nso, u)
                } else {
                    sp.phong(lobe, *exponent, reflect(wo, nso), u, s)?
                };
                if wi.dot(ngo) <= 0.0 || wi.dot(nso) <= 0.0 {
                    return None;
                }
                let pdf = self.pdf_in::<D>(lobe, wo, wi, ng, ns);
                if pdf <= 0.0 || !pdf.is_finite() {
                    return None;
                }
                Some(BsdfSample {
                    wi,
                    weight: self.eval_in::<D>(lobe, wo, wi, ng, ns, mode) / pdf,
                    pdf,
                    delta: false,
                    etap: 1.0,
                })
            }
            Bsdf::Mirror { kd, ks } => {
                sample_mirror_mixture(wo, ngo, nso, *kd, *ks, u_lobe, || {
                    let wi = sp.cosine(nso, u);
                    (wi, D::pdf_cosine(wi.dot(nso)))
                })
            }
            Bsdf::Dielectric { ior, tint } => {
                sample_dielectric(wo, ng, ngo, nso, *ior, *tint, u_lobe, mode, D::DIMS)
            }
        }
    }

    /// `f(wo, wi) |cos θi|` of the non-delta lobes in the space `D` (per steradian or radian).
    #[inline(always)]
    pub fn eval_in<D: Space>(
        &self,
        lobe: &D::Lobe,
        wo: DVec3,
        wi: DVec3,
        ng: DVec3,
        ns: DVec3,
        _mode: Mode,
    ) -> Rgb {
        let Some((nso, cos_i)) = Self::cos_i(wo, wi, ng, ns) else {
            return Rgb::ZERO;
        };
        match self {
            Bsdf::Black | Bsdf::Dielectric { .. } => Rgb::ZERO,
            Bsdf::Diffuse { kd } | Bsdf::Mirror { kd, .. } => *kd * (D::LAMBERT * cos_i),
            Bsdf::Glossy { kd, ks, exponent } => {
                let cos_a = reflect(wo, nso).dot(wi);
                let spec = D::phong_brdf(lobe, *exponent, cos_a, cos_i, wo.dot(nso));
                (*kd * D::LAMBERT + *ks * spec) * cos_i
            }
        }
    }

    /// Density with which [`sample_in`](Self::sample_in) produces `wi` through its non-delta
    /// lobes.
    #[inline(always)]
    pub fn pdf_in<D: Space>(
        &self,
        lobe: &D::Lobe,
        wo: DVec3,
        wi: DVec3,
        ng: DVec3,
        ns: DVec3,
    ) -> f64 {
        // `sample` rejects directions below the shading horizon, so none has density there
        // (the Phong lobe around the mirror direction may reach below it when ns ≠ ng).
        let Some((nso, cos_i)) = Self::cos_i(wo, wi, ng, ns) else {
            return 0.0;
        };
        match self {
            Bsdf::Black | Bsdf::Dielectric { .. } => 0.0,
            Bsdf::Diffuse { .. } => D::pdf_cosine(cos_i),
            Bsdf::Mirror { kd, ks } => Self::diffuse_probability(*kd, *ks) * D::pdf_cosine(cos_i),
            Bsdf::Glossy { kd, ks, exponent } => {
                let pd = Self::diffuse_probability(*kd, *ks);
                let cos_a = reflect(wo, nso).dot(wi);
                pd * D::pdf_cosine(cos_i) + (1.0 - pd) * D::phong_pdf(lobe, *exponent, cos_a)
            }
        }
    }
}

impl Bsdf {
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

/// The 2D material of a flatland run, with the plane it lives in given where needed.
impl FlatBsdf {
    /// [`Bsdf::sample_in`] in the plane `pl`.
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
        self.bsdf
            .sample_in(pl, &self.lobe, wo, ng, ns, u_lobe, u, s, mode)
    }

    /// [`Bsdf::eval_in`] in flatland (per radian).
    #[inline]
    pub fn eval(&self, wo: DVec3, wi: DVec3, ng: DVec3, ns: DVec3, mode: Mode) -> Rgb {
        self.bsdf
            .eval_in::<Flatland>(&self.lobe, wo, wi, ng, ns, mode)
    }

    /// [`Bsdf::pdf_in`] in flatland (per radian).
    #[inline]
    pub fn pdf(&self, wo: DVec3, wi: DVec3, ng: DVec3, ns: DVec3) -> f64 {
        self.bsdf.pdf_in::<Flatland>(&self.lobe, wo, wi, ng, ns)
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
            etap: 1.0,
        }
    } else {
        BsdfSample {
            wi: reflect(wo, nso),
            weight: ks / (1.0 - pd),
            pdf: 0.0,
            delta: true,
            etap: 1.0,
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
            etap: 1.0,
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
        etap: eta,
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
