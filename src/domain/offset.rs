//! How far a domain lies from the scene: where the default run lengths of a run over it start
//! (walks that end in empty space are never deflected, so pairs must reach the scene), and the
//! size of a flatland scene.

use super::Plane;
use crate::scene::flat::Flatland;
use crate::scene::{self, Scene};

/// Where a slice's default run lengths start: the distance between its rectangle and the scene's
/// bounds, 0 for a scene without bounds and for distances below 1e-9 of the scene's size (a
/// rectangle touching the bounds overlaps them).
pub fn plane_offset(scene: &Scene, plane: &Plane) -> f64 {
    if scene.bounds.is_empty() {
        return 0.0;
    }
    let d = plane.distance_to_box(&scene.bounds);
    if d > 1e-9 * scene.extent() { d } else { 0.0 }
}

/// The distance between two boxes (0 when they overlap).
pub fn box_offset(bounds: &scene::Aabb, bbox: &scene::Aabb) -> f64 {
    if bounds.is_empty() {
        return 0.0;
    }
    let gap = (bounds.min - bbox.max)
        .max(bbox.min - bounds.max)
        .max(glam::DVec3::ZERO);
    gap.length()
}

/// Diagonal of the bounds projected onto the plane of `fl` (the size of a flatland scene).
pub fn flat_extent(bounds: &scene::Aabb, fl: &Flatland) -> f64 {
    if bounds.is_empty() {
        return 1.0;
    }
    let (mut lo, mut hi) = (
        glam::DVec2::splat(f64::INFINITY),
        glam::DVec2::splat(f64::NEG_INFINITY),
    );
    for c in bounds.corners() {
        let q = glam::DVec2::new(c.dot(fl.e1), c.dot(fl.e2));
        lo = lo.min(q);
        hi = hi.max(q);
    }
    let d = (hi - lo).length();
    if d > 0.0 && d.is_finite() { d } else { 1.0 }
}
