//! Where samples start: planar slices (axis-aligned or arbitrary), voxel volumes and camera images.
//! Each domain is a grid of cells and knows how to draw one FTPD sample for a cell with any kernel.
pub mod camera;
pub mod slice;
pub mod tile;
pub mod volume;
pub use camera::CameraView;
pub use slice::{Axis, Plane};
pub use tile::{Stripe, Tile};
pub use volume::{Volume, VolumeRes};

use crate::ftpd::{self, Params, Sample};
use crate::kernel::Kernel;
use crate::rng::Sampler;
use crate::scene::Scene;

/// A grid of cells over which FTPD is estimated (see [`crate::app::run_domain_with`], which
/// dispatches the kernel once for any domain).
pub trait Domain: Sync {
    /// Grid size (width, height, depth); cells are numbered x fastest.
    fn dims(&self) -> (usize, usize, usize);
    /// One sample for `cell` with kernel `K`, drawn from the cell's stream `s`.
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

impl Domain for Volume {
    fn dims(&self) -> (usize, usize, usize) {
        (self.nx, self.ny, self.nz)
    }
    #[inline]
    fn sample<K: Kernel>(&self, scene: &Scene, cell: usize, p: &Params, s: &mut Sampler) -> Sample {
        let (a, b) = s.next_2d();
        let x = self.point(cell, (a, b, s.next_f64()));
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

/// Some cells of another domain, by index (cell `k` here is cell `cells[k]` there): the ETA
/// calibration samples a few random voxels of a volume through it.
pub struct Subset<'a, D> {
    pub inner: &'a D,
    pub cells: Vec<usize>,
}

impl<D: Domain> Domain for Subset<'_, D> {
    fn dims(&self) -> (usize, usize, usize) {
        (self.cells.len(), 1, 1)
    }
    #[inline]
    fn sample<K: Kernel>(&self, scene: &Scene, cell: usize, p: &Params, s: &mut Sampler) -> Sample {
        self.inner.sample::<K>(scene, self.cells[cell], p, s)
    }
}
