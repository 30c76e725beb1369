//! Runs of one domain with the kernel its parameters need: a plane, a camera image or any
//! [`Domain`] run to a [`Field`] by the progressive driver, the kernel chosen once per run.

use super::describe::{camera_info, plane_info};
use super::{Hooks, Progress, RenderOptions, RunError, RunStats, describe_run, run_progressive};
use crate::domain::{CameraView, Domain, Plane, PlaneDomain};
use crate::field::Field;
use crate::ftpd::{self, Params};
use crate::rng::Sampler;
use crate::run_info::{DomainKind, RunInfo};
use crate::scene::Scene;
use crate::transport::guide::Guide;
use crate::transport::training;

/// Runs FTPD over a plane (the whole grid, or the stripe `opts.tile`); the field comes back with
/// its metadata filled in. A plane with a surface lying in it (a slice through a wall) starts its
/// points on the surfaces' front sides ([`PlaneDomain`]).
pub fn run_plane(
    scene: &Scene,
    plane: &Plane,
    params: &Params,
    opts: &RenderOptions,
) -> Result<(Field, RunStats), RunError> {
    check_flatland(scene, plane, params)?;
    let (mut field, stats) = run_domain(scene, &PlaneDomain::new(plane, scene), params, opts)?;
    field.set_info(&RunInfo {
        plane: Some(plane_info(plane)),
        ..describe_run(scene, params, opts, DomainKind::Slice)
    });
    Ok((field, stats))
}

/// Runs FTPD over any domain (the whole grid, or the stripe `opts.tile`) with the kernel `params`
/// needs ([`ftpd::kernel_for`]); the field comes back without a description ([`describe_run`]).
pub fn run_domain(
    scene: &Scene,
    domain: &dyn Domain,
    params: &Params,
    opts: &RenderOptions,
) -> Result<(Field, RunStats), RunError> {
    let (w, h, d) = domain.dims();
    let mut field = Field::new(w, h, d);
    if let Some(alpha) = opts.gradient_domain {
        field = field.with_shift(alpha);
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.threads)
        .build()?;
    let stats = run_domain_progressive(
        &pool,
        scene,
        domain,
        params,
        opts,
        &mut field,
        &mut Progress::default(),
        Hooks::default(),
    )?;
    Ok((field, stats))
}

/// Runs passes over `field` (new, or resumed at `progress`) with the kernel `params` needs until a
/// budget of `opts` is reached or `hooks.stop` is set; see [`run_progressive`].
#[allow(clippy::too_many_arguments)]
pub fn run_domain_progressive(
    pool: &rayon::ThreadPool,
    scene: &Scene,
    domain: &dyn Domain,
    params: &Params,
    opts: &RenderOptions,
    field: &mut Field,
    progress: &mut Progress,
    hooks: Hooks,
) -> Result<RunStats, RunError> {
    let dims = domain.dims();
    let have = (field.width, field.height, field.depth);
    if have != dims {
        return Err(RunError::FieldSize {
            field: have,
            domain: dims,
        });
    }
    // Chosen once per run, so that the per-sample call inside is monomorphic and inlined into the
    // driver's loop (a call through `ftpd::sampler`'s function pointer is not).
    use crate::kernel::{Plain3D, PlainFlat, Radiance3D, RadianceFlat};
    let k = ftpd::kernel_for(params);
    let drive: Drive = match (k.radiance, k.flatland) {
        (true, false) => drive::<Radiance3D>,
        (false, false) => drive::<Plain3D>,
        (true, true) => drive::<RadianceFlat>,
        (false, true) => drive::<PlainFlat>,
    };
    drive(pool, scene, domain, params, opts, field, progress, hooks)
}

type Drive = fn(
    &rayon::ThreadPool,
    &Scene,
    &dyn Domain,
    &Params,
    &RenderOptions,
    &mut Field,
    &mut Progress,
    Hooks,
) -> Result<RunStats, RunError>;

/// [`run_domain_progressive`] with kernel `K`.
#[allow(clippy::too_many_arguments)]
fn drive<K: crate::kernel::Kernel>(
    pool: &rayon::ThreadPool,
    scene: &Scene,
    domain: &dyn Domain,
    params: &Params,
    opts: &RenderOptions,
    field: &mut Field,
    progress: &mut Progress,
    hooks: Hooks,
) -> Result<RunStats, RunError> {
    let guide = train_guide::<K>(pool, scene, params, opts, progress);
    run_progressive(
        pool,
        field,
        opts,
        progress,
        hooks,
        |cell, s: &mut Sampler| {
            let start = domain.start(scene, cell, s);
            ftpd::sample_guided::<K>(scene, start, params, guide.as_ref(), s)
        },
    )
}

/// The guide of a guided run ([`crate::transport::guide`]; radiance weighting in 3D), trained
/// before its first pass (and again when it resumes: the guide is a function of the scene, the
/// parameters and the seed, so the same). Its compute time counts as the run's.
fn train_guide<K: crate::kernel::Kernel>(
    pool: &rayon::ThreadPool,
    scene: &Scene,
    params: &Params,
    opts: &RenderOptions,
    progress: &mut Progress,
) -> Option<Guide> {
    use crate::kernel::Space;
    let wanted = params.guide
        && K::RADIANCE
        && K::Space::DIMS == 3
        && params.weighting == ftpd::Weighting::Radiance;
    if !wanted {
        return None;
    }
    let t = std::time::Instant::now();
    let g = training::train::<K>(scene, params.radiance_cap(), opts.seed, pool);
    progress.elapsed += t.elapsed().as_secs_f64();
    Some(g)
}

/// A flatland run needs a flatland kernel, a scene prepared for its plane, and a domain in it.
pub fn check_flatland(scene: &Scene, plane: &Plane, params: &Params) -> Result<(), RunError> {
    let Some(fl) = params.flat else {
        return Ok(());
    };
    if scene.flat.as_ref().map(|f| f.plane) != Some(fl) {
        return Err(RunError::FlatlandNotPrepared {
            plane: plane.label.clone(),
        });
    }
    let tol = 1e-9 * scene.extent().max(plane.origin.abs().max_element());
    if plane.normal().cross(fl.normal).length() > 1e-12 || fl.distance(plane.origin).abs() > tol {
        return Err(RunError::FlatlandOffPlane {
            plane: plane.label.clone(),
        });
    }
    Ok(())
}

/// Importance-weighted FTPD over a camera image (the whole image, or the stripe `opts.tile`), with
/// its beauty image (`radiance.R/G/B`).
pub fn run_camera(
    scene: &Scene,
    view: &CameraView,
    params: &Params,
    opts: &RenderOptions,
) -> Result<(Field, RunStats), RunError> {
    let (mut field, stats) = run_domain(scene, view, params, opts)?;
    field.set_info(&RunInfo {
        camera: Some(camera_info(view)),
        ..describe_run(scene, params, opts, DomainKind::Camera)
    });
    Ok((field, stats))
}
