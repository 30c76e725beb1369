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

/// The effects of a run of `p` on `scene`, in a fixed order.
pub fn effects(scene: &Scene, p: &Params) -> Vec<Effect> {
    let f = &scene.features;
    let k = kernel_for(p);
    let has_lights = if p.flat.is_some() {
        scene.flat.as_ref().is_some_and(|fl| !fl.lights.is_empty())
    } else {
        !scene.lights.is_empty()
    };
    let radiance = k.radiance;
    let mirrors = if p.flat.is_some() {
        scene.flat.as_ref().is_some_and(|fl| !fl.mirrors.is_empty())
    } else {
        !scene.mirrors.is_empty()
    };
    let e = |name, simulated, why| Effect {
        name,
        simulated,
        why: if simulated { "" } else { why },
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
        e(
            "area-lights",
            radiance && f.area_lights,
            if radiance {
                "no emissive triangle"
            } else {
                "no radiance estimate"
            },
        ),
        e(
            "point-lights",
            radiance && f.point_lights,
            if radiance {
                "no point light"
            } else {
                "no radiance estimate"
            },
        ),
        e(
            "spot-lights",
            radiance && f.spot_lights,
            if radiance {
                "no spot light"
            } else {
                "no radiance estimate"
            },
        ),
        e(
            "sun",
            radiance && f.sun,
            if radiance {
                "no sun"
            } else {
                "no radiance estimate"
            },
        ),
        e(
            "sky",
            radiance && f.sky,
            if radiance {
                "no sky: rays that leave the scene collect nothing"
            } else {
                "no radiance estimate"
            },
        ),
        e(
            "light-sampling",
            radiance && has_lights,
            if radiance {
                "no light to sample"
            } else {
                "no radiance estimate"
            },
        ),
        e(
            "mirror-images",
            radiance && has_lights && mirrors,
            if !radiance {
                "no radiance estimate"
            } else if !has_lights {
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
