//! The validated job: what to run (scene, domain, lights, estimator settings, budgets) and what to
//! write, as the command line hands it to [`super::run_job`].

use crate::analysis::separatrix::SepParams;
use crate::domain::VolumeRes;
use crate::domain::slice::SliceArg;
use crate::params::EstimatorArgs;
use crate::render::RenderOptions;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Cells along the longer side of a slice when none is given.
pub const DEFAULT_RES: usize = 256;
/// A camera image's size in pixels (width, height) when none is given.
pub const DEFAULT_IMAGE_SIZE: (usize, usize) = (512, 512);
/// The vertical field of view, in degrees, of a camera placed by eye and target when none is given.
pub const DEFAULT_FOV_DEG: f64 = 40.0;
/// The up vector of a camera placed by eye and target when none is given.
pub const DEFAULT_UP: glam::DVec3 = glam::DVec3::Y;

/// Where a run's samples start.
#[derive(Clone, Debug)]
pub enum DomainArg {
    /// One or more planes (axis slices, named slices or arbitrary planes), optionally a window
    /// (axis slices only), cells along the longer side. Each plane is written to its own file.
    Slice {
        slices: Vec<SliceArg>,
        window: Option<[f64; 4]>,
        res: usize,
    },
    /// A camera image of `size` pixels (width, height).
    Camera {
        camera: CameraArg,
        size: (usize, usize),
    },
    /// A voxel grid, written as `.vti`: `res` voxels (`--volume`) over `bbox`
    /// (`--box xmin,ymin,zmin,xmax,ymax,zmax`; `None` = the scene bounds, flat sides padded).
    Volume {
        res: VolumeRes,
        bbox: Option<[f64; 6]>,
    },
}

/// The output file of slice `index` of `count`: the job's output itself for a single slice, else
/// `<stem>_<label>.exr` next to it.
pub fn slice_output(output: &Path, slice: &SliceArg, index: usize, count: usize) -> PathBuf {
    if count <= 1 {
        return output.to_path_buf();
    }
    let stem = output
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    output.with_file_name(format!("{stem}_{}.exr", slice.file_label(index)))
}

/// Which camera.
#[derive(Clone, Debug)]
pub enum CameraArg {
    /// A camera of the scene file, by name or index (`None`: the first).
    Scene(Option<String>),
    /// Given on the command line.
    Explicit {
        eye: glam::DVec3,
        target: glam::DVec3,
        up: glam::DVec3,
        fov_deg: f64,
    },
}

/// A run, validated enough to start (the rest is checked against the loaded scene).
#[derive(Clone, Debug)]
pub struct Job {
    pub scene: PathBuf,
    pub domain: DomainArg,
    /// Lights added to the scene file's (`--point-light`, `--sun`, `--sky`, `--env`).
    pub lights: Vec<crate::scene::Light>,
    pub estimator: EstimatorArgs,
    /// How many samples, when to stop, and which stripe of the grid (`render.tile`, `--tile i/N`).
    pub render: RenderOptions,
    pub output: PathBuf,
    pub png: bool,
    pub quiet: bool,
    /// Confine every direction to the slice plane (2D light transport in an extruded scene).
    pub flatland: bool,
    /// Write the field so far (marked partial) to `output` at the first pass boundary after each
    /// such interval.
    pub checkpoint_every: Option<Duration>,
    /// Continue the run saved in this file (a partial or finished field of the same job).
    pub resume: Option<PathBuf>,
    /// The command line that started the job, without any `--resume`, for the resume hint.
    pub command: Option<String>,
    /// Extract separatrices from the finished field (`--separatrices`): extra channels in the
    /// output and the side files of [`crate::analysis::separatrix::side_paths`].
    pub separatrices: Option<SepParams>,
    /// How the scene file is read (strict loading or not).
    pub load: crate::scene::load::LoadOptions,
}
