//! Instanced geometry (glTF's EXT_mesh_gpu_instancing): each prototype (a mesh's triangles,
//! stored once in prototype space) is an Embree scene of its own, and each instance a geometry of
//! type `RTC_GEOMETRY_TYPE_INSTANCE` in the top-level scene that refers to its prototype's scene
//! with a 3×4 affine transform (prototype to world). Embree transforms rays into prototype space
//! while traversing an instance and reports the instance in `RTCHit::instID[0]`; the hit's
//! `primID` is the triangle within the prototype. The same calls exist in Embree 3.13 and 4.x.
//!
//! Geometry ids in the top-level scene: 0 and 1 are the world-space triangles (opaque and
//! cut-out, see `scene`), instance `k` is geometry [`FIRST_INSTANCE_GEOM`] + `k`.

use super::buffer::SharedArray;
use super::device::{AccelError, check};
use super::triangles::attach;
use embree_sys as sys;
use glam::Vec3;
use std::ops::Range;

/// The top-level geometry id of instance 0.
pub(super) const FIRST_INSTANCE_GEOM: u32 = 2;

/// The `instance` of a hit or point-query result on world-space triangles.
pub const NO_INSTANCE: u32 = u32::MAX;

/// One instance as the acceleration structure sees it: its prototype (an index into the
/// prototypes' triangle ranges) and its prototype-to-world transform, 3×4 column-major (the
/// three columns of the linear part, then the translation), in f32 as Embree takes it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InstanceXfm {
    pub prototype: u32,
    pub columns: [[f32; 3]; 4],
}

/// A committed prototype scene, released when dropped (after the top-level scene that refers to
/// it: `Accel`'s `Drop` releases the top-level scene first, then the fields go).
pub(super) struct ProtoScene(pub(super) sys::RTCScene);

impl Drop for ProtoScene {
    fn drop(&mut self) {
        // SAFETY: the handle is a live scene owned by this value and released exactly once.
        unsafe { sys::rtcReleaseScene(self.0) };
    }
}

/// Builds and commits one scene per prototype, each with one triangle geometry that reads the
/// prototype's range of the shared index array (over the shared vertex array) in place.
pub(super) fn prototype_scenes(
    dev: sys::RTCDevice,
    positions: &SharedArray<Vec3>,
    triangles: &SharedArray<[u32; 3]>,
    ranges: &[Range<u32>],
) -> Result<Vec<ProtoScene>, AccelError> {
    let mut scenes = Vec::with_capacity(ranges.len());
    for r in ranges {
        // SAFETY: dev is live; the scene is owned by the `ProtoScene` pushed right after, which
        // releases it (also when a later step fails).
        let scene = unsafe { sys::rtcNewScene(dev) };
        check(dev, "rtcNewScene (prototype)")?;
        scenes.push(ProtoScene(scene));
        // SAFETY: scene is live. Robust mode as for the top-level scene (rays cross shared edges).
        unsafe {
            sys::rtcSetSceneFlags(scene, sys::RTCSceneFlags_RTC_SCENE_FLAG_ROBUST);
            sys::rtcSetSceneBuildQuality(scene, sys::RTCBuildQuality_RTC_BUILD_QUALITY_HIGH);
        }
        if !r.is_empty() {
            attach(dev, scene, 0, positions, triangles, r.clone(), None)?;
        }
        // SAFETY: scene is live and fully described.
        unsafe { sys::rtcCommitScene(scene) };
        check(dev, "rtcCommitScene (prototype)")?;
    }
    Ok(scenes)
}

/// Attaches instance `k` of `instances` to `scene` as geometry [`FIRST_INSTANCE_GEOM`] + `k`,
/// referring to the committed `prototypes`.
pub(super) fn attach_instances(
    dev: sys::RTCDevice,
    scene: sys::RTCScene,
    prototypes: &[ProtoScene],
    instances: &[InstanceXfm],
) -> Result<(), AccelError> {
    for (k, inst) in instances.iter().enumerate() {
        let proto = &prototypes[inst.prototype as usize];
        // SAFETY: dev is live; the geometry is released after being attached (the scene keeps a
        // reference), or below on error.
        let geom =
            unsafe { sys::rtcNewGeometry(dev, sys::RTCGeometryType_RTC_GEOMETRY_TYPE_INSTANCE) };
        check(dev, "rtcNewGeometry (instance)")?;
        // SAFETY: geom is live; proto.0 is a live committed scene (Embree takes its own reference
        // to it); the transform is 12 f32 in the column-major 3×4 layout the format names, read
        // (copied) during the call.
        unsafe {
            sys::rtcSetGeometryInstancedScene(geom, proto.0);
            sys::rtcSetGeometryTransform(
                geom,
                0,
                sys::RTCFormat_RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR,
                inst.columns.as_ptr() as *const std::ffi::c_void,
            );
        }
        if let Err(e) = check(dev, "instance transform") {
            // SAFETY: geom is live and not yet attached.
            unsafe { sys::rtcReleaseGeometry(geom) };
            return Err(e);
        }
        // SAFETY: geom and scene are live; after attaching, the scene holds its own reference.
        unsafe {
            sys::rtcCommitGeometry(geom);
            sys::rtcAttachGeometryByID(scene, geom, FIRST_INSTANCE_GEOM + k as u32);
            sys::rtcReleaseGeometry(geom);
        }
        check(dev, "instance commit")?;
    }
    Ok(())
}
