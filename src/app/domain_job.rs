//! One domain of a job as the command line runs it: start or resume the field, say what runs,
//! run it ([`run_domain`]) with checkpoints and the interrupt flag, report, extract separatrices,
//! write the outputs and say how to resume a partial run.

use super::blank::blank_warning;
use super::describe::describe_domain;
use super::job::Job;
use super::progress::write_volume_progress_with;
use super::progress::{check_resume, mark_progress, read_progress, write_progress_with};
use super::report::{domain_line, eta_line, resume_line, shell_quote, summary};
use super::resolve::JobDomain;
use super::run_domain::{DomainRun, Start, run_domain};
use super::{RunOutcome, say};
use crate::analysis::separatrix;
use crate::field::Field;
use crate::ftpd::Params;
use crate::render::{self, Hooks, Progress, RunStats, estimate_time};
use crate::run_info::RunInfo;
use crate::scene::Scene;
use std::path::Path;
use std::time::Instant;

/// Extra per-cell arrays written with a field (the separatrices').
type Arrays = Vec<(&'static str, Vec<f64>)>;

/// One domain of a job: progressive passes, checkpoints, resume, tile, summary, outputs.
pub(super) fn run_domain_job(
    job: &Job,
    scene: &Scene,
    domain: &JobDomain,
    params: &Params,
    output: &Path,
) -> anyhow::Result<RunOutcome> {
    let opts = &job.render;
    let info = describe_domain(scene, domain, params, opts, &job.lights);
    // The header the EXR will hold is checked now, so that nothing can fail after the run.
    if !matches!(domain, JobDomain::Volume(_)) {
        crate::output::exr::check_header(output, &info.to_attributes())?;
    }
    let start = start_field(job, domain, &info)?;
    announce(job, scene, domain, params, &start)?;
    let write = |f: &Field, p: &Progress, png: bool, more: Arrays| match domain {
        JobDomain::Volume(v) => write_volume_progress_with(f, p, v, output, png, more),
        _ => write_progress_with(f, p, output, png, more),
    };
    let mut last_checkpoint = Instant::now();
    let mut checkpoint_info = info.clone();
    let mut checkpoint = |f: &mut Field, p: &Progress, _: &RunStats| -> anyhow::Result<()> {
        let Some(every) = job.checkpoint_every else {
            return Ok(());
        };
        if last_checkpoint.elapsed() < every {
            return Ok(());
        }
        mark_progress(f, &mut checkpoint_info, p, opts, true, None);
        write(f, p, false, Vec::new())?;
        last_checkpoint = Instant::now();
        let written = format!("{} passes written to {}", p.passes, output.display());
        say(job, format!("checkpoint: {written}"));
        Ok(())
    };
    let hooks = Hooks {
        stop: Some(&render::INTERRUPT),
        after_pass: Some(&mut checkpoint),
        samples: None,
    };
    let run = run_domain(scene, domain, params, opts, info, start, hooks)?;
    let error = render::field_error_stats(&run.field, 0..run.field.cells.len());
    if let Some(w) = blank_warning(job, scene, domain, params, &run) {
        eprintln!("{w}");
    }
    say(job, summary(&run.field, &run.stats, &error, params));
    write_outputs(job, &run, output, write)?;
    finish(job, &run, output);
    Ok(RunOutcome {
        field: run.field,
        stats: run.stats,
        error,
        progress: run.progress,
    })
}

/// A new field, or the job's file to resume, checked against the run `info` describes.
fn start_field(job: &Job, domain: &JobDomain, info: &RunInfo) -> anyhow::Result<Start> {
    let Some(path) = &job.resume else {
        return Ok(Start::Fresh);
    };
    let (mut field, progress) = read_progress(path)?;
    check_resume(path, &field, info, domain.dims())?;
    field.set_info(info);
    say(job, resume_line(path, &field, &progress));
    Ok(Start::Resumed(field, progress))
}

/// Says what runs (grid, tile, budget, passes, estimator) and, for a volume with a sample cap, how
/// long the samples still to take should last (a short calibration, on other random streams).
fn announce(
    job: &Job,
    scene: &Scene,
    domain: &JobDomain,
    params: &Params,
    start: &Start,
) -> anyhow::Result<()> {
    let opts = &job.render;
    let (w, h, d) = domain.dims();
    let tile_note = tile_note(opts.tile, domain.dims());
    say(
        job,
        domain_line(
            &domain.name(),
            (w, h, d),
            &tile_note,
            opts,
            params,
            job.estimator.angle_deg,
        ),
    );
    if let JobDomain::Volume(v) = domain
        && !job.quiet
        && opts.budget.cap_spp
    {
        let e = estimate_time(scene, v, params, opts)?;
        let done = match start {
            Start::Fresh => 0,
            Start::Resumed(f, _) => f.total_samples(),
        };
        let cells = opts.active_cells(w, h, d).len();
        let left = (cells as u64 * opts.spp as u64).saturating_sub(done);
        say(job, eta_line(&e, left));
    }
    Ok(())
}

/// `, tile 1/4 (rows 16..32)` for a tile's run (a warning when the tile has no rows), else empty.
fn tile_note(tile: Option<crate::domain::Tile>, (_, h, d): (usize, usize, usize)) -> String {
    // What a tile splits: a 2D grid's rows, a volume's z layers (see `Tile::cells`).
    let (rows, row_name) = if d > 1 { (d, "z layers") } else { (h, "rows") };
    match tile {
        Some(t) if t.rows(rows).is_empty() => {
            eprintln!(
                "warning: --tile {t}: the grid has {rows} {row_name}, fewer than {} tiles; this \
                 tile is empty",
                t.count
            );
            String::new()
        }
        Some(t) => {
            let r = t.rows(rows);
            format!(", tile {t} ({row_name} {}..{})", r.start, r.end)
        }
        None => String::new(),
    }
}

/// Writes the field, and when the job asks for separatrices, extracts them from the field as
/// written (a partial field's too: they say what it shows so far), adds their channels and writes
/// their files beside it.
fn write_outputs(
    job: &Job,
    run: &DomainRun,
    output: &Path,
    write: impl Fn(&Field, &Progress, bool, Arrays) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let Some(sp) = &job.separatrices else {
        return write(&run.field, &run.progress, job.png, Vec::new());
    };
    let (sep, placement) = separatrix::of_field(&run.field, &output.display().to_string(), sp)?;
    say(job, sep.summary());
    write(&run.field, &run.progress, job.png, sep.arrays())?;
    separatrix::write_side_files(output, &run.field, &sep, &placement)?;
    let files: Vec<String> = separatrix::side_paths(output, sep.dims[2] > 1)
        .iter()
        .map(|p| p.display().to_string())
        .collect();
    say(job, format!("wrote {}", files.join(", ")));
    Ok(())
}

/// Says what was written, and for a partial run how to resume it.
fn finish(job: &Job, run: &DomainRun, output: &Path) {
    let partial = run.partial();
    say(
        job,
        format!(
            "wrote {}{}",
            output.display(),
            if partial { " (partial)" } else { "" }
        ),
    );
    if partial {
        eprintln!(
            "to resume: {} --resume {}",
            job.command
                .as_deref()
                .unwrap_or("ftpd3d <the same arguments>"),
            shell_quote(&output.display().to_string())
        );
    }
}
