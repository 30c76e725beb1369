//! How rays meet the scene: closest hits reconstructed in f64 with their float error bound, and
//! shadow rays. Where a ray leaving a hit starts is [`crate::scene::offset`].

use crate::accel::{NO_INSTANCE, RawHit};
use crate::scene::geometry::{Aabb, barycentric, closest_point_on_triangle};
use crate::scene::instance::Instancing;
use crate::scene::model::Scene;
use glam::{DVec3, Vec3A};

/// Everything the transport code needs about a ray-surface hit, in f64.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    pub p: DVec3,
    /// The triangle hit (for a hit on an instance, its prototype's triangle).
    pub prim: u32,
    /// The instance hit ([`NO_INSTANCE`] for a world-space triangle; see
    /// [`crate::scene::instance`]).
    pub inst: u32,
    /// Unit geometric normal (front side from the winding).
    pub ng: DVec3,
    /// Unit shading normal on the same side as `ng`.
    pub ns: DVec3,
    pub material: u32,
    /// Half-width of the region around `p` that may hold the true surface (float error bound).
    pub eps: f64,
    /// Barycentric coordinates of `p` (weights of the triangle's second and third vertex), for
    /// texture coordinates, shading normals and the test for edges ([`Scene::near_edge`]).
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

/// Where the ray `o + t d` meets the plane through `a` with normal `n` (any length): the
/// parameter t (not finite for a ray parallel to the plane) and the point, in f64.
#[inline(always)]
fn ray_plane(o: DVec3, d: DVec3, a: DVec3, n: DVec3) -> (f64, DVec3) {
    let t = (a - o).dot(n) / d.dot(n);
    (t, o + d * t)
}

/// The barycentric coordinates (weights of the second and third vertex) of the point of the
/// triangle `[pa, pb, pc]` that the ray `o + t d` meets, from the ray and the vertices alone, in
/// f64: the ray's point on the triangle's plane, or the triangle's point closest to it where that
/// lies off the triangle (a grazing ray, or one through an edge within rounding). Never Embree's
/// own u, v: those differ in their last bits with the instruction set Embree picks at run time
/// (SSE, AVX2, AVX-512), and a decision read from them made outputs depend on the machine.
pub fn ray_barycentrics(o: DVec3, d: DVec3, [pa, pb, pc]: [DVec3; 3]) -> [f32; 2] {
    let (_, q) = ray_plane(o, d, pa, (pb - pa).cross(pc - pa));
    barycentrics_near(if q.is_finite() { q } else { o }, [pa, pb, pc])
}

/// The barycentric coordinates of the triangle's point closest to `q` (a point in or near its
/// plane), in f64, rounded to f32.
#[inline(always)]
fn barycentrics_near(q: DVec3, [pa, pb, pc]: [DVec3; 3]) -> [f32; 2] {
    let [u, v] = barycentric(closest_point_on_triangle(q, pa, pb, pc), pa, pb, pc);
    [u as f32, v as f32]
}

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
    /// point `target` (e.g. a sampled light point): its unit direction and the distance at which
    /// it stops. `None` when `o` and `target` coincide or are not finite: nothing is visible then.
    ///
    /// A `target` on a surface of unit normal `surface` (an area light's point) is first moved off
    /// that surface, towards `o`'s side, by the error bound of both ends, and the ray ends there
    /// (pbrt's spawn-ray-to, both ends off their surfaces). So its end lies as far from the
    /// surface at every angle: a ray that ended a distance short *along the ray* instead came
    /// within that distance times the sine of its angle of the surface, less than the f32
    /// rounding of the ray's origin for a lamp seen a degree from its plane, and the lamp hid its
    /// own sample. A free `target` (a point light, a far point towards a sun or the sky) has
    /// nothing to move off: the ray stops its error bound short of it. The ray is aimed at the
    /// end itself (keeping a direction measured from an un-offset point would make oblique
    /// lights occlude themselves).
    #[inline]
    pub fn shadow_ray(
        &self,
        o: DVec3,
        target: DVec3,
        surface: Option<DVec3>,
    ) -> Option<(DVec3, f64)> {
        let (end, short) = match surface {
            Some(n) => {
                // The f32 rounding of the ray's origin counts too (a lamp seen from afar).
                let eps = self.eps_at(o.abs().max(target.abs()));
                let side = if (o - target).dot(n) >= 0.0 {
                    eps
                } else {
                    -eps
                };
                (target + n * side, 0.0)
            }
            None => (target, self.eps_at(target)),
        };
        let to = end - o;
        let len = to.length();
        if !(len > 0.0) || !len.is_finite() {
            return None;
        }
        Some((to / len, len - short))
    }

    /// True when nothing blocks the segment from `o` to `target` (on a surface of unit normal
    /// `surface`, if any; see [`shadow_ray`](Self::shadow_ray)).
    #[inline]
    pub fn visible(&self, o: DVec3, target: DVec3, surface: Option<DVec3>) -> bool {
        self.shadow_ray(o, target, surface)
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
        if raw.inst != NO_INSTANCE {
            return self.instance_hit::<FLAT>(o, d, raw);
        }
        let i = raw.prim as usize;
        let th = &self.tri_hit[i];
        let shading =
            (!self.tri_shading.is_empty()).then(|| self.tri_shading[i].map(|n| n.as_dvec3()));
        // The largest coordinate magnitude of the vertices, taken in f32, four lanes at a time:
        // exactly that of their f64 copies (the conversion is exact and monotonic).
        let [qa, qb, qc] = th.p.map(Vec3A::from);
        let mag = f64::from(qa.abs().max(qb.abs()).max(qc.abs()).max_element());
        let p = th.p.map(|q| q.as_dvec3());
        self.hit_on::<FLAT>(o, d, raw, p, mag, th.ng, shading, th.material)
    }

    /// [`Scene::hit_from_raw`] for a hit on an instance: the triangle in world space (see
    /// [`crate::scene::instance`]).
    #[cold]
    #[inline(never)]
    fn instance_hit<const FLAT: bool>(&self, o: DVec3, d: DVec3, raw: RawHit) -> Hit {
        let p = self.world_vertices(raw.inst, raw.prim);
        let [pa, pb, pc] = p;
        let mag = pa.abs().max(pb.abs()).max(pc.abs()).max_element();
        let ng = self.world_normal(raw.inst, raw.prim);
        let shading = self.instance_corner_normals(raw.inst, raw.prim);
        let material = self.tri_hit[raw.prim as usize].material;
        self.hit_on::<FLAT>(o, d, raw, p, mag, ng, shading, material)
    }

    /// The hit of `raw` on the world-space triangle of vertices `[pa, pb, pc]` (whose largest
    /// coordinate magnitude is `tri_mag`), unit geometric normal `ng`, corner shading normals
    /// `shading` and material `material`.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn hit_on<const FLAT: bool>(
        &self,
        o: DVec3,
        d: DVec3,
        raw: RawHit,
        [pa, pb, pc]: [DVec3; 3],
        tri_mag: f64,
        ng: DVec3,
        shading: Option<[DVec3; 3]>,
        material: u32,
    ) -> Hit {
        let mag = tri_mag.max(o.abs().max_element());
        let eps = F32_ERROR_ULPS * mag + 1e-9 * self.extent();
        // The hit point: the f64 intersection of the ray with the triangle's plane, which is exact to
        // f64 rounding. For grazing rays (|d·n| ≤ 1e-4) that point may lie far along the ray from
        // Embree's (which traced the f32-rounded ray), so it is taken only when it lies on the
        // triangle (within the error bound); else Embree's f32 barycentrics, which keep the point on
        // the triangle but are off sideways by the f32 rounding of the ray's origin (enough to break
        // the mirror isometry of pairs 10⁻⁶ rad apart). Embree's t only checks that the plane's
        // point is the one Embree found (to 10⁻³), and its u, v are read only in that grazing
        // case: both differ in their last bits with Embree's instruction set.
        let dn = d.dot(ng);
        let (t_plane, q) = ray_plane(o, d, pa, ng);
        let t_raw = raw.t as f64;
        let consistent =
            t_plane.is_finite() && (t_plane - t_raw).abs() <= 1e-3 * (t_raw + self.extent());
        let on_triangle = || {
            t_plane.is_finite()
                && t_plane > 0.0
                && (t_plane - t_raw).abs() <= 1e-3 * (t_raw + self.extent()) + eps / dn.abs()
                && (closest_point_on_triangle(q, pa, pb, pc) - q).length_squared() <= eps * eps
        };
        let p = if (dn.abs() > 1e-4 && consistent) || on_triangle() {
            q
        } else {
            let (u, v) = (raw.u as f64, raw.v as f64);
            (1.0 - u - v) * pa + u * pb + v * pc
        };
        // Texture coordinates, shading normals and the test for edges read the barycentrics of
        // `p`, not Embree's.
        let bary = barycentrics_near(p, [pa, pb, pc]);
        let (u, v) = (bary[0] as f64, bary[1] as f64);
        let ns = if let Some([na, nb, nc]) = shading {
            let n = (1.0 - u - v) * na + u * nb + v * nc;
            let len = n.length();
            if len > 1e-12 && len.is_finite() {
                let n = n / len;
                if n.dot(ng) < 0.0 { -n } else { n }
            } else {
                ng
            }
        } else {
            ng
        };
        // Flatland: normals projected into the plane (the geometric one is in it up to the
        // validated 1e-4; shading normals may point anywhere), so scattered directions stay in it.
        let (ng, ns) = if FLAT {
            let pl = &self.flat().plane;
            let ngp = pl.in_plane(ng).unwrap_or(ng);
            // Without shading normals ns = ng, whose projection is ngp (the same bits).
            let nsp = if shading.is_none() {
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
            inst: raw.inst,
            ng,
            ns,
            material,
            eps: eps.max(1e-12),
            bary,
            eps_edge: eps,
        }
    }

    /// `hit.p` lies within twice the error bound of an edge of its triangle, where other surfaces
    /// may meet it (see [`Scene::spawn_origin_from`]). Asked only where a ray leaves the hit: a
    /// walk's last hit never needs it.
    #[inline(always)]
    pub fn near_edge(&self, hit: &Hit) -> bool {
        let [pa, pb, pc] = self.world_vertices(hit.inst, hit.prim);
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

impl Scene {
    /// The vertices of triangle `prim` seen through instance `inst` (as stored for
    /// [`NO_INSTANCE`]), in world space.
    #[inline]
    pub fn world_vertices(&self, inst: u32, prim: u32) -> [DVec3; 3] {
        let p = self.tri_hit[prim as usize].p;
        if inst == NO_INSTANCE {
            p.map(|q| q.as_dvec3())
        } else {
            let i = &self.instancing.instances[inst as usize];
            p.map(|q| i.point(q))
        }
    }

    /// The unit geometric normal (front side) of triangle `prim` seen through instance `inst`,
    /// from its world-space vertices as a flattened copy's (whose winding a mirroring transform
    /// reverses).
    #[inline]
    pub fn world_normal(&self, inst: u32, prim: u32) -> DVec3 {
        if inst == NO_INSTANCE {
            return self.tri_normal(prim as usize);
        }
        let i = &self.instancing.instances[inst as usize];
        let [a, b, c] = self.world_vertices(inst, prim);
        let n = (b - a).cross(c - a);
        let len = n.length();
        if len > 0.0 && len.is_finite() {
            let n = n / len;
            if i.mirrored { -n } else { n }
        } else {
            // Rounded to a sliver in world space: the exact image of the prototype's normal.
            (i.normal_matrix * self.tri_normal(prim as usize)).normalize_or_zero()
        }
    }

    /// The world-space shading normals of triangle `prim`'s corners through instance `inst`, as
    /// [`Instance::normal`](crate::scene::Instance::normal) gives them; `None` without shading
    /// normals.
    #[inline]
    pub(super) fn instance_corner_normals(&self, inst: u32, prim: u32) -> Option<[DVec3; 3]> {
        if self.tri_shading.is_empty() {
            return None;
        }
        let i = &self.instancing.instances[inst as usize];
        Some(self.tri_shading[prim as usize].map(|n| i.normal(n)))
    }

    /// True when the scene has instances.
    pub fn is_instanced(&self) -> bool {
        !self.instancing.is_empty()
    }

    /// The scene's instancing (prototypes and instances; empty without).
    pub fn instancing(&self) -> &Instancing {
        &self.instancing
    }

    /// Calls `f(inst, prim)` for every instanced triangle whose instance's bounds satisfy
    /// `near(bounds)`: the walk over instances × prototype triangles that the code which needs
    /// world-space triangles uses.
    pub fn for_instanced_triangles(
        &self,
        near: impl Fn(&Aabb) -> bool,
        mut f: impl FnMut(u32, u32) -> bool,
    ) -> bool {
        for (k, inst) in self.instancing.instances.iter().enumerate() {
            if !near(&inst.bounds) {
                continue;
            }
            let r = self.instancing.prototypes[inst.prototype as usize]
                .triangles
                .clone();
            for prim in r {
                if f(k as u32, prim) {
                    return true;
                }
            }
        }
        false
    }
}
