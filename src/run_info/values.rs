//! The typed values of a run's attributes: the domain it covers and where, sample counts, what is
//! left of the budgets, and the parts of a merged field.

use glam::DVec3;
use std::fmt;
use std::ops::Range;
use std::str::FromStr;

/// Which kind of domain a field covers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DomainKind {
    Slice,
    Camera,
    Volume,
}

impl fmt::Display for DomainKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            DomainKind::Slice => "slice",
            DomainKind::Camera => "camera",
            DomainKind::Volume => "volume",
        })
    }
}

/// A slice's rectangle: label, corner at u = v = 0, in-plane axes, size.
#[derive(Clone, Debug, PartialEq)]
pub struct PlaneInfo {
    pub label: String,
    pub origin: DVec3,
    pub u: DVec3,
    pub v: DVec3,
    pub size: (f64, f64),
}

/// A camera image's camera.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraInfo {
    pub name: String,
    pub eye: DVec3,
    pub forward: DVec3,
    pub up: DVec3,
    pub fov_y_deg: f64,
}

/// A volume's box and grid.
#[derive(Clone, Debug, PartialEq)]
pub struct VolumeInfo {
    pub min: DVec3,
    pub max: DVec3,
    pub dims: [usize; 3],
    pub spacing: DVec3,
}

/// A gradient-domain run's reconstruction ([`crate::gradient_domain`]): its weight α of the
/// cells' own estimates, and the replicates its samples were dealt into.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GradientInfo {
    pub alpha: f64,
    pub replicates: usize,
}

/// Samples (or batches) per cell: a cap, no cap, or the range a merged field holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CellCount {
    /// `none`: no sample cap (time or error budget only).
    Uncapped,
    Each(u64),
    /// `lo-hi`: cells differ (a merged field).
    Range(u64, u64),
}

impl CellCount {
    /// `lo` alone when `lo == hi`.
    pub fn range(lo: u64, hi: u64) -> CellCount {
        if lo == hi {
            CellCount::Each(lo)
        } else {
            CellCount::Range(lo, hi)
        }
    }
}

impl fmt::Display for CellCount {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CellCount::Uncapped => f.write_str("none"),
            CellCount::Each(n) => write!(f, "{n}"),
            CellCount::Range(lo, hi) => write!(f, "{lo}-{hi}"),
        }
    }
}

impl FromStr for CellCount {
    type Err = ();
    fn from_str(s: &str) -> Result<Self, ()> {
        if s == "none" {
            return Ok(CellCount::Uncapped);
        }
        match s.split_once('-') {
            Some((a, b)) => Ok(CellCount::Range(
                a.parse().map_err(|_| ())?,
                b.parse().map_err(|_| ())?,
            )),
            None => s.parse().map(CellCount::Each).map_err(|_| ()),
        }
    }
}

/// Samples still to take before the sample cap.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Remaining {
    Samples(u64),
    /// No sample cap.
    Unbounded,
}

impl fmt::Display for Remaining {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Remaining::Samples(n) => write!(f, "{n}"),
            Remaining::Unbounded => f.write_str("unbounded"),
        }
    }
}

/// One seed over a range of grid rows (a 2D grid's rows from the bottom, a volume's z layers).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Part {
    pub seed: u64,
    pub rows: Range<usize>,
}

impl fmt::Display for Part {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}@{}-{}", self.seed, self.rows.start, self.rows.end)
    }
}

impl FromStr for Part {
    type Err = String;
    fn from_str(s: &str) -> Result<Part, String> {
        let bad = || format!("'{s}' is not SEED@ROW0-ROW1");
        let (seed, rows) = s.trim().split_once('@').ok_or_else(bad)?;
        let (r0, r1) = rows.split_once('-').ok_or_else(bad)?;
        let n = |t: &str| t.trim().parse::<usize>().map_err(|_| bad());
        Ok(Part {
            seed: seed.trim().parse().map_err(|_| bad())?,
            rows: n(r0)?..n(r1)?,
        })
    }
}

/// `seed@r0-r1;…`.
pub fn fmt_parts(parts: &[Part]) -> String {
    join(parts, ";")
}

/// The items of `v` as text, separated by `sep`.
pub(super) fn join<T: std::fmt::Display>(v: &[T], sep: &str) -> String {
    v.iter().map(T::to_string).collect::<Vec<_>>().join(sep)
}
