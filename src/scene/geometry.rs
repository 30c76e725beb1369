//! Geometry helpers that every part of the scene uses: bounding boxes, triangle normals,
//! barycentric coordinates, closest points and texture-coordinate interpolation. A leaf: it
//! imports nothing of `crate::scene`.

use glam::{DVec3, Vec2, Vec3};

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

/// The texture coordinate at barycentric `bary` = (u, v) of a triangle whose corners have `uv`:
/// (1 − u − v) uv₀ + u uv₁ + v uv₂.
#[inline]
pub fn interpolate_uv(uv: [Vec2; 3], bary: [f32; 2]) -> [f64; 2] {
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
