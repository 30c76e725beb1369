//! The arrays Embree reads in place (shared geometry buffers): immutable, padded as Embree
//! requires, and reference-counted so that the [`Accel`](super::Accel) reading them keeps them
//! alive.

use glam::Vec3;
use std::sync::Arc;

/// Zeroed elements after the end of a [`SharedArray`]: Embree reads vertices with 16-byte loads,
/// so the last one must be followed by at least 4 readable bytes; two elements (24 bytes for a
/// vertex, 24 for a triangle's indices) cover 16 bytes past the end whatever the element.
const SHARED_PAD: usize = 2;

// The layouts Embree is told (RTC_FORMAT_FLOAT3 and RTC_FORMAT_UINT3, stride 12).
const _: () = assert!(std::mem::size_of::<Vec3>() == 12 && std::mem::align_of::<Vec3>() == 4);
const _: () = assert!(std::mem::size_of::<[u32; 3]>() == 12);

/// An array that Embree reads in place (a shared geometry buffer): immutable (it derefs to a
/// slice and offers no way to change it), followed by `SHARED_PAD` zeroed elements that Embree
/// may read, and reference-counted, so that the [`Accel`](super::Accel) reading it keeps it
/// alive. Cloning shares the array.
pub struct SharedArray<T: Copy + Default>(Arc<Vec<T>>);

impl<T: Copy + Default> SharedArray<T> {
    /// Takes `v` over; its spare capacity is grown by the padding if needed (a reallocation that
    /// moves pages rather than copying them, for large arrays), which is zeroed.
    pub fn new(mut v: Vec<T>) -> Self {
        v.shrink_to(v.len() + SHARED_PAD);
        v.reserve_exact(SHARED_PAD);
        for p in &mut v.spare_capacity_mut()[..SHARED_PAD] {
            p.write(T::default());
        }
        SharedArray(Arc::new(v))
    }

    /// The elements and the padding after them, for Embree.
    pub(super) fn padded_ptr(&self) -> *const T {
        self.0.as_ptr()
    }
}

impl<T: Copy + Default> Clone for SharedArray<T> {
    fn clone(&self) -> Self {
        SharedArray(Arc::clone(&self.0))
    }
}

impl<T: Copy + Default> std::ops::Deref for SharedArray<T> {
    type Target = [T];
    fn deref(&self) -> &[T] {
        &self.0
    }
}

impl<T: Copy + Default + std::fmt::Debug> std::fmt::Debug for SharedArray<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list().entries(self.0.iter()).finish()
    }
}

impl<T: Copy + Default> Default for SharedArray<T> {
    fn default() -> Self {
        SharedArray::new(Vec::new())
    }
}
