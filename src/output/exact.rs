//! The exact accumulator as files keep it: every sum of a cell's [`Moments`] by name, bit for bit
//! (EXR as hi/lo u32 pairs, VTI as Float64), and the one way both readers fill a field from them,
//! so that fields read back merge and resume bit for bit. A gradient-domain field keeps its
//! replayed neighbours' sums ([`Shift`]) the same way ([`shift_names`]).

use crate::field::Field;
use crate::ftpd::moments::Moments;
use crate::gradient_domain::{REPLICATES, Shift};
use crate::output::FileError;
use std::path::Path;

/// How an exact sum is read from and written to a cell's accumulator.
pub(crate) type Getter = fn(&Moments) -> f64;
pub(crate) type Setter = fn(&mut Moments, f64);

/// The sums every output keeps exactly, by name, with accessors: with the sample, batch and group
/// counts and the compensations ([`EXACT_COMP`]) they are a cell's whole [`Moments`].
pub(crate) const EXACT: &[(&str, Getter, Setter)] = &[
    ("sum.w", |m| m.s0, |m, v| m.s0 = v),
    ("sum.wd", |m| m.s1, |m, v| m.s1 = v),
    ("sum.wd2", |m| m.s2, |m, v| m.s2 = v),
    ("sum.fluence.R", |m| m.fluence.x, |m, v| m.fluence.x = v),
    ("sum.fluence.G", |m| m.fluence.y, |m, v| m.fluence.y = v),
    ("sum.fluence.B", |m| m.fluence.z, |m, v| m.fluence.z = v),
    ("sum.w.w", |m| m.cross[0], |m, v| m.cross[0] = v),
    ("sum.w.wd", |m| m.cross[1], |m, v| m.cross[1] = v),
    ("sum.w.wd2", |m| m.cross[2], |m, v| m.cross[2] = v),
    ("sum.wd.wd", |m| m.cross[3], |m, v| m.cross[3] = v),
    ("sum.wd.wd2", |m| m.cross[4], |m, v| m.cross[4] = v),
    ("sum.wd2.wd2", |m| m.cross[5], |m, v| m.cross[5] = v),
    ("sum3.w.w.w", |m| m.cube[0], |m, v| m.cube[0] = v),
    ("sum3.w.w.wd", |m| m.cube[1], |m, v| m.cube[1] = v),
    ("sum3.w.w.wd2", |m| m.cube[2], |m, v| m.cube[2] = v),
    ("sum3.w.wd.wd", |m| m.cube[3], |m, v| m.cube[3] = v),
    ("sum3.w.wd.wd2", |m| m.cube[4], |m, v| m.cube[4] = v),
    ("sum3.w.wd2.wd2", |m| m.cube[5], |m, v| m.cube[5] = v),
    ("sum3.wd.wd.wd", |m| m.cube[6], |m, v| m.cube[6] = v),
    ("sum3.wd.wd.wd2", |m| m.cube[7], |m, v| m.cube[7] = v),
    ("sum3.wd.wd2.wd2", |m| m.cube[8], |m, v| m.cube[8] = v),
    ("sum3.wd2.wd2.wd2", |m| m.cube[9], |m, v| m.cube[9] = v),
];

/// The Neumaier compensations of the weighted sums, kept exactly like [`EXACT`], after it.
pub(crate) const EXACT_COMP: &[(&str, Getter, Setter)] = &[
    ("sum.w.comp", |m| m.comp[0], |m, v| m.comp[0] = v),
    ("sum.wd.comp", |m| m.comp[1], |m, v| m.comp[1] = v),
    ("sum.wd2.comp", |m| m.comp[2], |m, v| m.comp[2] = v),
];

/// Whether an exact sum is one of the triple product sums, which files written before the
/// standard error was taken over groups of samples lack: such files read with every sample as its
/// own group and these sums 0 (no skewness correction for their part; [`legacy_groups`]).
fn is_triple_sum(name: &str) -> bool {
    name.starts_with("sum3.")
}

/// A field read from a file without group counts: each sample was its own unit of the standard
/// error (the product sums were per sample), and the triple product sums are unknown (0).
fn legacy_groups(field: &mut Field) {
    for c in &mut field.cells {
        c.groups = c.n;
        c.cube = [0.0; 10];
    }
}

/// A file's per-cell arrays under the names of the exact accumulator, each read as one value per
/// cell in field order: what [`read_exact`] fills a field from.
pub(crate) trait ExactArrays {
    /// Whether the file has the group counts (files written before the standard error was taken
    /// over groups of samples lack them: [`legacy_groups`]).
    fn has_groups(&self) -> bool;
    /// The count `name`: `samples`, `batches` or `groups`.
    fn counts(&self, name: &str) -> Result<Vec<u64>, FileError>;
    /// The exact sum `name` of [`EXACT`].
    fn sums(&self, name: &str) -> Result<Vec<f64>, FileError>;
    /// The compensation `name` of [`EXACT_COMP`]; `None` where the format reads a file without
    /// it as uncompensated sums (EXR files of versions before the compensation).
    fn compensation(&self, name: &str) -> Result<Option<Vec<f64>>, FileError>;
}

/// Fills `field` (sized as the file) with the counts, exact sums and compensations of `file`.
pub(crate) fn read_exact(field: &mut Field, file: &impl ExactArrays) -> Result<(), FileError> {
    let legacy = !file.has_groups();
    for (c, n) in field.cells.iter_mut().zip(file.counts("samples")?) {
        c.n = n;
    }
    for (c, n) in field.cells.iter_mut().zip(file.counts("batches")?) {
        c.batches = n;
    }
    if legacy {
        legacy_groups(field);
    } else {
        for (c, n) in field.cells.iter_mut().zip(file.counts("groups")?) {
            c.groups = n;
        }
    }
    for &(name, _, set) in EXACT {
        if legacy && is_triple_sum(name) {
            continue;
        }
        for (c, x) in field.cells.iter_mut().zip(file.sums(name)?) {
            set(c, x);
        }
    }
    for &(name, _, set) in EXACT_COMP {
        if let Some(values) = file.compensation(name)? {
            for (c, x) in field.cells.iter_mut().zip(values) {
                set(c, x);
            }
        }
    }
    Ok(())
}

/// The name of every value a cell of a gradient-domain field keeps besides its [`Moments`]
/// ([`Shift`]), in the order of [`Shift::data`]: per replicate `rNN` (00 to 15), `shift.rNN.n`
/// (its samples), `shift.rNN.w`, `shift.rNN.wd`, `shift.rNN.wd2` (their ΣP, ΣPΔ, ΣPΔ²), then for
/// each axis `a` of `axes` (`x`, `y`, and `z` in a volume) `shift.rNN.a.w`, `.wd`, `.wd2` (the sums
/// of the same samples replayed at the upper neighbour along it).
pub(crate) fn shift_names(axes: usize) -> Vec<String> {
    let sums = ["w", "wd", "wd2"];
    let mut names = Vec::with_capacity(REPLICATES * (1 + 3 * (1 + axes)));
    for r in 0..REPLICATES {
        names.push(format!("shift.r{r:02}.n"));
        names.extend(sums.iter().map(|s| format!("shift.r{r:02}.{s}")));
        for axis in ["x", "y", "z"].iter().take(axes) {
            names.extend(sums.iter().map(|s| format!("shift.r{r:02}.{axis}.{s}")));
        }
    }
    names
}

/// One of a gradient-domain field's replayed sums ([`shift_names`]) across the cells.
pub(crate) struct ShiftColumn<'a> {
    pub name: String,
    data: &'a [f64],
    stride: usize,
    k: usize,
}

impl ShiftColumn<'_> {
    /// The value of cell `j` (field order).
    pub fn value(&self, j: usize) -> f64 {
        self.data[j * self.stride + self.k]
    }
}

/// Every value of a gradient-domain field's [`Shift`] as a column by name ([`shift_names`]),
/// read in place; none for an ordinary field. Refuses (naming `path`) sums that do not fit the
/// grid, which only a field built by hand can have.
pub(crate) fn shift_columns<'a>(
    path: &Path,
    field: &'a Field,
) -> Result<Vec<ShiftColumn<'a>>, FileError> {
    let Some(s) = &field.shift else {
        return Ok(Vec::new());
    };
    let cells = field.cells.len();
    if s.axes != Shift::axes_of(field.dims()) || s.data.len() != cells * s.stride() {
        return Err(FileError::unfit(
            path,
            format!(
                "gradient-domain sums of {} values over {} axes for a {}x{}x{} grid",
                s.data.len(),
                s.axes,
                field.width,
                field.height,
                field.depth
            ),
        ));
    }
    Ok(shift_names(s.axes)
        .into_iter()
        .enumerate()
        .map(|(k, name)| ShiftColumn {
            name,
            data: &s.data,
            stride: s.stride(),
            k,
        })
        .collect())
}

/// Gives a field read from a file its gradient-domain sums when its description says it is one
/// (`gradient.alpha`, read from `field.meta` with errors naming `path`); every sum must be there.
pub(crate) fn read_shift(
    path: &Path,
    field: &mut Field,
    file: &impl ExactArrays,
) -> Result<(), FileError> {
    let Some(g) = field.info(&path.display().to_string())?.gradient else {
        return Ok(());
    };
    let mut shift = Shift::new(field.cells.len(), Shift::axes_of(field.dims()), g.alpha);
    let stride = shift.stride();
    for (k, name) in shift_names(shift.axes).iter().enumerate() {
        for (j, x) in file.sums(name)?.into_iter().enumerate() {
            shift.data[j * stride + k] = x;
        }
    }
    field.shift = Some(shift);
    Ok(())
}
