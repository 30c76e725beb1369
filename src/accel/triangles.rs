//! A triangle geometry that reads ranges of the shared vertex and index arrays in place: what the
//! world-space geometries (`scene`) and the prototypes (`instances`) are made of.

use super::SharedArray;
use super::cutout::cutout_filter;
use super::device::{AccelError, check};
use embree_sys as sys;
use glam::Vec3;
use std::ffi::c_void;
use std::ops::Range;

/// Gives `scene` a triangle geometry with id `id` that reads the triangles `range` of `triangles`
/// over `positions` in place; with `filter_data`, the cut-out filters and that pointer as the
/// geometry's user data (a live `Cutouts` the caller keeps alive).
pub(super) fn attach(
    dev: sys::RTCDevice,
    scene: sys::RTCScene,
    id: u32,
    positions: &SharedArray<Vec3>,
    triangles: &SharedArray<[u32; 3]>,
    range: Range<u32>,
    filter_data: Option<*mut c_void>,
) -> Result<(), AccelError> {
    debug_assert!(range.start <= range.end && range.end as usize <= triangles.len());
    // SAFETY: dev is live; the geometry is released after being attached (the scene keeps a
    // reference), or below on error.
    let geom = unsafe { sys::rtcNewGeometry(dev, sys::RTCGeometryType_RTC_GEOMETRY_TYPE_TRIANGLE) };
    check(dev, "rtcNewGeometry")?;
    // SAFETY: geom is live. The arrays are Vec3 (three f32, 12 bytes, `glam`'s layout without
    // SIMD alignment) and [u32; 3] (12 bytes), 4-byte aligned as Embree requires, of exactly the
    // item counts given, followed by SHARED_PAD zeroed elements (24 bytes), so Embree's 16-byte
    // loads of the last vertex stay inside the allocation. They are never changed (`SharedArray`
    // has no mutable access) and outlive the Embree scene: the caller's `Accel` holds a reference
    // to each (the index arrays of cut-out scenes through its `Cutouts`) and releases the scene
    // before dropping them (on error too, since the `Accel` is dropped then). The range lies
    // within the index array (a byte offset of 12 per triangle keeps the 4-byte alignment).
    unsafe {
        sys::rtcSetSharedGeometryBuffer(
            geom,
            sys::RTCBufferType_RTC_BUFFER_TYPE_VERTEX,
            0,
            sys::RTCFormat_RTC_FORMAT_FLOAT3,
            positions.padded_ptr() as *const c_void,
            0,
            12,
            positions.len(),
        );
        sys::rtcSetSharedGeometryBuffer(
            geom,
            sys::RTCBufferType_RTC_BUFFER_TYPE_INDEX,
            0,
            sys::RTCFormat_RTC_FORMAT_UINT3,
            triangles.padded_ptr() as *const c_void,
            12 * range.start as usize,
            12,
            range.len(),
        );
    }
    if let Err(e) = check(dev, "shared geometry buffers") {
        // SAFETY: geom is live and not yet attached.
        unsafe { sys::rtcReleaseGeometry(geom) };
        return Err(e);
    }
    if let Some(user) = filter_data {
        // SAFETY: geom is live; `user` points to a `Cutouts` that the caller keeps alive and
        // unmoved as long as the scene exists, which is what `cutout_filter` reads.
        unsafe {
            sys::rtcSetGeometryUserData(geom, user);
            sys::rtcSetGeometryIntersectFilterFunction(geom, Some(cutout_filter));
            sys::rtcSetGeometryOccludedFilterFunction(geom, Some(cutout_filter));
        }
    }
    // SAFETY: geom and scene are live; after attaching, the scene holds its own reference, so
    // releasing ours is the documented pattern.
    unsafe {
        sys::rtcCommitGeometry(geom);
        sys::rtcAttachGeometryByID(scene, geom, id);
        sys::rtcReleaseGeometry(geom);
    }
    check(dev, "geometry commit")
}
