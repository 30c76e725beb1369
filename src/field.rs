//! A finished (or partial) run: a grid of per-cell sums with the metadata that describes it. Fields
//! merge by addition (see [`crate::ftpd::moments::Moments::merge`]).

use crate::ftpd::moments::{CellValue, Moments};
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
            meta: BTreeMap::new(),
        }
    }

    pub fn values(&self) -> Vec<CellValue> {
        self.cells.iter().map(Moments::finalize).collect()
    }

    pub fn sigma(&self) -> Vec<f64> {
        self.cells.iter().map(|c| c.finalize().sigma).collect()
    }

    pub fn valid(&self) -> Vec<bool> {
        self.cells.iter().map(|c| c.finalize().valid).collect()
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
