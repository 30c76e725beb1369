//! Building a scene from a loader's parts: degenerate triangles dropped, the per-triangle hit
//! records, bounds, lights, planar mirrors, cut-outs and the feature set computed, and the Embree
//! acceleration structure built. Then the scene is immutable but for its textures and the lights
//! that do not come from triangles.

use crate::accel::{Accel, AccelError, InstanceXfm, SharedArray};
use crate::math::Rgb;
use crate::scene::cutout::{cut_materials, cut_triangles};
use crate::scene::features::Features;
use crate::scene::geometry::{Aabb, triangle_normal};
use crate::scene::instance::Instancing;
use crate::scene::light::{Light, LightSet};
use crate::scene::material::Material;
use crate::scene::mirror::Mirrors;
use crate::scene::model::{LoadReport, Scene, Shading, TexCoords, TriHit};
use crate::scene::texture::TextureSet;
use glam::{DVec3, Vec2, Vec3};
use rayon::prelude::*;
use std::path::Path;

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
    ) -> Result<Scene, AccelError> {
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
        triangles: Vec<[u32; 3]>,
        tri_material: Vec<u32>,
        shading: Shading,
        texcoords: TexCoords,
        materials: Vec<Material>,
        report: LoadReport,
    ) -> Result<Scene, AccelError> {
        Scene::from_instanced_parts(
            source,
            positions,
            triangles,
            tri_material,
            shading,
            texcoords,
            materials,
            report,
            Instancing::default(),
        )
    }

    /// As [`Scene::from_parts`], where the triangles of `instancing`'s prototypes (ranges of
    /// `triangles`, all after the world-space ones, in prototype space) are placed by its
    /// instances (see [`crate::scene::instance`]). Their materials must be
    /// [`instanceable`](crate::scene::instance::instanceable): lights, cut-outs and mirrors are
    /// found among the world-space triangles only.
    #[allow(clippy::too_many_arguments)]
    pub fn from_instanced_parts(
        source: &Path,
        positions: Vec<Vec3>,
        mut triangles: Vec<[u32; 3]>,
        mut tri_material: Vec<u32>,
        shading: Shading,
        texcoords: TexCoords,
        materials: Vec<Material>,
        mut report: LoadReport,
        mut instancing: Instancing,
    ) -> Result<Scene, AccelError> {
        assert_eq!(triangles.len(), tri_material.len());
        let n = triangles.len();
        report.triangles_read += n;
        let textured = materials.iter().any(|m| m.maps.reads_textures());
        let mut texcoords = kept_texcoords(texcoords, textured, positions.len(), n);
        let (normals, mut corners) = split_shading(shading, positions.len(), n);
        let mut tri_hit = hit_records(&positions, &triangles, &tri_material, materials.len());
        let dropped = tri_hit.par_iter().filter(|h| h.ng.x.is_nan()).count();
        report.degenerate_dropped += dropped;
        if dropped > 0 && !instancing.is_empty() {
            renumber_prototypes(&mut instancing, &tri_hit);
        }
        let kept = if dropped > 0 {
            drop_degenerate(&mut tri_hit, &mut triangles, &mut corners, &mut texcoords)
        } else {
            n
        };
        tri_material.clear();
        tri_material.par_extend(tri_hit.par_iter().map(|h| h.material));
        tri_material.shrink_to_fit();
        let world = instancing.world_triangles(kept);
        let mut bounds = bounds_of(&tri_hit[..world]);
        if !instancing.is_empty() {
            instance_bounds(&mut instancing, &positions, &triangles);
            for i in &instancing.instances {
                bounds.grow(i.bounds.min);
                bounds.grow(i.bounds.max);
            }
        }
        let tri_shading = shading_records(corners, &normals, &triangles, kept);
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
            &triangles[..world],
            |i| tri_hit[i].ng,
            &tri_material,
            &materials,
            center,
            0.5 * extent,
        );
        let mut features = Features::of(&materials, &tri_material, &lights);
        let mirrors = planar_mirrors(
            &tri_hit[..world],
            &tri_shading,
            &materials,
            &tri_material,
            extent,
        );
        features.planar_mirrors = !mirrors.is_empty();
        let cut_materials = cut_materials(&materials, &mut report);
        let cutout = cut_triangles(&cut_materials, &tri_material[..world]);
        features.cutouts = !cutout.is_empty();
        // Embree reads these two in place: from here on they are immutable.
        let (positions, triangles) = (SharedArray::new(positions), SharedArray::new(triangles));
        let t_bvh = std::time::Instant::now();
        let accel = if instancing.is_empty() {
            Accel::with_cutouts(&positions, &triangles, &cutout)?
        } else {
            let ranges: Vec<_> = instancing
                .prototypes
                .iter()
                .map(|p| p.triangles.clone())
                .collect();
            let xfms: Vec<_> = instancing
                .instances
                .iter()
                .map(|i| InstanceXfm {
                    prototype: i.prototype,
                    columns: i.columns(),
                })
                .collect();
            Accel::with_instances(&positions, &triangles, world, &cutout, &ranges, &xfms)?
        };
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
            file_lights: Vec::new(),
            extent,
            tri_hit,
            tri_shading,
            uvs: texcoords,
            textures: Default::default(),
            flat: None,
            cut_materials,
            instancing,
            accel,
        };
        // Installed once: here when the coverage reads no texture, else when the textures (and
        // for glTF the texture coordinates) arrive (`attach_textures`, `set_textures`).
        if !scene.cut_reads_textures() {
            scene.install_cut_test(&cutout);
        }
        Ok(scene)
    }

    /// Sets per-vertex texture coordinates (v up) and the textures materials refer to (glTF).
    /// Ignored (left without) when `uvs` does not have one entry per vertex or no material has a
    /// texture.
    pub fn set_textures(&mut self, uvs: Vec<Vec2>, textures: TextureSet) {
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
    pub fn attach_textures(&mut self, textures: TextureSet) {
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
}

/// The texture coordinates a scene keeps: only when some material reads a texture, and
/// per-vertex ones only with one per vertex.
fn kept_texcoords(texcoords: TexCoords, textured: bool, vertices: usize, n: usize) -> TexCoords {
    match texcoords {
        TexCoords::PerVertex(v) if textured && v.len() == vertices => TexCoords::PerVertex(v),
        TexCoords::PerCorner { table, corners } if textured => {
            assert_eq!(corners.len(), n);
            TexCoords::PerCorner { table, corners }
        }
        _ => TexCoords::None,
    }
}

/// Per-vertex shading normals (empty when there are none, or not one per vertex) or per-corner
/// ones.
fn split_shading(
    shading: Shading,
    vertices: usize,
    n: usize,
) -> (Vec<Vec3>, Option<Vec<[Vec3; 3]>>) {
    match shading {
        Shading::None => (Vec::new(), None),
        Shading::PerVertex(v) if v.len() == vertices => (v, None),
        Shading::PerVertex(_) => (Vec::new(), None),
        Shading::PerCorner(c) => {
            assert_eq!(c.len(), n);
            (Vec::new(), Some(c))
        }
    }
}

/// The hit records, in parallel, on huge pages; a degenerate triangle's gets a NaN normal, and
/// [`drop_degenerate`] removes it. Material indices past the table are clamped to its last entry.
fn hit_records(
    positions: &[Vec3],
    triangles: &[[u32; 3]],
    tri_material: &[u32],
    materials: usize,
) -> Vec<TriHit> {
    let max_material = materials.saturating_sub(1) as u32;
    let mut tri_hit: Vec<TriHit> = crate::accel::vec_with_huge_pages(triangles.len());
    tri_hit.par_extend(triangles.par_iter().zip(tri_material).map(|(tri, &m)| {
        let ng = triangle_normal(positions, tri).unwrap_or(DVec3::NAN);
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
    tri_hit
}

/// Removes the triangles whose hit record has a NaN normal from every per-triangle array,
/// compacting them in place, in order; returns how many are kept.
fn drop_degenerate(
    tri_hit: &mut Vec<TriHit>,
    triangles: &mut Vec<[u32; 3]>,
    corners: &mut Option<Vec<[Vec3; 3]>>,
    texcoords: &mut TexCoords,
) -> usize {
    let mut kept = 0;
    for k in 0..tri_hit.len() {
        if tri_hit[k].ng.x.is_nan() {
            continue;
        }
        triangles[kept] = triangles[k];
        tri_hit[kept] = tri_hit[k];
        if let Some(c) = corners.as_mut() {
            c[kept] = c[k];
        }
        if let TexCoords::PerCorner { corners, .. } = texcoords {
            corners[kept] = corners[k];
        }
        kept += 1;
    }
    if let TexCoords::PerCorner { corners, .. } = texcoords {
        corners.truncate(kept);
        corners.shrink_to_fit();
    }
    tri_hit.truncate(kept);
    triangles.truncate(kept);
    triangles.shrink_to_fit();
    kept
}

/// Bounds of the kept triangles' vertices, in their order (as a sequential loader would: min and
/// max of a signed zero depend on the order).
fn bounds_of(tri_hit: &[TriHit]) -> Aabb {
    let mut bounds = Aabb::EMPTY;
    for h in tri_hit {
        for p in h.p {
            bounds.grow(p.as_dvec3());
        }
    }
    bounds
}

/// The shading normals of each kept triangle's corners (empty without shading normals), so that
/// a hit reads one record: the per-corner ones as given, or the per-vertex ones gathered, on huge
/// pages.
fn shading_records(
    corners: Option<Vec<[Vec3; 3]>>,
    normals: &[Vec3],
    triangles: &[[u32; 3]],
    kept: usize,
) -> Vec<[Vec3; 3]> {
    match corners {
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
    }
}

/// Moves the prototypes' triangle ranges to where they are once the degenerate triangles (NaN
/// normals in `tri_hit`, not yet dropped) are.
fn renumber_prototypes(instancing: &mut Instancing, tri_hit: &[TriHit]) {
    let mut kept_before = Vec::with_capacity(tri_hit.len() + 1);
    let mut kept = 0u32;
    kept_before.push(0);
    for h in tri_hit {
        kept += u32::from(!h.ng.x.is_nan());
        kept_before.push(kept);
    }
    for p in &mut instancing.prototypes {
        let r = &p.triangles;
        p.triangles = kept_before[r.start as usize]..kept_before[r.end as usize];
    }
}

/// Each instance's world-space bounds: its prototype's vertices (those its triangles use),
/// transformed and rounded as a flattened copy's, so that the scene's bounds are the flattened
/// scene's.
fn instance_bounds(instancing: &mut Instancing, positions: &[Vec3], triangles: &[[u32; 3]]) {
    let used: Vec<Vec<u32>> = instancing
        .prototypes
        .iter()
        .map(|p| {
            let mut v: Vec<u32> = triangles[p.triangles.start as usize..p.triangles.end as usize]
                .iter()
                .flatten()
                .copied()
                .collect();
            v.sort_unstable();
            v.dedup();
            v
        })
        .collect();
    instancing.instances.par_iter_mut().for_each(|inst| {
        let mut b = Aabb::EMPTY;
        for &v in &used[inst.prototype as usize] {
            b.grow(inst.point(positions[v as usize]));
        }
        inst.bounds = b;
    });
}

/// The planar mirrors among the triangles: those of perfect-mirror materials whose shading normals
/// (if any) agree with the geometric one, grouped by plane.
fn planar_mirrors(
    tri_hit: &[TriHit],
    tri_shading: &[[Vec3; 3]],
    materials: &[Material],
    tri_material: &[u32],
    extent: f64,
) -> Mirrors {
    Mirrors::detect(
        tri_hit.len(),
        materials,
        tri_material,
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
    )
}
