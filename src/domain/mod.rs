//! Where samples start: planar slices (axis-aligned or arbitrary), voxel volumes and camera images.
//! Each domain is a grid of cells and knows where a sample of a cell starts (a point, or an eye and
//! a direction); the estimator ([`crate::ftpd::sample`]) does the rest with the run's kernel.
pub mod camera;
pub mod offset;
pub mod slice;
pub mod tile;
pub mod volume;
pub use camera::CameraView;
pub use slice::{Axis, Plane};
pub use tile::Tile;
pub use volume::{Volume, VolumeRes};

use crate::ftpd::Start;
use crate::rng::Sampler;
use crate::scene::Scene;
use glam::DVec3;

/// Largest accepted grid side (a slice's cells along its longer side, a camera image's pixels
/// each way).
pub const MAX_RES: usize = 16384;

/// A domain that cannot be built, as a typed value; the command line names its flags in the
/// message (`cli::errors`), other callers their own.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum DomainError {
    #[error("slice {slice}: the scene has no geometry to take bounds from; give a window")]
    SliceWithoutBounds { slice: String },
    #[error("slice {slice}: outside the scene bounds, which span {lo} to {hi} along that axis")]
    SliceOutsideBounds { slice: String, lo: f64, hi: f64 },
    #[error(
        "window {}: needs u0 < u1 and v0 < v1 (an empty rectangle)",
        commas(window)
    )]
    EmptyWindow { window: [f64; 4] },
    #[error(
        "window {}: the plane's size={w},{h} sets its rectangle too; give one of them",
        commas(window)
    )]
    WindowAndSize { window: [f64; 4], w: f64, h: f64 },
    #[error("a grid needs at least 1 cell along its longer side")]
    NoCells,
    #[error("plane {label}: size {w} x {h} is empty")]
    EmptyPlane { label: String, w: f64, h: f64 },
    #[error("plane: up ({}, {}, {}) is parallel to the normal", up.x, up.y, up.z)]
    UpAlongNormal { up: DVec3 },
    #[error("plane: the scene has no bounds to cover; give size=w,h")]
    PlaneWithoutBounds,
    /// An `AXIS=VALUE` that does not parse; the parser's message (which quotes the value).
    #[error("slice {0}")]
    SliceSyntax(String),
    #[error("slice {name}: the scene file's plane {message}")]
    NamedSliceSyntax { name: String, message: String },
    #[error("slice {name}: expected AXIS=VALUE such as z=1.2 (the scene names no slices)")]
    NoNamedSlices { name: String },
    #[error("slice {name}: not AXIS=VALUE and not a slice of the scene file (it names: {names})")]
    UnknownSlice { name: String, names: String },
    #[error(
        "box {}: needs xmin < xmax, ymin < ymax and zmin < zmax (an empty box)",
        commas(bbox)
    )]
    EmptyBox { bbox: [f64; 6] },
    #[error("volume: the scene has no geometry to take bounds from; give a box")]
    VolumeWithoutBounds,
    #[error("volume: every axis needs at least 1 voxel")]
    NoVoxels,
    #[error("volume box {min:?} .. {max:?} is empty")]
    EmptyVolumeBox { min: DVec3, max: DVec3 },
    #[error("image size {w},{h}: the image needs at least one pixel each way")]
    EmptyImage { w: usize, h: usize },
    #[error("camera '{name}': vertical field of view {fov_deg}° must lie between 0 and 180")]
    FieldOfView { name: String, fov_deg: f64 },
    #[error("camera '{name}': the up vector is parallel to the viewing direction (or zero)")]
    UpAlongView { name: String },
}

/// `1,2,3`: numbers as the command line takes them.
pub fn commas(v: &[f64]) -> String {
    v.iter().map(f64::to_string).collect::<Vec<_>>().join(",")
}

/// A grid of cells over which FTPD is estimated. Object-safe: the driver runs any domain through
/// `&dyn Domain`, and only the four kernels ([`crate::kernel`]) are compiled, not one copy per
/// domain type.
pub trait Domain: Sync {
    /// Grid size (width, height, depth); cells are numbered x fastest.
    fn dims(&self) -> (usize, usize, usize);
    /// Where one sample for `cell` starts, drawn from the cell's stream `s` (the estimator goes on
    /// drawing from the same stream).
    fn start(&self, scene: &Scene, cell: usize, s: &mut Sampler) -> Start;
}

impl Domain for Plane {
    fn dims(&self) -> (usize, usize, usize) {
        (self.width, self.height, 1)
    }
    #[inline]
    fn start(&self, _scene: &Scene, cell: usize, s: &mut Sampler) -> Start {
        Start::Point(self.point(cell, s.next_2d()))
    }
}

/// A plane as runs sample it. Where a surface lies in the plane (a slice through a wall,
/// [`Scene::surface_in_plane`]), sample points start on the front side of the surfaces they lie on
/// ([`Scene::off_surfaces`]); elsewhere they are the plane's own points. Same cells and random
/// streams either way.
pub struct PlaneDomain<'a> {
    plane: &'a Plane,
    on_surfaces: bool,
}

impl<'a> PlaneDomain<'a> {
    /// Decides once, for the whole run, whether `plane` cuts a surface of `scene` lying in it.
    pub fn new(plane: &'a Plane, scene: &Scene) -> Self {
        PlaneDomain {
            plane,
            on_surfaces: scene.surface_in_plane(plane.origin, plane.normal()),
        }
    }
}

impl Domain for PlaneDomain<'_> {
    fn dims(&self) -> (usize, usize, usize) {
        self.plane.dims()
    }
    #[inline]
    fn start(&self, scene: &Scene, cell: usize, s: &mut Sampler) -> Start {
        let [u0, u1] = s.next_n();
        let x = self.plane.point(cell, (u0, u1));
        Start::Point(if self.on_surfaces {
            moved_off(scene, x)
        } else {
            x
        })
    }
}

/// [`Scene::off_surfaces`], not inlined: inlined into [`PlaneDomain::start`] its point query made
/// every sample's start save and restore registers, planes that cut no surface too.
#[inline(never)]
fn moved_off(scene: &Scene, x: DVec3) -> DVec3 {
    scene.off_surfaces(x)
}

impl Domain for Volume {
    fn dims(&self) -> (usize, usize, usize) {
        (self.nx, self.ny, self.nz)
    }
    #[inline]
    fn start(&self, _scene: &Scene, cell: usize, s: &mut Sampler) -> Start {
        let (a, b) = s.next_2d();
        Start::Point(self.point(cell, (a, b, s.next_f64())))
    }
}

impl Domain for CameraView {
    fn dims(&self) -> (usize, usize, usize) {
        (self.width, self.height, 1)
    }
    #[inline]
    fn start(&self, _scene: &Scene, cell: usize, s: &mut Sampler) -> Start {
        Start::Eye {
            eye: self.camera.eye,
            dir: self.direction(cell, s.next_2d()),
        }
    }
}

/// Some cells of another domain, by index (cell `k` here is cell `cells[k]` there): the ETA
/// calibration samples a few random voxels of a volume through it.
pub struct Subset<'a> {
    pub inner: &'a dyn Domain,
    pub cells: Vec<usize>,
}

impl Domain for Subset<'_> {
    fn dims(&self) -> (usize, usize, usize) {
        (self.cells.len(), 1, 1)
    }
    #[inline]
    fn start(&self, scene: &Scene, cell: usize, s: &mut Sampler) -> Start {
        self.inner.start(scene, self.cells[cell], s)
    }
}
