//! Where samples start: planar slices, camera images (and volumes). Each domain is a grid of cells
//! and knows how to draw one FTPD sample for a cell with any kernel.
pub mod camera;
pub mod slice;
pub mod tile;
pub use camera::CameraView;
pub use slice::{Axis, Plane};
pub use tile::{Stripe, Tile};

use crate::ftpd::{self, Params, Sample};
use crate::kernel::Kernel;
use crate::rng::Sampler;
use crate::scene::Scene;

/// A grid of cells over which FTPD is estimated.
pub trait Domain: Sync {
    /// Grid size (width, height, depth); cells are numbered x fastest.
    fn dims(&self) -> (usize, usize, usize);
    /// One sample for `cell` with kernel `K`.
    fn sample<K: Kernel>(&self, scene: &Scene, cell: usize, p: &Params, s: &mut Sampler) -> Sample;
}

impl Domain for Plane {
    fn dims(&self) -> (usize, usize, usize) {
        (self.width, self.height, 1)
    }
    #[inline]
    fn sample<K: Kernel>(&self, scene: &Scene, cell: usize, p: &Params, s: &mut Sampler) -> Sample {
        let x = self.point(cell, s.next_2d());
        ftpd::sample_at_k::<K>(scene, x, p, s)
    }
}

impl Domain for CameraView {
    fn dims(&self) -> (usize, usize, usize) {
        (self.width, self.height, 1)
    }
    #[inline]
    fn sample<K: Kernel>(&self, scene: &Scene, cell: usize, p: &Params, s: &mut Sampler) -> Sample {
        let d = self.direction(cell, s.next_2d());
        ftpd::sample_camera_k::<K>(scene, self.camera.eye, d, p, s)
    }
}
