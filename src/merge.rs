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

use crate::domain::Tile;
use crate::field::Field;
use crate::output::{self, vti::Vti};
use anyhow::{Context, bail};
use std::collections::{BTreeMap, BTreeSet};
use std::ops::Range;
use std::path::{Path, PathBuf};

/// Metadata keys that describe what a run estimates: merged fields must agree on every one (absent
/// on both counts as agreeing), and so must a resumed run with its file (which checks a few keys
/// more).
pub const MUST_MATCH: &[&str] = &[
    "scene",
    "domain",
    "plane",
    "plane.origin",
    "plane.u",
    "plane.v",
    "plane.size",
    "camera",
    "camera.eye",
    "camera.forward",
    "camera.up",
    "camera.fov_y_deg",
    "weighting",
    "t0",
    "t1",
    "angle_deg",
    "max_bounces",
    "features",
    "point_lights",
    "volume.box",
];

/// Keys the merge writes itself rather than carrying over.
const REWRITTEN: &[&str] = &[
    "seed",
    "seeds",
    "tile",
    "parts",
    "spp",
    "batches",
    "merged",
    "tool",
    // Progress of the run: recomputed for the merged field (totals, not one input's values).
    "samples",
    "elapsed",
    "passes",
    "partial",
    "pass.inflight",
    "remaining.samples",
    "remaining.time",
    "stop",
];

/// One seed over a range of grid rows.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Part {
    pub seed: u64,
    pub rows: Range<usize>,
}

/// Checks that `b` (read from `b_name`) describes the same run as `a` (from `a_name`): grid size
/// and every key of [`MUST_MATCH`]. The message names the file and the key, e.g.
/// `b.exr: t1 = 2e0 differs from a.exr's 1.5e0`.
pub fn check_same_run(a_name: &str, a: &Field, b_name: &str, b: &Field) -> anyhow::Result<()> {
    if (a.width, a.height, a.depth) != (b.width, b.height, b.depth) {
        bail!(
            "{b_name}: resolution {} differs from {a_name}'s {}",
            grid(b),
            grid(a)
        );
    }
    for key in MUST_MATCH {
        match (a.meta.get(*key), b.meta.get(*key)) {
            (Some(x), Some(y)) if x != y => {
                bail!("{b_name}: {key} = {y} differs from {a_name}'s {x}")
            }
            (Some(x), None) => bail!("{b_name}: has no {key}, while {a_name} has {key} = {x}"),
            (None, Some(y)) => bail!("{b_name}: {key} = {y}, while {a_name} has no {key}"),
            _ => {}
        }
    }
    Ok(())
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
/// [`Tile::cells`] splits them).
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
    if let Some(p) = f.meta.get("parts") {
        return p
            .split(';')
            .filter(|s| !s.trim().is_empty())
            .map(|s| parse_part(s).with_context(|| format!("{name}: parts = {p}")))
            .collect();
    }
    let seed = f
        .meta
        .get("seed")
        .with_context(|| format!("{name}: no seed attribute (not a field written by ftpd3d?)"))?;
    let seed = seed
        .parse::<u64>()
        .map_err(|_| anyhow::anyhow!("{name}: seed = {seed} is not a whole number"))?;
    let rows = match f.meta.get("tile") {
        Some(t) => t
            .parse::<Tile>()
            .map_err(|e| anyhow::anyhow!("{name}: tile {e}"))?
            .rows(rows(f)),
        None => 0..rows(f),
    };
    Ok(vec![Part { seed, rows }])
}

fn parse_part(s: &str) -> anyhow::Result<Part> {
    let bad = || anyhow::anyhow!("'{s}' is not SEED@ROW0-ROW1");
    let (seed, rows) = s.trim().split_once('@').ok_or_else(bad)?;
    let (r0, r1) = rows.split_once('-').ok_or_else(bad)?;
    let n = |t: &str| t.trim().parse::<usize>().map_err(|_| bad());
    Ok(Part {
        seed: seed.trim().parse().map_err(|_| bad())?,
        rows: n(r0)?..n(r1)?,
    })
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

fn fmt_parts(parts: &[Part]) -> String {
    parts
        .iter()
        .map(|p| format!("{}@{}-{}", p.seed, p.rows.start, p.rows.end))
        .collect::<Vec<_>>()
        .join(";")
}

/// The result of [`merge_fields`]: the summed field and what the user should know.
#[derive(Debug)]
pub struct Merged {
    pub field: Field,
    pub warnings: Vec<String>,
}

/// Merges named fields: checks them ([`check_same_run`], parts), adds their sums in the given order
/// (the first field's sums, plus the second's, ...) and writes the merged metadata: `parts`,
/// `seeds` (the distinct seeds merged), `seed` (when there is one), `tile` (only while the rows
/// are not all covered), `spp` (from the sample counts: `N`, or `MIN-MAX` when cells differ),
/// `batches` (per row, summed over the inputs covering it), `merged` (the input names).
pub fn merge_fields(inputs: Vec<(String, Field)>) -> anyhow::Result<Merged> {
    let Some((first_name, first)) = inputs.first() else {
        bail!("merge: no input fields");
    };
    let mut warnings = Vec::new();
    let mut all_parts: Vec<(Part, usize)> = Vec::new();
    for (k, (name, f)) in inputs.iter().enumerate() {
        if f.cells.len() != f.width * f.height * f.depth {
            bail!("{name}: {} cells for a {} grid", f.cells.len(), grid(f));
        }
        check_same_run(first_name, first, name, f)?;
        let parts = parts_of(name, f)?;
        // Cells outside the rows the file claims must be empty, or its metadata lies.
        let mut covered = vec![false; rows(f)];
        for p in &parts {
            if p.rows.end > rows(f) {
                bail!(
                    "{name}: part {}@{}-{} lies outside its {} rows",
                    p.seed,
                    p.rows.start,
                    p.rows.end,
                    rows(f)
                );
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

    // Metadata: the run's description from the first file; other keys kept when all agree.
    let mut meta: BTreeMap<String, String> = BTreeMap::new();
    let keys: BTreeSet<&String> = inputs.iter().flat_map(|(_, f)| f.meta.keys()).collect();
    for key in keys {
        if REWRITTEN.contains(&key.as_str()) {
            continue;
        }
        let values: BTreeSet<&str> = inputs
            .iter()
            .filter_map(|(_, f)| f.meta.get(key).map(String::as_str))
            .collect();
        meta.insert(
            key.clone(),
            values.into_iter().collect::<Vec<_>>().join("; "),
        );
    }
    let tools: BTreeSet<&str> = inputs
        .iter()
        .filter_map(|(_, f)| f.meta.get("tool").map(String::as_str))
        .collect();
    if tools.len() > 1 {
        warnings.push(format!(
            "the inputs were written by different versions ({})",
            tools.iter().copied().collect::<Vec<_>>().join(", ")
        ));
    }
    meta.insert(
        "tool".into(),
        format!("ftpd3d {}", env!("CARGO_PKG_VERSION")),
    );
    let parts = coalesce(all_parts.iter().map(|(p, _)| p.clone()).collect());
    let seeds: BTreeSet<u64> = parts.iter().map(|p| p.seed).collect();
    meta.insert(
        "seeds".into(),
        seeds
            .iter()
            .map(u64::to_string)
            .collect::<Vec<_>>()
            .join(","),
    );
    if seeds.len() == 1 {
        meta.insert("seed".into(), seeds.iter().next().expect("one").to_string());
    }
    meta.insert("parts".into(), fmt_parts(&parts));
    let h = rows(&field);
    let mut covered = vec![false; h];
    for p in &parts {
        covered[p.rows.clone()].iter_mut().for_each(|c| *c = true);
    }
    if covered.iter().any(|c| !c) {
        let tiles: BTreeSet<&str> = inputs
            .iter()
            .filter_map(|(_, f)| f.meta.get("tile").map(String::as_str))
            .flat_map(|t| t.split(','))
            .collect();
        meta.insert(
            "tile".into(),
            tiles.into_iter().collect::<Vec<_>>().join(","),
        );
        warnings.push(format!(
            "the merged field covers {} of {h} rows: merge the missing tiles too for a full grid",
            covered.iter().filter(|c| **c).count()
        ));
    }
    let counts: BTreeSet<u64> = field.cells.iter().map(|c| c.n).filter(|&n| n > 0).collect();
    if let (Some(lo), Some(hi)) = (counts.first(), counts.last()) {
        meta.insert(
            "spp".into(),
            if lo == hi {
                lo.to_string()
            } else {
                format!("{lo}-{hi}")
            },
        );
    }
    // Batches per row: every input adds its batch count to the rows it covers.
    let mut row_batches = vec![Some(0u64); h];
    for (name, f) in &inputs {
        let b = f.meta.get("batches").and_then(|b| b.parse::<u64>().ok());
        for p in parts_of(name, f)? {
            for r in p.rows {
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
            meta.insert(
                "batches".into(),
                if lo == hi {
                    lo.to_string()
                } else {
                    format!("{lo}-{hi}")
                },
            );
        }
    }
    meta.insert(
        "merged".into(),
        inputs
            .iter()
            .map(|(n, _)| n.as_str())
            .collect::<Vec<_>>()
            .join(";"),
    );
    progress_totals(&mut meta, &inputs, &field);
    field.meta = meta;
    Ok(Merged { field, warnings })
}

/// The progress keys of a merged field describe the merged field: `samples` is its total,
/// `elapsed` the compute seconds of all inputs together, `remaining.samples` what the inputs still
/// lacked of their budgets (added; `unbounded` if any input had no sample cap), `partial` and
/// `pass.inflight` true if any input was; `passes` and `stop` are kept only where all inputs agree.
/// A merged field is not resumable (`--resume` takes one run's file), so nothing else is needed.
fn progress_totals(meta: &mut BTreeMap<String, String>, inputs: &[(String, Field)], field: &Field) {
    meta.insert("samples".into(), field.total_samples().to_string());
    let get = |k: &str| -> Vec<Option<&str>> {
        inputs
            .iter()
            .map(|(_, f)| f.meta.get(k).map(String::as_str))
            .collect()
    };
    let elapsed: Option<f64> = get("elapsed")
        .into_iter()
        .map(|v| v.and_then(|v| v.parse::<f64>().ok()))
        .sum();
    if let Some(e) = elapsed {
        meta.insert("elapsed".into(), e.to_string());
    }
    let remaining = get("remaining.samples");
    if remaining.iter().all(Option::is_some) && !remaining.is_empty() {
        let total: Option<u64> = remaining
            .iter()
            .map(|v| v.and_then(|v| v.parse::<u64>().ok()))
            .sum();
        meta.insert(
            "remaining.samples".into(),
            total.map_or_else(|| "unbounded".into(), |t| t.to_string()),
        );
    }
    for key in ["partial", "pass.inflight"] {
        let v = get(key);
        if v.iter().any(Option::is_some) {
            let any = v.contains(&Some("true"));
            meta.insert(key.into(), any.to_string());
        }
    }
    for key in ["passes", "stop"] {
        let v: BTreeSet<Option<&str>> = get(key).into_iter().collect();
        if let [Some(one)] = v.into_iter().collect::<Vec<_>>()[..] {
            meta.insert(key.into(), one.to_string());
        }
    }
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

    #[test]
    fn parts_coalesce_and_print() {
        let p = |seed, a, b| Part { seed, rows: a..b };
        let c = coalesce(vec![p(2, 0, 4), p(1, 5, 9), p(1, 0, 5), p(1, 9, 9)]);
        assert_eq!(c, vec![p(1, 0, 9), p(2, 0, 4)]);
        assert_eq!(fmt_parts(&c), "1@0-9;2@0-4");
        assert_eq!(parse_part(" 7@3-8").unwrap(), p(7, 3, 8));
        assert!(parse_part("7:3-8").is_err());
    }
}
