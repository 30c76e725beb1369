//! A scene prepared for a flatland run on a plane: the check that its geometry is extruded along
//! the plane normal and its lights lie in the plane, and the emitters' cross-sections with it
//! ([`FlatScene`]).

use crate::math::{Rgb, luminance};
use crate::scene::flat::{
    FlatBsdf, FlatLight, FlatLights, FlatScene, Flatland, FlatlandError, MAX_NORMAL_OUT_OF_PLANE,
    Section, cross_section,
};
use crate::scene::light::{Light, Segment};
use crate::scene::model::Scene;
use glam::DVec3;
use std::collections::HashMap;

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
    pub fn new(scene: &Scene, plane: Flatland, label: &str) -> Result<FlatScene, FlatlandError> {
        let Sections {
            mut lights,
            light_of_prim,
            bad,
            mirror_lengths,
            ..
        } = Sections::of(scene, &plane);
        if let Some(&(i, out)) = bad.first() {
            return Err(not_extruded(scene, label, i, out, bad.len()));
        }
        let place = InPlane {
            scene,
            plane: &plane,
            label,
        };
        // The lights that are not triangles, as the plane sees them.
        for l in &scene.lights.lights {
            if let Some(l) = place.light(l)? {
                lights.push(l);
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

/// What the triangles give a flatland plane: the emitters' cross-sections as lights, each
/// triangle's light (`u32::MAX`: none), the triangles that cross it with their normal out of it
/// (index, |n_g · n|), and the length of each planar mirror's cross-section.
struct Sections {
    lights: Vec<FlatLight>,
    light_of_prim: Vec<u32>,
    bad: Vec<(usize, f64)>,
    mirror_lengths: Vec<f64>,
    /// Cross-sections that are mesh edges lying in the plane, by their end points' bits: the
    /// triangles on both sides of such an edge share one light (a ray hitting the edge may report
    /// either triangle).
    edges: HashMap<[u64; 6], u32>,
}

impl Sections {
    fn of(scene: &Scene, plane: &Flatland) -> Sections {
        let mut s = Sections {
            lights: Vec::new(),
            light_of_prim: vec![u32::MAX; scene.triangles.len()],
            bad: Vec::new(),
            mirror_lengths: vec![0.0; scene.mirrors.planes.len()],
            edges: HashMap::new(),
        };
        for (i, tri) in scene.triangles.iter().enumerate() {
            let v = tri.map(|k| scene.positions[k as usize].as_dvec3());
            let mag = v
                .iter()
                .map(|p| p.abs().max_element())
                .fold(plane.offset.abs(), f64::max);
            let tol = 8.0 * f32::EPSILON as f64 * mag;
            let section = cross_section(plane, v, tol);
            if section == Section::None {
                continue;
            }
            let ng = scene.tri_normal(i);
            let out = ng.dot(plane.normal).abs();
            if out > MAX_NORMAL_OUT_OF_PLANE {
                s.bad.push((i, out));
                continue;
            }
            if let (Some(k), Section::Segment { a, b, .. }) =
                (scene.mirrors.plane_of(i as u32), section)
            {
                s.mirror_lengths[k as usize] += (b - a).length();
            }
            let emission = scene.materials[scene.tri_material[i] as usize].emission;
            if luminance(emission) <= 0.0 {
                continue;
            }
            if let (Section::Segment { a, b, edge }, Some(normal)) = (section, plane.in_plane(ng)) {
                s.emitter(i, a, b, edge, normal, emission);
            }
        }
        s.instanced(scene, plane);
        s
    }

    /// The instanced triangles that cross the plane with their normal out of it (instances hold
    /// no lights or mirrors: see `crate::scene::instance`), in world space; bad ones are named
    /// by their prototype triangle.
    fn instanced(&mut self, scene: &Scene, plane: &Flatland) {
        scene.for_instanced_triangles(
            |b| {
                let d = b.corners().map(|c| c.dot(plane.normal) - plane.offset);
                let mag = b.min.abs().max(b.max.abs()).max_element();
                let tol = 8.0 * f32::EPSILON as f64 * mag.max(plane.offset.abs());
                d.iter().any(|&x| x >= -tol) && d.iter().any(|&x| x <= tol)
            },
            |inst, prim| {
                let v = scene.world_vertices(inst, prim);
                let mag = v
                    .iter()
                    .map(|p| p.abs().max_element())
                    .fold(plane.offset.abs(), f64::max);
                let tol = 8.0 * f32::EPSILON as f64 * mag;
                if cross_section(plane, v, tol) != Section::None {
                    let out = scene.world_normal(inst, prim).dot(plane.normal).abs();
                    if out > MAX_NORMAL_OUT_OF_PLANE {
                        self.bad.push((prim as usize, out));
                    }
                }
                false
            },
        );
    }

    /// The light of emissive triangle `i`, whose cross-section is the segment `a`–`b` (`edge`: an
    /// edge of the triangle, lying in the plane) with in-plane normal `normal`: the light of the
    /// triangle on the other side of that edge when it faces the same way and emits the same,
    /// else a new one.
    fn emitter(&mut self, i: usize, a: DVec3, b: DVec3, edge: bool, normal: DVec3, emission: Rgb) {
        let length = (b - a).length();
        if !(length > 0.0) {
            return;
        }
        let (p, q) = if a.to_array() <= b.to_array() {
            (a, b)
        } else {
            (b, a)
        };
        let key = [p.x, p.y, p.z, q.x, q.y, q.z].map(f64::to_bits);
        if edge
            && let Some(&j) = self.edges.get(&key)
            && let Light::Area {
                normal: nj,
                emission: ej,
                ..
            } = &self.lights[j as usize]
            && nj.dot(normal) > 0.0
            && *ej == emission
        {
            self.light_of_prim[i] = j;
            return;
        }
        if edge {
            self.edges.insert(key, self.lights.len() as u32);
        }
        self.light_of_prim[i] = self.lights.len() as u32;
        self.lights.push(Light::Area {
            prim: i as u32,
            shape: Segment { a, b },
            normal,
            measure: length,
            emission,
        });
    }
}

/// The refusal of a scene whose triangle `i` (the first of `count`) crosses the plane `label`
/// with its normal out of the plane by |n_g · n| = `out`.
fn not_extruded(scene: &Scene, label: &str, i: usize, out: f64, count: usize) -> FlatlandError {
    let deg = out.clamp(0.0, 1.0).asin().to_degrees();
    let deg = if deg >= 1.0 {
        format!("{deg:.0}")
    } else {
        format!("{deg:.2}")
    };
    let name = &scene.materials[scene.tri_material[i] as usize].name;
    let more = match count {
        1 => String::new(),
        k => format!("; {} more triangles do too", k - 1),
    };
    FlatlandError::NotExtruded {
        file: scene.source.display().to_string(),
        detail: format!(
            "triangle {i} (material '{name}') crosses {label} with its normal {deg}° out of the \
             plane{more}"
        ),
    }
}

/// The lights that are not triangles as a flatland plane (named `label`) sees them.
struct InPlane<'a> {
    scene: &'a Scene,
    plane: &'a Flatland,
    label: &'a str,
}

impl InPlane<'_> {
    /// `l` in the plane: points moved onto it by at most rounding, directions in it, the
    /// environment on the plane's circle; `None` for area lights (their cross-sections are
    /// [`Sections`]).
    fn light(&self, l: &Light) -> Result<Option<FlatLight>, FlatlandError> {
        Ok(Some(match l {
            Light::Area { .. } => return Ok(None),
            Light::Point {
                position,
                intensity,
            } => Light::Point {
                position: self.onto_plane("point light", *position)?,
                intensity: *intensity,
            },
            Light::Spot {
                position,
                direction,
                intensity,
                cos_inner,
                cos_outer,
            } => Light::Spot {
                position: self.onto_plane("spot light", *position)?,
                direction: self.direction("spot light's direction", *direction)?,
                intensity: *intensity,
                cos_inner: *cos_inner,
                cos_outer: *cos_outer,
            },
            Light::Distant {
                direction,
                irradiance,
                half_angle,
                ..
            } => Light::distant(
                self.direction("sun direction", *direction)?,
                *irradiance,
                *half_angle,
            ),
            Light::Sky { radiance } => Light::Sky {
                radiance: *radiance,
            },
            Light::Env(env) => Light::Env(env.in_plane(self.plane.e1, self.plane.e2)),
        }))
    }

    /// A light's position, moved onto the plane by at most rounding.
    fn onto_plane(&self, what: &str, p: DVec3) -> Result<DVec3, FlatlandError> {
        let off = self.plane.distance(p);
        if off.abs() > 1e-9 * self.scene.extent().max(p.abs().max_element()) {
            return Err(FlatlandError::LightOffPlane {
                file: self.scene.source.display().to_string(),
                detail: format!(
                    "the {what} at ({}, {}, {}) lies {} off the slice plane {}; in flatland, \
                     lights must lie in the plane",
                    p.x,
                    p.y,
                    p.z,
                    off.abs(),
                    self.label
                ),
            });
        }
        Ok(p - self.plane.normal * off)
    }

    /// An in-plane direction: an out-of-plane component must be rounding only.
    fn direction(&self, what: &str, d: DVec3) -> Result<DVec3, FlatlandError> {
        let out = d.dot(self.plane.normal).abs();
        match self.plane.in_plane(d) {
            Some(v) if out <= MAX_NORMAL_OUT_OF_PLANE => Ok(v),
            _ => Err(FlatlandError::LightOffPlane {
                file: self.scene.source.display().to_string(),
                detail: format!(
                    "the {what} ({}, {}, {}) is not in the slice plane {}; in flatland, light \
                     directions must lie in the plane",
                    d.x, d.y, d.z, self.label
                ),
            }),
        }
    }
}
