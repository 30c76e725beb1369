//! Tiles: one stripe of a domain's grid, for splitting a run over jobs (stripe i of N, `i/N`).
//!
//! Stripe `i` of `N` holds the rows `⌊i·H/N⌋ .. ⌊(i+1)·H/N⌋` of a grid of height H (field row 0 is the
//! bottom, v minimal, so stripe 0 is the bottom of the image); for volumes the rows are the z
//! layers, so a stripe is a slab of whole layers. Either way a stripe is one contiguous range of
//! cell indices ([`Tile::cells`]), and the driver ([`crate::render`]) samples exactly those cells, with
//! the streams of a full run (a cell's stream is keyed by its global index). A tile run keeps the
//! **full grid**, with every other cell empty, so tiles merge by plain addition and merging all N
//! tiles of one seed gives the full run bit for bit.

use std::fmt;
use std::ops::Range;
use std::str::FromStr;

/// Stripe `index` of `count`, written `index/count` (from 0).
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

    /// The cells of a grid of `width` × `height` × `depth` (x fastest) that this tile covers: the
    /// rows of a 2D grid, the z layers of a volume.
    pub fn cells(&self, width: usize, height: usize, depth: usize) -> Range<usize> {
        if depth > 1 {
            let r = self.rows(depth);
            let layer = width * height;
            r.start * layer..r.end * layer
        } else {
            let r = self.rows(height);
            r.start * width..r.end * width
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
        let t = Tile { index: 1, count: 3 };
        assert_eq!(t.cells(4, 6, 1), 8..16);
        assert_eq!(t.cells(4, 6, 3), 24..48);
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
