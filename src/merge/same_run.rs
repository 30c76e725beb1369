//! Whether two fields describe the same run: grid size and every attribute of what a run
//! estimates.

use super::MergeError;
use crate::field::Field;
use crate::run_info::{ESTIMATE_KEYS, RunInfo};

/// The attributes that describe what a run estimates ([`ESTIMATE_KEYS`], among them `flatland`):
/// merged fields must agree on every one (compared as typed values; absent on both counts as
/// agreeing), and so must a resumed run with its file (which checks a few more).
pub const MUST_MATCH: &[&str] = ESTIMATE_KEYS;

/// Checks that `b` (read from `b_name`) describes the same run as `a` (from `a_name`): grid size
/// and every attribute of [`MUST_MATCH`]. The message names the file and the attribute, e.g.
/// `b.exr: t1 = 2e0 differs from a.exr's 1.5e0`.
pub fn check_same_run(a_name: &str, a: &Field, b_name: &str, b: &Field) -> Result<(), MergeError> {
    if (a.width, a.height, a.depth) != (b.width, b.height, b.depth) {
        return Err(MergeError::Resolution {
            file: b_name.to_string(),
            grid: grid(b),
            other: a_name.to_string(),
            other_grid: grid(a),
        });
    }
    check_same_info(a_name, &a.info(a_name)?, b_name, &b.info(b_name)?)?;
    check_same_shift(a_name, a, b_name, b)
}

/// Checks that `a` and `b`, which describe the same run, hold the same kind of sums: both ordinary,
/// or both gradient-domain with the same α and layout (fields read from files always do, as their
/// description decides what is read; a field built in memory is checked here too).
fn check_same_shift(a_name: &str, a: &Field, b_name: &str, b: &Field) -> Result<(), MergeError> {
    let kind = |f: &Field| {
        f.shift
            .as_ref()
            .map(|s| (s.alpha.to_bits(), s.axes, s.data.len()))
    };
    if kind(a) == kind(b) {
        return Ok(());
    }
    let alpha = |f: &Field| f.shift.as_ref().map(|s| s.alpha.to_string());
    Err(MergeError::Differs {
        file: b_name.to_string(),
        key: "gradient.alpha",
        value: alpha(b),
        other: a_name.to_string(),
        other_value: alpha(a),
    })
}

/// [`check_same_run`] of two descriptions.
pub(super) fn check_same_info(
    a_name: &str,
    a: &RunInfo,
    b_name: &str,
    b: &RunInfo,
) -> Result<(), MergeError> {
    let Some(key) = a.first_difference(b, MUST_MATCH) else {
        return Ok(());
    };
    let (am, bm) = (a.to_attributes(), b.to_attributes());
    Err(MergeError::Differs {
        file: b_name.to_string(),
        key,
        value: bm.get(key).cloned(),
        other: a_name.to_string(),
        other_value: am.get(key).cloned(),
    })
}

/// The message of [`MergeError::Differs`].
pub(super) fn differs(
    file: &str,
    key: &str,
    value: Option<&str>,
    other: &str,
    other_value: Option<&str>,
) -> String {
    match (other_value, value) {
        (Some(x), Some(y)) => format!("{file}: {key} = {y} differs from {other}'s {x}"),
        (Some(x), None) => format!("{file}: has no {key}, while {other} has {key} = {x}"),
        (None, Some(y)) => format!("{file}: {key} = {y}, while {other} has no {key}"),
        // Values that differ yet print alike (0 and -0 do not: they print apart).
        (None, None) => format!("{file}: {key} differs from {other}'s"),
    }
}

/// `WxH`, or `WxHxD` for a volume.
pub(super) fn grid(f: &Field) -> String {
    if f.depth == 1 {
        format!("{}x{}", f.width, f.height)
    } else {
        format!("{}x{}x{}", f.width, f.height, f.depth)
    }
}
