//! Where samples start: planar slices, camera images (and volumes). Each domain is a grid of cells
//! and knows how to draw one FTPD sample for a cell with any kernel.
pub mod camera;
pub mod slice;
pub use camera::CameraView;
pub use slice::{Axis, Plane};

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

/// A plane with a surface lying in it (a slice through a wall, [`Scene::surface_in_plane`]): its
/// sample points start on the front side of the surfaces they lie on ([`Scene::off_surfaces`]).
/// Same cells and random streams as the plane itself.
pub struct PlaneOnSurfaces<'a>(pub &'a Plane);

impl Domain for PlaneOnSurfaces<'_> {
    fn dims(&self) -> (usize, usize, usize) {
        self.0.dims()
    }
    #[inline]
    fn sample<K: Kernel>(&self, scene: &Scene, cell: usize, p: &Params, s: &mut Sampler) -> Sample {
        let x = scene.off_surfaces(self.0.point(cell, s.next_2d()));
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
