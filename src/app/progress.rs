//! Where a run stands, in its output: progress metadata, the arrays of a pass cut part-way, and the
//! checks that a file may be resumed by this run. EXR fields and VTI volumes alike.

use crate::domain::volume::Volume;
use crate::field::Field;
use crate::output::{self, write_outputs_with};
use crate::render::{InFlight, Progress, RenderOptions, StopReason};
use crate::run_info::{Remaining, RunInfo, fmt_duration};
use crate::scene::load::extension;
use anyhow::{Context, bail};
use std::collections::BTreeMap;
use std::path::Path;
use std::time::Duration;

pub use crate::run_info::RESUME_KEYS;

/// Checks that the field read from `path` was made by the run described by `run` on a grid of
/// `dims`: the same grid, and the same value of every attribute of [`crate::merge::MUST_MATCH`]
/// (what the samples estimate) and [`RESUME_KEYS`] (how they were drawn), compared as typed
/// values; the error names the first attribute that differs.
pub fn check_resume(
    path: &Path,
    file: &Field,
    run: &RunInfo,
    dims: (usize, usize, usize),
) -> anyhow::Result<()> {
    let have = (file.width, file.height, file.depth);
    if have != dims {
        bail!(
            "--resume {}: grid size differs: the file has {} cells, this run {} \
             (give the --res/--window/--size/--volume/--box the run was started with)",
            path.display(),
            grid_text(have),
            grid_text(dims)
        );
    }
    let info = file.info(&format!("--resume {}", path.display()))?;
    if info.schedule.is_none() {
        bail!(
            "--resume {}: not a field this version of ftpd3d can resume (no 'schedule' key)",
            path.display()
        );
    }
    let keys: Vec<&str> = crate::merge::MUST_MATCH
        .iter()
        .chain(RESUME_KEYS)
        .copied()
        .collect();
    if let Some(key) = info.first_difference(run, &keys) {
        let (a, b) = (info.to_attributes(), run.to_attributes());
        let show = |v: Option<&String>| v.map_or_else(|| "(none)".to_string(), Clone::clone);
        // Runs that stop at a target error became adaptive by default: say how to match a file
        // started before, or with the other allocation.
        let hint = match (key, a.get(key).map(String::as_str)) {
            ("adaptive", Some("off")) => " (this file's passes were uniform: add --uniform)".into(),
            ("adaptive", Some(_)) => " (this file's passes were adaptive: add --adaptive)".into(),
            ("pairs", Some(p)) => format!(" (add --pairs {p})"),
            ("guide", g) => format!(" (add --guide {})", g.unwrap_or("off")),
            ("light_scale", Some(l)) => {
                let flags: Vec<String> =
                    l.split(';').map(|s| format!("--light-scale {s}")).collect();
                format!(" (add {})", flags.join(" "))
            }
            ("gradient.alpha", Some(alpha)) => gradient_hint(alpha),
            ("gradient.alpha", None) => {
                " (this file's run was not gradient-domain: leave out --gradient-domain)".into()
            }
            _ => String::new(),
        };
        bail!(
            "--resume {}: {key} differs: the file has {}, this run {}{hint}; a run resumes only \
             with the scene, domain, parameters, seed and pass schedule it was started with",
            path.display(),
            show(a.get(key)),
            show(b.get(key))
        );
    }
    Ok(())
}

/// How a command matches a gradient-domain file of α `alpha` (as the file writes it).
fn gradient_hint(alpha: &str) -> String {
    let default = crate::gradient_domain::DEFAULT_ALPHA;
    if alpha.parse::<f64>().ok() == Some(default) {
        " (this file's run was gradient-domain: add --gradient-domain)".into()
    } else {
        format!(
            " (this file's run was gradient-domain: add --gradient-domain --gradient-alpha {alpha})"
        )
    }
}

/// `64x48` for a 2D grid, `6x6x6` for a volume.
pub(super) fn grid_text((w, h, d): (usize, usize, usize)) -> String {
    if d > 1 {
        format!("{w}x{h}x{d}")
    } else {
        format!("{w}x{h}")
    }
}

/// Records where a run stands in `info` and describes `field` by it: `partial`, `passes`,
/// `samples`, `elapsed` (compute seconds so far), `remaining.samples` and `remaining.time` (what is
/// left of the budgets), `pass.inflight`, and `stop` (why it stopped, when it has).
pub fn mark_progress(
    field: &mut Field,
    info: &mut RunInfo,
    progress: &Progress,
    opts: &RenderOptions,
    partial: bool,
    stop: Option<StopReason>,
) {
    let samples = field.total_samples();
    let cells = opts
        .active_cells(field.width, field.height, field.depth)
        .len() as u64;
    info.partial = Some(partial);
    info.passes = Some(progress.passes);
    info.samples = Some(samples);
    info.elapsed = Some(progress.elapsed);
    info.remaining_samples = Some(if opts.budget.cap_spp {
        Remaining::Samples((cells * opts.spp as u64).saturating_sub(samples))
    } else {
        Remaining::Unbounded
    });
    info.remaining_time = Some(opts.budget.time.map_or_else(
        || "none".into(),
        |t| fmt_duration(t.saturating_sub(Duration::from_secs_f64(progress.elapsed))),
    ));
    info.inflight = Some(progress.inflight.is_some());
    info.stop = stop.map(|s| s.to_string());
    field.set_info(info);
}

/// Writes a field with its progress: for a pass interrupted part-way, the channels `pass.done`
/// (1 where the cell completed it) and, for adaptive passes, `pass.units` (the pass's allocation).
pub fn write_progress(
    field: &Field,
    progress: &Progress,
    path: &Path,
    png: bool,
) -> anyhow::Result<()> {
    write_progress_with(field, progress, path, png, Vec::new())
}

/// [`write_progress`] with more per-cell channels (the separatrices' arrays).
pub fn write_progress_with(
    field: &Field,
    progress: &Progress,
    path: &Path,
    png: bool,
    more: Vec<(&'static str, Vec<f64>)>,
) -> anyhow::Result<()> {
    let mut extra = progress_arrays(progress);
    extra.extend(more);
    Ok(write_outputs_with(field, path, png, extra)?)
}

/// [`write_progress`] for a volume: the `.vti`, whose `pass.done` and `pass.units` arrays are
/// Float64 (read back by [`read_progress`]).
pub fn write_volume_progress(
    field: &Field,
    progress: &Progress,
    volume: &Volume,
    path: &Path,
    png: bool,
) -> anyhow::Result<()> {
    write_volume_progress_with(field, progress, volume, path, png, Vec::new())
}

/// [`write_volume_progress`] with more per-voxel arrays (the separatrices' arrays).
pub fn write_volume_progress_with(
    field: &Field,
    progress: &Progress,
    volume: &Volume,
    path: &Path,
    png: bool,
    more: Vec<(&'static str, Vec<f64>)>,
) -> anyhow::Result<()> {
    let mut extra = progress_arrays(progress);
    extra.extend(more);
    Ok(output::write_volume_outputs_with(
        field,
        volume.vtk_origin(),
        volume.spacing,
        path,
        png,
        &extra,
    )?)
}

/// The per-cell arrays of a pass interrupted part-way (none between passes), as the writers add
/// them to a field's file.
pub fn progress_arrays(progress: &Progress) -> Vec<(&'static str, Vec<f64>)> {
    let mut extra = Vec::new();
    if let Some(f) = &progress.inflight {
        extra.push((
            "pass.done",
            f.done.iter().map(|&d| if d { 1.0 } else { 0.0 }).collect(),
        ));
        if let Some(u) = &f.units {
            extra.push(("pass.units", u.iter().map(|&x| x as f64).collect()));
        }
    }
    extra
}

/// Reads a field (`.exr`) or volume (`.vti`) to resume from, with where its run stands (see
/// [`mark_progress`]).
pub fn read_progress(path: &Path) -> anyhow::Result<(Field, Progress)> {
    let volume = extension(path).as_deref() == Some("vti");
    let (field, mut arrays) = if volume {
        let v =
            output::vti::read_vti(path).with_context(|| format!("--resume {}", path.display()))?;
        (v.field, v.extra)
    } else {
        let f =
            output::exr::read_exr(path).with_context(|| format!("--resume {}", path.display()))?;
        (f, BTreeMap::new())
    };
    // A pass's progress array, from the volume's arrays or the field's channels.
    let mut array = |name: &str| -> anyhow::Result<Vec<f64>> {
        if volume {
            arrays
                .remove(name)
                .with_context(|| format!("--resume {}: no array '{name}'", path.display()))
        } else {
            let (_, _, v) = output::exr::read_channel(path, name)?;
            Ok(v.into_iter().map(f64::from).collect())
        }
    };
    let info = field.info(&format!("--resume {}", path.display()))?;
    let missing = |key: &str| {
        anyhow::anyhow!(
            "--resume {}: no '{key}' in the file (not written by a progressive run?)",
            path.display()
        )
    };
    let passes = info.passes.ok_or_else(|| missing("passes"))?;
    let elapsed = info.elapsed.ok_or_else(|| missing("elapsed"))?;
    let inflight = if info.inflight == Some(true) {
        let done = array("pass.done")?;
        let units = if info.is_adaptive() && passes >= 2 {
            Some(array("pass.units")?.iter().map(|&x| x as u32).collect())
        } else {
            None
        };
        if done.len() != field.cells.len()
            || units
                .as_ref()
                .is_some_and(|u: &Vec<u32>| u.len() != done.len())
        {
            bail!(
                "--resume {}: the interrupted pass's arrays do not match the grid",
                path.display()
            );
        }
        Some(InFlight {
            done: done.iter().map(|&d| d != 0.0).collect(),
            units,
        })
    } else {
        None
    };
    Ok((
        field,
        Progress {
            passes,
            inflight,
            elapsed,
        },
    ))
}
