//! Merging partial runs (`ftpd3d merge`): other seeds, other tiles, other machines. A field is sums,
//! so merging adds them cell by cell in f64 ([`Moments::merge`]), in the order the files are given;
//! σ, its standard error, the gradient and the previews are then computed afresh from the sums.
//!
//! What may differ between the inputs, and what may not:
//! - The run must be the same: scene, domain (plane or camera and their geometry), resolution,
//!   weighting, t0, t1, angle, bounce cap, feature set and extra point lights ([`MUST_MATCH`]).
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

use crate::field::Field;
use crate::output::{self, vti::Vti};
pub use crate::run_info::Part;
use crate::run_info::{CellCount, ESTIMATE_KEYS, Remaining, RunInfo};
use anyhow::bail;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// The attributes that describe what a run estimates ([`ESTIMATE_KEYS`], among them `flatland`):
/// merged fields must agree on every one (compared as typed values; absent on both counts as
/// agreeing), and so must a resumed run with its file (which checks a few more).
pub const MUST_MATCH: &[&str] = ESTIMATE_KEYS;

/// Checks that `b` (read from `b_name`) describes the same run as `a` (from `a_name`): grid size
/// and every attribute of [`MUST_MATCH`]. The message names the file and the attribute, e.g.
/// `b.exr: t1 = 2e0 differs from a.exr's 1.5e0`.
pub fn check_same_run(a_name: &str, a: &Field, b_name: &str, b: &Field) -> anyhow::Result<()> {
    if (a.width, a.height, a.depth) != (b.width, b.height, b.depth) {
        bail!(
            "{b_name}: resolution {} differs from {a_name}'s {}",
            grid(b),
            grid(a)
        );
    }
    check_same_info(a_name, &a.info(a_name)?, b_name, &b.info(b_name)?)
}

/// [`check_same_run`] of two descriptions.
fn check_same_info(a_name: &str, a: &RunInfo, b_name: &str, b: &RunInfo) -> anyhow::Result<()> {
    let Some(key) = a.first_difference(b, MUST_MATCH) else {
        return Ok(());
    };
    let (am, bm) = (a.to_attributes(), b.to_attributes());
    match (am.get(key), bm.get(key)) {
        (Some(x), Some(y)) => bail!("{b_name}: {key} = {y} differs from {a_name}'s {x}"),
        (Some(x), None) => bail!("{b_name}: has no {key}, while {a_name} has {key} = {x}"),
        (None, Some(y)) => bail!("{b_name}: {key} = {y}, while {a_name} has no {key}"),
        // Values that differ yet print alike (0 and -0 do not: they print apart).
        (None, None) => bail!("{b_name}: {key} differs from {a_name}'s"),
    }
}

/// `WxH`, or `WxHxD` for a volume.
fn grid(f: &Field) -> String {
    if f.depth == 1 {
        format!("{}x{}", f.width, f.height)
    } else {
        format!("{}x{}x{}", f.width, f.height, f.depth)
    }
}

/// The rows tiles and parts count in: a 2D grid's rows, a volume's z layers (as
/// [`crate::domain::Tile::cells`] splits them).
pub fn rows(f: &Field) -> usize {
    if f.depth > 1 { f.depth } else { f.height }
}

/// The row ([`rows`]) of cell `k`.
fn row_of(f: &Field, k: usize) -> usize {
    if f.depth > 1 {
        k / (f.width * f.height)
    } else {
        (k / f.width) % f.height
    }
}

/// The parts of a field: its `parts` attribute, or else its `seed` over its `tile`'s rows (all
/// rows without a tile).
pub fn parts_of(name: &str, f: &Field) -> anyhow::Result<Vec<Part>> {
    parts_in(name, &f.info(name)?, f)
}

/// [`parts_of`] with the field's description read.
fn parts_in(name: &str, info: &RunInfo, f: &Field) -> anyhow::Result<Vec<Part>> {
    if let Some(p) = &info.parts {
        return Ok(p.clone());
    }
    let Some(seed) = info.seed else {
        bail!("{name}: no seed attribute (not a field written by ftpd3d?)");
    };
    let rows = match info.tiles.as_slice() {
        [] => 0..rows(f),
        [t] => t.rows(rows(f)),
        _ => bail!("{name}: several tiles and no parts attribute: its header is damaged"),
    };
    Ok(vec![Part { seed, rows }])
}

/// Sorted, with adjacent or overlapping row ranges of one seed joined.
fn coalesce(mut parts: Vec<Part>) -> Vec<Part> {
    parts.retain(|p| !p.rows.is_empty());
    parts.sort_by_key(|p| (p.seed, p.rows.start, p.rows.end));
    let mut out: Vec<Part> = Vec::new();
    for p in parts {
        match out.last_mut() {
            Some(q) if q.seed == p.seed && p.rows.start <= q.rows.end => {
                q.rows.end = q.rows.end.max(p.rows.end)
            }
            _ => out.push(p),
        }
    }
    out
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
pub fn merge_fields(inputs: Vec<(String, Field)>) -> anyhow::Result<Merged> {
    let Some((first_name, first)) = inputs.first() else {
        bail!("merge: no input fields");
    };
    let infos = inputs
        .iter()
        .map(|(name, f)| f.info(name))
        .collect::<Result<Vec<_>, _>>()?;
    let mut warnings = Vec::new();
    let mut all_parts: Vec<(Part, usize)> = Vec::new();
    let mut parts_per_input = Vec::with_capacity(inputs.len());
    for (k, (name, f)) in inputs.iter().enumerate() {
        if f.cells.len() != f.width * f.height * f.depth {
            bail!("{name}: {} cells for a {} grid", f.cells.len(), grid(f));
        }
        check_same_run(first_name, first, name, f)?;
        let parts = parts_in(name, &infos[k], f)?;
        parts_per_input.push(parts.clone());
        // Cells outside the rows the file claims must be empty, or its metadata lies.
        let mut covered = vec![false; rows(f)];
        for p in &parts {
            if p.rows.end > rows(f) {
                bail!("{name}: part {p} lies outside its {} rows", rows(f));
            }
            covered[p.rows.clone()].iter_mut().for_each(|c| *c = true);
        }
        if let Some(k) = (0..f.cells.len()).find(|&k| f.cells[k].n > 0 && !covered[row_of(f, k)]) {
            bail!(
                "{name}: cell {k} (row {}) holds samples outside the rows its seed/tile/parts \
                 attributes name: its header does not describe its contents",
                row_of(f, k)
            );
        }
        for p in parts {
            if let Some((q, j)) = all_parts.iter().find(|(q, _)| {
                q.seed == p.seed && q.rows.start.max(p.rows.start) < q.rows.end.min(p.rows.end)
            }) {
                let other = &inputs[*j].0;
                if q.rows == (0..rows(f)) && p.rows == (0..rows(f)) {
                    bail!(
                        "{name}: seed {} is also the seed of {other}: the same seed repeats the \
                         same random streams, so merging would count the same samples twice \
                         (run the extra part with another --seed)",
                        p.seed
                    );
                }
                bail!(
                    "{name}: seed {} over rows {}-{} overlaps rows {}-{} of {other} with the same \
                     seed: the same seed repeats the same random streams, so merging would count \
                     the same samples twice (run the extra part with another --seed)",
                    p.seed,
                    p.rows.start,
                    p.rows.end,
                    q.rows.start,
                    q.rows.end
                );
            }
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
    }

    // What the run estimates, from the first input (they all agree on it).
    let one = &infos[0];
    let mut info = RunInfo {
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
        tool: Some(format!("ftpd3d {}", env!("CARGO_PKG_VERSION"))),
        ..RunInfo::default()
    };
    // Text attributes the inputs may differ on: kept, joined where they do.
    info.embree = join_text(infos.iter().map(|i| i.embree.as_ref()));
    info.kernel = join_text(infos.iter().map(|i| i.kernel.as_ref()));
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
    if tools.len() > 1 {
        warnings.push(format!(
            "the inputs were written by different versions ({})",
            tools.iter().copied().collect::<Vec<_>>().join(", ")
        ));
    }
    let parts = coalesce(all_parts.iter().map(|(p, _)| p.clone()).collect());
    let seeds: BTreeSet<u64> = parts.iter().map(|p| p.seed).collect();
    info.seeds = seeds.iter().copied().collect();
    if seeds.len() == 1 {
        info.seed = seeds.first().copied();
    }
    let h = rows(&field);
    let mut covered = vec![false; h];
    for p in &parts {
        covered[p.rows.clone()].iter_mut().for_each(|c| *c = true);
    }
    info.parts = Some(parts);
    if covered.iter().any(|c| !c) {
        let mut tiles: Vec<_> = infos.iter().flat_map(|i| i.tiles.iter().copied()).collect();
        tiles.sort_by_key(|t| t.to_string());
        tiles.dedup();
        info.tiles = tiles;
        warnings.push(format!(
            "the merged field covers {} of {h} rows: merge the missing tiles too for a full grid",
            covered.iter().filter(|c| **c).count()
        ));
    }
    let counts: BTreeSet<u64> = field.cells.iter().map(|c| c.n).filter(|&n| n > 0).collect();
    if let (Some(lo), Some(hi)) = (counts.first(), counts.last()) {
        info.spp = Some(CellCount::range(*lo, *hi));
    }
    // Batches per row: every input adds its batch count to the rows it covers.
    let mut row_batches = vec![Some(0u64); h];
    for (i, parts) in infos.iter().zip(&parts_per_input) {
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
    info.merged = inputs.iter().map(|(n, _)| n.clone()).collect();
    progress_totals(&mut info, &infos, &field);
    field.set_info(&info);
    Ok(Merged { field, warnings })
}

/// The progress of a merged field describes the merged field: `samples` is its total, `elapsed`
/// the compute seconds of all inputs together, `remaining.samples` what the inputs still lacked
/// of their budgets (added; `unbounded` if any input had no sample cap), `partial` and
/// `pass.inflight` true if any input was; `passes` and `stop` are kept only where all inputs
/// agree. A merged field is not resumable (`--resume` takes one run's file), so nothing else is
/// needed.
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

/// What `merge` reads and writes, by file extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    /// 2D fields (slices, camera images): OpenEXR.
    Exr,
    /// Volumes: VTK XML ImageData.
    Vti,
}

impl Format {
    fn of(path: &Path) -> Option<Format> {
        match path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref()
        {
            Some("exr") => Some(Format::Exr),
            Some("vti") => Some(Format::Vti),
            _ => None,
        }
    }

    fn describe(self) -> &'static str {
        match self {
            Format::Exr => "an .exr field",
            Format::Vti => "a .vti volume",
        }
    }

    fn ext(self) -> &'static str {
        match self {
            Format::Exr => "exr",
            Format::Vti => "vti",
        }
    }
}

/// Checks that volume `b` (from `b_name`) lies on the same points as `a`: the same `Origin` and
/// `Spacing`, exactly (both are written as the shortest decimal that reads back as the same f64).
fn check_same_grid(a_name: &str, a: &Vti, b_name: &str, b: &Vti) -> anyhow::Result<()> {
    for (key, x, y) in [
        ("Origin", a.origin, b.origin),
        ("Spacing", a.spacing, b.spacing),
    ] {
        if x != y {
            bail!(
                "{b_name}: {key} {} {} {} differs from {a_name}'s {} {} {}",
                y.x,
                y.y,
                y.z,
                x.x,
                x.y,
                x.z
            );
        }
    }
    Ok(())
}

/// Reads EXR fields or VTI volumes (all of one kind, told by the extension), merges them
/// ([`merge_fields`]) and writes the result in the same format to `output` (whose extension must
/// match), with fresh σ, standard error, gradient and (when `png`) previews (of the middle z-layer
/// for volumes). Input names in messages are the paths as given.
pub fn merge_files(inputs: &[PathBuf], output: &Path, png: bool) -> anyhow::Result<Merged> {
    let Some(first) = inputs.first() else {
        bail!("merge: give the .exr fields or .vti volumes to merge");
    };
    let format_of = |p: &Path| {
        Format::of(p).ok_or_else(|| {
            anyhow::anyhow!(
                "{}: merge reads .exr fields and .vti volumes written by ftpd3d; this name has \
                 neither extension",
                p.display()
            )
        })
    };
    let format = format_of(first)?;
    for p in &inputs[1..] {
        let f = format_of(p)?;
        if f != format {
            bail!(
                "{}: is {}, while {} is {}: fields and volumes cannot be merged together \
                 (merge the .exr and the .vti files separately)",
                p.display(),
                f.describe(),
                first.display(),
                format.describe()
            );
        }
    }
    if Format::of(output) != Some(format) {
        bail!(
            "-o {}: the inputs are {} files, so the merged file is one too: name it .{}",
            output.display(),
            format.ext(),
            format.ext()
        );
    }
    output::check_writable(output)?;
    for p in inputs {
        if !p.exists() {
            bail!("{}: no such file", p.display());
        }
    }
    let name = |p: &PathBuf| p.display().to_string();
    match format {
        Format::Exr => {
            let fields = inputs
                .iter()
                .map(|p| Ok((name(p), output::exr::read_exr(p)?)))
                .collect::<anyhow::Result<Vec<_>>>()?;
            let merged = merge_fields(fields)?;
            output::write_outputs(&merged.field, output, png)?;
            Ok(merged)
        }
        Format::Vti => {
            let volumes = inputs
                .iter()
                .map(|p| Ok((name(p), output::vti::read_vti(p)?)))
                .collect::<anyhow::Result<Vec<_>>>()?;
            let (first_name, head) = &volumes[0];
            for (n, v) in &volumes[1..] {
                check_same_run(first_name, &head.field, n, &v.field)?;
                check_same_grid(first_name, head, n, v)?;
            }
            let (origin, spacing) = (head.origin, head.spacing);
            let merged = merge_fields(volumes.into_iter().map(|(n, v)| (n, v.field)).collect())?;
            output::write_volume_outputs(&merged.field, origin, spacing, output, png)?;
            Ok(merged)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::run_info::fmt_parts;

    #[test]
    fn parts_coalesce_and_print() {
        let p = |seed, a, b| Part { seed, rows: a..b };
        let c = coalesce(vec![p(2, 0, 4), p(1, 5, 9), p(1, 0, 5), p(1, 9, 9)]);
        assert_eq!(c, vec![p(1, 0, 9), p(2, 0, 4)]);
        assert_eq!(fmt_parts(&c), "1@0-9;2@0-4");
        assert_eq!(" 7@3-8".parse::<Part>().unwrap(), p(7, 3, 8));
        assert!("7:3-8".parse::<Part>().is_err());
    }
}
