//! Kernels specialised per scene feature set ("simulate only what the scene calls for").
//!
//! A [`Kernel`] is a type whose associated constants say which effects exist. The sample kernel
//! (`ftpd::sample_at_k`, `transport::walk::walk_k`, `radiance_k`, `Bsdf::sample_k`, ...) is generic
//! over it, so code for absent effects is removed at compile time: a diffuse-only scene has no
//! Fresnel or Phong branch in its walks, an unweighted run no light sampling, a scene without point
//! lights no Dirac-light handling, a scene without shading normals no normal interpolation. The
//! kernel is chosen once per run from the scene's [`Features`] and the weighting ([`dispatch`]);
//! [`AllFeatures`] is the unspecialised kernel every scene may use.
//!
//! `FLATLAND` is not a scene feature but a mode of the run: directions confined to the slice plane
//! (2D light transport, angle measure; see [`crate::transport::flat`]). 3D kernels compile every
//! flatland branch out, so the 3D code paths are the same as without it.

use crate::ftpd::Weighting;
use crate::scene::Features;
use std::fmt;

/// Which effects a kernel simulates.
pub trait Kernel: Send + Sync + 'static {
    const GLOSSY: bool;
    const MIRROR: bool;
    const DIELECTRIC: bool;
    const POINT_LIGHTS: bool;
    const SHADING_NORMALS: bool;
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
/// [`crate::scene::take_ray_log`]), so that a benchmark can replay exactly the same rays through
/// Embree alone. Other kernels compile the logging out.
pub struct Record<K>(std::marker::PhantomData<K>);

impl<K: Kernel> Kernel for Record<K> {
    const GLOSSY: bool = K::GLOSSY;
    const MIRROR: bool = K::MIRROR;
    const DIELECTRIC: bool = K::DIELECTRIC;
    const POINT_LIGHTS: bool = K::POINT_LIGHTS;
    const SHADING_NORMALS: bool = K::SHADING_NORMALS;
    const RADIANCE: bool = K::RADIANCE;
    const FLATLAND: bool = K::FLATLAND;
    const RECORD: bool = true;
}

/// The kernel for one combination of effects.
pub struct Spec<
    const G: bool,
    const M: bool,
    const D: bool,
    const P: bool,
    const N: bool,
    const R: bool,
    const F: bool,
>;

impl<
    const G: bool,
    const M: bool,
    const D: bool,
    const P: bool,
    const N: bool,
    const R: bool,
    const F: bool,
> Kernel for Spec<G, M, D, P, N, R, F>
{
    const GLOSSY: bool = G;
    const MIRROR: bool = M;
    const DIELECTRIC: bool = D;
    const POINT_LIGHTS: bool = P;
    const SHADING_NORMALS: bool = N;
    const RADIANCE: bool = R;
    const FLATLAND: bool = F;
}

/// The unspecialised kernel: every effect compiled in (3D).
pub type AllFeatures = Spec<true, true, true, true, true, true, false>;
/// Every effect but radiance estimation (for unweighted and importance weighting; 3D).
pub type AllButRadiance = Spec<true, true, true, true, true, false, false>;
/// [`AllFeatures`] in flatland.
pub type AllFeaturesFlat = Spec<true, true, true, true, true, true, true>;
/// [`AllButRadiance`] in flatland.
pub type AllButRadianceFlat = Spec<true, true, true, true, true, false, true>;

/// The effects a run needs: the scene's features plus the weighting.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct KernelChoice {
    pub glossy: bool,
    pub mirror: bool,
    pub dielectric: bool,
    pub point_lights: bool,
    pub shading_normals: bool,
    pub radiance: bool,
    /// Directions confined to the slice plane (a mode of the run, not a scene feature).
    pub flatland: bool,
}

impl KernelChoice {
    pub fn new(f: &Features, has_shading_normals: bool, weighting: Weighting) -> KernelChoice {
        let radiance = matches!(weighting, Weighting::Radiance | Weighting::Importance);
        KernelChoice {
            glossy: f.glossy,
            mirror: f.mirror,
            dielectric: f.dielectric,
            // Point lights only matter where light is sampled.
            point_lights: f.point_lights && radiance,
            shading_normals: has_shading_normals,
            radiance,
            flatland: false,
        }
    }

    /// The kernel with every effect, whatever the scene (radiance estimation as the weighting
    /// needs it).
    pub fn all(weighting: Weighting) -> KernelChoice {
        KernelChoice {
            glossy: true,
            mirror: true,
            dielectric: true,
            point_lights: true,
            shading_normals: true,
            radiance: matches!(weighting, Weighting::Radiance | Weighting::Importance),
            flatland: false,
        }
    }

    /// The same effects in flatland (`true`) or in 3D.
    pub fn with_flatland(self, flatland: bool) -> KernelChoice {
        KernelChoice { flatland, ..self }
    }
}

impl fmt::Display for KernelChoice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let on = |b: bool| if b { "+" } else { "-" };
        write!(
            f,
            "kernel<{}glossy {}mirror {}dielectric {}point-lights {}shading-normals {}radiance {}flatland>",
            on(self.glossy),
            on(self.mirror),
            on(self.dielectric),
            on(self.point_lights),
            on(self.shading_normals),
            on(self.radiance),
            on(self.flatland)
        )
    }
}

/// Something to run with a kernel type chosen at run time.
pub trait WithKernel {
    type Output;
    fn run<K: Kernel>(self) -> Self::Output;
}

/// Calls `f.run::<K>()` with the kernel type matching `c` (128 monomorphised variants).
pub fn dispatch<F: WithKernel>(c: KernelChoice, f: F) -> F::Output {
    fn g<F: WithKernel>(c: KernelChoice, f: F) -> F::Output {
        if c.glossy {
            m::<F, true>(c, f)
        } else {
            m::<F, false>(c, f)
        }
    }
    fn m<F: WithKernel, const G: bool>(c: KernelChoice, f: F) -> F::Output {
        if c.mirror {
            d::<F, G, true>(c, f)
        } else {
            d::<F, G, false>(c, f)
        }
    }
    fn d<F: WithKernel, const G: bool, const M: bool>(c: KernelChoice, f: F) -> F::Output {
        if c.dielectric {
            p::<F, G, M, true>(c, f)
        } else {
            p::<F, G, M, false>(c, f)
        }
    }
    fn p<F: WithKernel, const G: bool, const M: bool, const D: bool>(
        c: KernelChoice,
        f: F,
    ) -> F::Output {
        if c.point_lights {
            n::<F, G, M, D, true>(c, f)
        } else {
            n::<F, G, M, D, false>(c, f)
        }
    }
    fn n<F: WithKernel, const G: bool, const M: bool, const D: bool, const P: bool>(
        c: KernelChoice,
        f: F,
    ) -> F::Output {
        if c.shading_normals {
            r::<F, G, M, D, P, true>(c, f)
        } else {
            r::<F, G, M, D, P, false>(c, f)
        }
    }
    fn r<
        F: WithKernel,
        const G: bool,
        const M: bool,
        const D: bool,
        const P: bool,
        const N: bool,
    >(
        c: KernelChoice,
        f: F,
    ) -> F::Output {
        if c.radiance {
            fl::<F, G, M, D, P, N, true>(c, f)
        } else {
            fl::<F, G, M, D, P, N, false>(c, f)
        }
    }
    fn fl<
        F: WithKernel,
        const G: bool,
        const M: bool,
        const D: bool,
        const P: bool,
        const N: bool,
        const R: bool,
    >(
        c: KernelChoice,
        f: F,
    ) -> F::Output {
        if c.flatland {
            f.run::<Spec<G, M, D, P, N, R, true>>()
        } else {
            f.run::<Spec<G, M, D, P, N, R, false>>()
        }
    }
    g(c, f)
}
