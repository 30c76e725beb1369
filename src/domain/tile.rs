//! Tiles: one horizontal stripe of a domain's grid, for splitting a run over jobs (`--tile i/N`).
//!
//! Stripe `i` of `N` holds the rows `⌊i·H/N⌋ .. ⌊(i+1)·H/N⌋` of a grid of height H (field row 0 is the
//! bottom, v minimal, so stripe 0 is the bottom of the image). A tile run keeps the **full grid**: the
//! cells of its stripe are sampled with exactly the streams of a full run (a cell's stream is keyed
//! by its global index), every other cell stays empty (no samples). Tiles therefore merge by plain
//! addition, and merging all N tiles of one seed gives the full run bit for bit.
//!
//! The driver ([`crate::render`]) runs every cell; [`Stripe`] answers cells outside the stripe with
//! an empty sample (no rays, no random numbers used) and [`Tile::finish`] clears them afterwards.

use super::Domain;
use crate::field::Field;
use crate::ftpd::moments::Moments;
use crate::ftpd::{Params, Sample};
use crate::kernel::Kernel;
use crate::render::RunStats;
use crate::rng::Sampler;
use crate::scene::Scene;
use std::fmt;
use std::ops::Range;
use std::str::FromStr;

/// Stripe `index` of `count` (`--tile index/count`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tile {
    pub index: usize,
    pub count: usize,
}

impl FromStr for Tile {
    type Err = String;
    fn from_str(s: &str) -> Result<Tile, String> {
        let (i, n) = s
            .split_once('/')
            .ok_or_else(|| format!("'{s}': expected I/N such as 3/16 (stripe I of N, from 0)"))?;
        let num = |t: &str| {
            t.trim()
                .parse::<usize>()
                .map_err(|_| format!("'{s}': '{t}' is not a whole number"))
        };
        let (index, count) = (num(i)?, num(n)?);
        if count == 0 {
            return Err(format!("'{s}': the number of tiles must be at least 1"));
        }
        if index >= count {
            return Err(format!(
                "'{s}': tiles are numbered 0 to {} (I must be less than N)",
                count - 1
            ));
        }
        Ok(Tile { index, count })
    }
}

impl fmt::Display for Tile {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl Tile {
    /// The rows of a grid of `height` rows that this tile covers (possibly empty when N > height).
    pub fn rows(&self, height: usize) -> Range<usize> {
        let at = |k: usize| (k as u128 * height as u128 / self.count as u128) as usize;
        at(self.index)..at(self.index + 1)
    }

    /// Suffix of default output names: `_tile3of16`.
    pub fn suffix(&self) -> String {
        format!("_tile{}of{}", self.index, self.count)
    }

    /// After a run over `Stripe::new(domain, self)`: empties the cells outside the stripe, counts
    /// only the stripe's samples and records the tile in the metadata.
    pub fn finish(&self, field: &mut Field, stats: &mut RunStats, spp: u32) {
        let rows = self.rows(field.height);
        let w = field.width;
        let mut inside = 0u64;
        for (k, cell) in field.cells.iter_mut().enumerate() {
            if rows.contains(&((k / w) % field.height)) {
                inside += 1;
            } else {
                *cell = Moments::default();
            }
        }
        stats.samples = inside * spp as u64;
        field.meta.insert("tile".into(), self.to_string());
    }
}

/// A domain restricted to one tile's rows: same grid, same per-cell streams, empty samples outside.
pub struct Stripe<'a, D> {
    inner: &'a D,
    rows: Range<usize>,
    width: usize,
    height: usize,
}

impl<'a, D: Domain> Stripe<'a, D> {
    pub fn new(inner: &'a D, tile: Tile) -> Self {
        let (width, height, _) = inner.dims();
        Stripe {
            inner,
            rows: tile.rows(height),
            width: width.max(1),
            height: height.max(1),
        }
    }

    /// Rows sampled.
    pub fn rows(&self) -> Range<usize> {
        self.rows.clone()
    }
}

impl<D: Domain> Domain for Stripe<'_, D> {
    fn dims(&self) -> (usize, usize, usize) {
        self.inner.dims()
    }
    #[inline]
    fn sample<K: Kernel>(&self, scene: &Scene, cell: usize, p: &Params, s: &mut Sampler) -> Sample {
        if self.rows.contains(&((cell / self.width) % self.height)) {
            self.inner.sample::<K>(scene, cell, p, s)
        } else {
            Sample::default()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tiles_partition_the_rows() {
        for h in [1, 2, 7, 16, 100] {
            for n in [1, 3, 4, 16] {
                let mut next = 0;
                for i in 0..n {
                    let r = Tile { index: i, count: n }.rows(h);
                    assert_eq!(r.start, next);
                    next = r.end;
                }
                assert_eq!(next, h);
            }
        }
    }

    #[test]
    fn parse_tiles() {
        assert_eq!(
            "3/16".parse::<Tile>(),
            Ok(Tile {
                index: 3,
                count: 16
            })
        );
        assert!(
            "16/16"
                .parse::<Tile>()
                .unwrap_err()
                .contains("numbered 0 to 15")
        );
        assert!("0/0".parse::<Tile>().unwrap_err().contains("at least 1"));
        assert!("a/2".parse::<Tile>().is_err());
        assert!("3".parse::<Tile>().is_err());
        assert_eq!(
            Tile {
                index: 3,
                count: 16
            }
            .suffix(),
            "_tile3of16"
        );
    }
}
