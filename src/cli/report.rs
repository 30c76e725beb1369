//! Report formatting: the run summary, what more accuracy costs, sizes and shell quoting.

use crate::field::Field;
use crate::ftpd::{Params, Weighting};
use crate::render::{self, ErrorStats, RunStats};
pub use crate::run_info::fmt_duration;
use std::time::Duration;

/// Mean and 95th percentile of the relative standard error over valid cells with σ > 0 (see
/// [`render::error_stats`] for the definitions).
pub fn relative_error_summary(field: &Field) -> (f64, f64) {
    let e = render::error_stats(&field.cells);
    (e.mean, e.p95)
}

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
    format!(
        "stopped after {} passes ({}): {} samples in {:.2} s{earlier}, {:.3e} samples/s, \
         {:.3e} rays/s; relative error mean {:.4}, p95 {:.4}{unestimated}; {} pairs hit the \
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
    ) + &cost_of_accuracy(
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
        "scene {}: {} triangles ({} degenerate dropped), {} lights, features: {}{textures} (loaded \
         in {:.2} s: parsing {:.2} s, BVH {:.2} s)",
        path.display(),
        scene.triangles.len(),
        scene.report.degenerate_dropped,
        scene.lights.lights.len(),
        scene.features,
        load.as_secs_f64(),
        scene.report.parse_seconds,
        scene.report.bvh_seconds
    )
}

/// The line `merge` prints: what the merged field holds and its error.
pub fn merge_summary(files: usize, field: &Field) -> String {
    let m = &field.meta;
    let get = |k: &str| m.get(k).map_or("?", String::as_str);
    let (rel_mean, rel_p95) = relative_error_summary(field);
    format!(
        "merged {files} files: {}, seeds {}, parts {}, {} spp; relative error mean {:.3}, p95 {:.3}",
        match field.depth {
            1 => format!("{}x{} cells", field.width, field.height),
            d => format!("{}x{}x{d} voxels", field.width, field.height),
        },
        get("seeds"),
        get("parts"),
        get("spp"),
        rel_mean,
        rel_p95
    )
}

/// The line `converge` prints per curve: fitted slopes and the time one more doubling costs.
pub fn converge_line(c: &crate::analysis::converge::Curve) -> String {
    let f = |v: Option<f64>| v.map_or("n/a".to_string(), |x| format!("{x:.3}"));
    format!(
        "{:<10} slope vs time {} ± {}, vs spp {} ± {}; time per doubling {}",
        c.label(),
        f(c.fit_time.map(|f| f.slope)),
        f(c.fit_time.and_then(|f| f.slope_se)),
        f(c.fit_spp.map(|f| f.slope)),
        f(c.fit_spp.and_then(|f| f.slope_se)),
        f(c.time_per_doubling)
    )
}
