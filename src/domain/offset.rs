//! How far a domain lies from the scene: where the default run lengths of a run over it start
//! (walks that end in empty space are never deflected, so pairs must reach the scene), and the
//! size of a flatland scene.

use super::{CameraView, Plane};
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

/// Rays per side of the grid over the image that [`camera_offset`] probes the view with (odd, so
/// that one looks along the view's centre).
const CAMERA_PROBES: usize = 17;

/// Where a camera's default run lengths start: the distance from the eye to the nearest surface
/// its view meets, probed by a grid of [`CAMERA_PROBES`]² rays over the image, and never less than
/// the distance to the scene's bounds (which is all there is when no probe meets a surface). A
/// camera inside a room sees its walls further away than a fraction of the room's diagonal: run
/// lengths from the eye that end before them would never be deflected.
pub fn camera_offset(scene: &Scene, view: &CameraView) -> f64 {
    let eye = view.camera.eye;
    let to_bounds = if scene.bounds.is_empty() {
        0.0
    } else {
        scene.bounds.distance(eye)
    };
    let last = (CAMERA_PROBES - 1) as f64;
    let mut nearest = f64::INFINITY;
    for j in 0..CAMERA_PROBES {
        for i in 0..CAMERA_PROBES {
            let d = view.direction_at(i as f64 / last, j as f64 / last);
            if let Some(hit) = scene.intersect(eye, d, f64::INFINITY) {
                nearest = nearest.min((hit.p - eye).length());
            }
        }
    }
    if nearest.is_finite() {
        nearest.max(to_bounds)
    } else {
        to_bounds
    }
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
