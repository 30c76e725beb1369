//! The compile-time kernels: specialised only where the mathematics of a sample changes.
//!
//! Two axes change the algorithm itself, and only these are type parameters of the sample code
//! (`ftpd::sample_at`, `transport::walk::walk`, `radiance`, ...):
//! - the **space** of directions ([`Space`]): the sphere of 3D light transport ([`Sphere`]) or the
//!   circle of a flatland plane ([`Flatland`]). It decides how directions are drawn and measured
//!   (per steradian or per radian), the Lambertian and Phong normalisations, radiance across
//!   refraction (1/η^(d−1)), the falloff of lights (dist^(d−1)) and what an emitter's shape is.
//!   Walks, the radiance estimate, BSDFs and lights are written once over it
//!   (`crate::transport::space` implements it);
//! - `RADIANCE`: the radiance estimate (light sampling, next-event estimation, MIS) is compiled in;
//!   unweighted runs carry none of it.
//!
//! That is four kernels, chosen once per run (`ftpd::sampler`). Everything a scene may or may not have
//! (glossy, mirror and dielectric materials, point lights, shading normals) is run-time data matched
//! on closed enums: a branch a scene never takes is always predicted and costs nothing measurable,
//! and work for an absent effect is still never done (there is no Fresnel term to evaluate where no
//! material is a dielectric, no light to sample where there is none). What a run simulates and skips
//! is listed by [`crate::ftpd::effects::effects`], from the scene's [`crate::scene::Features`].
//!
//! This module names scene data only: every layer from transport up may name a kernel.

use crate::rng::Uniform;
use crate::scene::env::Environment;
use crate::scene::light::{Lights, Shape};
use crate::scene::material::Bsdf;
use crate::scene::{Hit, Scene};
use glam::DVec3;
use std::fmt;

pub use crate::scene::flat::Flatland;

/// The space of directions light travels in: the dimension policy of light transport. The 3D
/// formulas and their flatland counterparts (the table in `crate::transport::space`) differ only
/// here; everything above is written once.
///
/// Implemented by [`Sphere`] (3D) and [`Flatland`] (the slice plane of a 2D run), in
/// `crate::transport::space`.
pub trait Space: Send + Sync + 'static {
    /// 3, or 2 in flatland: radiance changes by 1/η^(DIMS−1) across refraction, lights fall off
    /// as dist^(DIMS−1).
    const DIMS: i32;
    /// Density of a uniform direction: 1/4π per steradian, or 1/2π per radian.
    const PDF_UNIFORM: f64;
    /// The Lambertian BRDF per unit albedo: 1/π per steradian, or 1/2 per radian.
    const LAMBERT: f64;
    /// The shape of area emitters as this space sees them: triangles, or their cross-sections.
    type Shape: Shape;
    /// What the Phong lobe needs besides its exponent (flatland: its normalisations).
    type Lobe: 'static;

    /// The space a run on `scene` uses (flatland: the plane the scene was prepared for).
    fn of(scene: &Scene) -> &Self;
    /// The lights as this space sees them.
    fn lights(scene: &Scene) -> &Lights<Self::Shape>;
    /// The planar mirrors as this space sees them (flatland: lines in the plane).
    fn mirrors(scene: &Scene) -> &crate::scene::mirror::Mirrors;
    /// Material `m`'s scattering model and its Phong lobe's constants.
    fn scatter(scene: &Scene, m: u32) -> (&Bsdf, &Self::Lobe);
    /// The Phong lobe's constants for `bsdf`, the model a hit read from textures
    /// ([`Scene::textured_bsdf`]), given `own`, those of its material: `own` unless the texels
    /// changed the exponent (a metallic-roughness texture), then computed for it.
    fn textured_lobe(bsdf: &Bsdf, own: &Self::Lobe) -> Self::Lobe;
    /// Closest hit along `o + t d` for t in (0, tmax).
    fn intersect(scene: &Scene, o: DVec3, d: DVec3, tmax: f64) -> Option<Hit>;

    /// A uniform direction (density [`PDF_UNIFORM`](Self::PDF_UNIFORM)).
    fn uniform(&self, u: (f64, f64)) -> DVec3;
    /// The second direction of a deflection pair: ω turned by an angle θ ≤ θmax, uniform over the
    /// cone (3D) or over [−θmax, θmax] (flatland). Returns ω', the chord ‖ω − ω'‖ = 2 sin(θ/2) and
    /// `r = tan(θ/2) / tan(θmax/2)`. `one_minus_cos_max` = 1 − cos θmax, `tan_half_max` =
    /// tan(θmax/2).
    fn perturb(
        &self,
        omega: DVec3,
        theta_max: f64,
        one_minus_cos_max: f64,
        tan_half_max: f64,
        u: (f64, f64),
    ) -> (DVec3, f64, f64);
    /// A direction uniform over those within `alpha` (radians, > 0) of the unit `axis`.
    fn cone(&self, axis: DVec3, alpha: f64, u: (f64, f64)) -> DVec3;
    /// A cosine-weighted direction about the unit normal `n`.
    fn cosine(&self, n: DVec3, u: (f64, f64)) -> DVec3;
    /// Density of [`cosine`](Self::cosine) at cosine `cos_theta` to the normal.
    fn pdf_cosine(cos_theta: f64) -> f64;
    /// A direction about the mirror direction `r` with density ∝ cosⁿ of the angle to it; `None`
    /// when a rejection sampler gives up. May draw more numbers from `s`.
    fn phong(
        &self,
        lobe: &Self::Lobe,
        exponent: f64,
        r: DVec3,
        u: (f64, f64),
        s: &mut impl Uniform,
    ) -> Option<DVec3>;
    /// Density of [`phong`](Self::phong) at cosine `cos_a` to the mirror direction.
    fn phong_pdf(lobe: &Self::Lobe, exponent: f64, cos_a: f64) -> f64;
    /// The Phong BRDF per unit `ks` at cosine `cos_a` to the mirror direction, with `cos_i` and
    /// `cos_o` the cosines of the two directions to the shading normal.
    fn phong_brdf(lobe: &Self::Lobe, exponent: f64, cos_a: f64, cos_i: f64, cos_o: f64) -> f64;
    /// A direction towards the environment map, with its density per steradian (radian); `None`
    /// where the tables give none.
    fn env_sample(env: &Environment, u: (f64, f64)) -> Option<(DVec3, f64)>;
    /// The density of [`env_sample`](Self::env_sample) at the unit `d`.
    fn env_pdf(env: &Environment, d: DVec3) -> f64;
    /// The point of an emitter's shape for the uniform `u` (uniform by area or length).
    fn point_on(shape: &Self::Shape, u: (f64, f64)) -> DVec3;
}

/// The space of 3D light transport: directions on the unit sphere, per steradian.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Sphere;

/// Which algorithm a kernel runs.
pub trait Kernel: Send + Sync + 'static {
    /// Radiance estimates with light sampling and MIS are compiled in (radiance weighting, and
    /// the beauty image of importance-weighted camera runs).
    const RADIANCE: bool;
    /// The space directions live in: [`Sphere`], or [`Flatland`] (then the scene must have been
    /// prepared with [`crate::scene::Scene::prepare_flatland`]).
    type Space: Space;
    /// Log every ray query (benchmarks only: see [`Record`]).
    const RECORD: bool = false;
}

/// Kernel `K` that also logs each ray it traces into a per-thread log (see
/// [`crate::transport::trace::take_ray_log`]), so that a benchmark can replay exactly the same rays
/// through Embree alone. Other kernels compile the logging out.
pub struct Record<K>(std::marker::PhantomData<K>);

impl<K: Kernel> Kernel for Record<K> {
    const RADIANCE: bool = K::RADIANCE;
    type Space = K::Space;
    const RECORD: bool = true;
}

/// The kernel for one combination of the two axes.
pub struct Spec<const R: bool, S>(std::marker::PhantomData<S>);

impl<const R: bool, S: Space> Kernel for Spec<R, S> {
    const RADIANCE: bool = R;
    type Space = S;
}

/// 3D, with radiance estimates (radiance weighting; camera images with their beauty image).
pub type Radiance3D = Spec<true, Sphere>;
/// 3D, no radiance estimate (unweighted slices and volumes).
pub type Plain3D = Spec<false, Sphere>;
/// Flatland, with radiance estimates.
pub type RadianceFlat = Spec<true, Flatland>;
/// Flatland, no radiance estimate.
pub type PlainFlat = Spec<false, Flatland>;

/// The kernel a run needs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct KernelChoice {
    /// Radiance estimates compiled in.
    pub radiance: bool,
    /// Directions confined to the slice plane.
    pub flatland: bool,
}

impl fmt::Display for KernelChoice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let on = |b: bool| if b { "+" } else { "-" };
        write!(
            f,
            "kernel<{}radiance {}flatland>",
            on(self.radiance),
            on(self.flatland)
        )
    }
}
