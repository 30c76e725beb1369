//! Cut-outs: the triangles of materials with alpha, which rays pass through where their coverage
//! says so. The test is installed on the acceleration structure once the coverage it reads
//! (factor, texture coordinates, textures) is known, and asked directly by the point query.

use crate::math::Rgb;
use crate::scene::geometry::{barycentric, closest_point_on_triangle, interpolate_uv};
use crate::scene::hit::ray_barycentrics;
use crate::scene::material::Material;
use crate::scene::material::{Alpha, AlphaMode};
use crate::scene::model::{LoadReport, Scene};
use glam::{DVec3, Vec2, Vec3};

impl Scene {
    /// True when some cut-out material's coverage reads a texture, so its cut-out test waits for
    /// the textures ([`Scene::attach_textures`]).
    pub(super) fn cut_reads_textures(&self) -> bool {
        self.materials
            .iter()
            .zip(&self.cut_materials)
            .any(|(m, &cut)| cut && m.maps.alpha.as_ref().is_some_and(|a| a.map.is_some()))
    }

    /// The cut-out test of a scene whose coverage reads textures, once they are attached (or
    /// known to be ignored): [`Scene::build`] left it out.
    pub(super) fn install_textured_cut_test(&mut self) {
        if self.accel.has_cutouts() && self.cut_reads_textures() {
            let cutout = cut_triangles(&self.cut_materials, &self.tri_material);
            self.install_cut_test(&cutout);
        }
    }

    /// Gives the acceleration structure the cut-out test of triangles `cutout` (their materials'
    /// [`Alpha`](Alpha) at the hit's texture coordinate), holding what it
    /// reads (coverage, corner coordinates, textures) in its own compact table, one entry per
    /// cut-out triangle.
    pub(super) fn install_cut_test(&mut self, cutout: &[u32]) {
        if cutout.is_empty() {
            return;
        }
        let alphas: Vec<Alpha> = self
            .materials
            .iter()
            .map(|m| {
                m.maps.alpha.clone().unwrap_or(Alpha {
                    factor: 1.0,
                    map: None,
                    channel: 3,
                    mode: AlphaMode::Stochastic,
                })
            })
            .collect();
        // Cut-out triangles are in world space (never instanced), as Embree holds them.
        let table: Vec<(u32, [Vec2; 3], [Vec3; 3])> = cutout
            .iter()
            .map(|&t| {
                let uv = self.corner_uvs(t);
                let p = self.triangles[t as usize].map(|v| self.positions[v as usize]);
                (self.tri_material[t as usize], uv, p)
            })
            .collect();
        let textures = self.textures.textures.clone();
        self.accel.set_cut_test(Box::new(move |k, ray| {
            table.get(k as usize).is_some_and(|&(m, uv, p)| {
                let o = Vec3::from(ray.origin()).as_dvec3();
                let d = Vec3::from(ray.dir()).as_dvec3();
                let bary = ray_barycentrics(o, d, p.map(|q| q.as_dvec3()));
                alphas[m as usize].cut(&textures, interpolate_uv(uv, bary), || ray.xi())
            })
        }));
    }

    /// True when triangle `prim` is cut out at `p` (a point on or near it: its closest point is
    /// tested), for the point query; the coverage hash is keyed by the point and the triangle.
    pub(super) fn cut_at(&self, prim: u32, p: DVec3) -> bool {
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
}

/// Per material: whether its triangles are cut-outs (it has alpha that is not opaque). An emitter
/// stays opaque, with a warning: its light samples would otherwise land on cut-out texels.
pub(super) fn cut_materials(materials: &[Material], report: &mut LoadReport) -> Vec<bool> {
    let mut cut = vec![false; materials.len()];
    for (k, m) in materials.iter().enumerate() {
        if m.maps.alpha.as_ref().is_some_and(|a| !a.is_opaque()) {
            if m.emission == Rgb::ZERO {
                cut[k] = true;
            } else {
                report.warnings.push(format!(
                    "material '{}' emits light: its alpha is ignored (emitters are opaque)",
                    m.name
                ));
            }
        }
    }
    cut
}

/// The triangles of cut-out materials, in increasing order (the acceleration structure puts them
/// in a geometry of their own).
pub(super) fn cut_triangles(cut_materials: &[bool], tri_material: &[u32]) -> Vec<u32> {
    if !cut_materials.contains(&true) {
        return Vec::new();
    }
    (0..tri_material.len() as u32)
        .filter(|&i| cut_materials[tri_material[i as usize] as usize])
        .collect()
}
