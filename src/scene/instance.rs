//! Instanced geometry (glTF's EXT_mesh_gpu_instancing) in the scene model: prototypes, whose
//! triangles (with their materials, shading normals and texture coordinates) are stored once, in
//! prototype space, after the world-space triangles of [`Scene::triangles`](crate::scene::Scene::triangles); and instances, each
//! a prototype and its prototype-to-world affine transform. Embree traverses the instances
//! (`crate::accel`'s instances); a hit on one carries the instance and its prototype's triangle
//! ([`crate::scene::Hit`]), and is reconstructed in world space here: the triangle's
//! vertices are transformed and rounded to f32 exactly as a flattened copy's would be, so that the
//! hit point, its error bound and the geometric normal are those of the flattened copy; shading
//! normals go through the inverse transpose and are renormalised per vertex, as the flattened
//! copy's are. A mirroring transform (negative determinant) reverses the winding, as glTF says,
//! so the front side's normal is the inverse-transpose image of the prototype's.
//!
//! What stays world-space (never instanced, flattened by the loader instead; see
//! [`instanceable`]): emissive triangles, which are the lights that light sampling picks from
//! by area (a light triangle per instance keeps that sampling exact), cut-out (alpha) triangles,
//! whose filter reads the world-space triangle, and perfect mirrors, whose planes the mirror
//! images ([`crate::scene::mirror::Mirrors`]) are built from. Everything else that walks the triangles
//! sees instances through `Scene::world_vertices` and `Scene::world_normal` (in `hit`): the bounds, the
//! placing of points off surfaces, flatland's check that the geometry is an extrusion.

use crate::math::Rgb;
use crate::scene::geometry::Aabb;
use crate::scene::material::Material;
use glam::{DMat3, DMat4, DVec3, Vec3};
use std::ops::Range;

/// A mesh stored once: its triangles are the range `triangles` of [`Scene::triangles`](crate::scene::Scene::triangles).
#[derive(Clone, Debug, PartialEq)]
pub struct Prototype {
    /// What the file calls it (e.g. `mesh 0 'tree'`), for messages.
    pub name: String,
    pub triangles: Range<u32>,
}

/// A prototype placed in the world.
#[derive(Clone, Debug, PartialEq)]
pub struct Instance {
    pub prototype: u32,
    /// Prototype space to world space.
    pub to_world: DMat4,
    /// The inverse transpose of `to_world`'s linear part: how normals transform.
    pub(super) normal_matrix: DMat3,
    /// The transform mirrors (negative determinant): the winding reverses.
    pub(super) mirrored: bool,
    /// The world-space bounds of the instance's triangles (set when the scene is built).
    pub(super) bounds: Aabb,
}

impl Instance {
    /// The instance of `prototype` at `to_world`; `None` when the transform is not finite or its
    /// linear part is singular (it would flatten the prototype: no normals, no area).
    pub fn new(prototype: u32, to_world: DMat4) -> Option<Instance> {
        let linear = DMat3::from_mat4(to_world);
        let det = linear.determinant();
        let scale = linear.x_axis.length() * linear.y_axis.length() * linear.z_axis.length();
        // Relative test: a determinant negligible against the columns' lengths is singular.
        if !to_world.is_finite() || !(det.abs() > 1e-12 * scale) {
            return None;
        }
        Some(Instance {
            prototype,
            to_world,
            normal_matrix: linear.inverse().transpose(),
            mirrored: det < 0.0,
            bounds: Aabb::EMPTY,
        })
    }

    /// The world-space point of prototype-space `p`, rounded to f32 as a flattened copy's vertex.
    #[inline]
    pub fn point(&self, p: Vec3) -> DVec3 {
        self.to_world
            .transform_point3(p.as_dvec3())
            .as_vec3()
            .as_dvec3()
    }

    /// The world-space unit shading normal of prototype-space `n`, rounded to f32 as a flattened
    /// copy's; zero (the geometric normal is used) when it has no length.
    #[inline]
    pub fn normal(&self, n: Vec3) -> DVec3 {
        let w = self.normal_matrix * n.as_dvec3();
        let len = w.length();
        if len > 0.0 && len.is_finite() {
            (w / len).as_vec3().as_dvec3()
        } else {
            DVec3::ZERO
        }
    }

    /// The 3×4 column-major f32 transform Embree takes.
    pub(super) fn columns(&self) -> [[f32; 3]; 4] {
        let m = self.to_world;
        [m.x_axis, m.y_axis, m.z_axis, m.w_axis].map(|c| c.truncate().as_vec3().to_array())
    }
}

/// The prototypes and instances of a scene (both empty for a scene without instancing).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Instancing {
    pub prototypes: Vec<Prototype>,
    pub instances: Vec<Instance>,
}

impl Instancing {
    pub fn is_empty(&self) -> bool {
        self.instances.is_empty()
    }

    /// The index of the first prototype triangle: the triangles before are in world space.
    pub fn world_triangles(&self, all: usize) -> usize {
        self.prototypes
            .iter()
            .map(|p| p.triangles.start as usize)
            .min()
            .unwrap_or(all)
    }

    /// How many triangles the instances place in the world (each prototype's count per instance).
    pub fn instanced_triangles(&self) -> u64 {
        self.instances
            .iter()
            .map(|i| self.prototypes[i.prototype as usize].triangles.len() as u64)
            .sum()
    }
}

/// True when triangles of material `m` may stay in a prototype; false for emitters, materials
/// with an alpha mode (possible cut-outs: their texture may come later) and perfect mirrors,
/// which the loader flattens into world space (see the module docs).
pub fn instanceable(m: &Material) -> bool {
    m.emission == Rgb::ZERO && m.maps.alpha.is_none() && !crate::scene::mirror::is_perfect_mirror(m)
}
