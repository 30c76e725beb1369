//! The compile-time kernels: specialised only where the mathematics of a sample changes.
//!
//! Two axes change the algorithm itself, and only these are type parameters of the sample code
//! (`ftpd::sample_at`, `transport::walk::walk`, `radiance`, ...):
//! - `FLATLAND`: directions on the circle of the slice plane, densities per radian, 1/η and 1/dist
//!   instead of 1/η² and 1/dist² (2D light transport; [`crate::transport::flat`]);
//! - `RADIANCE`: the radiance estimate (light sampling, next-event estimation, MIS) is compiled in;
//!   unweighted runs carry none of it.
//!
//! That is four kernels, chosen once per run (`ftpd::sampler`). Everything a scene may or may not have
//! (glossy, mirror and dielectric materials, point lights, shading normals) is run-time data matched
//! on closed enums: a branch a scene never takes is always predicted and costs nothing measurable,
//! and work for an absent effect is still never done (there is no Fresnel term to evaluate where no
//! material is a dielectric, no light to sample where there is none). What a run simulates and skips
//! is listed by `--explain` ([`crate::scene::Features`]).
//!
//! This module imports nothing from the crate: every layer above may name a kernel.

use std::fmt;

/// Which algorithm a kernel runs.
pub trait Kernel: Send + Sync + 'static {
    /// Radiance estimates with light sampling and MIS are compiled in (radiance weighting, and
    /// the beauty image of importance-weighted camera runs).
    const RADIANCE: bool;
    /// Flatland: every direction lies in the slice plane, densities are per radian
    /// (the scene must have been prepared with [`crate::scene::Scene::prepare_flatland`]).
    const FLATLAND: bool;
    /// Log every ray query (benchmarks only: see [`Record`]).
    const RECORD: bool = false;
}

/// Kernel `K` that also logs each ray it traces into a per-thread log (see
/// [`crate::transport::trace::take_ray_log`]), so that a benchmark can replay exactly the same rays
/// through Embree alone. Other kernels compile the logging out.
pub struct Record<K>(std::marker::PhantomData<K>);

impl<K: Kernel> Kernel for Record<K> {
    const RADIANCE: bool = K::RADIANCE;
    const FLATLAND: bool = K::FLATLAND;
    const RECORD: bool = true;
}

/// The kernel for one combination of the two axes.
pub struct Spec<const R: bool, const F: bool>;

impl<const R: bool, const F: bool> Kernel for Spec<R, F> {
    const RADIANCE: bool = R;
    const FLATLAND: bool = F;
}

/// 3D, with radiance estimates (radiance weighting; camera images with their beauty image).
pub type Radiance3D = Spec<true, false>;
/// 3D, no radiance estimate (unweighted slices and volumes).
pub type Plain3D = Spec<false, false>;
/// Flatland, with radiance estimates.
pub type RadianceFlat = Spec<true, true>;
/// Flatland, no radiance estimate.
pub type PlainFlat = Spec<false, true>;

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
