//! Merging partial runs: other seeds, other tiles, other machines. A field is sums,
//! so merging adds them cell by cell in f64 ([`Moments::merge`]), in the order the files are given;
//! σ, its standard error, the gradient and the previews are then computed afresh from the sums.
//!
//! What may differ between the inputs, and what may not:
//! - The run must be the same: scene, domain (plane or camera and their geometry), resolution,
//!   weighting, t0, t1, angle, bounce cap, feature set, extra point lights, and for
//!   gradient-domain runs α and the replicates ([`MUST_MATCH`]; an ordinary field does not merge
//!   with a gradient-domain one).
//!   A mismatch is refused with the file and key named.
//! - Seeds and tiles may differ. What a field holds is recorded as *parts*: a seed and the rows of
//!   the grid it sampled (`seed@r0-r1`, rows from the bottom). A fresh run is one part (its seed,
//!   all rows or its tile's rows); a merged file lists its parts in the `parts` attribute. Two parts
//!   with the same seed over overlapping rows are refused: a cell's random streams are keyed by
//!   (seed, batch, cell), so the same seed would count the same samples twice.
//!
//! Tiles are full-size grids with only their stripe filled ([`crate::domain::tile`]); adding the
//! empty cells is exact (x + 0 = x), so merging all tiles of one seed reproduces the full run bit
//! for bit.
//!
//! Volumes (`.vti`) merge the same way: they hold the same exact sums, voxel by voxel, and their
//! tiles are slabs of whole z layers, so a volume's "rows" are its z layers ([`rows`]). Their grid
//! geometry (`Origin`, `Spacing`) must match as well. Fields and volumes are
//! not mixed, and the output is written in the inputs' format.

mod files;
mod parts;
mod same_run;

pub use crate::run_info::Part;
pub use files::merge_files;
pub use parts::{parts_of, rows};
pub use same_run::{MUST_MATCH, check_same_run};

use crate::field::Field;
use crate::run_info::{CellCount, InfoError, Remaining, RunInfo};
use glam::DVec3;
use parts::{check_not_seen, check_parts_cover, coalesce, parts_in};
use same_run::grid;
use std::collections::BTreeSet;
use std::ops::Range;
use std::path::PathBuf;

/// What merging refuses, in its own terms (the command line names its flags:
/// `crate::cli::analysis_errors`). Files are named as the caller named them.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MergeError {
    #[error("merge: no input fields")]
    NoFields,
    #[error("merge: give the .exr fields or .vti volumes to merge")]
    NoFiles,
    #[error(
        "{}: merge reads .exr fields and .vti volumes written by ftpd3d; this name has neither \
         extension",
        .path.display()
    )]
    UnknownFormat { path: PathBuf },
    #[error(
        "{}: is {kind}, while {} is {first_kind}: fields and volumes cannot be merged together \
         (merge the .exr and the .vti files separately)",
        .path.display(),
        .first.display()
    )]
    MixedFormats {
        path: PathBuf,
        kind: &'static str,
        first: PathBuf,
        first_kind: &'static str,
    },
    #[error(
        "output {}: the inputs are {ext} files, so the merged file is one too: name it .{ext}",
        .output.display()
    )]
    OutputFormat { output: PathBuf, ext: &'static str },
    #[error("{}: no such file", .path.display())]
    NoSuchFile { path: PathBuf },
    #[error(transparent)]
    Info(#[from] InfoError),
    #[error("{file}: resolution {grid} differs from {other}'s {other_grid}")]
    Resolution {
        file: String,
        grid: String,
        other: String,
        other_grid: String,
    },
    /// An attribute of what the run estimates ([`MUST_MATCH`]) differs; a value is `None` where
    /// that file has no such attribute.
    #[error("{}", same_run::differs(.file, .key, .value.as_deref(), .other, .other_value.as_deref()))]
    Differs {
        file: String,
        key: &'static str,
        value: Option<String>,
        other: String,
        other_value: Option<String>,
    },
    #[error(
        "{file}: {key} {} {} {} differs from {other}'s {} {} {}",
        .value.x, .value.y, .value.z, .other_value.x, .other_value.y, .other_value.z
    )]
    GridDiffers {
        file: String,
        key: &'static str,
        value: DVec3,
        other: String,
        other_value: DVec3,
    },
    #[error("{file}: {cells} cells for a {grid} grid")]
    CellCount {
        file: String,
        cells: usize,
        grid: String,
    },
    #[error("{file}: no seed attribute (not a field written by ftpd3d?)")]
    NoSeed { file: String },
    #[error("{file}: several tiles and no parts attribute: its header is damaged")]
    DamagedTiles { file: String },
    #[error("{file}: part {part} lies outside its {rows} rows")]
    PartOutsideRows {
        file: String,
        part: Part,
        rows: usize,
    },
    #[error(
        "{file}: cell {cell} (row {row}) holds samples outside the rows its seed/tile/parts \
         attributes name: its header does not describe its contents"
    )]
    SamplesOutsideParts {
        file: String,
        cell: usize,
        row: usize,
    },
    /// Two whole-grid parts of one seed.
    #[error(
        "{file}: seed {seed} is also the seed of {other}: the same seed repeats the same random \
         streams, so merging would count the same samples twice (run the extra part with another \
         seed)"
    )]
    SeedRepeated {
        file: String,
        seed: u64,
        other: String,
    },
    /// Parts of one seed over overlapping rows.
    #[error(
        "{file}: seed {seed} over rows {}-{} overlaps rows {}-{} of {other} with the same seed: the \
         same seed repeats the same random streams, so merging would count the same samples twice \
         (run the extra part with another seed)",
        .rows.start, .rows.end, .other_rows.start, .other_rows.end
    )]
    SeedOverlap {
        file: String,
        seed: u64,
        rows: Range<usize>,
        other: String,
        other_rows: Range<usize>,
    },
}

/// The result of [`merge_fields`]: the summed field and what the user should know.
#[derive(Debug)]
pub struct Merged {
    pub field: Field,
    pub warnings: Vec<String>,
}

/// The distinct values of a text attribute over the inputs, sorted and joined with `; ` (one
/// value when they agree); `None` when no input has it.
fn join_text<'a>(values: impl Iterator<Item = Option<&'a String>>) -> Option<String> {
    let set: BTreeSet<&str> = values.flatten().map(String::as_str).collect();
    (!set.is_empty()).then(|| set.into_iter().collect::<Vec<_>>().join("; "))
}

/// The one value all inputs have, if they do.
fn agreed<T: PartialEq + Clone>(values: impl Iterator<Item = Option<T>>) -> Option<T> {
    let v: Vec<Option<T>> = values.collect();
    match v.first() {
        Some(Some(x)) if v.iter().all(|y| y.as_ref() == Some(x)) => Some(x.clone()),
        _ => None,
    }
}

/// Merges named fields: checks them ([`check_same_run`], parts), adds their sums in the given order
/// (the first field's sums, plus the second's, ...) and describes the merged field: what the run
/// estimates from the inputs (they agree on it), the other text attributes joined where the
/// inputs differ, and afresh `parts`, `seeds` (the distinct seeds merged), `seed` (when there is
/// one), `tile` (only while the rows are not all covered), `spp` (from the sample counts: `N`, or
/// `MIN-MAX` when cells differ), `batches` (per row, summed over the inputs covering it),
/// `merged` (the input names) and the progress totals ([`progress_totals`]).
pub fn merge_fields(inputs: Vec<(String, Field)>) -> Result<Merged, MergeError> {
    let Some((first_name, first)) = inputs.first() else {
        return Err(MergeError::NoFields);
    };
    let infos = inputs
        .iter()
        .map(|(name, f)| f.info(name))
        .collect::<Result<Vec<_>, _>>()?;
    let mut all_parts: Vec<(Part, usize)> = Vec::new();
    let mut parts_per_input = Vec::with_capacity(inputs.len());
    let names: Vec<&str> = inputs.iter().map(|(n, _)| n.as_str()).collect();
    for (k, (name, f)) in inputs.iter().enumerate() {
        if f.cells.len() != f.width * f.height * f.depth {
            return Err(MergeError::CellCount {
                file: name.clone(),
                cells: f.cells.len(),
                grid: grid(f),
            });
        }
        check_same_run(first_name, first, name, f)?;
        let parts = parts_in(name, &infos[k], f)?;
        parts_per_input.push(parts.clone());
        check_parts_cover(name, f, &parts)?;
        for p in parts {
            check_not_seen(name, rows(f), &p, &all_parts, &names)?;
            all_parts.push((p, k));
        }
    }

    let mut it = inputs.iter();
    let (_, head) = it.next().expect("not empty");
    let mut field = head.clone();
    for (_, f) in it {
        for (c, o) in field.cells.iter_mut().zip(&f.cells) {
            c.merge(o);
        }
        // Both gradient-domain with the same α and replicates ([`check_same_run`]): their
        // replayed sums add like the cells'.
        if let (Some(s), Some(o)) = (field.shift.as_mut(), f.shift.as_ref()) {
            s.merge(o);
        }
    }

    let mut warnings = Vec::new();
    let mut info = estimate_of(&infos[0]);
    warnings.extend(join_differing(&mut info, &infos));
    if info.pairs.as_deref().is_some_and(|p| p.contains(';')) {
        // Each design's samples estimate the same expectations, one unit each: the sums add.
        warnings.push(format!(
            "the inputs took different deflection pairs per sample ({}): every sample counts \
             once, whatever its pairs",
            info.pairs.as_deref().unwrap_or_default()
        ));
    }
    let parts = coalesce(all_parts.iter().map(|(p, _)| p.clone()).collect());
    let covered = set_parts(&mut info, &infos, parts, rows(&field));
    let h = covered.len();
    if covered.iter().any(|c| !c) {
        warnings.push(format!(
            "the merged field covers {} of {h} rows: merge the missing tiles too for a full grid",
            covered.iter().filter(|c| **c).count()
        ));
    }
    set_counts(&mut info, &infos, &parts_per_input, &covered, &field);
    info.merged = inputs.iter().map(|(n, _)| n.clone()).collect();
    progress_totals(&mut info, &infos, &field);
    field.set_info(&info);
    Ok(Merged { field, warnings })
}

/// What the run estimates, from one input (they all agree on it), as the start of the merged
/// field's description.
fn estimate_of(one: &RunInfo) -> RunInfo {
    RunInfo {
        scene: one.scene.clone(),
        domain: one.domain,
        plane: one.plane.clone(),
        camera: one.camera.clone(),
        volume: one.volume.clone(),
        weighting: one.weighting,
        t0: one.t0,
        t1: one.t1,
        angle_deg: one.angle_deg,
        max_bounces: one.max_bounces,
        radiance_bounces: one.radiance_cap(),
        features: one.features.clone(),
        point_lights: one.point_lights.clone(),
        sun: one.sun.clone(),
        sky: one.sky.clone(),
        flatland: one.flatland,
        gradient: one.gradient,
        tool: Some(format!("ftpd3d {}", env!("CARGO_PKG_VERSION"))),
        ..RunInfo::default()
    }
}

/// The text attributes the inputs may differ on, kept, joined where they do; a warning when the
/// inputs were written by different versions.
fn join_differing(info: &mut RunInfo, infos: &[RunInfo]) -> Option<String> {
    info.embree = join_text(infos.iter().map(|i| i.embree.as_ref()));
    info.kernel = join_text(infos.iter().map(|i| i.kernel.as_ref()));
    info.pairs = join_text(infos.iter().map(|i| i.pairs.as_ref()));
    let off = "off".to_string();
    info.guide =
        join_text(infos.iter().map(|i| i.guide.as_ref().or(Some(&off)))).filter(|g| g != "off");
    info.schedule = join_text(infos.iter().map(|i| i.schedule.as_ref()));
    info.adaptive = join_text(infos.iter().map(|i| i.adaptive.as_ref()));
    info.budget_time = join_text(infos.iter().map(|i| i.budget_time.as_ref()));
    info.budget_target_error = join_text(infos.iter().map(|i| i.budget_target_error.as_ref()));
    let extra_keys: BTreeSet<&String> = infos.iter().flat_map(|i| i.extra.keys()).collect();
    for key in extra_keys {
        if let Some(v) = join_text(infos.iter().map(|i| i.extra.get(key))) {
            info.extra.insert(key.clone(), v);
        }
    }
    let tools: BTreeSet<&str> = infos.iter().filter_map(|i| i.tool.as_deref()).collect();
    (tools.len() > 1).then(|| {
        format!(
            "the inputs were written by different versions ({})",
            tools.iter().copied().collect::<Vec<_>>().join(", ")
        )
    })
}

/// `parts`, `seeds`, `seed` (when there is one) and, while the `rows` are not all covered, the
/// inputs' `tile`s; returns which rows the parts cover.
fn set_parts(info: &mut RunInfo, infos: &[RunInfo], parts: Vec<Part>, rows: usize) -> Vec<bool> {
    let seeds: BTreeSet<u64> = parts.iter().map(|p| p.seed).collect();
    info.seeds = seeds.iter().copied().collect();
    if seeds.len() == 1 {
        info.seed = seeds.first().copied();
    }
    let mut covered = vec![false; rows];
    for p in &parts {
        covered[p.rows.clone()].iter_mut().for_each(|c| *c = true);
    }
    info.parts = Some(parts);
    if covered.iter().any(|c| !c) {
        let mut tiles: Vec<_> = infos.iter().flat_map(|i| i.tiles.iter().copied()).collect();
        tiles.sort_by_key(|t| t.to_string());
        tiles.dedup();
        info.tiles = tiles;
    }
    covered
}

/// `spp` from the sample counts (`N`, or `MIN-MAX` when cells differ) and `batches` per covered
/// row, summed over the inputs covering it (left out when an input's count is not one number).
fn set_counts(
    info: &mut RunInfo,
    infos: &[RunInfo],
    parts_per_input: &[Vec<Part>],
    covered: &[bool],
    field: &Field,
) {
    let counts: BTreeSet<u64> = field.cells.iter().map(|c| c.n).filter(|&n| n > 0).collect();
    if let (Some(lo), Some(hi)) = (counts.first(), counts.last()) {
        info.spp = Some(CellCount::range(*lo, *hi));
    }
    let h = covered.len();
    let mut row_batches = vec![Some(0u64); h];
    for (i, parts) in infos.iter().zip(parts_per_input) {
        let b = match i.batches {
            Some(CellCount::Each(n)) => Some(n),
            _ => None,
        };
        for p in parts {
            for r in p.rows.clone() {
                row_batches[r] = match (row_batches[r], b) {
                    (Some(x), Some(y)) => Some(x + y),
                    _ => None,
                };
            }
        }
    }
    let per_row: BTreeSet<Option<u64>> = (0..h)
        .filter(|&r| covered[r])
        .map(|r| row_batches[r])
        .collect();
    if !per_row.contains(&None) {
        let v: Vec<u64> = per_row.into_iter().flatten().collect();
        if let (Some(lo), Some(hi)) = (v.first(), v.last()) {
            info.batches = Some(CellCount::range(*lo, *hi));
        }
    }
}

/// The progress of a merged field describes the merged field: `samples` is its total, `elapsed`
/// the compute seconds of all inputs together, `remaining.samples` what the inputs still lacked
/// of their budgets (added; `unbounded` if any input had no sample cap), `partial` and
/// `pass.inflight` true if any input was; `passes` and `stop` are kept only where all inputs
/// agree. A merged field is not resumable (a resumed run continues one run's file), so nothing
/// else is needed.
fn progress_totals(info: &mut RunInfo, inputs: &[RunInfo], field: &Field) {
    info.samples = Some(field.total_samples());
    info.elapsed = inputs.iter().map(|i| i.elapsed).sum();
    if !inputs.is_empty() && inputs.iter().all(|i| i.remaining_samples.is_some()) {
        info.remaining_samples = Some(
            match inputs
                .iter()
                .map(|i| match i.remaining_samples {
                    Some(Remaining::Samples(n)) => Some(n),
                    _ => None,
                })
                .sum::<Option<u64>>()
            {
                Some(n) => Remaining::Samples(n),
                None => Remaining::Unbounded,
            },
        );
    }
    let any = |get: fn(&RunInfo) -> Option<bool>| {
        let v: Vec<Option<bool>> = inputs.iter().map(get).collect();
        v.iter()
            .any(Option::is_some)
            .then(|| v.contains(&Some(true)))
    };
    info.partial = any(|i| i.partial);
    info.inflight = any(|i| i.inflight);
    info.passes = agreed(inputs.iter().map(|i| i.passes));
    info.stop = agreed(inputs.iter().map(|i| i.stop.clone()));
}
