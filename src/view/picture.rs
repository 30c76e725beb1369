//! What the page is shown: the picture of a snapshot in one of the previews' views, the run's
//! status as JSON, and saving a snapshot as the command line would write it.

use super::session::{Inner, Shared, Snapshot};
use crate::analysis::separatrix;
use crate::app;
use crate::cli::view::{Samples, command_line, reproduce_state, state_args, state_query};
use crate::output::png::{field_colors, gradient_colors, png_bytes};
use crate::render::{Schedule, StopReason, samples_in_pass};
use std::fmt::Write;
use std::sync::atomic::Ordering;

/// The views the page offers, by their `channel=` name: σ (the `.png` preview), its gradient
/// (the `.grad.png`), fluence, σ's relative standard error, and the separatrices over σ (the
/// `.sep.png`).
pub const CHANNELS: [&str; 5] = ["ftpd", "grad", "fluence", "relerr", "separatrix"];

/// The PNG of `snap` in view `channel`.
pub fn picture(snap: &Snapshot, channel: &str) -> anyhow::Result<Vec<u8>> {
    let f = &snap.field;
    let (w, h) = (f.width, f.height);
    let sigma = f.sigma();
    let valid = f.valid();
    let rgb = match channel {
        "ftpd" => field_colors(&sigma, &valid, w, h),
        "grad" => gradient_colors(&sigma, &valid, w, h),
        "relerr" => {
            let vals = f.values();
            let rel: Vec<f64> = vals.iter().map(|v| v.relative_error()).collect();
            let ok: Vec<bool> = vals.iter().map(|v| v.valid && v.estimated).collect();
            field_colors(&rel, &ok, w, h)
        }
        "fluence" => {
            let lum: Vec<f64> = f
                .cells
                .iter()
                .map(|c| {
                    let l = c.fluence();
                    0.2126 * l.x + 0.7152 * l.y + 0.0722 * l.z
                })
                .collect();
            let ok: Vec<bool> = f.cells.iter().map(|c| c.n > 0).collect();
            field_colors(&lum, &ok, w, h)
        }
        "separatrix" => {
            let params = snap.run.job.separatrices.unwrap_or_default();
            let (sep, _) = separatrix::of_field(f, "the view", &params)?;
            let (bw, bh, img) = separatrix::overlay_colors(&sigma, &valid, &sep);
            return png_bytes(bw, bh, &img).map_err(anyhow::Error::msg);
        }
        other => anyhow::bail!("channel={other}: one of {}", CHANNELS.join(", ")),
    };
    png_bytes(w, h, &rgb).map_err(anyhow::Error::msg)
}

/// The samples of `snap` as the command line's sampling flags, and whether that command takes
/// exactly these samples (an adaptive pass that spent less than its budget does not).
fn samples_of(snap: &Snapshot) -> (Samples, bool) {
    let opts = &snap.run.job.render;
    let passes = snap.progress.passes;
    let schedule = Schedule::of(opts);
    let uniform: u64 = (0..passes).map(|p| schedule.uniform(p) as u64).sum();
    let samples = match schedule {
        Schedule::Split { spp, batches } => Samples::Split {
            spp: (0..passes)
                .map(|p| samples_in_pass(spp, batches, p) as u64)
                .sum(),
            passes,
        },
        Schedule::Every { per_pass, .. } => Samples::Every {
            spp: uniform,
            pass_spp: per_pass,
            adaptive_cap: opts.adaptive.map(|a| a.max_share),
        },
    };
    let f = &snap.field;
    let cells = opts.active_cells(f.width, f.height, f.depth).len() as u64;
    (samples, f.total_samples() == uniform * cells)
}

/// What a save wrote and the command line that writes the same.
pub struct Saved {
    pub files: Vec<String>,
    pub command: String,
    /// Whether the command takes exactly the samples saved (see [`samples_of`]).
    pub exact: bool,
}

/// Writes `snap` (a complete pass) as the command line that takes its samples would: the EXR,
/// its previews unless `--no-png`, and the separatrices' channels and files with
/// `--separatrices`, described as that command's run.
pub fn save(shared: &Shared, snap: &Snapshot) -> anyhow::Result<Saved> {
    let (samples, exact) = samples_of(snap);
    let state = reproduce_state(&snap.run.state, samples);
    let job = state_args(&shared.fixed, &state)
        .map_err(anyhow::Error::msg)?
        .job()?;
    let run = &snap.run;
    let out = &job.output;
    app::check_job(&job)?;
    crate::output::check_writable(out)?;
    let mut field = snap.field.clone();
    let mut info = app::describe_domain(
        &run.scene,
        &run.domain,
        &run.params,
        &job.render,
        &job.lights,
    );
    let stop = Some(StopReason::Samples);
    app::mark_progress(
        &mut field,
        &mut info,
        &snap.progress,
        &job.render,
        false,
        stop,
    );
    let mut files = vec![out.display().to_string()];
    if job.png {
        files.push(out.with_extension("png").display().to_string());
        files.push(out.with_extension("grad.png").display().to_string());
    }
    match &job.separatrices {
        None => app::write_progress_with(&field, &snap.progress, out, job.png, Vec::new())?,
        Some(sp) => {
            let (sep, placement) = separatrix::of_field(&field, &out.display().to_string(), sp)?;
            app::write_progress_with(&field, &snap.progress, out, job.png, sep.arrays())?;
            separatrix::write_side_files(out, &field, &sep, &placement)?;
            let side = separatrix::side_paths(out, false);
            files.extend(side.iter().map(|p| p.display().to_string()));
        }
    }
    let command = command_line(&shared.fixed, &state, &out.display().to_string());
    Ok(Saved {
        files,
        command,
        exact,
    })
}

/// The run's status as the page shows it (JSON): the state, its generation, samples, p95
/// relative error, the time to the target error, warnings and errors, the scene file's lights.
pub fn status(shared: &Shared, g: &Inner) -> String {
    let mut s = String::from("{");
    let live = shared.samples.load(Ordering::Relaxed);
    let _ = write!(
        s,
        "\"generation\":{},\"state\":{},\"samples\":{},\"seconds\":{:.3},",
        g.generation,
        json_str(&state_query(&g.state)),
        live,
        match (&g.stopped, &g.snapshot) {
            (Some(_), Some(snap)) => snap.progress.elapsed,
            _ => g.since.elapsed().as_secs_f64(),
        }
    );
    let _ = write!(
        s,
        "\"running\":{},\"stopped\":{},\"error\":{},\"warnings\":[{}]",
        g.stopped.is_none(),
        opt_str(g.stopped.as_deref()),
        opt_str(g.error.as_deref()),
        g.warnings
            .iter()
            .map(|w| json_str(w))
            .collect::<Vec<_>>()
            .join(",")
    );
    let lights: Vec<String> = g
        .lights
        .iter()
        .map(|l| {
            format!(
                "{{\"name\":{},\"kind\":{},\"scale\":{}}}",
                json_str(&l.name),
                json_str(l.kind),
                num(l.scale)
            )
        })
        .collect();
    let _ = write!(s, ",\"lights\":[{}]", lights.join(","));
    if let Some(snap) = &g.snapshot {
        let f = &snap.field;
        let cells = (f.width * f.height * f.depth).max(1) as f64;
        let target = snap.run.job.render.budget.target_error;
        let _ = write!(
            s,
            ",\"pass\":{{\"generation\":{},\"passes\":{},\"width\":{},\"height\":{},\
             \"spp\":{:.2},\"p95\":{},\"target\":{},\"eta\":{},\"domain\":{}}}",
            snap.generation,
            snap.progress.passes,
            f.width,
            f.height,
            f.total_samples() as f64 / cells,
            num(snap.error.p95),
            target.map_or("null".into(), num),
            target.map_or("null".into(), |t| eta(
                snap.error.p95,
                t,
                snap.progress.elapsed
            )),
            json_str(&snap.run.domain.name()),
        );
        let b = &snap.run.scene.bounds;
        let corners = [b.min.x, b.min.y, b.min.z, b.max.x, b.max.y, b.max.z];
        let corners: Vec<String> = corners.iter().map(|&x| num(x)).collect();
        let _ = write!(s, ",\"bounds\":[{}]", corners.join(","));
    }
    s.push('}');
    s
}

/// Seconds until the p95 relative error reaches `target`, if the error falls as 1/√samples
/// (`null` while it is unknown).
fn eta(p95: f64, target: f64, elapsed: f64) -> String {
    if !(p95.is_finite() && p95 > 0.0 && target > 0.0 && elapsed > 0.0) {
        return "null".into();
    }
    let ratio = (p95 / target).powi(2);
    num((elapsed * (ratio - 1.0)).max(0.0))
}

/// A finite number, else `null`.
fn num(x: f64) -> String {
    if x.is_finite() {
        format!("{x}")
    } else {
        "null".into()
    }
}

fn opt_str(s: Option<&str>) -> String {
    s.map_or("null".into(), json_str)
}

/// `s` as a JSON string.
pub fn json_str(s: &str) -> String {
    let mut o = String::from("\"");
    for c in s.chars() {
        match c {
            '"' => o.push_str("\\\""),
            '\\' => o.push_str("\\\\"),
            '\n' => o.push_str("\\n"),
            c if (c as u32) < 0x20 || c == '<' || c == '>' || c == '&' => {
                let _ = write!(o, "\\u{:04x}", c as u32);
            }
            c => o.push(c),
        }
    }
    o.push('"');
    o
}
