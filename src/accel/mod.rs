//! The only module with `unsafe` Embree calls: a process-wide device, a committed triangle scene that
//! owns its Embree handles (RAII), and thread-safe `intersect` / `occluded` queries.
//!
//! Embree 3 and 4 share this code; the build script of `embree-sys` detects the header's major version
//! and the top-level build script turns it into the cfg `embree3` or `embree4`. Differences handled:
//! - Embree 3's queries take an `RTCIntersectContext`, initialised by a header-inline function that
//!   bindgen cannot see: it is initialised here in Rust (flags, no filter, invalid instance ids).
//! - Embree 4's queries take optional argument structs: passing null selects the defaults.
//!
//! Object lifecycle: a device is created once per process (its TBB thread pool is process-wide); a
//! scene is created, given one triangle geometry that reads the scene's own vertex and index arrays
//! in place (`rtcSetSharedGeometryBuffer`: no copies), committed, and released on drop. A scene
//! with cut-outs (alpha) has two geometries over the same vertex array: the opaque triangles, and
//! the cut-out ones with Embree's intersection and occlusion filter functions. The arrays
//! are [`SharedArray`]s: immutable, padded as Embree requires, and kept alive by the [`Accel`]
//! (a reference count) for as long as Embree may read them. After commit the scene is immutable
//! and queries may run on any thread.
//!
//! The submodules follow that lifecycle: `device` (the process-wide device, its error and memory
//! callbacks), `buffer` (the arrays Embree reads in place), `scene` (geometries, build and
//! commit), `cutout` (the alpha filter callbacks), `query` (ray queries), `near` (the point query)
//! `huge_pages` (allocation advice for large per-triangle tables), `triangles` (a triangle
//! geometry over ranges of the shared arrays) and `instances` (prototype scenes and their
//! instances, for instanced glTF). Every
//! `unsafe` block of the crate is in this module, each with its `// SAFETY:` note.

mod buffer;
mod cutout;
mod device;
mod huge_pages;
mod instances;
mod near;
mod query;
mod scene;
mod triangles;

pub use buffer::SharedArray;
pub use cutout::{CutRay, CutTest};
pub use device::{AccelError, EMBREE_CONFIG_VAR, embree_config, embree_memory};
pub use huge_pages::vec_with_huge_pages;
pub use instances::{InstanceXfm, NO_INSTANCE};
pub use near::{MAX_NEAR, Near};
pub use query::RawHit;

use cutout::Cutouts;
use embree_sys as sys;
use glam::Vec3;

/// A committed Embree scene of triangles; immutable and shareable across threads. It holds the
/// vertex and index arrays Embree reads (shared buffers), so they live at least as long as the
/// Embree scene: `Drop` releases the scene first, then the fields (the arrays) are dropped.
pub struct Accel {
    scene: sys::RTCScene,
    shared_positions: SharedArray<Vec3>,
    shared_triangles: SharedArray<[u32; 3]>,
    /// With cut-outs: geometry 0 holds the opaque triangles, geometry 1 those that may be cut
    /// out, with the filter functions; `None` (one geometry of all triangles, no filter) otherwise.
    /// Boxed, so that the address Embree holds as the geometry's user data stays put; dropped after
    /// the scene (`Drop` releases the scene before the fields go).
    cutouts: Option<Box<Cutouts>>,
    /// The prototype scenes that the instance geometries refer to (empty without instances);
    /// released after the top-level scene.
    prototypes: Vec<instances::ProtoScene>,
    /// Per instance, the index of its prototype's first triangle in the buffer given at build
    /// time: a hit's `primID` within the prototype plus this is its index there.
    instance_first: Vec<u32>,
}

// SAFETY: a committed Embree scene is read-only; Embree documents rtcIntersect1/rtcOccluded1 as safe
// to call concurrently from many threads on the same committed scene.
unsafe impl Send for Accel {}
// SAFETY: as above; no method mutates the scene after commit.
unsafe impl Sync for Accel {}

impl Drop for Accel {
    fn drop(&mut self) {
        // SAFETY: self.scene is a live scene handle owned by this value and released exactly once.
        unsafe { sys::rtcReleaseScene(self.scene) };
    }
}

impl Accel {
    /// Sets the test that decides, per candidate hit, whether a cut-out triangle is absent there
    /// (see [`CutTest`]); no effect on a scene built without cut-outs.
    pub fn set_cut_test(&mut self, test: Box<CutTest>) {
        if let Some(c) = self.cutouts.as_mut() {
            c.test = Some(test);
        }
    }

    /// True when the scene was built with cut-out triangles.
    pub fn has_cutouts(&self) -> bool {
        self.cutouts.is_some()
    }

    /// The index into the triangles given at build time of triangle `prim` of geometry `geom`.
    #[inline]
    fn global(&self, geom: u32, prim: u32) -> u32 {
        match &self.cutouts {
            None => prim,
            Some(c) => c.global(geom, prim),
        }
    }

    /// The instance (or [`NO_INSTANCE`]) and the index into the triangles given at build time of
    /// what Embree reports as instance id `inst_id`, geometry `geom` and primitive `prim`.
    #[inline(always)]
    fn resolve(&self, inst_id: u32, geom: u32, prim: u32) -> (u32, u32) {
        if inst_id == sys::RTC_INVALID_GEOMETRY_ID {
            (NO_INSTANCE, self.global(geom, prim))
        } else {
            self.resolve_instance(inst_id, prim)
        }
    }

    /// [`Accel::resolve`] for a hit on an instance; out of line, so that the ray queries of
    /// scenes without instances stay as small as they were (and are inlined where they were).
    #[inline(never)]
    fn resolve_instance(&self, inst_id: u32, prim: u32) -> (u32, u32) {
        let k = inst_id - instances::FIRST_INSTANCE_GEOM;
        (k, self.instance_first[k as usize] + prim)
    }
}
