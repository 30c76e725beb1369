//! The description a job's run gives its field: the driver's ([`describe_run`]), where the domain
//! lies, and the lights added to the scene file's, which are part of the scene (merging refuses
//! fields computed with other lights, resuming a file computed with others).

use super::resolve::JobDomain;
use crate::ftpd::Params;
use crate::render::{RenderOptions, camera_info, describe_run, plane_info, volume_info};
use crate::run_info::{RunInfo, fmt_vec};
use crate::scene::{Light, Scene};

/// The description of a run of `params` and `opts` over `domain` of `scene`, with `lights` added
/// to the scene file's.
pub fn describe_domain(
    scene: &Scene,
    domain: &JobDomain,
    params: &Params,
    opts: &RenderOptions,
    lights: &[Light],
) -> RunInfo {
    let (sun, sky) = describe_suns_and_skies(lights);
    RunInfo {
        plane: match domain {
            JobDomain::Plane(p) => Some(plane_info(p)),
            _ => None,
        },
        camera: match domain {
            JobDomain::Camera(v) => Some(camera_info(v)),
            _ => None,
        },
        volume: match domain {
            JobDomain::Volume(v) => Some(volume_info(v)),
            _ => None,
        },
        point_lights: lights
            .iter()
            .filter_map(|l| match l {
                Light::Point {
                    position,
                    intensity,
                } => Some((*position, *intensity)),
                _ => None,
            })
            .collect(),
        sun,
        sky,
        light_scale: describe_light_scales(scene),
        ..describe_run(scene, params, opts, domain.kind())
    }
}

/// The scene file's lights the run scaled, `name=factor;…` (see [`RunInfo::light_scale`]).
fn describe_light_scales(scene: &Scene) -> Option<String> {
    let scaled: Vec<String> = scene
        .file_lights
        .iter()
        .filter(|f| f.scale != 1.0)
        .map(|f| format!("{}={}", f.name, f.scale))
        .collect();
    (!scaled.is_empty()).then(|| scaled.join(";"))
}

/// The added suns, and sky or environment map, each `;`-separated in the syntax that adds them
/// (see [`RunInfo::sun`] and [`RunInfo::sky`]).
fn describe_suns_and_skies(lights: &[Light]) -> (Option<String>, Option<String>) {
    let (mut suns, mut skies) = (Vec::new(), Vec::new());
    for l in lights {
        match l {
            Light::Distant {
                direction,
                irradiance,
                half_angle,
                ..
            } => suns.push(format!(
                "{}:{}:{}",
                fmt_vec(*direction),
                fmt_vec(*irradiance),
                (2.0 * half_angle).to_degrees()
            )),
            Light::Sky { radiance } => skies.push(fmt_vec(*radiance)),
            Light::Env(env) => skies.push(format!(
                "{}:{}:{}",
                env.map.source,
                env.map.scale,
                env.map.rotation.to_degrees()
            )),
            Light::Area { .. } | Light::Point { .. } | Light::Spot { .. } => {}
        }
    }
    let joined = |v: Vec<String>| (!v.is_empty()).then(|| v.join(";"));
    (joined(suns), joined(skies))
}
