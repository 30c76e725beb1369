//! A scene prepared for a flatland run on a plane: the check that its geometry is extruded along
//! the plane normal and its lights lie in the plane, and the emitters' cross-sections with it
//! ([`FlatScene`]).

use crate::math::luminance;
use crate::scene::flat::{
    FlatBsdf, FlatLights, FlatScene, Flatland, FlatlandError, MAX_NORMAL_OUT_OF_PLANE, Section,
    cross_section,
};
use crate::scene::light::{Light, Segment};
use crate::scene::model::Scene;
use glam::DVec3;

impl Scene {
    /// Prepares a flatland run on `plane` (named `label`, e.g. `z=0`, in messages): checks that the
    /// geometry is extruded along the plane normal and point lights lie in the plane, and computes
    /// the emitters' cross-sections. Call after every light has been added.
    pub fn prepare_flatland(&mut self, plane: Flatland, label: &str) -> anyhow::Result<()> {
        self.flat = Some(FlatScene::new(self, plane, label)?);
        Ok(())
    }
}

impl FlatScene {
    /// Validates `scene` for flatland on `plane` and precomputes the light cross-sections.
    ///
    /// Every triangle that meets the plane along a segment (or lies in it) must have its geometric
    /// normal in the plane, |n_g · n| ≤ [`MAX_NORMAL_OUT_OF_PLANE`]: the scene must be extruded
    /// along the plane normal, otherwise in-plane rays would be reflected out of the plane. Point
    /// lights must lie in the plane. Errors name the scene file, the first offending triangle (its
    /// index among the loaded triangles and its material) and how many there are.
    pub fn new(scene: &Scene, plane: Flatland, label: &str) -> anyhow::Result<FlatScene> {
        let file = scene.source.display();
        let n_tri = scene.triangles.len();
        let mut lights = Vec::new();
        let mut light_of_prim = vec![u32::MAX; n_tri];
        // Cross-sections that are mesh edges lying in the plane, by their end points' bits: the
        // triangles on both sides of such an edge share one light (a ray hitting the edge may
        // report either triangle).
        let mut edges: std::collections::HashMap<[u64; 6], u32> = Default::default();
        let mut bad: Vec<(usize, f64)> = Vec::new();
        let mut mirror_lengths = vec![0.0; scene.mirrors.planes.len()];
        for (i, tri) in scene.triangles.iter().enumerate() {
            let v = tri.map(|k| scene.positions[k as usize].as_dvec3());
            let mag = v
                .iter()
                .map(|p| p.abs().max_element())
                .fold(plane.offset.abs(), f64::max);
            let tol = 8.0 * f32::EPSILON as f64 * mag;
            let section = cross_section(&plane, v, tol);
            if section == Section::None {
                continue;
            }
            let ng = scene.tri_normal(i);
            let out = ng.dot(plane.normal).abs();
            if out > MAX_NORMAL_OUT_OF_PLANE {
                bad.push((i, out));
                continue;
            }
            if let (Some(k), Section::Segment { a, b, .. }) =
                (scene.mirrors.plane_of(i as u32), section)
            {
                mirror_lengths[k as usize] += (b - a).length();
            }
            let m = &scene.materials[scene.tri_material[i] as usize];
            if luminance(m.emission) <= 0.0 {
                continue;
            }
            let Section::Segment { a, b, edge } = section else {
                continue;
            };
            let Some(normal) = plane.in_plane(ng) else {
                continue;
            };
            let length = (b - a).length();
            if !(length > 0.0) {
                continue;
            }
            let (p, q) = if a.to_array() <= b.to_array() {
                (a, b)
            } else {
                (b, a)
            };
            let key = [p.x, p.y, p.z, q.x, q.y, q.z].map(f64::to_bits);
            if edge
                && let Some(&j) = edges.get(&key)
                && let Light::Area {
                    normal: nj,
                    emission: ej,
                    ..
                } = &lights[j as usize]
                && nj.dot(normal) > 0.0
                && *ej == m.emission
            {
                light_of_prim[i] = j;
                continue;
            }
            if edge {
                edges.insert(key, lights.len() as u32);
            }
            light_of_prim[i] = lights.len() as u32;
            lights.push(Light::Area {
                prim: i as u32,
                shape: Segment { a, b },
                normal,
                measure: length,
                emission: m.emission,
            });
        }
        if let Some(&(i, out)) = bad.first() {
            let deg = out.clamp(0.0, 1.0).asin().to_degrees();
            let deg = if deg >= 1.0 {
                format!("{deg:.0}")
            } else {
                format!("{deg:.2}")
            };
            let name = &scene.materials[scene.tri_material[i] as usize].name;
            let more = match bad.len() {
                1 => String::new(),
                k => format!("; {} more triangles do too", k - 1),
            };
            return Err(FlatlandError::NotExtruded {
                file: file.to_string(),
                detail: format!(
                    "triangle {i} (material '{name}') crosses {label} with its normal {deg}° out \
                     of the plane{more}"
                ),
            }
            .into());
        }
        // A light's position, moved onto the plane by at most rounding.
        let onto_plane = |what: &str, p: DVec3| -> anyhow::Result<DVec3> {
            let off = plane.distance(p);
            if off.abs() > 1e-9 * scene.extent().max(p.abs().max_element()) {
                return Err(FlatlandError::LightOffPlane {
                    file: file.to_string(),
                    detail: format!(
                        "the {what} at ({}, {}, {}) lies {} off the slice plane {label}; in \
                         flatland, lights must lie in the plane",
                        p.x,
                        p.y,
                        p.z,
                        off.abs()
                    ),
                }
                .into());
            }
            Ok(p - plane.normal * off)
        };
        // In-plane directions: an out-of-plane component must be rounding only.
        let in_plane_dir = |what: &str, d: DVec3| -> anyhow::Result<DVec3> {
            let out = d.dot(plane.normal).abs();
            match plane.in_plane(d) {
                Some(v) if out <= MAX_NORMAL_OUT_OF_PLANE => Ok(v),
                _ => Err(FlatlandError::LightOffPlane {
                    file: file.to_string(),
                    detail: format!(
                        "the {what} ({}, {}, {}) is not in the slice plane {label}; in flatland, \
                         light directions must lie in the plane",
                        d.x, d.y, d.z
                    ),
                }
                .into()),
            }
        };
        // The lights that are not triangles, as the plane sees them.
        for l in &scene.lights.lights {
            match l {
                Light::Area { .. } => {}
                Light::Point {
                    position,
                    intensity,
                } => lights.push(Light::Point {
                    position: onto_plane("point light", *position)?,
                    intensity: *intensity,
                }),
                Light::Spot {
                    position,
                    direction,
                    intensity,
                    cos_inner,
                    cos_outer,
                } => lights.push(Light::Spot {
                    position: onto_plane("spot light", *position)?,
                    direction: in_plane_dir("spot light's direction", *direction)?,
                    intensity: *intensity,
                    cos_inner: *cos_inner,
                    cos_outer: *cos_outer,
                }),
                Light::Distant {
                    direction,
                    irradiance,
                    half_angle,
                    ..
                } => lights.push(Light::distant(
                    in_plane_dir("sun direction", *direction)?,
                    *irradiance,
                    *half_angle,
                )),
                Light::Sky { radiance } => lights.push(Light::Sky {
                    radiance: *radiance,
                }),
                Light::Env(env) => lights.push(Light::Env(env.in_plane(plane.e1, plane.e2))),
            }
        }
        Ok(FlatScene {
            plane,
            label: label.to_string(),
            lights: FlatLights::new(
                lights,
                light_of_prim,
                scene.lights.center,
                scene.lights.radius,
            ),
            bsdfs: scene
                .materials
                .iter()
                .map(|m| FlatBsdf::new(&m.bsdf))
                .collect(),
            mirrors: scene.mirrors.section(
                plane.normal,
                plane.offset,
                |v| plane.in_plane(v),
                &mirror_lengths,
            ),
        })
    }
}
