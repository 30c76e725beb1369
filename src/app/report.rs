//! The text a job's run prints on stderr: the scene line, each domain's line and budget, the
//! ETA, the summary with what more accuracy costs; sizes and shell quoting.

use super::progress::grid_text;
use crate::domain::volume::Volume;
use crate::field::Field;
use crate::ftpd::{Params, Weighting};
use crate::render::{ErrorStats, Eta, Progress, RenderOptions, RunStats, Schedule};
use crate::run_info::{fmt_duration, fmt_vec};
use crate::scene::Aabb;
use std::path::Path;
use std::time::Duration;

/// The run summary: time, rates, passes, why the run stopped, the error, and what was clamped.
pub fn summary(field: &Field, stats: &RunStats, error: &ErrorStats, params: &Params) -> String {
    let unestimated = if error.unestimated > 0 {
        format!(
            " ({} of {} cells with σ > 0 have no estimate yet)",
            error.unestimated, error.cells
        )
    } else {
        String::new()
    };
    let radiance_cap = match params.radiance_bounces {
        Some(n) if n != params.max_bounces => format!(" (radiance paths: {n})"),
        _ => String::new(),
    };
    let total = field.total_samples();
    let earlier = if total > stats.samples {
        format!(" ({total} in the field with the resumed ones)")
    } else {
        String::new()
    };
    let reconstructed = match &field.shift {
        Some(s) => format!(
            "\nfield reconstructed from each cell's samples and its neighbours' replayed \
             differences (gradient domain, screened Poisson in L2, α {}); its standard errors \
             come from {} independent replicates and include the correlation between cells \
             (each sample above was also traced at {} neighbours){}",
            s.alpha,
            crate::gradient_domain::REPLICATES,
            s.axes,
            difference_share_note(field, s)
        ),
        None => String::new(),
    };
    format!(
        "stopped after {} passes ({}): {} samples in {:.2} s{earlier}, {:.3e} samples/s, \
         {:.3e} rays/s; relative error mean {:.4}, p95 {:.4}{unestimated}; {} walks hit the \
         bounce cap ({}){radiance_cap}, {} non-finite samples dropped",
        stats.passes,
        stats.stop,
        stats.samples,
        stats.seconds,
        stats.samples_per_second(),
        stats.rays_per_second(),
        error.mean,
        error.p95,
        stats.capped,
        params.max_bounces,
        stats.clamped
    ) + &reconstructed
        + &cost_of_accuracy(
            total,
            stats.samples_per_second(),
            error.p95,
            params.weighting,
        )
        .map(|c| format!("\n{c}"))
        .unwrap_or_default()
}

/// What more accuracy costs, projected from this run: `None` without an error or a rate.
///
/// Monte Carlo error falls as samples^−½, so halving the p95 relative error takes 4× the samples
/// in all and one more digit 100×; the extra time is the samples still missing at the rate just
/// measured. Radiance weighting is slower than that at first (its contributions are heavy-tailed,
/// and its estimated error is optimistic at low samples), which the text says.
pub fn cost_of_accuracy(
    total_samples: u64,
    samples_per_second: f64,
    p95: f64,
    weighting: Weighting,
) -> Option<String> {
    if total_samples == 0 || !(samples_per_second > 0.0) || !(p95 > 0.0 && p95.is_finite()) {
        return None;
    }
    let more = |factor: f64| {
        let secs = (factor - 1.0) * total_samples as f64 / samples_per_second;
        Duration::try_from_secs_f64(secs).map_or_else(|_| "forever".into(), fmt_duration)
    };
    let caveat = if weighting == Weighting::Radiance {
        "; radiance weighting converges slower than this at first, `ftpd3d converge` measures it"
    } else {
        ""
    };
    Some(format!(
        "cost of accuracy (error ∝ samples^-1/2): p95 {:.3} needs 4x the samples (about {} more \
         at this rate), p95 {:.4} 100x (about {} more){caveat}",
        p95 / 2.0,
        more(4.0),
        p95 / 10.0,
        more(100.0)
    ))
}

/// `s` quoted for a POSIX shell when it needs it.
pub fn shell_quote(s: &str) -> String {
    if !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./=:,+@%".contains(c))
    {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', r"'\''"))
    }
}

/// `1.5 GB`, `640 GB`, `3.2 TB` (decimal units).
pub fn human_bytes(b: f64) -> String {
    let units = ["B", "kB", "MB", "GB", "TB", "PB", "EB"];
    let mut x = b;
    let mut u = 0;
    while x >= 1000.0 && u + 1 < units.len() {
        x /= 1000.0;
        u += 1;
    }
    if u == 0 || x >= 100.0 {
        format!("{x:.0} {}", units[u])
    } else {
        format!("{x:.1} {}", units[u])
    }
}

/// The scene line every run prints: triangles, lights, features, textures and their memory, load
/// time (parsing and the BVH build apart).
pub fn scene_line(path: &std::path::Path, scene: &crate::scene::Scene, load: Duration) -> String {
    let textures = match scene.textures.textures.len() {
        0 => String::new(),
        n => format!(
            ", {n} textures ({})",
            human_bytes(scene.report.texture_bytes as f64)
        ),
    };
    format!(
        "scene {}: {} triangles ({} degenerate dropped{}), {} lights, features: {}{textures} \
         (loaded in {:.2} s: parsing {:.2} s, BVH {:.2} s)",
        path.display(),
        scene.triangles.len(),
        scene.report.degenerate_dropped,
        instancing_text(scene),
        scene.lights.lights.len(),
        scene.features,
        load.as_secs_f64(),
        scene.report.parse_seconds,
        scene.report.bvh_seconds
    )
}

/// For a scene with instances (glTF's EXT_mesh_gpu_instancing): how many of its triangles are
/// prototypes' and how many the instances place in the world, after a `; `; empty otherwise.
pub fn instancing_text(scene: &crate::scene::Scene) -> String {
    let inst = scene.instancing();
    if inst.is_empty() {
        return String::new();
    }
    let stored: u64 = inst
        .prototypes
        .iter()
        .map(|p| p.triangles.len() as u64)
        .sum();
    format!(
        "; {stored} of them in {} prototype(s), placed by {} instances as {} triangles",
        inst.prototypes.len(),
        inst.instances.len(),
        inst.instanced_triangles()
    )
}

/// What a run's budget is: `64 spp`, `time 1m30s`, `target error 0.05`, joined by `or`.
pub fn budget_text(opts: &RenderOptions) -> String {
    let mut budget = Vec::new();
    if opts.budget.cap_spp {
        budget.push(format!("{} spp", opts.spp));
    }
    if let Some(t) = opts.budget.time {
        budget.push(format!("time {}", fmt_duration(t)));
    }
    if let Some(e) = opts.budget.target_error {
        budget.push(format!("target error {e}"));
    }
    budget.join(" or ")
}

/// The line that starts a domain's run: grid, tile, budget, passes, weighting, run lengths, cone.
pub fn domain_line(
    name: &str,
    dims: (usize, usize, usize),
    tile_note: &str,
    opts: &RenderOptions,
    params: &Params,
    angle_deg: f64,
) -> String {
    format!(
        "{name} → {} {}{tile_note}, budget {}, passes: {}{}{}, weighting {}, T ∈ [{:.4}, {:.4}], θmax {}°",
        grid_text(dims),
        if dims.2 > 1 { "voxels" } else { "cells" },
        budget_text(opts),
        Schedule::of(opts).key(),
        match opts.adaptive {
            Some(a) => format!(", adaptive (at most {}x the uniform share)", a.max_share),
            None => String::new(),
        },
        match opts.gradient_domain {
            Some(alpha) => format!(
                ", gradient-domain (α {alpha}, {} replicates)",
                crate::gradient_domain::REPLICATES
            ),
            None => String::new(),
        },
        params.weighting,
        params.t0,
        params.t1,
        angle_deg
    )
}

/// A volume's grid and memory, before it is allocated.
pub fn volume_line(volume: &Volume, bbox: &Aabb, need: u128, available: u64) -> String {
    format!(
        "volume {}x{}x{} voxels over [{}] .. [{}], spacing [{}]; memory {} of {} available",
        volume.nx,
        volume.ny,
        volume.nz,
        fmt_vec(bbox.min),
        fmt_vec(bbox.max),
        fmt_vec(volume.spacing),
        human_bytes(need as f64),
        human_bytes(available as f64),
    )
}

/// How long the `left` samples still to take should last, at the calibrated rate of `eta`.
pub fn eta_line(eta: &Eta, left: u64) -> String {
    format!(
        "ETA {:.1} s ({:.3e} samples/s on {} random voxels × {} spp, calibrated in {:.2} s)",
        if eta.rate > 0.0 {
            left as f64 / eta.rate
        } else {
            0.0
        },
        eta.rate,
        eta.cells,
        eta.spp,
        eta.calibration_seconds
    )
}

/// Where a resumed run starts.
pub fn resume_line(path: &Path, field: &Field, progress: &Progress) -> String {
    format!(
        "resuming {}: {} passes done, {} samples, {:.1} s of compute so far{}",
        path.display(),
        progress.passes,
        field.total_samples(),
        progress.elapsed,
        if progress.inflight.is_some() {
            "; finishing the interrupted pass first"
        } else {
            ""
        }
    )
}

/// A power to 4 decimals, never "-0.0000": a sum of non-negative terms that rounds to zero (or is
/// a negative zero) prints as 0.
pub fn power(p: f64) -> String {
    let text = format!("{p:.4}");
    if text
        .trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        "0.0000".to_string()
    } else {
        text
    }
}

/// The gain from which the summary says the replay pays: on 9 of the 11 shipped scenes in each of
/// two rounds the gain a run reads from itself was 0.6-1.7 times the one measured at equal time
/// against a plain run (the cells' own samples lose some of their QMC stratification to the
/// replays, and each cell keeps the more precise of two estimates by their noisy errors), so
/// below 1.5 the flag may buy nothing (docs/performance.md#gradient-domain).
const PAYS: f64 = 1.5;

/// What the replayed differences of σ gained: their share of independent cells' variance
/// ([`crate::gradient_domain::difference_share`]), and how much lower the reconstructed field's
/// variance is than the same samples' without the differences
/// ([`crate::gradient_domain::recon::gain`]), which is what the replay buys at equal time.
fn difference_share_note(field: &Field, shift: &crate::gradient_domain::Shift) -> String {
    let dims = field.dims();
    let share = crate::gradient_domain::difference_share(shift, dims)
        .map(|s| {
            format!(
                "\nneighbour differences of σ: {s:.2} of the variance per sample that independent \
                 cells' differences would have"
            )
        })
        .unwrap_or_default();
    let Some(gain) = crate::gradient_domain::recon::gain(shift, dims, &field.cells) else {
        return share;
    };
    let verdict = if gain >= PAYS {
        "the replay pays here"
    } else {
        "it pays little or nothing here: a plain run of the same time is about as precise"
    };
    format!(
        "{share}\nreconstructed field: variance of σ {gain:.2}x lower than its samples' without \
         the differences (each cell's own and those replayed into it: the paths a plain run \
         traces for it): {verdict}"
    )
}

#[cfg(test)]
mod tests {
    #[test]
    fn powers_that_round_to_zero_print_as_zero() {
        assert_eq!(super::power(-0.0), "0.0000");
        assert_eq!(super::power(-1e-9), "0.0000");
        assert_eq!(super::power(0.0), "0.0000");
        assert_eq!(super::power(1.23456), "1.2346");
    }
}
