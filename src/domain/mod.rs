//! Where samples start: planar slices (axis-aligned or arbitrary) and voxel volumes; later cameras.
pub mod slice;
pub mod volume;
pub use slice::{Axis, Plane};
pub use volume::{Volume, VolumeRes};

use crate::rng::Sampler;
use glam::DVec3;

/// A grid of cells and where a cell's sample points lie: the only thing that differs between a
/// plane run and a volume run (see [`crate::app::run_domain_with`]).
pub trait Domain: Sync {
    /// Cells along x (u), y (v) and z; a plane has depth 1.
    fn dims(&self) -> [usize; 3];
    /// A jittered sample point of `cell`, drawn from the cell's stream.
    fn point(&self, cell: usize, s: &mut Sampler) -> DVec3;
}

impl Domain for Plane {
    fn dims(&self) -> [usize; 3] {
        [self.width, self.height, 1]
    }
    #[inline]
    fn point(&self, cell: usize, s: &mut Sampler) -> DVec3 {
        Plane::point(self, cell, s.next_2d())
    }
}

/// Some cells of another domain, by index (cell `k` here is cell `cells[k]` there): the ETA
/// calibration samples a few random voxels of a volume through it.
pub struct Subset<'a> {
    pub inner: &'a dyn Domain,
    pub cells: Vec<usize>,
}

impl Domain for Subset<'_> {
    fn dims(&self) -> [usize; 3] {
        [self.cells.len(), 1, 1]
    }
    #[inline]
    fn point(&self, cell: usize, s: &mut Sampler) -> DVec3 {
        self.inner.point(self.cells[cell], s)
    }
}
