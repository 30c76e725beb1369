//! What a field holds, as parts (a seed over a range of rows), and the checks that merging never
//! counts a sample twice.

use super::MergeError;
use crate::field::Field;
use crate::run_info::{Part, RunInfo};

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
pub fn parts_of(name: &str, f: &Field) -> Result<Vec<Part>, MergeError> {
    parts_in(name, &f.info(name)?, f)
}

/// [`parts_of`] with the field's description read.
pub(super) fn parts_in(name: &str, info: &RunInfo, f: &Field) -> Result<Vec<Part>, MergeError> {
    if let Some(p) = &info.parts {
        return Ok(p.clone());
    }
    let Some(seed) = info.seed else {
        return Err(MergeError::NoSeed {
            file: name.to_string(),
        });
    };
    let rows = match info.tiles.as_slice() {
        [] => 0..rows(f),
        [t] => t.rows(rows(f)),
        _ => {
            return Err(MergeError::DamagedTiles {
                file: name.to_string(),
            });
        }
    };
    Ok(vec![Part { seed, rows }])
}

/// Checks that the cells outside the rows a file's parts claim are empty (or its metadata lies).
pub(super) fn check_parts_cover(name: &str, f: &Field, parts: &[Part]) -> Result<(), MergeError> {
    let mut covered = vec![false; rows(f)];
    for p in parts {
        if p.rows.end > rows(f) {
            return Err(MergeError::PartOutsideRows {
                file: name.to_string(),
                part: p.clone(),
                rows: rows(f),
            });
        }
        covered[p.rows.clone()].iter_mut().for_each(|c| *c = true);
    }
    if let Some(k) = (0..f.cells.len()).find(|&k| f.cells[k].n > 0 && !covered[row_of(f, k)]) {
        return Err(MergeError::SamplesOutsideParts {
            file: name.to_string(),
            cell: k,
            row: row_of(f, k),
        });
    }
    Ok(())
}

/// Checks that `p` (of the file `name`, whose grid has `rows` rows) shares no seed over
/// overlapping rows with the parts seen so far (`seen`: each part with the index of its input in
/// `names`): the same seed repeats the same random streams.
pub(super) fn check_not_seen(
    name: &str,
    rows: usize,
    p: &Part,
    seen: &[(Part, usize)],
    names: &[&str],
) -> Result<(), MergeError> {
    let Some((q, j)) = seen.iter().find(|(q, _)| {
        q.seed == p.seed && q.rows.start.max(p.rows.start) < q.rows.end.min(p.rows.end)
    }) else {
        return Ok(());
    };
    let other = names[*j].to_string();
    if q.rows == (0..rows) && p.rows == (0..rows) {
        return Err(MergeError::SeedRepeated {
            file: name.to_string(),
            seed: p.seed,
            other,
        });
    }
    Err(MergeError::SeedOverlap {
        file: name.to_string(),
        seed: p.seed,
        rows: p.rows.clone(),
        other,
        other_rows: q.rows.clone(),
    })
}

/// Sorted, with adjacent or overlapping row ranges of one seed joined.
pub(super) fn coalesce(mut parts: Vec<Part>) -> Vec<Part> {
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
