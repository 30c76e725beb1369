//! How rays meet the scene: closest hits reconstructed in f64 with their float error bound, and
//! shadow rays. Where a ray leaving a hit starts is [`crate::scene::offset`].

use crate::accel::RawHit;
use crate::scene::geometry::closest_point_on_triangle;
use crate::scene::model::Scene;
use glam::DVec3;

/// Everything the transport code needs about a ray-surface hit, in f64.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    pub p: DVec3,
    pub prim: u32,
    /// Unit geometric normal (front side from the winding).
    pub ng: DVec3,
    /// Unit shading normal on the same side as `ng`.
    pub ns: DVec3,
    pub material: u32,
    /// Half-width of the region around `p` that may hold the true surface (float error bound).
    pub eps: f64,
    /// Embree's barycentric coordinates of the hit (weights of the triangle's second and third
    /// vertex), for texture coordinates and the test for edges ([`Scene::near_edge`]).
    pub bary: [f32; 2],
    /// The error bound before the floor `eps` has, which the test for edges uses.
    eps_edge: f64,
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
    /// Float error bound of a point on the scene's f32 geometry (see [`Hit::eps`]).
    #[inline]
    pub fn eps_at(&self, p: DVec3) -> f64 {
        F32_ERROR_ULPS * p.abs().max_element() + 1e-9 * self.extent()
    }

    /// Closest hit along the ray `o + t d` (d unit) for t in (0, tmax).
    #[inline(always)]
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

    #[inline(always)]
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

    #[inline(always)]
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
        Hit {
            p,
            prim: raw.prim,
            ng,
            ns,
            material: th.material,
            eps: eps.max(1e-12),
            bary: [raw.u, raw.v],
            eps_edge: eps,
        }
    }

    /// `hit.p` lies within twice the error bound of an edge of its triangle, where other surfaces
    /// may meet it (see [`Scene::spawn_origin_from`]). Asked only where a ray leaves the hit: a
    /// walk's last hit never needs it.
    #[inline(always)]
    pub fn near_edge(&self, hit: &Hit) -> bool {
        let [pa, pb, pc] = self.tri_hit[hit.prim as usize].p.map(|q| q.as_dvec3());
        let (u, v) = (hit.bary[0] as f64, hit.bary[1] as f64);
        let eps = hit.eps_edge;
        // Distance from p to each edge (barycentric × the opposite altitude), squared, against
        // (2 eps)², without square roots: with e0 = p1 − p0, e1 = p2 − p0, e2 = p2 − p1, the
        // altitude onto edge k is |e0 × e1| / |e_k|.
        let (e0, e1, e2) = (pb - pa, pc - pa, pc - pb);
        let (c2, lim) = (e0.cross(e1).length_squared(), 4.0 * eps * eps);
        let w = 1.0 - u - v;
        w * w * c2 <= lim * e2.length_squared()
            || u * u * c2 <= lim * e1.length_squared()
            || v * v * c2 <= lim * e0.length_squared()
    }
}
