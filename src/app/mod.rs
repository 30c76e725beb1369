//! Jobs, the layer between the command line and the library. The command line ([`crate::cli`])
//! validates its arguments into a [`Job`] (slices, planes, camera images and volumes alike);
//! [`run_job`] loads the scene, resolves every domain ([`JobDomain`]) and checks every output,
//! then runs each domain, writes its files and reports on stderr. [`run_domain`] is the part that
//! computes a resolved domain's field without printing or writing, for any caller that wants the
//! field the command line would compute. Everything here returns errors, never panics.

mod blank;
mod check;
mod describe;
mod domain_job;
mod job;
mod lights;
mod memory;
mod progress;
pub mod report;
mod resolve;
mod run_domain;
mod sampling;

pub use check::{check_job, check_job_to_run};
pub use describe::describe_domain;
pub use job::{
    CameraArg, DEFAULT_FOV_DEG, DEFAULT_IMAGE_SIZE, DEFAULT_RES, DEFAULT_UP, DomainArg, Job,
    slice_output,
};
pub use lights::{LightError, environment, point_light, sky, sun};
pub use memory::{
    FALLBACK_MEMORY_BYTES, available_memory, bytes_per_voxel, check_volume_memory,
    check_volume_memory_at, volume_bytes, volume_bytes_at,
};
pub use progress::{
    RESUME_KEYS, check_resume, mark_progress, progress_arrays, read_progress, write_progress,
    write_progress_with, write_volume_progress, write_volume_progress_with,
};
pub use resolve::{JobDomain, PLACED_CAMERA, resolve_camera};
pub use run_domain::{DomainRun, Start, run_domain};
pub use sampling::{DEFAULT_BUDGET, Sampling};

use crate::domain::slice::resolve_plane;
use crate::domain::volume::Volume;
use crate::field::Field;
use crate::output::check_writable_with_previews;
use crate::params::ways_to_light;
use crate::render::{self, ErrorStats, Progress, RunStats};
use crate::scene::Scene;
use crate::scene::load::load_scene_with;
use report::{scene_line, volume_line};
use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::time::Instant;

/// What [`run_job`] did.
#[derive(Clone, Debug)]
pub struct RunOutcome {
    pub field: Field,
    pub stats: RunStats,
    pub error: ErrorStats,
    pub progress: Progress,
}

/// Runs a job end to end: load the scene once, resolve every plane (or the camera) and check every
/// output before any work, then run each domain in progressive passes (resuming a saved run if
/// asked), checkpoint, write EXR (and PNG) and print a summary on stderr. A run stopped by
/// [`render::INTERRUPT`] writes what it has, marked partial, and says how to resume.
pub fn run_job(job: &Job) -> anyhow::Result<Vec<RunOutcome>> {
    check_job(job)?;
    let t_load = Instant::now();
    let mut scene = load_scene_with(&job.scene, &job.lights, &job.load)?;
    for w in &scene.report.warnings {
        eprintln!("warning: {w}");
    }
    say(job, scene_line(&job.scene, &scene, t_load.elapsed()));
    let domains = resolve_domains(job, &scene)?;
    let mut outcomes = Vec::with_capacity(domains.len());
    for (k, (domain, out)) in domains.iter().enumerate() {
        // A stop that came while the previous domain's outputs were written: the domains left
        // are not started (nothing of theirs is written).
        if render::INTERRUPT.load(Ordering::SeqCst) {
            eprintln!(
                "interrupted: {} of {} domains not run",
                domains.len() - k,
                domains.len()
            );
            break;
        }
        // Until this domain's passes start, a signal ends the process (see `render::LISTENING`).
        render::LISTENING.store(false, Ordering::SeqCst);
        let params = domain.params(&mut scene, &job.estimator, job.flatland)?;
        if let (JobDomain::Plane(plane), Some(f)) = (domain, &scene.flat)
            && job.flatland
        {
            say(
                job,
                format!(
                    "flatland in {}: {} light cross-sections, 2D power {}",
                    plane.label,
                    f.lights.lights.len(),
                    report::power(f.lights.total_power())
                ),
            );
        }
        let outcome = domain_job::run_domain_job(job, &scene, domain, &params, out)?;
        let interrupted =
            !outcome.stats.stop.is_complete() && render::INTERRUPT.load(Ordering::Relaxed);
        outcomes.push(outcome);
        if interrupted {
            break;
        }
    }
    Ok(outcomes)
}

/// Every domain of the job with its output, resolved and checked before the first one runs: each
/// slice's plane, output and estimator settings; the camera; the volume's box and memory.
fn resolve_domains(job: &Job, scene: &Scene) -> anyhow::Result<Vec<(JobDomain, PathBuf)>> {
    let mut domains = Vec::new();
    match &job.domain {
        DomainArg::Slice {
            slices,
            window,
            res,
        } => {
            for (k, arg) in slices.iter().enumerate() {
                let plane = resolve_plane(arg, scene, *window, *res)?;
                let out = slice_output(&job.output, arg, k, slices.len());
                check_writable_with_previews(&out, job.png)?;
                if !job.flatland {
                    job.estimator.resolve_for_plane(scene, &plane)?;
                }
                domains.push((JobDomain::Plane(plane), out));
            }
        }
        DomainArg::Camera { camera, size } => {
            if scene.lights.is_empty() {
                eprintln!(
                    "warning: {} has no lights ({}): the beauty image (radiance.R/G/B) will be \
                     black; add one with --point-light X,Y,Z:R,G,B, --sun X,Y,Z:R,G,B, --sky \
                     R,G,B or --env FILE",
                    job.scene.display(),
                    ways_to_light(scene)
                );
            }
            let view = resolve_camera(camera, scene, *size)?;
            domains.push((JobDomain::Camera(view), job.output.clone()));
        }
        DomainArg::Volume { res, bbox } => {
            let bbox = Volume::resolve_box(&scene.bounds, *bbox)?;
            job.estimator.resolve_for_box(scene, &bbox)?;
            // Refused before anything is allocated (the resumed file included).
            let (available, measured) = available_memory();
            let per_voxel = bytes_per_voxel(job.render.gradient_domain.is_some());
            let size = bbox.max - bbox.min;
            let dims = check_volume_memory_at(*res, size, available, measured, per_voxel)?;
            let volume = Volume::new(&bbox, dims)?;
            say(
                job,
                volume_line(&volume, &bbox, volume_bytes_at(dims, per_voxel), available),
            );
            domains.push((JobDomain::Volume(volume), job.output.clone()));
        }
    }
    Ok(domains)
}

/// Prints a line of the job's report on stderr, unless the job is quiet.
fn say(job: &Job, s: String) {
    if !job.quiet {
        eprintln!("{s}");
    }
}
