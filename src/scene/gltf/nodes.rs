//! The node trees of the default scene, flattened: every node's world transform applied to its
//! mesh's positions and normals (normals with the inverse transpose, renormalised; triangle winding
//! flipped where the transform mirrors), a mesh used by several nodes copied once per node; lights
//! and cameras placed by their nodes. A mesh placed by EXT_mesh_gpu_instancing becomes a
//! prototype, stored once in its own space, and each instance a transform of it
//! ([`crate::scene::instance`]), unless one of its materials emits, has alpha or is a perfect
//! mirror: then (or when instancing is turned off, [`World::instancing`]) it is flattened like
//! the rest, one copy per instance.

use crate::math::Rgb;
use crate::scene::error::LoadError;
use crate::scene::gltf::accessor::{Quantized, read_components};
use crate::scene::gltf::document::malformed;
use crate::scene::gltf::document::{Warnings, named};
use crate::scene::gltf::mesh::{LocalPrimitive, decode_mesh};
use crate::scene::instance::{Instance, Prototype};
use crate::scene::light::Light;
use crate::scene::model::Camera;
use ::gltf::khr_lights_punctual::Kind as LightKind;
use glam::{DMat3, DMat4, DQuat, DVec3, Vec2, Vec3};
use std::collections::HashMap;
use std::path::Path;

/// The world-space content of a document's node trees, accumulated by [`World::walk`].
pub(super) struct World<'a> {
    path: &'a Path,
    buffers: &'a [Vec<u8>],
    /// The material of primitives without one.
    default_material: u32,
    /// Each mesh's triangle primitives, decoded on first use.
    meshes: HashMap<usize, Vec<LocalPrimitive>>,
    pub(super) warnings: Warnings,
    /// The world-space triangles.
    pub(super) geometry: Geometry,
    /// The prototypes' triangles, in their own space (normals as the file gives them).
    pub(super) proto_geometry: Geometry,
    /// The prototypes: ranges of `proto_geometry`'s triangles.
    pub(super) prototypes: Vec<Prototype>,
    /// The prototype of each mesh that has one, by mesh index.
    proto_of_mesh: HashMap<usize, u32>,
    pub(super) instances: Vec<Instance>,
    /// Per material: it may stay in a prototype; empty when instancing is off (every instance is
    /// flattened).
    pub(super) instancing: Vec<bool>,
    /// Point lights: world position and intensity.
    pub(super) points: Vec<(DVec3, Rgb)>,
    /// Spot and directional lights.
    pub(super) others: Vec<Light>,
    pub(super) cameras: Vec<Camera>,
}

impl<'a> World<'a> {
    /// An empty world for the document of file `path` with buffers `buffers`; primitives
    /// without a material get `default_material`.
    pub(super) fn new(
        path: &'a Path,
        buffers: &'a [Vec<u8>],
        default_material: u32,
        warnings: Warnings,
    ) -> World<'a> {
        World {
            path,
            buffers,
            default_material,
            meshes: HashMap::new(),
            warnings,
            geometry: Geometry::default(),
            proto_geometry: Geometry::default(),
            prototypes: Vec::new(),
            proto_of_mesh: HashMap::new(),
            instances: Vec::new(),
            instancing: Vec::new(),
            points: Vec::new(),
            others: Vec::new(),
            cameras: Vec::new(),
        }
    }

    /// defines no scene), accumulating world-space geometry, lights and cameras.
    pub(super) fn walk(&mut self, doc: &::gltf::Document) -> Result<(), LoadError> {
        let roots: Vec<::gltf::Node> = match doc.default_scene().or_else(|| doc.scenes().next()) {
            Some(scene) => {
                if doc.default_scene().is_none() && doc.scenes().len() > 1 {
                    let w = format!(
                        "{} scenes and no default one; loading the first",
                        doc.scenes().len()
                    );
                    self.warnings.warn(w);
                }
                scene.nodes().collect()
            }
            None => {
                let mut is_child = vec![false; doc.nodes().len()];
                for n in doc.nodes() {
                    for c in n.children() {
                        is_child[c.index()] = true;
                    }
                }
                let roots: Vec<_> = doc.nodes().filter(|n| !is_child[n.index()]).collect();
                if !roots.is_empty() {
                    self.warnings
                        .warn("no scene defined; loading every root node".into());
                }
                roots
            }
        };
        let mut seen = vec![false; doc.nodes().len()];
        let mut stack: Vec<(::gltf::Node, DMat4)> = roots
            .into_iter()
            .rev()
            .map(|n| (n, DMat4::IDENTITY))
            .collect();
        while let Some((node, parent)) = stack.pop() {
            let label = named("node", node.index(), node.name());
            if std::mem::replace(&mut seen[node.index()], true) {
                self.warnings.warn(format!(
                    "{label} is reached more than once (the node hierarchy must be a forest); skipped"
                ));
                continue;
            }
            let world = parent * local_matrix(node.transform());
            if !world.is_finite() {
                return Err(malformed(
                    self.path,
                    format!("{label}: non-finite transform"),
                ));
            }
            if let Some(mesh) = node.mesh() {
                if node.skin().is_some() {
                    self.warnings.warn(format!(
                        "{label}: skin ignored; the mesh is placed by the node's transform"
                    ));
                }
                match self.gpu_instances(doc, &node, &label)? {
                    Some(instances) if self.instanceable(doc, &mesh)? => {
                        self.place_instances(&mesh, &label, world, &instances);
                    }
                    Some(instances) => {
                        for m in instances {
                            self.instance(doc, &mesh, world * m)?;
                        }
                    }
                    None => self.instance(doc, &mesh, world)?,
                }
            }
            if let Some(camera) = node.camera() {
                self.camera(doc, &camera, &node, world)?;
            }
            if let Some(light) = node.light() {
                self.light(&light, world);
            }
            let children: Vec<_> = node.children().collect();
            stack.extend(children.into_iter().rev().map(|c| (c, world)));
        }
        Ok(())
    }

    /// The instance transforms of EXT_mesh_gpu_instancing on `node` (labelled `label`), each
    /// translation · rotation · scale, to be applied before the node's world transform; `None`
    /// when the node does not use the extension. Accessors are f32, or with KHR_mesh_quantization
    /// integers read as [`read_components`] does; all must have the same count.
    fn gpu_instances(
        &mut self,
        doc: &::gltf::Document,
        node: &::gltf::Node,
        label: &str,
    ) -> Result<Option<Vec<DMat4>>, LoadError> {
        let Some(ext) = node.extension_value(INSTANCING) else {
            return Ok(None);
        };
        let fail = |e: String| malformed(self.path, format!("{label}: {INSTANCING}: {e}"));
        let attributes = ext.get("attributes").and_then(|a| a.as_object());
        let accessor = |name: &str| -> Result<Option<::gltf::Accessor>, LoadError> {
            let Some(i) = attributes.and_then(|a| a.get(name)) else {
                return Ok(None);
            };
            i.as_u64()
                .and_then(|i| doc.accessors().nth(i as usize))
                .map(Some)
                .ok_or_else(|| fail(format!("{name} accessor {i} does not exist")))
        };
        let any = Quantized::Any;
        let read3 = |name: &str| -> Result<Option<Vec<[f32; 3]>>, LoadError> {
            accessor(name)?
                .map(|a| read_components::<3>(&a, self.buffers, name, any).map_err(fail))
                .transpose()
        };
        let translation = read3("TRANSLATION")?;
        let scale = read3("SCALE")?;
        let rotation = accessor("ROTATION")?
            .map(|a| read_components::<4>(&a, self.buffers, "ROTATION", any).map_err(fail))
            .transpose()?;
        let counts = [
            translation.as_ref().map(Vec::len),
            rotation.as_ref().map(Vec::len),
            scale.as_ref().map(Vec::len),
        ];
        let count = counts.iter().flatten().copied().max().unwrap_or(0);
        if counts.iter().flatten().any(|&c| c != count) {
            return Err(fail(format!(
                "TRANSLATION, ROTATION and SCALE have different counts ({counts:?})"
            )));
        }
        if count == 0 {
            self.warnings.warn(format!(
                "{label}: {INSTANCING} without TRANSLATION, ROTATION or SCALE; no instance placed"
            ));
        }
        let v3 = |a: &Option<Vec<[f32; 3]>>, i: usize, default: DVec3| {
            a.as_ref()
                .map_or(default, |a| DVec3::from(a[i].map(f64::from)))
        };
        Ok(Some(
            (0..count)
                .map(|i| {
                    let q = rotation.as_ref().map_or(DQuat::IDENTITY, |r| {
                        let [x, y, z, w] = r[i].map(f64::from);
                        unit_or_identity(DQuat::from_xyzw(x, y, z, w))
                    });
                    DMat4::from_scale_rotation_translation(
                        v3(&scale, i, DVec3::ONE),
                        q,
                        v3(&translation, i, DVec3::ZERO),
                    )
                })
                .collect(),
        ))
    }

    /// Decodes `mesh` once (cached).
    fn decoded(
        &mut self,
        doc: &::gltf::Document,
        mesh: &::gltf::Mesh,
    ) -> Result<&[LocalPrimitive], LoadError> {
        if !self.meshes.contains_key(&mesh.index()) {
            let decoded = decode_mesh(
                mesh,
                doc,
                self.buffers,
                self.default_material,
                self.path,
                &mut self.warnings,
            )?;
            self.meshes.insert(mesh.index(), decoded);
        }
        Ok(&self.meshes[&mesh.index()])
    }

    /// True when instancing is on and every material of `mesh` may stay in a prototype.
    fn instanceable(
        &mut self,
        doc: &::gltf::Document,
        mesh: &::gltf::Mesh,
    ) -> Result<bool, LoadError> {
        if self.instancing.is_empty() {
            return Ok(false);
        }
        let flags = std::mem::take(&mut self.instancing);
        let ok = self.decoded(doc, mesh).map(|prims| {
            prims
                .iter()
                .all(|p| flags.get(p.material as usize).copied().unwrap_or(false))
        });
        self.instancing = flags;
        ok
    }

    /// Places `mesh` (decoded) at `world` × each of `instances`, as instances of its prototype
    /// (made on first use). An instance whose transform is singular or not finite is dropped with
    /// a warning naming the node (`label`).
    fn place_instances(
        &mut self,
        mesh: &::gltf::Mesh,
        label: &str,
        world: DMat4,
        instances: &[DMat4],
    ) {
        let proto = match self.proto_of_mesh.get(&mesh.index()) {
            Some(&k) => k,
            None => {
                let first = self.proto_geometry.triangles.len() as u32;
                let prims = &self.meshes[&mesh.index()];
                for prim in prims {
                    self.proto_geometry.append(prim, DMat4::IDENTITY, true);
                }
                let k = self.prototypes.len() as u32;
                self.prototypes.push(Prototype {
                    name: named("mesh", mesh.index(), mesh.name()),
                    triangles: first..self.proto_geometry.triangles.len() as u32,
                });
                self.proto_of_mesh.insert(mesh.index(), k);
                k
            }
        };
        let mut dropped = Vec::new();
        for (k, m) in instances.iter().enumerate() {
            match Instance::new(proto, world * *m) {
                Some(i) => self.instances.push(i),
                None => dropped.push(k),
            }
        }
        if let Some(first) = dropped.first() {
            self.warnings.warn(format!(
                "{label}: {INSTANCING}: {} instance(s) with a singular or non-finite transform \
                 dropped (the first: instance {first})",
                dropped.len()
            ));
        }
    }

    /// Appends a copy of `mesh`'s triangle primitives transformed by `world`.
    fn instance(
        &mut self,
        doc: &::gltf::Document,
        mesh: &::gltf::Mesh,
        world: DMat4,
    ) -> Result<(), LoadError> {
        self.decoded(doc, mesh)?;
        let prims = &self.meshes[&mesh.index()];
        for prim in prims {
            let base = self.geometry.positions.len();
            if base as u64 + prim.positions.len() as u64 >= u32::MAX as u64 {
                return Err(LoadError::TooLarge {
                    file: self.path.to_path_buf(),
                    what: "more than 2^32 vertices".into(),
                });
            }
            self.geometry.append(prim, world, false);
        }
        Ok(())
    }

    fn camera(
        &mut self,
        doc: &::gltf::Document,
        camera: &::gltf::Camera,
        node: &::gltf::Node,
        world: DMat4,
    ) -> Result<(), LoadError> {
        let label = named("camera", camera.index(), camera.name());
        // The crate's validation only asks for one of the two blocks; `projection()` unwraps the
        // one that `type` names.
        {
            use ::gltf::json::camera::Type;
            use ::gltf::json::validation::Checked;
            let json = &doc.as_json().cameras[camera.index()];
            let consistent = match json.type_ {
                Checked::Valid(Type::Perspective) => json.perspective.is_some(),
                Checked::Valid(Type::Orthographic) => json.orthographic.is_some(),
                Checked::Invalid => false,
            };
            if !consistent {
                return Err(malformed(
                    self.path,
                    format!(
                        "{label}: its type has no matching 'perspective' or 'orthographic' block"
                    ),
                ));
            }
        }
        let name = camera
            .name()
            .or(node.name())
            .filter(|n| !n.is_empty())
            .map_or_else(|| format!("camera {}", camera.index()), str::to_string);
        match camera.projection() {
            ::gltf::camera::Projection::Perspective(p) => {
                let eye = world.transform_point3(DVec3::ZERO);
                let forward = world.transform_vector3(-DVec3::Z).normalize_or_zero();
                let up0 = world.transform_vector3(DVec3::Y);
                let up = (up0 - forward * up0.dot(forward)).normalize_or_zero();
                let fov_y = p.yfov() as f64;
                if forward == DVec3::ZERO || up == DVec3::ZERO {
                    self.warnings.warn(format!(
                        "{label}: degenerate node transform (no view or up direction); skipped"
                    ));
                    return Ok(());
                }
                if !(fov_y > 0.0 && fov_y < std::f64::consts::PI) {
                    self.warnings
                        .warn(format!("{label}: yfov {fov_y} is not in (0, π); skipped"));
                    return Ok(());
                }
                let aspect = p
                    .aspect_ratio()
                    .map(|a| a as f64)
                    .filter(|a| *a > 0.0 && a.is_finite());
                self.cameras.push(Camera {
                    name,
                    eye,
                    forward,
                    up,
                    fov_y,
                    aspect,
                });
            }
            ::gltf::camera::Projection::Orthographic(_) => {
                self.warnings.warn(format!(
                    "{label}: orthographic cameras are not supported; skipped"
                ));
            }
        }
        Ok(())
    }

    fn light(&mut self, light: &::gltf::khr_lights_punctual::Light, world: DMat4) {
        let label = named("light", light.index(), light.name());
        let [r, g, b] = light.color();
        let intensity =
            (Rgb::new(r as f64, g as f64, b as f64) * light.intensity() as f64).max(Rgb::ZERO);
        let position = world.transform_point3(DVec3::ZERO);
        // Spots and directional lights shine along the node's local −Z.
        let axis = world.transform_vector3(DVec3::NEG_Z).try_normalize();
        match (light.kind(), axis) {
            (LightKind::Point, _) => self.points.push((position, intensity)),
            (
                LightKind::Spot {
                    inner_cone_angle,
                    outer_cone_angle,
                },
                Some(direction),
            ) => self.others.push(Light::Spot {
                position,
                direction,
                intensity,
                cos_inner: (inner_cone_angle as f64).cos(),
                cos_outer: (outer_cone_angle as f64).cos(),
            }),
            // glTF gives a directional light's intensity in lux: used as the irradiance, with no
            // photometric conversion, and as a Dirac delta (glTF's lights have no extent).
            (LightKind::Directional, Some(direction)) => {
                self.others.push(Light::distant(-direction, intensity, 0.0))
            }
            (_, None) => self.warnings.warn(format!(
                "{label}: degenerate node transform (no direction); skipped"
            )),
        }
    }
}

/// Refuses a `KHR_lights_punctual` light whose `intensity` or `color` is negative or not finite
/// (the extension: intensity ≥ 0, colour in [0, 1]; the glTF validator reports such values as
/// errors), naming the light and the field: clamping them to 0 would leave a light that gives
/// nothing, counted as a light.
pub(super) fn check_lights(doc: &::gltf::Document) -> Result<(), String> {
    let Some(lights) = doc.lights() else {
        return Ok(());
    };
    for light in lights {
        let label = named("KHR_lights_punctual light", light.index(), light.name());
        let intensity = light.intensity();
        if !(intensity.is_finite() && intensity >= 0.0) {
            return Err(format!(
                "{label}: intensity {intensity} must be finite and ≥ 0"
            ));
        }
        let color = light.color();
        if !color.iter().all(|c| c.is_finite() && *c >= 0.0) {
            return Err(format!(
                "{label}: color {color:?} must be finite and ≥ 0 in each component"
            ));
        }
    }
    Ok(())
}

/// A node's local transform in f64 (the matrix, or translation · rotation · scale).
fn local_matrix(t: ::gltf::scene::Transform) -> DMat4 {
    match t {
        ::gltf::scene::Transform::Matrix { matrix } => {
            DMat4::from_cols_array_2d(&matrix.map(|c| c.map(f64::from)))
        }
        ::gltf::scene::Transform::Decomposed {
            translation,
            rotation,
            scale,
        } => {
            let [x, y, z, w] = rotation.map(f64::from);
            let q = unit_or_identity(DQuat::from_xyzw(x, y, z, w));
            DMat4::from_scale_rotation_translation(
                DVec3::from(scale.map(f64::from)),
                q,
                DVec3::from(translation.map(f64::from)),
            )
        }
    }
}

/// `q` normalised; the identity when it has no length (or is not finite).
fn unit_or_identity(q: DQuat) -> DQuat {
    let len = q.length();
    if len > 0.0 && len.is_finite() {
        q / len
    } else {
        DQuat::IDENTITY
    }
}

/// The name of the instancing extension.
const INSTANCING: &str = "EXT_mesh_gpu_instancing";

/// Triangles with per-vertex normals (zero where none) and texture coordinates (zero where
/// none), as the scene builder takes them.
#[derive(Default)]
pub(super) struct Geometry {
    pub(super) positions: Vec<Vec3>,
    pub(super) normals: Vec<Vec3>,
    pub(super) any_normals: bool,
    pub(super) uvs: Vec<Vec2>,
    pub(super) triangles: Vec<[u32; 3]>,
    pub(super) tri_material: Vec<u32>,
}

impl Geometry {
    /// Appends `prim` transformed by `world`: positions, normals with the inverse transpose
    /// (renormalised unless `raw_normals`: a prototype keeps the file's, which each instance
    /// transforms and renormalises as a flattened copy does), the winding flipped where `world`
    /// mirrors. The caller checks the vertex count.
    fn append(&mut self, prim: &LocalPrimitive, world: DMat4, raw_normals: bool) {
        let linear = DMat3::from_mat4(world);
        let det = linear.determinant();
        let normal_matrix = (det != 0.0 && det.is_finite()).then(|| linear.inverse().transpose());
        let flip = det < 0.0;
        let base = self.positions.len();
        self.positions.extend(
            prim.positions
                .iter()
                .map(|p| world.transform_point3(p.as_dvec3()).as_vec3()),
        );
        match (&prim.normals, normal_matrix) {
            (Some(ns), _) if raw_normals => {
                self.any_normals = true;
                self.normals.extend_from_slice(ns);
            }
            (Some(ns), Some(nm)) => {
                self.any_normals = true;
                self.normals.extend(ns.iter().map(|n| {
                    let w = nm * n.as_dvec3();
                    let len = w.length();
                    if len > 0.0 && len.is_finite() {
                        (w / len).as_vec3()
                    } else {
                        Vec3::ZERO
                    }
                }));
            }
            // Zero normals fall back to the geometric normal.
            _ => self
                .normals
                .extend(std::iter::repeat_n(Vec3::ZERO, prim.positions.len())),
        }
        match &prim.uvs {
            Some(uv) => self.uvs.extend_from_slice(uv),
            None => self
                .uvs
                .extend(std::iter::repeat_n(Vec2::ZERO, prim.positions.len())),
        }
        let base = base as u32;
        self.triangles
            .extend(prim.triangles.iter().map(|&[a, b, c]| {
                if flip {
                    [a + base, c + base, b + base]
                } else {
                    [a + base, b + base, c + base]
                }
            }));
        self.tri_material
            .extend(std::iter::repeat_n(prim.material, prim.triangles.len()));
    }

    /// Appends `other` (its indices shifted past this one's vertices).
    pub(super) fn extend(&mut self, other: Geometry) {
        let base = self.positions.len() as u32;
        self.positions.extend(other.positions);
        self.normals.extend(other.normals);
        self.any_normals |= other.any_normals;
        self.uvs.extend(other.uvs);
        self.triangles
            .extend(other.triangles.iter().map(|t| t.map(|v| v + base)));
        self.tri_material.extend(other.tri_material);
    }
}
