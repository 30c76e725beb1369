//! The scene model: a loaded scene's data (triangles as Embree sees them, per-triangle records,
//! materials, lights, textures, cameras, bounds, the feature set) and the small queries on it. How
//! it is built is [`crate::scene::build`]; how rays meet it is [`crate::scene::hit`] and
//! [`crate::scene::offset`]; what a hit sees is [`crate::scene::shading`].

use crate::accel::{Accel, SharedArray};
use crate::scene::features::Features;
use crate::scene::flat::FlatScene;
use crate::scene::geometry::{Aabb, interpolate_uv};
use crate::scene::instance::Instancing;
use crate::scene::light::{FileLight, LightSet};
use crate::scene::material::Material;
use crate::scene::mirror::Mirrors;
use crate::scene::texture::TextureSet;
use glam::{DVec3, Vec2, Vec3};
use std::path::PathBuf;

/// A pinhole camera (from a glTF file, a sidecar scene file or the command line).
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub name: String,
    pub eye: DVec3,
    /// Unit viewing direction.
    pub forward: DVec3,
    /// Unit up vector, orthogonal to `forward`.
    pub up: DVec3,
    /// Vertical field of view, radians.
    pub fov_y: f64,
    /// Width over height, when the file gives one.
    pub aspect: Option<f64>,
}

/// What the loader had to drop or repair, reported once per run.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LoadReport {
    pub triangles_read: usize,
    pub degenerate_dropped: usize,
    pub warnings: Vec<String>,
    /// Seconds spent reading and parsing the files (everything but the BVH build).
    pub parse_seconds: f64,
    /// Seconds Embree spent building the BVH.
    pub bvh_seconds: f64,
    /// Bytes the decoded textures take.
    pub texture_bytes: usize,
}

/// The shading normals a loader hands to [`Scene::from_parts`].
#[derive(Clone, Debug, Default)]
pub enum Shading {
    /// None: hits use the geometric normal.
    #[default]
    None,
    /// One per vertex, same indexing as the positions (kept in [`Scene::normals`]).
    PerVertex(Vec<Vec3>),
    /// The three corners' of each triangle, same indexing as the triangles (what an OBJ file
    /// gives: a vertex may have a different normal in each face).
    PerCorner(Vec<[Vec3; 3]>),
}

/// Texture coordinates (v up), as a loader hands them to [`Scene::from_parts`] (glTF's per-vertex
/// ones come through [`Scene::set_textures`]) and as the scene keeps them; read only through
/// [`Scene::corner_uvs`].
#[derive(Clone, Debug, Default)]
pub enum TexCoords {
    /// None: every corner reads (0, 0).
    #[default]
    None,
    /// One per vertex, same indexing as the positions (glTF).
    PerVertex(Vec<Vec2>),
    /// A table and, per triangle, its corners' indices into it (OBJ's `vt` and the faces' vt
    /// indices: a vertex may have other coordinates in each face); an index past the table
    /// (a corner without `vt`) reads (0, 0).
    PerCorner {
        table: Vec<Vec2>,
        corners: Vec<[u32; 3]>,
    },
}

impl TexCoords {
    pub fn is_none(&self) -> bool {
        matches!(self, TexCoords::None)
    }
}

/// A loaded scene.
pub struct Scene {
    pub source: PathBuf,
    /// The vertices, read in place by Embree (hence immutable).
    pub positions: SharedArray<Vec3>,
    /// Per-vertex shading normals, same indexing as `positions`, when the loader gave them so
    /// (glTF); empty otherwise (see [`Scene::has_shading_normals`]).
    pub normals: Vec<Vec3>,
    /// Each triangle's vertex indices, read in place by Embree (hence immutable).
    pub triangles: SharedArray<[u32; 3]>,
    pub tri_material: Vec<u32>,
    pub materials: Vec<Material>,
    pub lights: LightSet,
    /// The planar mirrors (empty in scenes without: then nothing samples their virtual lights).
    pub mirrors: Mirrors,
    pub bounds: Aabb,
    pub features: Features,
    pub report: LoadReport,
    /// Cameras the scene file defines, in file order.
    pub cameras: Vec<Camera>,
    /// Named slice planes from a sidecar file: (name, plane such as `z=0`).
    pub named_slices: Vec<(String, String)>,
    /// The scene file's own lights by name, with the factors a run scaled them by (empty until
    /// the loader names them, [`crate::scene::dimmer`]).
    pub file_lights: Vec<FileLight>,
    /// Diagonal of the bounds (1 for an empty scene), cached: the hit code uses it per ray.
    pub(super) extent: f64,
    /// Per-triangle data the hit code needs on every hit, computed once at load (same indexing
    /// as `triangles`); it holds each triangle's unit geometric normal ([`Scene::tri_normal`]).
    pub(super) tri_hit: Vec<TriHit>,
    /// The shading normals of each triangle's three vertices (same indexing as `triangles`), so
    /// that a hit reads one record instead of the index and three normal entries; empty when the
    /// scene has no shading normals.
    pub(super) tri_shading: Vec<[Vec3; 3]>,
    /// Texture coordinates (v up), [`TexCoords::None`] when no material has a texture: then hits
    /// never look.
    pub(super) uvs: TexCoords,
    /// Per material: its triangles are cut-outs (it has alpha and does not emit).
    pub(super) cut_materials: Vec<bool>,
    /// The decoded textures that materials refer to ([`Material::maps`]).
    pub textures: TextureSet,
    /// The slice plane of a flatland run with its light cross-sections and 2D materials, set by
    /// [`Scene::prepare_flatland`]; `None` for 3D runs.
    pub flat: Option<FlatScene>,
    /// The prototypes and instances of instanced geometry (empty without).
    pub(super) instancing: Instancing,
    pub(super) accel: Accel,
}

/// What [`Scene::hit_from_raw`] reads of a triangle on every hit, packed into one 64-byte cache
/// line: on scenes of millions of triangles each hit is a cache and TLB miss, so one line, on huge
/// pages, stands for the index, position, normal and material arrays. The vertices are the scene's
/// own f32 values (exact), the normal the f64 one of `tri_normals`; what the hit code derives from
/// them (magnitude, edge lengths) is recomputed per hit with the same expressions, so hits are
/// bit-identical to reading it precomputed.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(super) struct TriHit {
    /// Unit geometric normal (as `tri_normals`).
    pub(super) ng: DVec3,
    /// Vertices.
    pub(super) p: [Vec3; 3],
    /// Material index (as `tri_material`).
    pub(super) material: u32,
}

const _: () = assert!(std::mem::size_of::<TriHit>() == 64);

impl Scene {
    /// Unit geometric normal of triangle `i`, (v1 - v0) × (v2 - v0) normalised (front side).
    #[inline]
    pub fn tri_normal(&self, i: usize) -> DVec3 {
        self.tri_hit[i].ng
    }

    /// The unit geometric normals of all triangles, in order (see [`Scene::tri_normal`]).
    pub fn tri_normals(&self) -> impl ExactSizeIterator<Item = DVec3> + '_ {
        self.tri_hit.iter().map(|t| t.ng)
    }

    /// The interpolated texture coordinate (v up) at barycentric `bary` of triangle `prim`.
    #[inline]
    pub fn hit_uv(&self, prim: u32, bary: [f32; 2]) -> [f64; 2] {
        interpolate_uv(self.corner_uvs(prim), bary)
    }

    /// The texture coordinates (v up) of triangle `prim`'s three corners: (0, 0) for a corner
    /// the file gave none (an OBJ face without `vt`) and in a scene without texture coordinates.
    #[inline]
    pub fn corner_uvs(&self, prim: u32) -> [Vec2; 3] {
        let i = prim as usize;
        match &self.uvs {
            TexCoords::PerVertex(uv) => self.triangles[i].map(|v| uv[v as usize]),
            TexCoords::PerCorner { table, corners } => {
                corners[i].map(|k| table.get(k as usize).copied().unwrap_or(Vec2::ZERO))
            }
            TexCoords::None => [Vec2::ZERO; 3],
        }
    }

    /// The texture coordinates the scene keeps (see [`TexCoords`]).
    pub fn texcoords(&self) -> &TexCoords {
        &self.uvs
    }

    /// True when hits interpolate shading normals (the file gave normals).
    pub fn has_shading_normals(&self) -> bool {
        !self.tri_shading.is_empty()
    }

    /// The flatland preparation; flatland kernels run only on prepared scenes.
    #[inline]
    pub fn flat(&self) -> &FlatScene {
        self.flat
            .as_ref()
            .expect("a flatland kernel needs a scene prepared with Scene::prepare_flatland")
    }

    /// Diagonal of the bounds (1 for an empty scene, so that defaults stay meaningful).
    #[inline]
    pub fn extent(&self) -> f64 {
        self.extent
    }

    /// The Embree scene, for benchmarks that trace raw rays.
    pub fn accel(&self) -> &Accel {
        &self.accel
    }
}
