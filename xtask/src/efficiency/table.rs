//! The efficiency report as a Markdown table.

use super::Row;
use super::measure::Level;
use std::fmt::Write as _;

/// The report as a Markdown table: per scene, weighting and error measure, the seconds each
/// binary needs for the baseline's error at its largest level, their ratio, the slopes of ln error
/// against ln seconds, and the z variance of each binary's largest level, over all cells and (in
/// brackets) over the cells the reference resolves.
pub fn table(rows: &[Row]) -> String {
    let f = |v: Option<f64>, p: usize| v.map_or("n/a".to_string(), |x| format!("{x:.p$}"));
    let mut s = String::from(
        "| scene | weighting | error | target | base s | new s | speed-up | base slope | new slope | z var base (resolved) | z var new (resolved) |\n\
         |---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    let zvar = |lv: &[Level]| {
        lv.last().map_or("n/a".to_string(), |l| {
            format!("{:.2} ({:.2})", l.errors.z_var, l.errors.z_var_resolved)
        })
    };
    for r in rows {
        for (name, sp) in [("RMSE σ", &r.rmse), ("p95 rel", &r.p95)] {
            let _ = writeln!(
                s,
                "| {} | {} | {name} | {:.3e} | {} | {} | {} | {} | {} | {} | {} |",
                r.scene,
                r.weighting,
                sp.target,
                f(sp.base_seconds, 2),
                f(sp.new_seconds, 2),
                sp.ratio().map_or("n/a".to_string(), |r| format!("{r:.2}x")),
                f(sp.base_slope, 2),
                f(sp.new_slope, 2),
                zvar(&r.base),
                zvar(&r.new),
            );
        }
    }
    s
}
