//! A finished (or partial) run: a grid of per-cell sums with the metadata that describes it. Fields
//! merge by addition (see [`crate::ftpd::moments::Moments::merge`]).

use crate::ftpd::moments::{CellValue, Moments};
use crate::gradient_domain::{Shift, recon};
use crate::run_info::{InfoError, RunInfo};
use std::collections::BTreeMap;

/// A 2D grid of accumulators; row 0 is the bottom row (v minimal), cell (i, j) = `cells[j * width + i]`.
/// Volumes stack `depth` such grids.
#[derive(Clone, Debug, PartialEq)]
pub struct Field {
    pub width: usize,
    pub height: usize,
    pub depth: usize,
    pub cells: Vec<Moments>,
    /// The replayed neighbours' sums of a gradient-domain run ([`crate::gradient_domain`]): the
    /// field's values are then reconstructed from them ([`Field::values`]).
    pub shift: Option<Shift>,
    /// The description of the run (scene, plane, parameters, seed, versions, ...) as the file's
    /// attributes hold it: set with [`Field::set_info`], read with [`Field::info`] (the typed
    /// [`RunInfo`]); the attributes as such are what the writers store.
    pub meta: BTreeMap<String, String>,
}

impl Field {
    pub fn new(width: usize, height: usize, depth: usize) -> Field {
        Field {
            width,
            height,
            depth,
            cells: vec![Moments::default(); width * height * depth],
            shift: None,
            meta: BTreeMap::new(),
        }
    }

    /// The finished value of every cell: each cell's own sums, or in a gradient-domain run the
    /// reconstruction from every cell's and its neighbours' ([`recon::values`]).
    pub fn values(&self) -> Vec<CellValue> {
        match &self.shift {
            Some(s) => recon::values(s, self.dims(), &self.cells),
            None => self.cells.iter().map(Moments::finalize).collect(),
        }
    }

    /// [`Field::values`] and, for a gradient-domain field, the replicates' linearised deviations
    /// of σ ([`recon::values_and_deviations`]), from which the variance of anything linear in σ
    /// follows with the correlation between cells.
    pub fn values_and_deviations(&self) -> (Vec<CellValue>, Option<Vec<Vec<f64>>>) {
        match &self.shift {
            Some(s) => {
                let (v, d) = recon::values_and_deviations(s, self.dims(), &self.cells);
                (v, Some(d))
            }
            None => (self.values(), None),
        }
    }

    /// A gradient-domain field: one that keeps its replayed neighbours' sums.
    pub fn with_shift(mut self, alpha: f64) -> Field {
        let axes = Shift::axes_of(self.dims());
        self.shift = Some(Shift::new(self.cells.len(), axes, alpha));
        self
    }

    pub fn dims(&self) -> (usize, usize, usize) {
        (self.width, self.height, self.depth)
    }

    pub fn sigma(&self) -> Vec<f64> {
        self.values().iter().map(|v| v.sigma).collect()
    }

    pub fn valid(&self) -> Vec<bool> {
        self.values().iter().map(|v| v.valid).collect()
    }

    /// The run's description, typed; `file` names the field in errors.
    pub fn info(&self, file: &str) -> Result<RunInfo, InfoError> {
        RunInfo::from_attributes(&self.meta, file)
    }

    /// Describes the run by `info` (replacing any earlier description).
    pub fn set_info(&mut self, info: &RunInfo) {
        self.meta = info.to_attributes();
    }

    pub fn total_samples(&self) -> u64 {
        self.cells.iter().map(|c| c.n).sum()
    }
}
