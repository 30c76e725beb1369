//! What a run simulates and what it skips ("simulate only what the scene calls for"), for a
//! caller to show before or beside a run. Each entry states a fact about the code paths a run
//! takes: the kernel ([`crate::kernel`]) decides the radiance estimate and flatland at compile
//! time, and the rest is decided at run time by the data (a material kind no triangle uses is
//! never evaluated, light sampling is never called in a scene without lights, shading normals are
//! interpolated only where the scene has vertex normals).

use super::{Params, Weighting, kernel_for};
use crate::scene::Scene;

/// One effect and whether the run computes it; for a skipped one, why.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Effect {
    pub name: &'static str,
    pub simulated: bool,
    /// Why it is skipped (empty when simulated).
    pub why: &'static str,
}

/// Why light transport that needs the radiance estimate is skipped by a kernel without it.
const NO_RADIANCE: &str = "no radiance estimate";

/// The effects of a run of `p` on `scene`, in a fixed order.
pub fn effects(scene: &Scene, p: &Params) -> Vec<Effect> {
    let f = &scene.features;
    let k = kernel_for(p);
    let radiance = k.radiance;
    // Lights and planar mirrors as the run's space sees them (flatland: those in the plane).
    let (has_lights, mirrors) = if p.flat.is_some() {
        scene.flat.as_ref().map_or((false, false), |fl| {
            (!fl.lights.is_empty(), !fl.mirrors.is_empty())
        })
    } else {
        (!scene.lights.is_empty(), !scene.mirrors.is_empty())
    };
    let e = |name, simulated, why| Effect {
        name,
        simulated,
        why: if simulated { "" } else { why },
    };
    // An effect of the radiance estimate: simulated where the kernel has it and the scene calls
    // for it.
    let lit = |name, present, why| {
        e(
            name,
            radiance && present,
            if radiance { why } else { NO_RADIANCE },
        )
    };
    vec![
        e(
            "lambertian-reflection",
            f.diffuse,
            "no material has a diffuse part",
        ),
        e("phong-lobe", f.glossy, "no glossy material"),
        e("mirror-reflection", f.mirror, "no mirror material"),
        e("fresnel-refraction", f.dielectric, "no dielectric material"),
        e(
            "shading-normals",
            scene.has_shading_normals(),
            "no vertex normals: the geometric normal is used",
        ),
        e(
            "radiance-estimate",
            radiance,
            if p.weighting == Weighting::Unweighted {
                "unweighted: every direction has weight 1"
            } else {
                "not needed by this weighting"
            },
        ),
        lit("area-lights", f.area_lights, "no emissive triangle"),
        lit("point-lights", f.point_lights, "no point light"),
        lit("spot-lights", f.spot_lights, "no spot light"),
        lit("sun", f.sun, "no sun"),
        lit(
            "sky",
            f.sky,
            "no sky: rays that leave the scene collect nothing",
        ),
        lit("light-sampling", has_lights, "no light to sample"),
        lit(
            "mirror-images",
            has_lights && mirrors,
            if !has_lights {
                "no light to sample"
            } else {
                "no planar perfect mirror: lights are not sampled through mirrors"
            },
        ),
        e(
            "textures",
            f.textures,
            "no textured material: albedos are constant per material",
        ),
        e(
            "cut-outs",
            f.cutouts,
            "no material has alpha: one geometry without filter functions",
        ),
        e("flatland", k.flatland, "3D: directions on the sphere"),
    ]
}
