//! Where rays start: points moved off the surfaces they lie on (within the float error bound), so
//! that a ray query from them is well posed, for hits at the edges of their triangles and for free
//! points (sample points, camera eyes) that lie on a surface.

use crate::scene::geometry::closest_point_on_triangle;
use crate::scene::hit::Hit;
use crate::scene::model::Scene;
use glam::DVec3;

impl Scene {
    /// Origin for a ray leaving `hit` along `dir` on a path that arrived from `from` (the origin of
    /// the ray that hit, off every surface): [`Hit::spawn_origin`], and where the hit lies at an edge of its triangle, also off
    /// the other surfaces that meet there (a room's corner, a box's edge), on the side where the
    /// path is: the side it came from, or the other one for a path that went through the hit
    /// surface. A path hitting the edge between two walls of a closed room otherwise started its
    /// next ray within rounding of the other wall's plane, and could pass through it and leave the
    /// room. Parallel surfaces (the hit surface's own neighbours) are left alone.
    #[inline]
    pub fn spawn_origin_from(&self, hit: &Hit, dir: DVec3, from: DVec3) -> DVec3 {
        self.spawn_origin_at(hit, self.near_edge(hit), dir, from)
    }

    /// [`spawn_origin_from`](Self::spawn_origin_from) with `near_edge`, [`Scene::near_edge`] of
    /// `hit`, already known: a vertex that spawns several rays (next-event estimation, the
    /// mirror images, the path's next segment) tests it once.
    #[inline(always)]
    pub fn spawn_origin_at(&self, hit: &Hit, near_edge: bool, dir: DVec3, from: DVec3) -> DVec3 {
        let o = hit.spawn_origin(dir);
        if near_edge {
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
            |t, n| t == (hit.inst, hit.prim) || n.dot(hit.ng).abs() > 1.0 - 1e-9,
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
    /// triangles). Triangles for which `skip((instance, index), normal)` holds are ignored.
    #[allow(clippy::too_many_arguments)]
    fn move_off(
        &self,
        start: DVec3,
        at: DVec3,
        eps: f64,
        prims: &[(u32, u32)],
        keep: Option<(DVec3, DVec3)>,
        skip: impl Fn((u32, u32), DVec3) -> bool,
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
        for &(inst, i) in prims {
            let n = self.world_normal(inst, i);
            if skip((inst, i), n) {
                continue;
            }
            let [a, b, c] = self.world_vertices(inst, i);
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

    /// The triangles an Embree point query finds within `radius` of `p` (by bounding box), as
    /// (instance, index) pairs in increasing order, so that what is done with them never depends
    /// on Embree's traversal order.
    fn triangles_near_sorted(
        &self,
        p: DVec3,
        radius: f64,
    ) -> ([(u32, u32); crate::accel::MAX_NEAR], usize) {
        let near = self.accel.triangles_near(p.as_vec3(), radius as f32);
        let mut prims = [(0u32, 0u32); crate::accel::MAX_NEAR];
        let mut len = near.prims().len();
        for (k, (&inst, &prim)) in near.insts().iter().zip(near.prims()).enumerate() {
            prims[k] = (inst, prim);
        }
        if self.features.cutouts {
            // Triangles cut out where the point lies are not there for it either (instances
            // have no cut-outs: the loader keeps those in world space).
            let mut kept = 0;
            for k in 0..len {
                let (inst, prim) = prims[k];
                if inst != crate::accel::NO_INSTANCE || !self.cut_at(prim, p) {
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

    /// True when some triangle lies in the plane through `origin` with unit normal `normal` (all
    /// three vertices within the float error bound of it): a slice through a wall, whose sample
    /// points must start off the surface ([`Scene::off_surfaces`]).
    pub fn surface_in_plane(&self, origin: DVec3, normal: DVec3) -> bool {
        let normal = normal.normalize_or_zero();
        let in_plane =
            |p: DVec3| (p - origin).dot(normal).abs() <= self.eps_at(p).max(self.eps_at(origin));
        if normal == DVec3::ZERO {
            return false;
        }
        let world = self.instancing.world_triangles(self.triangles.len());
        self.triangles[..world].iter().any(|t| {
            t.iter()
                .all(|&i| in_plane(self.positions[i as usize].as_dvec3()))
        }) || self.for_instanced_triangles(
            |b| {
                // Only instances whose bounds reach the plane (within the error bound).
                let s = b.corners().map(|c| (c - origin).dot(normal));
                let tol = self
                    .eps_at(b.min.abs().max(b.max.abs()))
                    .max(self.eps_at(origin));
                s.iter().any(|&x| x >= -tol) && s.iter().any(|&x| x <= tol)
            },
            |inst, prim| self.world_vertices(inst, prim).into_iter().all(in_plane),
        )
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
