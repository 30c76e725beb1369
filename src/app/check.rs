//! What a job can be refused for before its scene is loaded: budgets that cannot run, grids out of
//! range, domains the flatland kernels do not cover, and outputs that cannot be written or resumed.

use super::job::{DomainArg, Job};
use crate::domain::MAX_RES;
use crate::output::check_writable_with_previews;
use crate::scene::load::extension;
use anyhow::bail;

/// Refuses a job that cannot run, naming the flag, before anything is loaded or computed.
pub fn check_job(job: &Job) -> anyhow::Result<()> {
    check_budgets(job)?;
    check_domain(job)?;
    check_files(job)
}

/// [`check_job`] without the outputs: what a job that writes only when asked (the live view) is
/// refused for before it runs. Creates nothing.
pub fn check_job_to_run(job: &Job) -> anyhow::Result<()> {
    check_budgets(job)?;
    check_domain(job)
}

/// Sample counts, budgets and intervals that would never end, or never start.
fn check_budgets(job: &Job) -> anyhow::Result<()> {
    let opts = &job.render;
    if opts.budget.cap_spp && opts.spp == 0 {
        bail!("--spp 0: at least one sample per cell is needed");
    }
    if opts.pass_spp == Some(0) {
        bail!("--pass-spp 0: a pass needs at least one sample per cell");
    }
    if let Some(t) = opts.budget.target_error
        && !(t > 0.0 && t.is_finite())
    {
        bail!("--target-error {t}: must be a finite relative error > 0 (e.g. 0.05)");
    }
    if opts.budget.time.is_some_and(|t| t.is_zero()) {
        bail!("--time 0: the time budget must be positive");
    }
    if job.checkpoint_every.is_some_and(|t| t.is_zero()) {
        bail!("--checkpoint-every 0: the interval must be positive");
    }
    if opts.adaptive.is_some_and(|a| a.max_share == 0) {
        bail!("--adaptive-cap 0: a cell must be allowed at least the uniform share");
    }
    Ok(())
}

/// Grid sizes, the one output that resume and checkpoints work on, flatland's domain, a volume's
/// file type.
fn check_domain(job: &Job) -> anyhow::Result<()> {
    match &job.domain {
        DomainArg::Slice { res, .. } if *res == 0 || *res > MAX_RES => {
            bail!("--res {res}: must be between 1 and {MAX_RES}")
        }
        DomainArg::Slice { slices, .. }
            if slices.len() > 1 && (job.resume.is_some() || job.checkpoint_every.is_some()) =>
        {
            bail!(
                "--resume and --checkpoint-every work on one output; this job has {} slices \
                 (run them one by one)",
                slices.len()
            )
        }
        DomainArg::Camera { size: (w, h), .. }
            if *w == 0 || *h == 0 || *w > MAX_RES || *h > MAX_RES =>
        {
            bail!("--size {w},{h}: each side must be between 1 and {MAX_RES}")
        }
        DomainArg::Camera { .. } if job.flatland => {
            bail!(
                "--flatland works on slices (the plane confines the directions), not camera images"
            )
        }
        DomainArg::Volume { .. } if job.flatland => {
            bail!("--flatland works on slices (the plane confines the directions), not volumes")
        }
        DomainArg::Volume { .. } if extension(&job.output).as_deref() != Some("vti") => {
            bail!(
                "-o {}: a volume is written as VTK ImageData; name the file .vti",
                job.output.display()
            )
        }
        _ => Ok(()),
    }
}

/// The file to resume exists; a camera image's or volume's output can be written (each slice's is
/// checked when its plane is resolved).
fn check_files(job: &Job) -> anyhow::Result<()> {
    if let Some(r) = &job.resume
        && !r.is_file()
    {
        bail!("--resume {}: no such file", r.display());
    }
    if matches!(
        job.domain,
        DomainArg::Camera { .. } | DomainArg::Volume { .. }
    ) {
        check_writable_with_previews(&job.output, job.png)?;
    }
    Ok(())
}
