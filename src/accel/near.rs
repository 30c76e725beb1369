//! The point query: the triangles near a point, for placing points on surfaces.

use super::Accel;
use super::query::Spare;
use embree_sys as sys;
use glam::Vec3;
use std::ffi::c_void;

/// Most triangles one [`Accel::triangles_near`] query reports.
pub const MAX_NEAR: usize = 64;

/// Triangles reported by a point query, in the order Embree found them.
#[derive(Clone, Copy, Debug)]
pub struct Near {
    prims: [u32; MAX_NEAR],
    /// The geometry of each (0, or 1 for cut-out triangles), until mapped to triangle indices.
    geoms: [u32; MAX_NEAR],
    /// The instance of each: Embree's instance id until mapped, then the instance's index or
    /// [`NO_INSTANCE`](super::NO_INSTANCE).
    insts: [u32; MAX_NEAR],
    len: usize,
}

impl Near {
    pub fn prims(&self) -> &[u32] {
        &self.prims[..self.len]
    }

    /// The instance of each of [`Near::prims`] (for an instance's triangle, `prims` holds its
    /// prototype's triangle).
    pub fn insts(&self) -> &[u32] {
        &self.insts[..self.len]
    }
}

/// Point-query callback: records the primitive (up to [`MAX_NEAR`]) and never shrinks the query
/// radius. Plain stores only, so it cannot unwind into Embree.
unsafe extern "C" fn collect_near(args: *mut sys::RTCPointQueryFunctionArguments) -> bool {
    // SAFETY: Embree passes valid arguments for the duration of the call; their `userPtr` is the
    // `Near` that `triangles_near` handed to rtcPointQuery, live and used by nobody else meanwhile;
    // their `context` is the context handed to rtcPointQuery (checked for null all the same).
    // Within an instance, its id is `instID[0]`, outside one the invalid id `triangles_near`
    // put there (the stack size is not read: it moves in libraries built with instance arrays,
    // see `Spare`; `instID` does not).
    let (prim, geom, inst, near) = unsafe {
        let ctx = (*args).context;
        let inst = if ctx.is_null() {
            sys::RTC_INVALID_GEOMETRY_ID
        } else {
            (*ctx).instID[0]
        };
        (
            (*args).primID,
            (*args).geomID,
            inst,
            &mut *((*args).userPtr as *mut Near),
        )
    };
    if near.len < MAX_NEAR {
        near.prims[near.len] = prim;
        near.geoms[near.len] = geom;
        near.insts[near.len] = inst;
        near.len += 1;
    }
    false
}

impl Accel {
    /// The triangles whose bounding boxes come within `radius` of `p` (a superset of the triangles
    /// within `radius`; at most [`MAX_NEAR`] of them). Nothing for a non-finite point or radius.
    pub fn triangles_near(&self, p: Vec3, radius: f32) -> Near {
        let mut near = Near {
            prims: [0; MAX_NEAR],
            geoms: [0; MAX_NEAR],
            insts: [super::NO_INSTANCE; MAX_NEAR],
            len: 0,
        };
        if !(p.is_finite() && radius.is_finite() && radius >= 0.0) {
            return near;
        }
        let mut query = sys::RTCPointQuery {
            x: p.x,
            y: p.y,
            z: p.z,
            time: 0.0,
            radius,
        };
        // Embree's header-inline rtcInitPointQueryContext: no instance on the stack. Every byte
        // is zeroed first, the struct's tail padding and the spare words after it included: a
        // library built with instance arrays reads `instStackSize` one word later than a header
        // without them says, i.e. from what is padding here, and must read 0 there too.
        let mut buf = std::mem::MaybeUninit::<Spare<sys::RTCPointQueryContext>>::zeroed();
        let ctx: *mut sys::RTCPointQueryContext = buf.as_mut_ptr().cast();
        // SAFETY: `ctx` points into `buf`, which is live, aligned for the struct and all zero; all
        // zero bytes are a valid RTCPointQueryContext (floats and u32s only), and the fields are
        // written in place, so no typed copy drops the zeroed padding.
        unsafe {
            (*ctx).instStackSize = 0;
            for id in (*ctx).instID.iter_mut() {
                *id = sys::RTC_INVALID_GEOMETRY_ID;
            }
        }
        // SAFETY: the scene is committed and immutable (point queries may run concurrently like
        // ray queries); query and ctx are valid, 16-byte aligned (bindgen keeps the alignment) and
        // live for the call; the callback only writes to `near`, which outlives the call.
        unsafe {
            sys::rtcPointQuery(
                self.scene,
                &mut query,
                ctx,
                Some(collect_near),
                &mut near as *mut Near as *mut c_void,
            )
        };
        if self.cutouts.is_some() || !self.instance_first.is_empty() {
            for k in 0..near.len {
                (near.insts[k], near.prims[k]) =
                    self.resolve(near.insts[k], near.geoms[k], near.prims[k]);
            }
        }
        near
    }
}
