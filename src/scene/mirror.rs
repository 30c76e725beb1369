//! Planar mirrors: groups of coplanar triangles of a perfect-mirror material, found at load time.
//! Light that reaches a point by one reflection in such a plane comes from the plane's mirror image
//! of the light (a "virtual light"), which the radiance estimate can sample directly
//! (`crate::transport::mirror`). Scenes without them keep an empty [`Mirrors`] and never look.

use crate::scene::light::PowerCdf;
use crate::scene::material::{Bsdf, Material};
use glam::DVec3;

/// At most this many planes are sampled (the largest by area); the triangles of smaller planes
/// stay ordinary mirrors, found only by the paths that hit them. A curved mirror tessellated into
/// thousands of facets has no planar part worth sampling.
pub const MAX_PLANES: usize = 16;

/// A mirror plane `normal · x = offset`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MirrorPlane {
    pub normal: DVec3,
    pub offset: f64,
}

impl MirrorPlane {
    /// Signed distance of `p` from the plane.
    #[inline]
    pub fn distance(&self, p: DVec3) -> f64 {
        self.normal.dot(p) - self.offset
    }

    /// The mirror image of the point `p`.
    #[inline]
    pub fn reflect_point(&self, p: DVec3) -> DVec3 {
        p - self.normal * (2.0 * self.distance(p))
    }

    /// The mirror image of the direction `d`.
    #[inline]
    pub fn reflect_dir(&self, d: DVec3) -> DVec3 {
        d - self.normal * (2.0 * self.normal.dot(d))
    }
}

/// The planar mirrors of a scene (or of a flatland plane's cross-section), with the probability of
/// choosing each (in proportion to its area, or its cross-section's length in flatland).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mirrors {
    pub planes: Vec<MirrorPlane>,
    /// The choice of a plane, in proportion to its weight (the lights' choice, reused).
    choice: PowerCdf,
    /// Each plane's triangles' bounding box, widened by a margin: a point of the plane outside it
    /// is no mirror point, without a ray.
    bounds: Vec<(DVec3, DVec3)>,
    /// Each triangle's plane (`u32::MAX`: none); empty when there are no planes.
    plane_of_prim: Vec<u32>,
    /// How many triangles the planes hold.
    pub triangles: usize,
}

/// A perfect mirror whose reflection is the plane's: no diffuse part (also not from a texture), no
/// cut-out, no emission.
pub(super) fn is_perfect_mirror(m: &Material) -> bool {
    matches!(&m.bsdf, Bsdf::Mirror { kd, ks } if *kd == crate::math::Rgb::ZERO
        && *ks != crate::math::Rgb::ZERO)
        && m.maps.base_color.is_none()
        && m.maps.alpha.is_none()
        && m.emission == crate::math::Rgb::ZERO
}

impl Mirrors {
    /// Groups the triangles of perfect-mirror materials into planes. `ng(i)` is triangle `i`'s
    /// unit geometric normal, `vertices(i)` its vertices, `area(i)` its area, and
    /// `flat_shaded(i)` says that its shading normals (if any) are its geometric one, so that it
    /// reflects about the plane. Triangles whose normal and offset agree within `1e-6` (relative,
    /// offsets against the scene's `extent`) share a plane; only the [`MAX_PLANES`] largest planes
    /// are kept.
    #[allow(clippy::too_many_arguments)]
    pub fn detect(
        n: usize,
        materials: &[Material],
        tri_material: &[u32],
        ng: impl Fn(usize) -> DVec3,
        vertices: impl Fn(usize) -> [DVec3; 3],
        area: impl Fn(usize) -> f64,
        flat_shaded: impl Fn(usize) -> bool,
        extent: f64,
    ) -> Mirrors {
        let perfect: Vec<bool> = materials.iter().map(is_perfect_mirror).collect();
        if !perfect.contains(&true) {
            return Mirrors::default();
        }
        let tol_n = 1e-6;
        let tol_c = 1e-6 * extent.max(f64::MIN_POSITIVE);
        // Quantised keys; a plane split across a key boundary becomes two planes, which is still
        // correct (each only answers for its own triangles).
        let key = |nrm: DVec3, c: f64| {
            let q = |v: f64, t: f64| (v / t).round() as i64;
            [
                q(nrm.x, tol_n),
                q(nrm.y, tol_n),
                q(nrm.z, tol_n),
                q(c, tol_c),
            ]
        };
        let mut index: std::collections::HashMap<[i64; 4], usize> = Default::default();
        // (normal, offset, area, triangles, bounds)
        type Group = (DVec3, f64, f64, Vec<u32>, (DVec3, DVec3));
        let mut groups: Vec<Group> = Vec::new();
        for (i, &m) in tri_material.iter().enumerate().take(n) {
            if !perfect.get(m as usize).copied().unwrap_or(false) || !flat_shaded(i) {
                continue;
            }
            let nrm = ng(i);
            let v = vertices(i);
            let c = nrm.dot(v[0]);
            let a = area(i);
            if !(a > 0.0) || !c.is_finite() {
                continue;
            }
            let g = *index.entry(key(nrm, c)).or_insert_with(|| {
                groups.push((
                    nrm,
                    c,
                    0.0,
                    Vec::new(),
                    (DVec3::INFINITY, DVec3::NEG_INFINITY),
                ));
                groups.len() - 1
            });
            groups[g].2 += a;
            groups[g].3.push(i as u32);
            for p in v {
                groups[g].4.0 = groups[g].4.0.min(p);
                groups[g].4.1 = groups[g].4.1.max(p);
            }
        }
        // Largest first; ties by first triangle, so the order is deterministic.
        groups.sort_by(|a, b| b.2.total_cmp(&a.2).then(a.3[0].cmp(&b.3[0])));
        groups.truncate(MAX_PLANES);
        let weights: Vec<f64> = groups.iter().map(|g| g.2).collect();
        let margin = DVec3::splat(1e-6 * extent);
        let bounds: Vec<(DVec3, DVec3)> = groups
            .iter()
            .map(|g| (g.4.0 - margin, g.4.1 + margin))
            .collect();
        let planes = groups
            .iter()
            .map(|g| MirrorPlane {
                normal: g.0,
                offset: g.1,
            })
            .collect();
        let mut plane_of_prim = vec![u32::MAX; n];
        let mut triangles = 0;
        for (k, g) in groups.iter().enumerate() {
            for &t in &g.3 {
                plane_of_prim[t as usize] = k as u32;
                triangles += 1;
            }
        }
        Mirrors::with_weights(planes, &weights, bounds, plane_of_prim, triangles)
    }

    /// Planes chosen in proportion to `weights` (planes of weight 0 are dropped and their
    /// triangles forgotten).
    fn with_weights(
        planes: Vec<MirrorPlane>,
        weights: &[f64],
        bounds: Vec<(DVec3, DVec3)>,
        mut plane_of_prim: Vec<u32>,
        mut triangles: usize,
    ) -> Mirrors {
        let mut keep = Vec::new();
        let mut renumber = vec![u32::MAX; planes.len()];
        for (k, ((&w, p), b)) in weights.iter().zip(&planes).zip(&bounds).enumerate() {
            if w > 0.0 && w.is_finite() {
                renumber[k] = keep.len() as u32;
                keep.push((*p, w, *b));
            }
        }
        if keep.is_empty() {
            return Mirrors::default();
        }
        for q in plane_of_prim.iter_mut() {
            if *q != u32::MAX {
                *q = renumber[*q as usize];
                if *q == u32::MAX {
                    triangles -= 1;
                }
            }
        }
        Mirrors {
            planes: keep.iter().map(|k| k.0).collect(),
            bounds: keep.iter().map(|k| k.2).collect(),
            choice: PowerCdf::new(keep.iter().map(|k| k.1)),
            plane_of_prim,
            triangles,
        }
    }

    /// The same planes as a flatland plane of unit `normal` sees them: lines, with the normals
    /// turned into the plane (`in_plane`) and chosen in proportion to `lengths` (each plane's
    /// cross-section length; planes that do not cross are dropped).
    pub fn section(
        &self,
        plane_normal: DVec3,
        plane_offset: f64,
        in_plane: impl Fn(DVec3) -> Option<DVec3>,
        lengths: &[f64],
    ) -> Mirrors {
        if self.is_empty() {
            return Mirrors::default();
        }
        let mut weights = lengths.to_vec();
        let planes = self
            .planes
            .iter()
            .enumerate()
            .map(|(k, p)| match in_plane(p.normal) {
                // Points x of the slice on the mirror: n·x = c and N·x = c_s, so
                // n₂·x = (c − (n·N) c_s) / |n − (n·N) N| with n₂ the in-plane unit normal.
                Some(n2) => {
                    let nn = p.normal.dot(plane_normal);
                    let len = (p.normal - plane_normal * nn).length();
                    MirrorPlane {
                        normal: n2,
                        offset: (p.offset - nn * plane_offset) / len,
                    }
                }
                None => {
                    weights[k] = 0.0;
                    *p
                }
            })
            .collect();
        Mirrors::with_weights(
            planes,
            &weights,
            self.bounds.clone(),
            self.plane_of_prim.clone(),
            self.triangles,
        )
    }

    /// True when the scene has no planar mirror (then nothing looks further).
    #[inline(always)]
    pub fn is_empty(&self) -> bool {
        self.choice.is_empty()
    }

    /// The plane of triangle `prim`, if it is one of a planar mirror.
    #[inline]
    pub fn plane_of(&self, prim: u32) -> Option<u32> {
        match self.plane_of_prim.get(prim as usize) {
            Some(&k) if k != u32::MAX => Some(k),
            _ => None,
        }
    }

    /// Probability of choosing plane `k`.
    #[inline]
    pub fn prob(&self, k: usize) -> f64 {
        self.choice.prob(k)
    }

    /// The plane that `u` ∈ [0, 1) chooses, with its probability.
    #[inline]
    pub fn pick(&self, u: f64) -> Option<(usize, f64)> {
        self.choice.pick(u)
    }

    /// True when the point `q` (of plane `k`) lies in the bounding box of that plane's triangles;
    /// false means no triangle of the plane is there.
    #[inline]
    pub fn may_hold(&self, k: usize, q: DVec3) -> bool {
        let (lo, hi) = self.bounds[k];
        q.cmpge(lo).all() && q.cmple(hi).all()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reflections_are_isometries() {
        let p = MirrorPlane {
            normal: DVec3::new(0.6, 0.0, 0.8),
            offset: 0.5,
        };
        let x = DVec3::new(0.3, -1.0, 2.0);
        let xr = p.reflect_point(x);
        assert!((p.distance(xr) + p.distance(x)).abs() < 1e-12);
        assert!((p.reflect_point(xr) - x).length() < 1e-12);
        let d = DVec3::new(1.0, 2.0, -0.5).normalize();
        assert!((p.reflect_dir(d).length() - 1.0).abs() < 1e-12);
        // The ray from x towards the image of y meets the plane, and leaves it towards y.
        let y = DVec3::new(-1.0, 0.5, -2.0);
        let (yr, dx) = (p.reflect_point(y), p.distance(x));
        let q = x + (yr - x) * (dx / (dx - p.distance(yr)));
        assert!(p.distance(q).abs() < 1e-12);
        assert!((((y - xr).normalize()) - p.reflect_dir((yr - x).normalize())).length() < 1e-12);
    }
}
