//! How many deflection pairs one sample takes.
//!
//! Section 5.1 of the paper applies Δ to all pairs of two path distributions: the walks of length
//! T from x along ω and those along ω'. One sample (a point x, a direction ω with its weight) can
//! therefore trace `along` walks along ω and `across` walks along each of `cones` directions ω'_j
//! of the cone, read every walk at `lengths` run lengths T_m (one in each of `lengths` equal strata
//! of [t0, t1], all from the walk traced to the longest), and average Δ over every combination
//! (walk along ω, cone direction, walk along it, run length). Each combination is distributed as
//! the single pair of eqs. 9-14, so the average has the same expectation as one pair, and the
//! sample stays one unit of the standard error (its pairs are correlated, never independent).

use super::Weighting;
use std::fmt;
use std::str::FromStr;

/// The pairs of one sample: `along` × `cones` × `across` × `lengths` combinations from
/// `along` + `cones` · `across` walks. Written `kA,kB,J,M` (`along,across,cones,lengths`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Design {
    /// Walks along ω (kA).
    pub along: u32,
    /// Walks along each ω'_j (kB).
    pub across: u32,
    /// Directions ω'_j in the cone around ω (J).
    pub cones: u32,
    /// Run lengths read off each walk, one in each of as many equal strata of [t0, t1] (M).
    pub lengths: u32,
}

/// The largest number of walks per direction, cone directions and run lengths a design may have.
pub const MAX_WALKS: u32 = 16;
pub const MAX_CONES: u32 = 16;
pub const MAX_LENGTHS: u32 = 64;

/// A design that cannot run, naming the part that is out of range.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{what} = {value} must lie between 1 and {max}")]
pub struct DesignError {
    /// Which part: `kA` (walks along ω), `kB` (walks along each cone direction), `J` (cone
    /// directions) or `M` (run lengths).
    pub what: &'static str,
    pub value: u32,
    pub max: u32,
}

impl Design {
    /// One pair per sample: the estimator as eqs. 9-14 state it.
    pub const SINGLE: Design = Design::new(1, 1, 1, 1);

    /// The design `kA,kB,J,M`.
    pub const fn new(along: u32, across: u32, cones: u32, lengths: u32) -> Design {
        Design {
            along,
            across,
            cones,
            lengths,
        }
    }

    /// The design a run of `weighting` takes unless told otherwise, chosen by measured efficiency
    /// (1 / (variance · CPU time)) on the Cornell box, the stair wall and the glass sphere
    /// (docs/performance.md, "Deflection pairs per sample"): radiance weighting two cone
    /// directions (2,2,2,2: 16 pairs from 6 walks, whose radiance path, the costliest part of a
    /// sample, they share), every other weighting one (2,2,1,2: 8 pairs from 4 walks).
    pub fn default_for(weighting: Weighting) -> Design {
        match weighting {
            Weighting::Radiance => Design::new(2, 2, 2, 2),
            Weighting::Unweighted | Weighting::Importance => Design::new(2, 2, 1, 2),
        }
    }

    /// Checks each part against its range.
    pub fn check(&self) -> Result<(), DesignError> {
        for (what, value, max) in [
            ("kA", self.along, MAX_WALKS),
            ("kB", self.across, MAX_WALKS),
            ("J", self.cones, MAX_CONES),
            ("M", self.lengths, MAX_LENGTHS),
        ] {
            if value == 0 || value > max {
                return Err(DesignError { what, value, max });
            }
        }
        Ok(())
    }

    /// Combinations averaged per sample.
    pub fn pairs(&self) -> u32 {
        self.along * self.across * self.cones * self.lengths
    }

    /// Walks traced per sample.
    pub fn walks(&self) -> u32 {
        self.along + self.cones * self.across
    }
}

impl fmt::Display for Design {
    /// `kA,kB,J,M`, as the command line takes it and run metadata stores it.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{},{},{},{}",
            self.along, self.across, self.cones, self.lengths
        )
    }
}

impl FromStr for Design {
    type Err = String;
    /// The [`fmt::Display`] form: four whole numbers separated by commas (not checked against
    /// their ranges: [`Design::check`]).
    fn from_str(s: &str) -> Result<Self, String> {
        let parts: Vec<&str> = s.split(',').map(str::trim).collect();
        let [a, b, j, m] = parts[..] else {
            return Err(format!(
                "'{s}' is not four whole numbers kA,kB,J,M (e.g. 1,1,2,8)"
            ));
        };
        let num = |x: &str| {
            x.parse::<u32>()
                .map_err(|_| format!("'{x}' is not a whole number"))
        };
        Ok(Design::new(num(a)?, num(b)?, num(j)?, num(m)?))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_round_trip_and_refusals() {
        let d = Design::new(2, 3, 4, 8);
        assert_eq!(d.to_string(), "2,3,4,8");
        assert_eq!(d.to_string().parse::<Design>(), Ok(d));
        assert_eq!(" 2, 3,4 ,8".parse::<Design>(), Ok(d));
        assert_eq!(d.pairs(), 192);
        assert_eq!(d.walks(), 14);
        assert!("1,1,2".parse::<Design>().is_err());
        assert!("1,1,2,x".parse::<Design>().is_err());
        assert!("1,1,2,8,1".parse::<Design>().is_err());
        assert!("1,1,-2,8".parse::<Design>().is_err());
        let e = Design { cones: 0, ..d }.check().unwrap_err();
        assert_eq!((e.what, e.value), ("J", 0));
        assert!(Design { lengths: 65, ..d }.check().is_err());
        assert!(Design { across: 17, ..d }.check().is_err());
        assert!(d.check().is_ok());
        assert_eq!(Design::SINGLE.pairs(), 1);
    }
}
