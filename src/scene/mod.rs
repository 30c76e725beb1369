//! The scene: triangles (f32, as Embree sees them), per-triangle geometric normals and materials,
//! optional per-vertex shading normals, lights, bounds and the feature set. Built by a loader
//! ([`obj`], [`gltf`]), then immutable.

pub mod env;
pub mod features;
pub mod flat;
pub mod gltf;
pub mod light;
pub mod load;
pub mod material;
pub mod mirror;
pub mod mtl_maps;
pub mod obj;
pub mod obj_parse;
pub mod sidecar;
pub mod texture;

use crate::accel::{Accel, RawHit, SharedArray};
use crate::math::Rgb;
use crate::scene::flat::{FlatScene, Flatland};
use crate::scene::material::{Bsdf, TextureRef};
use glam::{DVec3, Vec2, Vec3};
use std::path::{Path, PathBuf};

pub use features::Features;
pub use light::{Light, LightSet};

/// The sun's angular diameter when a scene or flag does not give one, degrees (as seen from the
/// Earth).
pub const DEFAULT_SUN_DIAMETER_DEG: f64 = 0.53;
pub use material::Material;

/// Axis-aligned bounding box in scene units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: DVec3,
    pub max: DVec3,
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb {
        min: DVec3::splat(f64::INFINITY),
        max: DVec3::splat(f64::NEG_INFINITY),
    };

    pub fn grow(&mut self, p: DVec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }
    pub fn is_empty(&self) -> bool {
        !(self.min.x <= self.max.x && self.min.y <= self.max.y && self.min.z <= self.max.z)
    }
    /// Distance from `p` to the box (0 inside; 0 for an empty box).
    pub fn distance(&self, p: DVec3) -> f64 {
        if self.is_empty() {
            return 0.0;
        }
        (self.min - p).max(p - self.max).max(DVec3::ZERO).length()
    }
    pub fn diagonal(&self) -> f64 {
        if self.is_empty() {
            0.0
        } else {
            (self.max - self.min).length()
        }
    }
    /// The eight corners.
    pub fn corners(&self) -> [DVec3; 8] {
        std::array::from_fn(|k| {
            DVec3::new(
                if k & 1 == 0 { self.min.x } else { self.max.x },
                if k & 2 == 0 { self.min.y } else { self.max.y },
                if k & 4 == 0 { self.min.z } else { self.max.z },
            )
        })
    }
}

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
    pub mirrors: crate::scene::mirror::Mirrors,
    pub bounds: Aabb,
    pub features: Features,
    pub report: LoadReport,
    /// Cameras the scene file defines, in file order.
    pub cameras: Vec<Camera>,
    /// Named slice planes from a sidecar file: (name, plane such as `z=0`).
    pub named_slices: Vec<(String, String)>,
    /// Diagonal of the bounds (1 for an empty scene), cached: the hit code uses it per ray.
    extent: f64,
    /// Per-triangle data the hit code needs on every hit, computed once at load (same indexing
    /// as `triangles`); it holds each triangle's unit geometric normal ([`Scene::tri_normal`]).
    tri_hit: Vec<TriHit>,
    /// The shading normals of each triangle's three vertices (same indexing as `triangles`), so
    /// that a hit reads one record instead of the index and three normal entries; empty when the
    /// scene has no shading normals.
    tri_shading: Vec<[Vec3; 3]>,
    /// Texture coordinates (v up), [`TexCoords::None`] when no material has a texture: then hits
    /// never look.
    uvs: TexCoords,
    /// Per material: its triangles are cut-outs (it has alpha and does not emit).
    cut_materials: Vec<bool>,
    /// The decoded textures that materials refer to ([`Material::maps`]).
    pub textures: crate::scene::texture::TextureSet,
    /// The slice plane of a flatland run with its light cross-sections and 2D materials, set by
    /// [`Scene::prepare_flatland`]; `None` for 3D runs.
    pub flat: Option<FlatScene>,
    accel: Accel,
}

/// What [`Scene::hit_from_raw`] reads of a triangle on every hit, packed into one 64-byte cache
/// line: on scenes of millions of triangles each hit is a cache and TLB miss (most of the kernel's
/// own time per ray there), so one line, on huge pages, replaces the index, position, normal and
/// material arrays and the wider precomputed record this used to be. The vertices are the scene's own
/// f32 values (exact), the normal the f64 one of `tri_normals`; what the hit code derives from them
/// (magnitude, edge lengths) is recomputed per hit with the same expressions, so hits are
/// bit-identical to reading it precomputed.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct TriHit {
    /// Unit geometric normal (as `tri_normals`).
    ng: DVec3,
    /// Vertices.
    p: [Vec3; 3],
    /// Material index (as `tri_material`).
    material: u32,
}

const _: () = assert!(std::mem::size_of::<TriHit>() == 64);

/// Everything the transport code needs about a ray-surface hit, in f64.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    pub t: f64,
    pub p: DVec3,
    pub prim: u32,
    /// Unit geometric normal (front side from the winding).
    pub ng: DVec3,
    /// Unit shading normal on the same side as `ng`.
    pub ns: DVec3,
    pub material: u32,
    /// Half-width of the region around `p` that may hold the true surface (float error bound).
    pub eps: f64,
    /// `p` lies within twice the error bound of an edge of its triangle, where other surfaces may
    /// meet it (see [`Scene::spawn_origin_from`]).
    pub near_edge: bool,
    /// Embree's barycentric coordinates of the hit (weights of the triangle's second and third
    /// vertex), for texture coordinates.
    pub bary: [f32; 2],
}

impl Hit {
    /// Origin for a new ray leaving the surface in direction `dir`: `p` pushed off the surface along
    /// the geometric normal, to the side `dir` goes, by the hit's error bound (pbrt's approach, with a
    /// bound that scales with the coordinates' magnitude instead of a fixed epsilon).
    #[inline]
    pub fn spawn_origin(&self, dir: DVec3) -> DVec3 {
        let side = if dir.dot(self.ng) >= 0.0 { 1.0 } else { -1.0 };
        self.p + self.ng * (side * self.eps)
    }
}

/// Relative error bound of f32 geometry: a few ulps of the largest coordinate, covering the f32
/// rounding of ray origins, Embree's intersection error and our barycentric reconstruction. Rays
/// leaving random points of random triangles (tests/geometry.rs) never re-hit them with as little
/// as 2 ulps, at 1 and at 10⁴ from the origin; 16 keeps a margin. The bound is also how far rays
/// start off surfaces, which shortcuts geometry: with 64 ulps (7.6 cm at 10⁴) σ of the Cornell box
/// translated by 10⁴ came out 4 standard errors above the original's.
const F32_ERROR_ULPS: f64 = 16.0 * f32::EPSILON as f64;

impl Scene {
    /// Assembles a scene and builds its Embree acceleration structure, from per-vertex shading
    /// normals (empty or of another length than `positions`: none). See [`Scene::from_parts`].
    pub fn build(
        source: &Path,
        positions: Vec<Vec3>,
        normals: Vec<Vec3>,
        triangles: Vec<[u32; 3]>,
        tri_material: Vec<u32>,
        materials: Vec<Material>,
        report: LoadReport,
    ) -> anyhow::Result<Scene> {
        let shading = if normals.len() == positions.len() && !normals.is_empty() {
            Shading::PerVertex(normals)
        } else {
            Shading::None
        };
        Scene::from_parts(
            source,
            positions,
            triangles,
            tri_material,
            shading,
            TexCoords::None,
            materials,
            report,
        )
    }

    /// Assembles a scene and builds its Embree acceleration structure. Degenerate triangles (zero
    /// area, non-finite coordinates, out-of-range indices) are dropped and counted in the report.
    ///
    /// Texture coordinates are kept only when some material has a texture
    /// ([`Material::maps`]); hits read them once the textures are attached
    /// ([`Scene::attach_textures`]). Per-vertex ones of another length than `positions` are
    /// dropped.
    ///
    /// Memory: the triangle arrays are compacted in place, and the per-triangle records are made
    /// before the BVH build, so that no loader buffer is alive while Embree builds; Embree reads
    /// the vertex and index arrays in place ([`SharedArray`]). What stays per triangle is its
    /// indices (12 bytes), material (4), the 64-byte hit record and, with shading normals, their
    /// 36 bytes, with per-corner texture coordinates their 12 bytes of indices.
    #[allow(clippy::too_many_arguments)]
    pub fn from_parts(
        source: &Path,
        positions: Vec<Vec3>,
        mut triangles: Vec<[u32; 3]>,
        mut tri_material: Vec<u32>,
        shading: Shading,
        texcoords: TexCoords,
        materials: Vec<Material>,
        mut report: LoadReport,
    ) -> anyhow::Result<Scene> {
        assert_eq!(triangles.len(), tri_material.len());
        let n = triangles.len();
        report.triangles_read += n;
        let textured = materials.iter().any(|m| m.maps.reads_textures());
        let mut texcoords = match texcoords {
            TexCoords::PerVertex(v) if textured && v.len() == positions.len() => {
                TexCoords::PerVertex(v)
            }
            TexCoords::PerCorner { table, corners } if textured => {
                assert_eq!(corners.len(), n);
                TexCoords::PerCorner { table, corners }
            }
            _ => TexCoords::None,
        };
        let (normals, mut corners) = match shading {
            Shading::None => (Vec::new(), None),
            Shading::PerVertex(v) if v.len() == positions.len() => (v, None),
            Shading::PerVertex(_) => (Vec::new(), None),
            Shading::PerCorner(c) => {
                assert_eq!(c.len(), n);
                (Vec::new(), Some(c))
            }
        };
        let max_material = materials.len().saturating_sub(1) as u32;
        // The hit records, in parallel; a degenerate triangle's gets a NaN normal and is dropped
        // below (all arrays compacted in place, in order).
        use rayon::prelude::*;
        let mut tri_hit: Vec<TriHit> = crate::accel::vec_with_huge_pages(n);
        {
            tri_hit.par_extend(triangles.par_iter().zip(&tri_material).map(|(tri, &m)| {
                let ng = triangle_normal(&positions, tri).unwrap_or(DVec3::NAN);
                let m = m.min(max_material);
                TriHit {
                    ng,
                    p: if ng.x.is_nan() {
                        [Vec3::ZERO; 3]
                    } else {
                        tri.map(|v| positions[v as usize])
                    },
                    material: m,
                }
            }));
        }
        let dropped = tri_hit.par_iter().filter(|h| h.ng.x.is_nan()).count();
        report.degenerate_dropped += dropped;
        let mut kept = n;
        if dropped > 0 {
            kept = 0;
            for k in 0..n {
                if tri_hit[k].ng.x.is_nan() {
                    continue;
                }
                triangles[kept] = triangles[k];
                tri_hit[kept] = tri_hit[k];
                if let Some(c) = corners.as_mut() {
                    c[kept] = c[k];
                }
                if let TexCoords::PerCorner { corners, .. } = &mut texcoords {
                    corners[kept] = corners[k];
                }
                kept += 1;
            }
            if let TexCoords::PerCorner { corners, .. } = &mut texcoords {
                corners.truncate(kept);
                corners.shrink_to_fit();
            }
            tri_hit.truncate(kept);
            triangles.truncate(kept);
            triangles.shrink_to_fit();
        }
        tri_material.clear();
        tri_material.par_extend(tri_hit.par_iter().map(|h| h.material));
        tri_material.shrink_to_fit();
        // Bounds of the kept triangles' vertices, in their order (as a sequential loader would:
        // min and max of a signed zero depend on the order).
        let mut bounds = Aabb::EMPTY;
        for h in &tri_hit {
            for p in h.p {
                bounds.grow(p.as_dvec3());
            }
        }
        let tri_shading = match corners {
            Some(mut c) => {
                c.truncate(kept);
                c
            }
            None if !normals.is_empty() => {
                let mut s = crate::accel::vec_with_huge_pages(kept);
                s.extend(triangles.iter().map(|t| t.map(|v| normals[v as usize])));
                s
            }
            None => Vec::new(),
        };
        let extent = {
            let d = bounds.diagonal();
            if d > 0.0 && d.is_finite() { d } else { 1.0 }
        };
        // The bounding ball that distant lights fill (about the origin for an empty scene).
        let center = if bounds.min.x <= bounds.max.x {
            (bounds.min + bounds.max) * 0.5
        } else {
            DVec3::ZERO
        };
        let lights = LightSet::from_emitters(
            &positions,
            &triangles,
            |i| tri_hit[i].ng,
            &tri_material,
            &materials,
            center,
            0.5 * extent,
        );
        let mut features = Features::of(&materials, &tri_material, &lights);
        let mirrors = crate::scene::mirror::Mirrors::detect(
            tri_hit.len(),
            &materials,
            &tri_material,
            |i| tri_hit[i].ng,
            |i| tri_hit[i].p.map(|v| v.as_dvec3()),
            |i| {
                let [a, b, c] = tri_hit[i].p.map(|v| v.as_dvec3());
                0.5 * (b - a).cross(c - a).length()
            },
            |i| {
                tri_shading.get(i).is_none_or(|ns| {
                    ns.iter()
                        .all(|n| n.as_dvec3().normalize_or_zero().dot(tri_hit[i].ng) > 1.0 - 1e-9)
                })
            },
            extent,
        );
        features.planar_mirrors = !mirrors.is_empty();
        // Cut-outs: the triangles of materials with alpha, in a geometry of their own. An emitter
        // stays opaque (its light samples would otherwise land on cut-out texels).
        let mut cut_materials = vec![false; materials.len()];
        for (k, m) in materials.iter().enumerate() {
            if m.maps.alpha.as_ref().is_some_and(|a| !a.is_opaque()) {
                if m.emission == Rgb::ZERO {
                    cut_materials[k] = true;
                } else {
                    report.warnings.push(format!(
                        "material '{}' emits light: its alpha is ignored (emitters are opaque)",
                        m.name
                    ));
                }
            }
        }
        let cutout: Vec<u32> = if cut_materials.contains(&true) {
            (0..triangles.len() as u32)
                .filter(|&i| cut_materials[tri_material[i as usize] as usize])
                .collect()
        } else {
            Vec::new()
        };
        features.cutouts = !cutout.is_empty();
        // Embree reads these two in place: from here on they are immutable.
        let (positions, triangles) = (SharedArray::new(positions), SharedArray::new(triangles));
        let t_bvh = std::time::Instant::now();
        let accel = Accel::with_cutouts(&positions, &triangles, &cutout)?;
        report.bvh_seconds = t_bvh.elapsed().as_secs_f64();
        let mut scene = Scene {
            source: source.to_path_buf(),
            positions,
            normals,
            triangles,
            tri_material,
            materials,
            lights,
            mirrors,
            bounds,
            features,
            report,
            cameras: Vec::new(),
            named_slices: Vec::new(),
            extent,
            tri_hit,
            tri_shading,
            uvs: texcoords,
            textures: Default::default(),
            flat: None,
            cut_materials,
            accel,
        };
        // Installed once: here when the coverage reads no texture, else when the textures (and
        // for glTF the texture coordinates) arrive (`attach_textures`, `set_textures`).
        if !scene.cut_reads_textures() {
            scene.install_cut_test(&cutout);
        }
        Ok(scene)
    }

    /// True when some cut-out material's coverage reads a texture, so its cut-out test waits for
    /// the textures ([`Scene::attach_textures`]).
    fn cut_reads_textures(&self) -> bool {
        self.materials
            .iter()
            .zip(&self.cut_materials)
            .any(|(m, &cut)| cut && m.maps.alpha.as_ref().is_some_and(|a| a.map.is_some()))
    }

    /// The cut-out test of a scene whose coverage reads textures, once they are attached (or
    /// known to be ignored): [`Scene::build`] left it out.
    fn install_textured_cut_test(&mut self) {
        if self.accel.has_cutouts() && self.cut_reads_textures() {
            let cutout: Vec<u32> = (0..self.triangles.len() as u32)
                .filter(|&t| self.cut_materials[self.tri_material[t as usize] as usize])
                .collect();
            self.install_cut_test(&cutout);
        }
    }

    /// Gives the acceleration structure the cut-out test of triangles `cutout` (their materials'
    /// [`Alpha`](crate::scene::material::Alpha) at the hit's texture coordinate), holding what it
    /// reads (coverage, corner coordinates, textures) in its own compact table, one entry per
    /// cut-out triangle.
    fn install_cut_test(&mut self, cutout: &[u32]) {
        if cutout.is_empty() {
            return;
        }
        let alphas: Vec<crate::scene::material::Alpha> = self
            .materials
            .iter()
            .map(|m| {
                m.maps
                    .alpha
                    .clone()
                    .unwrap_or(crate::scene::material::Alpha {
                        factor: 1.0,
                        map: None,
                        channel: 3,
                        mode: crate::scene::material::AlphaMode::Stochastic,
                    })
            })
            .collect();
        let table: Vec<(u32, [glam::Vec2; 3])> = cutout
            .iter()
            .map(|&t| {
                let uv = self.corner_uvs(t);
                (self.tri_material[t as usize], uv)
            })
            .collect();
        let textures = self.textures.textures.clone();
        self.accel.set_cut_test(Box::new(move |k, bary, ray| {
            table.get(k as usize).is_some_and(|&(m, uv)| {
                alphas[m as usize].cut(&textures, interpolate_uv(uv, bary), || ray.xi())
            })
        }));
    }

    /// True when triangle `prim` is cut out at `p` (a point on or near it: its closest point is
    /// tested), for the point query; the coverage hash is keyed by the point and the triangle.
    fn cut_at(&self, prim: u32, p: DVec3) -> bool {
        let m = self.tri_material[prim as usize];
        if !self.cut_materials[m as usize] {
            return false;
        }
        let Some(alpha) = &self.materials[m as usize].maps.alpha else {
            return false;
        };
        let [a, b, c] =
            self.triangles[prim as usize].map(|v| self.positions[v as usize].as_dvec3());
        let q = closest_point_on_triangle(p, a, b, c);
        let bary = barycentric(q, a, b, c).map(|x| x as f32);
        let uv = self.hit_uv(prim, bary);
        let xi = || {
            crate::rng::hash_unit(&[
                (p.x as f32).to_bits(),
                (p.y as f32).to_bits(),
                (p.z as f32).to_bits(),
                prim,
            ])
        };
        alpha.cut(&self.textures.textures, uv, xi)
    }

    /// Unit geometric normal of triangle `i`, (v1 - v0) × (v2 - v0) normalised (front side).
    #[inline]
    pub fn tri_normal(&self, i: usize) -> DVec3 {
        self.tri_hit[i].ng
    }

    /// The unit geometric normals of all triangles, in order (see [`Scene::tri_normal`]).
    pub fn tri_normals(&self) -> impl ExactSizeIterator<Item = DVec3> + '_ {
        self.tri_hit.iter().map(|t| t.ng)
    }

    /// Sets per-vertex texture coordinates (v up) and the textures materials refer to (glTF).
    /// Ignored (left without) when `uvs` does not have one entry per vertex or no material has a
    /// texture.
    pub fn set_textures(&mut self, uvs: Vec<Vec2>, textures: crate::scene::texture::TextureSet) {
        let used = self.materials.iter().any(|m| m.maps.reads_textures());
        if used && uvs.len() == self.positions.len() {
            self.uvs = TexCoords::PerVertex(uvs);
            self.attach_textures(textures);
        } else {
            // Without textures the coverage is its factor alone.
            self.install_textured_cut_test();
        }
    }

    /// Sets the textures materials refer to, in a scene whose texture coordinates came with its
    /// parts ([`Scene::from_parts`], e.g. OBJ's `vt`); from then on hits read them. Ignored when
    /// the scene kept no texture coordinates (no material has a texture).
    pub fn attach_textures(&mut self, textures: crate::scene::texture::TextureSet) {
        if !self.uvs.is_none() {
            self.textures = textures;
            self.features.textures = true;
            self.features.emission_textures = self
                .materials
                .iter()
                .any(|m| m.maps.emission.is_some() && m.emission != Rgb::ZERO);
        }
        self.install_textured_cut_test();
    }

    /// The scattering model at a hit of a material with textures: its albedos replaced by the
    /// texels (base colour × its factor for `kd`, specular × its factor for `ks`, bilinear at the
    /// interpolated texture coordinate), or with a metallic-roughness map the whole glossy model
    /// rebuilt from the texels ([`MetallicRoughness::bsdf`]); `None` for materials without,
    /// which keep their own. Scenes without textures return at the first test.
    ///
    /// The model returned is of the material's own kind, so the kernel's choice of effects holds
    /// for it; its Phong exponent may differ from the material's (flatland then computes the
    /// lobe's normalisation for it: `Space::textured_lobe`).
    ///
    /// [`MetallicRoughness::bsdf`]: crate::scene::material::MetallicRoughness::bsdf
    #[inline(always)]
    pub fn textured_bsdf(&self, hit: &Hit) -> Option<Bsdf> {
        if !self.features.textures {
            return None;
        }
        self.texel_bsdf(hit)
    }

    /// The BSDF at `hit`: the one its texels give ([`textured_bsdf`](Self::textured_bsdf)) where
    /// they change it, else `own` (the material's model, or the flatland one made of it).
    #[inline(always)]
    pub fn bsdf_at<'a>(&self, hit: &Hit, own: &'a Bsdf) -> std::borrow::Cow<'a, Bsdf> {
        match self.textured_bsdf(hit) {
            Some(b) => std::borrow::Cow::Owned(b),
            None => std::borrow::Cow::Borrowed(own),
        }
    }

    /// [`textured_bsdf`](Self::textured_bsdf) in a scene with textures: kept out of line, so
    /// that the hit code of scenes without stays as small as it was.
    #[inline(never)]
    fn texel_bsdf(&self, hit: &Hit) -> Option<Bsdf> {
        let m = &self.materials[hit.material as usize];
        let (base, spec) = (m.maps.base_color.as_ref(), m.maps.specular.as_ref());
        let mr = m.maps.metallic_roughness.as_ref();
        if base.is_none() && spec.is_none() && mr.is_none() {
            return None;
        }
        let uv = self.hit_uv(hit.prim, hit.bary);
        let colour = |t: &TextureRef| {
            let [r, g, b, _] = t.texel(&self.textures.textures[t.texture as usize], uv);
            t.factor * Rgb::new(r, g, b)
        };
        if let Some(mr) = mr {
            let texel = mr
                .map
                .texel(&self.textures.textures[mr.map.texture as usize], uv);
            return Some(mr.bsdf(base.map_or(mr.base, colour), texel));
        }
        Some(m.bsdf.with_albedos(base.map(colour), spec.map(colour)))
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

    /// Adds an isotropic point light of radiant intensity `intensity` (per steradian) at
    /// `position`, and says so in the feature set.
    pub fn add_point_light(&mut self, position: DVec3, intensity: Rgb) {
        self.lights.add_point(position, intensity);
        self.features.point_lights = true;
    }

    /// Adds a light that is not a triangle (spot, sun, sky), and says so in the feature set.
    pub fn add_light(&mut self, light: Light) {
        match &light {
            Light::Point { .. } => self.features.point_lights = true,
            Light::Spot { .. } => self.features.spot_lights = true,
            Light::Distant { .. } => self.features.sun = true,
            Light::Sky { .. } | Light::Env(_) => self.features.sky = true,
            Light::Area { .. } => self.features.area_lights = true,
        }
        self.lights.push(light);
    }

    /// Prepares a flatland run on `plane` (named `label`, e.g. `z=0`, in messages): checks that the
    /// geometry is extruded along the plane normal and point lights lie in the plane, and computes
    /// the emitters' cross-sections. Call after every light has been added.
    pub fn prepare_flatland(&mut self, plane: Flatland, label: &str) -> anyhow::Result<()> {
        self.flat = Some(FlatScene::new(self, plane, label)?);
        Ok(())
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

    /// Closest hit along the ray `o + t d` (d unit) for t in (0, tmax).
    #[inline]
    pub fn intersect(&self, o: DVec3, d: DVec3, tmax: f64) -> Option<Hit> {
        self.intersect_with::<false>(o, d, tmax)
    }

    /// [`intersect`](Self::intersect) for flatland: the hit's normals are projected into the plane
    /// the scene was prepared for ([`prepare_flatland`](Self::prepare_flatland)), so scattered
    /// directions stay in it.
    #[inline]
    pub fn intersect_in_plane(&self, o: DVec3, d: DVec3, tmax: f64) -> Option<Hit> {
        self.intersect_with::<true>(o, d, tmax)
    }

    #[inline]
    fn intersect_with<const FLAT: bool>(&self, o: DVec3, d: DVec3, tmax: f64) -> Option<Hit> {
        let raw = self.accel.intersect(
            o.as_vec3(),
            d.as_vec3(),
            0.0,
            tmax.min(f32::MAX as f64) as f32,
        )?;
        Some(self.hit_from_raw::<FLAT>(o, d, raw))
    }

    /// The shadow ray from `o` (a point off any surface, e.g. from [`Hit::spawn_origin`]) to the
    /// point `target` (e.g. a sampled light point), which may lie on a surface: the ray is aimed at
    /// `target` itself and stops short of it by its error bound. (Keeping a direction measured from
    /// an un-offset point would make oblique lights occlude themselves.) `None` when `o` and
    /// `target` coincide or are not finite: nothing is visible then.
    #[inline]
    pub fn shadow_ray(&self, o: DVec3, target: DVec3) -> Option<(DVec3, f64)> {
        let to = target - o;
        let len = to.length();
        if !(len > 0.0) || !len.is_finite() {
            return None;
        }
        Some((to / len, len - self.eps_at(target)))
    }

    /// True when nothing blocks the segment from `o` to `target` (see [`shadow_ray`](Self::shadow_ray)).
    #[inline]
    pub fn visible(&self, o: DVec3, target: DVec3) -> bool {
        self.shadow_ray(o, target)
            .is_some_and(|(d, tmax)| !self.occluded(o, d, tmax))
    }

    /// True when something blocks the segment from `o` along unit `d` before `tmax`.
    #[inline]
    pub fn occluded(&self, o: DVec3, d: DVec3, tmax: f64) -> bool {
        tmax > 0.0
            && self.accel.occluded(
                o.as_vec3(),
                d.as_vec3(),
                0.0,
                tmax.min(f32::MAX as f64) as f32,
            )
    }

    #[inline]
    fn hit_from_raw<const FLAT: bool>(&self, o: DVec3, d: DVec3, raw: RawHit) -> Hit {
        let i = raw.prim as usize;
        let th = &self.tri_hit[i];
        let [pa, pb, pc] = th.p.map(|q| q.as_dvec3());
        let (u, v) = (raw.u as f64, raw.v as f64);
        let ng = th.ng;
        let mag = pa
            .abs()
            .max(pb.abs())
            .max(pc.abs())
            .max_element()
            .max(o.abs().max_element());
        let eps = F32_ERROR_ULPS * mag + 1e-9 * self.extent();
        // The hit point: the f64 intersection of the ray with the triangle's plane, which is exact to
        // f64 rounding. For grazing rays (|d·n| ≤ 1e-4) that point may lie far along the ray from
        // Embree's (which traced the f32-rounded ray), so it is taken only when it lies on the
        // triangle (within the error bound); else Embree's f32 barycentrics, which keep the point on
        // the triangle but are off sideways by the f32 rounding of the ray's origin (enough to break
        // the mirror isometry of pairs 10⁻⁶ rad apart).
        let dn = d.dot(ng);
        let t_plane = (pa - o).dot(ng) / dn;
        let t_raw = raw.t as f64;
        let consistent =
            t_plane.is_finite() && (t_plane - t_raw).abs() <= 1e-3 * (t_raw + self.extent());
        let p = if dn.abs() > 1e-4 && consistent {
            o + d * t_plane
        } else {
            let q = o + d * t_plane;
            if t_plane.is_finite()
                && t_plane > 0.0
                && (t_plane - t_raw).abs() <= 1e-3 * (t_raw + self.extent()) + eps / dn.abs()
                && (closest_point_on_triangle(q, pa, pb, pc) - q).length_squared() <= eps * eps
            {
                q
            } else {
                (1.0 - u - v) * pa + u * pb + v * pc
            }
        };
        let ns = if self.tri_shading.is_empty() {
            ng
        } else {
            let [na, nb, nc] = self.tri_shading[i];
            let n = (1.0 - u - v) * na.as_dvec3() + u * nb.as_dvec3() + v * nc.as_dvec3();
            let len = n.length();
            if len > 1e-12 && len.is_finite() {
                let n = n / len;
                if n.dot(ng) < 0.0 { -n } else { n }
            } else {
                ng
            }
        };
        // Flatland: normals projected into the plane (the geometric one is in it up to the
        // validated 1e-4; shading normals may point anywhere), so scattered directions stay in it.
        let (ng, ns) = if FLAT {
            let pl = &self.flat().plane;
            let ngp = pl.in_plane(ng).unwrap_or(ng);
            // Without shading normals ns = ng, whose projection is ngp (the same bits).
            let nsp = if self.tri_shading.is_empty() {
                ngp
            } else {
                pl.in_plane(ns)
                    .map_or(ngp, |n| if n.dot(ngp) < 0.0 { -n } else { n })
            };
            (ngp, nsp)
        } else {
            (ng, ns)
        };
        // Distance from p to each edge (barycentric × the opposite altitude), squared, against
        // (2 eps)², without square roots: with e0 = p1 − p0, e1 = p2 − p0, e2 = p2 − p1, the
        // altitude onto edge k is |e0 × e1| / |e_k|.
        let (e0, e1, e2) = (pb - pa, pc - pa, pc - pb);
        let (c2, lim) = (e0.cross(e1).length_squared(), 4.0 * eps * eps);
        let w = 1.0 - u - v;
        let near_edge = w * w * c2 <= lim * e2.length_squared()
            || u * u * c2 <= lim * e1.length_squared()
            || v * v * c2 <= lim * e0.length_squared();
        Hit {
            t: raw.t as f64,
            p,
            prim: raw.prim,
            ng,
            ns,
            material: th.material,
            eps: eps.max(1e-12),
            near_edge,
            bary: [raw.u, raw.v],
        }
        .with_t_from(o, d)
    }

    /// Origin for a ray leaving `hit` along `dir` on a path that arrived from `from` (the origin of
    /// the ray that hit, off every surface): [`Hit::spawn_origin`], and where the hit lies at an edge of its triangle, also off
    /// the other surfaces that meet there (a room's corner, a box's edge), on the side where the
    /// path is: the side it came from, or the other one for a path that went through the hit
    /// surface. A path hitting the edge between two walls of a closed room otherwise started its
    /// next ray within rounding of the other wall's plane, and could pass through it and leave the
    /// room. Parallel surfaces (the hit surface's own neighbours) are left alone.
    #[inline]
    pub fn spawn_origin_from(&self, hit: &Hit, dir: DVec3, from: DVec3) -> DVec3 {
        let o = hit.spawn_origin(dir);
        if hit.near_edge {
            self.spawn_near_edge(hit, dir, from, o)
        } else {
            o
        }
    }

    #[cold]
    fn spawn_near_edge(&self, hit: &Hit, dir: DVec3, from: DVec3, o: DVec3) -> DVec3 {
        let eps = hit.eps;
        let (prims, len) = self.triangles_near_sorted(hit.p, 3.0 * eps);
        let through = (dir.dot(hit.ng) >= 0.0) != ((from - hit.p).dot(hit.ng) >= 0.0);
        self.move_off(
            o,
            hit.p,
            eps,
            &prims[..len],
            // `o` is off the hit surface on `dir`'s side: it stays there.
            Some((hit.p, hit.ng)),
            // The hit triangle and those parallel to it (its own neighbours).
            |i, n| i == hit.prim || n.dot(hit.ng).abs() > 1.0 - 1e-9,
            // The side the path is on: where it came from, or the other for a path that went
            // through the hit surface.
            |a, n| {
                let from_side = if (from - a).dot(n) >= 0.0 { 1.0 } else { -1.0 };
                if through { -from_side } else { from_side }
            },
        )
    }

    /// Moves `start` off the triangles among `prims` that lie within `eps` of `at`, each to twice
    /// `eps` on the side `side(a, n)` (±1 times the normal `n`; `a` a vertex) of it, without
    /// crossing `keep` (a plane: point and normal) or the other triangles within 3 `eps` of `at`
    /// (except those in the plane of a triangle it is moved off: a flat surface's other
    /// triangles). Triangles for which `skip(index, normal)` holds are ignored.
    #[allow(clippy::too_many_arguments)]
    fn move_off(
        &self,
        start: DVec3,
        at: DVec3,
        eps: f64,
        prims: &[u32],
        keep: Option<(DVec3, DVec3)>,
        skip: impl Fn(u32, DVec3) -> bool,
        side: impl Fn(DVec3, DVec3) -> f64,
    ) -> DVec3 {
        const N: usize = crate::accel::MAX_NEAR;
        let mut moves = OffSurfaces::new(start, eps);
        if let Some((a, n)) = keep {
            moves.keep_side(a, n);
        }
        let (mut on, mut near) = (
            [(DVec3::ZERO, DVec3::ZERO); N],
            [(DVec3::ZERO, DVec3::ZERO); N],
        );
        let (mut n_on, mut n_near) = (0, 0);
        for &i in prims {
            let n = self.tri_normal(i as usize);
            if skip(i, n) {
                continue;
            }
            let [a, b, c] =
                self.triangles[i as usize].map(|v| self.positions[v as usize].as_dvec3());
            let dist = (closest_point_on_triangle(at, a, b, c) - at).length();
            if dist <= eps {
                on[n_on] = (a, n);
                n_on += 1;
            } else if dist <= 3.0 * eps {
                near[n_near] = (a, n);
                n_near += 1;
            }
        }
        let (on, near) = (&on[..n_on], &near[..n_near]);
        for &(a, n) in near {
            let coplanar = on
                .iter()
                .any(|(b, m)| n.dot(*m).abs() > 1.0 - 1e-9 && (a - *b).dot(*m).abs() <= eps);
            if !coplanar {
                moves.keep_side(a, n);
            }
        }
        for &(a, n) in on {
            moves.move_in_front_of(a, n * side(a, n));
        }
        moves.p
    }

    pub fn material(&self, hit: &Hit) -> &Material {
        &self.materials[hit.material as usize]
    }

    /// Emitted radiance leaving a hit towards `wo` (front side only): the material's emission, or
    /// its emission texture's texel times it.
    #[inline]
    pub fn emitted(&self, hit: &Hit, wo: DVec3) -> Rgb {
        let m = self.material(hit);
        if m.emission != Rgb::ZERO && wo.dot(hit.ng) > 0.0 {
            if self.features.emission_textures {
                return self
                    .emission_texel(hit.prim, hit.bary)
                    .unwrap_or(m.emission);
            }
            m.emission
        } else {
            Rgb::ZERO
        }
    }

    /// The emission texture's radiance at point `y` of triangle `prim` (the texel at its
    /// barycentric coordinates, times the material's emission); `None` when the scene has no
    /// emission textures or the material none. For light samples, which know a point, not a hit.
    #[inline(always)]
    pub fn emission_at(&self, prim: u32, y: DVec3) -> Option<Rgb> {
        if !self.features.emission_textures {
            return None;
        }
        let [a, b, c] =
            self.triangles[prim as usize].map(|v| self.positions[v as usize].as_dvec3());
        self.emission_texel(prim, barycentric(y, a, b, c).map(|u| u as f32))
    }

    /// The emission texture's radiance (texel × the material's emission) at barycentric `bary` of
    /// triangle `prim`; `None` when its material has no emission texture.
    #[inline(never)]
    fn emission_texel(&self, prim: u32, bary: [f32; 2]) -> Option<Rgb> {
        let m = &self.materials[self.tri_material[prim as usize] as usize];
        let t = m.maps.emission.as_ref()?;
        let texture = self.textures.textures.get(t.texture as usize)?;
        let [r, g, b, _] = t.texel(texture, self.hit_uv(prim, bary));
        Some(m.emission * Rgb::new(r, g, b))
    }
}

impl Hit {
    /// Keeps `t` consistent with the reconstructed point (f64 distance from the origin).
    fn with_t_from(mut self, o: DVec3, d: DVec3) -> Hit {
        let t = (self.p - o).dot(d);
        if t.is_finite() && t > 0.0 {
            self.t = t;
        }
        self
    }
}

/// Unit normal of a triangle, or `None` when it is degenerate or has non-finite coordinates.
pub fn triangle_normal(positions: &[Vec3], tri: &[u32; 3]) -> Option<DVec3> {
    let get = |i: u32| positions.get(i as usize).map(|p| p.as_dvec3());
    let (a, b, c) = (get(tri[0])?, get(tri[1])?, get(tri[2])?);
    if !(crate::math::is_finite3(a) && crate::math::is_finite3(b) && crate::math::is_finite3(c)) {
        return None;
    }
    let n = (b - a).cross(c - a);
    let len = n.length();
    // Relative test: area negligible against the edge lengths (slivers Embree cannot hit reliably).
    let scale = (b - a).length_squared().max((c - a).length_squared());
    if !(len > 1e-14 * scale) || !len.is_finite() {
        return None;
    }
    Some(n / len)
}

impl Scene {
    /// Float error bound of a point on the scene's f32 geometry (see [`Hit::eps`]).
    #[inline]
    pub fn eps_at(&self, p: DVec3) -> f64 {
        F32_ERROR_ULPS * p.abs().max_element() + 1e-9 * self.extent()
    }

    /// The triangles an Embree point query finds within `radius` of `p` (by bounding box), in
    /// index order, so that what is done with them never depends on Embree's traversal order.
    fn triangles_near_sorted(
        &self,
        p: DVec3,
        radius: f64,
    ) -> ([u32; crate::accel::MAX_NEAR], usize) {
        let near = self.accel.triangles_near(p.as_vec3(), radius as f32);
        let mut prims = [0u32; crate::accel::MAX_NEAR];
        let mut len = near.prims().len();
        prims[..len].copy_from_slice(near.prims());
        if self.features.cutouts {
            // Triangles cut out where the point lies are not there for it either.
            let mut kept = 0;
            for k in 0..len {
                if !self.cut_at(prims[k], p) {
                    prims[kept] = prims[k];
                    kept += 1;
                }
            }
            len = kept;
        }
        prims[..len].sort_unstable();
        (prims, len)
    }

    /// Where paths from a free point `x` (a sample point or a camera, not a surface hit) start:
    /// `x` itself, unless it lies on a surface within the float error bound (a slice through a
    /// wall, a point on an edge or a corner). There a ray query is ill-posed: a ray starting on a
    /// triangle's plane may or may not hit it (Embree rejects t = 0), so walks would leak through
    /// walls and radiance paths see through them. Such a point is moved to the front side of every
    /// surface it lies on, twice the bound off it, where its neighbours in front of those surfaces
    /// are: the field on a surface is the limit from its front side.
    ///
    /// This costs about one ray query (an Embree point query), so domains call it only where
    /// points may lie on surfaces: single points ([`crate::ftpd::sample_at`]), camera eyes, and
    /// planes that contain a surface ([`Scene::surface_in_plane`]); elsewhere a jittered point
    /// lands within the bound of a surface with negligible probability.
    #[inline]
    pub fn off_surfaces(&self, x: DVec3) -> DVec3 {
        let eps = self.eps_at(x);
        let (prims, len) = self.triangles_near_sorted(x, 3.0 * eps);
        if len == 0 {
            return x;
        }
        self.move_off(x, x, eps, &prims[..len], None, |_, _| false, |_, _| 1.0)
    }
}

impl Scene {
    /// True when some triangle lies in the plane through `origin` with unit normal `normal` (all
    /// three vertices within the float error bound of it): a slice through a wall, whose sample
    /// points must start off the surface ([`Scene::off_surfaces`]).
    pub fn surface_in_plane(&self, origin: DVec3, normal: DVec3) -> bool {
        let normal = normal.normalize_or_zero();
        normal != DVec3::ZERO
            && self.triangles.iter().any(|t| {
                t.iter().all(|&i| {
                    let p = self.positions[i as usize].as_dvec3();
                    (p - origin).dot(normal).abs() <= self.eps_at(p).max(self.eps_at(origin))
                })
            })
    }
}

/// A point being moved off the surfaces it lies on, each time to twice the error bound in front
/// of one (plane through `a` with unit normal `n`), unless the move would cross a surface near it
/// (or come within half the bound of one it was moved off): surfaces closer to each other than the
/// bound (a gap thinner than the f32 spacing) cannot all be honoured, and the first ones win.
struct OffSurfaces {
    p: DVec3,
    eps: f64,
    /// Half-spaces the point must stay in: (q − a)·n ≥ min.
    keep: [(DVec3, DVec3, f64); crate::accel::MAX_NEAR + 1],
    len: usize,
}

impl OffSurfaces {
    fn new(p: DVec3, eps: f64) -> Self {
        OffSurfaces {
            p,
            eps,
            keep: [(DVec3::ZERO, DVec3::ZERO, 0.0); crate::accel::MAX_NEAR + 1],
            len: 0,
        }
    }

    fn push(&mut self, a: DVec3, n: DVec3, min: f64) {
        if self.len < self.keep.len() {
            self.keep[self.len] = (a, n, min);
            self.len += 1;
        }
    }

    /// The point must stay on its side of the plane through `a` with normal `n`.
    fn keep_side(&mut self, a: DVec3, n: DVec3) {
        let s = (self.p - a).dot(n);
        if s != 0.0 {
            self.push(a, n * s.signum(), 0.0);
        }
    }

    fn move_in_front_of(&mut self, a: DVec3, n: DVec3) {
        let s = (self.p - a).dot(n);
        if s >= 2.0 * self.eps {
            return;
        }
        let q = self.p + n * (2.0 * self.eps - s);
        if self.keep[..self.len]
            .iter()
            .all(|(b, m, min)| (q - *b).dot(*m) >= *min)
        {
            self.p = q;
            self.push(a, n, 0.5 * self.eps);
        }
    }
}

/// The texture coordinate at barycentric `bary` = (u, v) of a triangle whose corners have `uv`:
/// (1 − u − v) uv₀ + u uv₁ + v uv₂.
#[inline]
pub fn interpolate_uv(uv: [glam::Vec2; 3], bary: [f32; 2]) -> [f64; 2] {
    let [u, v] = bary.map(|x| x as f64);
    let w = 1.0 - u - v;
    let at = |k: usize| w * uv[0][k] as f64 + u * uv[1][k] as f64 + v * uv[2][k] as f64;
    [at(0), at(1)]
}

/// Barycentric (u, v) of a point `p` in the plane of triangle (a, b, c): p = (1-u-v) a + u b + v c
/// (0 for a degenerate triangle).
pub fn barycentric(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> [f64; 2] {
    let (e1, e2, d) = (b - a, c - a, p - a);
    let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (d1, d2) = (d.dot(e1), d.dot(e2));
    let det = d11 * d22 - d12 * d12;
    if !(det.abs() > 0.0) || !det.is_finite() {
        return [0.0; 2];
    }
    [(d22 * d1 - d12 * d2) / det, (d11 * d2 - d12 * d1) / det]
}

/// The point of triangle (a, b, c) closest to `p` (Ericson, Real-Time Collision Detection, 5.1.5).
pub fn closest_point_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

impl Scene {
    /// The Embree scene, for benchmarks that trace raw rays.
    pub fn accel(&self) -> &Accel {
        &self.accel
    }
}
