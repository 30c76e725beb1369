//! Allocation advice for large tables read at random on every hit.

#[cfg(target_os = "linux")]
use std::ffi::c_void;

/// An empty vector with room for `capacity` elements, whose buffer the operating system is asked
/// to back with transparent huge pages (Linux `madvise(MADV_HUGEPAGE)`; a plain vector elsewhere and
/// below 2 MiB). For per-triangle records read at random on every hit: on a scene of millions of
/// triangles each hit otherwise misses the TLB as well as the cache. Fill it before reading it;
/// the advice only changes how the kernel backs the pages, never what they hold, and where huge
/// pages are disabled it has no effect.
pub fn vec_with_huge_pages<T>(capacity: usize) -> Vec<T> {
    let mut v: Vec<T> = Vec::with_capacity(capacity);
    #[cfg(target_os = "linux")]
    {
        const HUGE_PAGE: usize = 2 << 20;
        let bytes = v.capacity().saturating_mul(std::mem::size_of::<T>());
        // SAFETY: sysconf has no preconditions.
        let page = unsafe { libc::sysconf(libc::_SC_PAGESIZE) };
        if bytes >= HUGE_PAGE && page > 0 {
            let page = page as usize;
            let start = v.as_mut_ptr() as usize;
            let (lo, hi) = (start.next_multiple_of(page), (start + bytes) / page * page);
            if hi > lo {
                // SAFETY: [lo, hi) are whole pages inside the vector's own allocation, which nothing
                // has read or written yet; MADV_HUGEPAGE is advice about the backing of those pages
                // and leaves their contents and the mapping's permissions as they are. A failure
                // (huge pages disabled) is harmless and ignored.
                let _ = unsafe { libc::madvise(lo as *mut c_void, hi - lo, libc::MADV_HUGEPAGE) };
            }
        }
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn huge_page_vectors_hold_what_is_put_in_them() {
        // Below, at and well above the 2 MiB threshold, and an odd element size, so that the
        // advised range starts and ends inside pages.
        for n in [
            0usize,
            1,
            1000,
            (2 << 20) / 8,
            (2 << 20) / 8 + 12_345,
            3_000_001,
        ] {
            let mut v: Vec<u64> = vec_with_huge_pages(n);
            assert!(v.capacity() >= n);
            v.extend((0..n as u64).map(|i| i.wrapping_mul(0x9E37_79B9_7F4A_7C15)));
            assert!(
                v.iter()
                    .enumerate()
                    .all(|(i, &x)| x == (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15))
            );
        }
        let mut w: Vec<[u8; 13]> = vec_with_huge_pages(400_000);
        w.extend((0..400_000u32).map(|i| [(i % 251) as u8; 13]));
        assert!(w.iter().enumerate().all(|(i, x)| x[12] == (i % 251) as u8));
    }
}
