//! A job's domains resolved against the loaded scene: the camera it names, and the estimator
//! settings of a run over each domain.

use super::job::CameraArg;
use crate::domain::volume::Volume;
use crate::domain::{CameraView, Domain, Plane, PlaneDomain};
use crate::ftpd::Params;
use crate::params::{EstimatorArgs, prepare_flatland};
use crate::run_info::DomainKind;
use crate::scene::{self, Scene};
use anyhow::{Context, bail};

/// The domain of a job, resolved against its scene.
#[derive(Clone, Debug)]
pub enum JobDomain {
    Plane(Plane),
    Camera(CameraView),
    Volume(Volume),
}

impl JobDomain {
    /// Grid size (width, height, depth).
    pub fn dims(&self) -> (usize, usize, usize) {
        match self {
            JobDomain::Plane(p) => Domain::dims(p),
            JobDomain::Camera(v) => Domain::dims(v),
            JobDomain::Volume(v) => Domain::dims(v),
        }
    }

    pub fn kind(&self) -> DomainKind {
        match self {
            JobDomain::Plane(_) => DomainKind::Slice,
            JobDomain::Camera(_) => DomainKind::Camera,
            JobDomain::Volume(_) => DomainKind::Volume,
        }
    }

    /// The domain as reports name it: `slice z=0`, `camera 'front'`, `volume`.
    pub fn name(&self) -> String {
        match self {
            JobDomain::Plane(p) => format!("slice {}", p.label),
            JobDomain::Camera(v) => format!("camera '{}'", v.camera.name),
            JobDomain::Volume(_) => "volume".to_string(),
        }
    }

    /// Calls `f` with the cells as runs sample them: a plane through [`PlaneDomain`] (decided
    /// once, here, for the whole run), a camera image or volume as it is.
    pub fn sampled<R>(&self, scene: &Scene, f: impl FnOnce(&dyn Domain) -> R) -> R {
        match self {
            JobDomain::Plane(p) => f(&PlaneDomain::new(p, scene)),
            JobDomain::Camera(v) => f(v),
            JobDomain::Volume(v) => f(v),
        }
    }

    /// The estimator settings of a run over this domain, with run-length defaults from where the
    /// domain lies. A flatland run (planes only) prepares `scene` for its plane first.
    pub fn params(
        &self,
        scene: &mut Scene,
        estimator: &EstimatorArgs,
        flatland: bool,
    ) -> anyhow::Result<Params> {
        Ok(match self {
            JobDomain::Plane(plane) if flatland => prepare_flatland(scene, plane, estimator)?,
            JobDomain::Plane(plane) => estimator.resolve_for_plane(scene, plane)?,
            JobDomain::Camera(view) => estimator.resolve_for_camera(scene, view)?,
            JobDomain::Volume(v) => estimator.resolve_for_box(
                scene,
                &scene::Aabb {
                    min: v.origin,
                    max: v.max_corner(),
                },
            )?,
        })
    }
}

/// The name of a camera placed by eye and target (rather than one of the scene file), as a run's
/// description holds it: every front end gives it, so that their fields merge.
pub const PLACED_CAMERA: &str = "command line";

/// Resolves the camera of a job against the scene.
pub fn resolve_camera(
    arg: &CameraArg,
    scene: &Scene,
    size: (usize, usize),
) -> anyhow::Result<CameraView> {
    let camera = match arg {
        CameraArg::Explicit {
            eye,
            target,
            up,
            fov_deg,
        } => scene::sidecar::camera_of(&scene::sidecar::CameraSpec {
            name: Some(PLACED_CAMERA.into()),
            eye: eye.to_array(),
            target: target.to_array(),
            up: Some(up.to_array()),
            fov: *fov_deg,
        })
        .context("--eye/--target/--up")?,
        CameraArg::Scene(which) => scene_camera(which.as_deref(), scene)?,
    };
    // An eye on a surface starts on its front side (once per run).
    let mut camera = camera;
    camera.eye = scene.off_surfaces(camera.eye);
    Ok(CameraView::new(camera, size.0, size.1)?)
}

/// A camera of the scene file by name, else by index (`None`: the first).
fn scene_camera(which: Option<&str>, scene: &Scene) -> anyhow::Result<scene::Camera> {
    if scene.cameras.is_empty() {
        bail!(
            "--camera: {} defines no camera; give --eye X,Y,Z --target X,Y,Z [--up X,Y,Z] [--fov DEG]",
            scene.source.display()
        );
    }
    let Some(w) = which else {
        return Ok(scene.cameras[0].clone());
    };
    let by_index = w.parse::<usize>().ok().and_then(|i| scene.cameras.get(i));
    let by_name = scene.cameras.iter().find(|c| c.name == w);
    by_name.or(by_index).cloned().with_context(|| {
        let names: Vec<_> = scene.cameras.iter().map(|c| c.name.as_str()).collect();
        format!(
            "--camera {w}: no such camera (the scene has: {})",
            names.join(", ")
        )
    })
}
