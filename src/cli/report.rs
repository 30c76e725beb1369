//! Report formatting: the run's lines (from [`crate::app::report`], where the job runner prints
//! them), and the lines of `merge` and `converge`.

pub use crate::app::report::{cost_of_accuracy, human_bytes, scene_line, shell_quote, summary};
use crate::field::Field;
use crate::render;
pub use crate::run_info::fmt_duration;

/// Mean and 95th percentile of the relative standard error over valid cells with σ > 0 (see
/// [`render::error_stats`] for the definitions).
pub fn relative_error_summary(field: &Field) -> (f64, f64) {
    let e = render::field_error_stats(field, 0..field.cells.len());
    (e.mean, e.p95)
}

/// The line `merge` prints: what the merged field holds and its error.
pub fn merge_summary(files: usize, field: &Field) -> String {
    let m = &field.meta;
    let get = |k: &str| m.get(k).map_or("?", String::as_str);
    let (rel_mean, rel_p95) = relative_error_summary(field);
    format!(
        "merged {files} files: {}, seeds {}, parts {}, {} spp{}; relative error mean {:.3}, p95 {:.3}",
        match field.depth {
            1 => format!("{}x{} cells", field.width, field.height),
            d => format!("{}x{}x{d} voxels", field.width, field.height),
        },
        get("seeds"),
        get("parts"),
        get("spp"),
        match (m.get("gradient.alpha"), &field.shift) {
            (Some(a), Some(s)) => {
                match crate::gradient_domain::recon::gain(s, field.dims(), &field.cells) {
                    Some(g) => format!(
                        ", gradient-domain (α {a}; variance of σ {g:.2}x lower than without the \
                         differences)"
                    ),
                    None => format!(", gradient-domain (α {a})"),
                }
            }
            (Some(a), None) => format!(", gradient-domain (α {a})"),
            _ => String::new(),
        },
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
