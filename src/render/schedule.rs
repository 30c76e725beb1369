//! How a run's samples are cut into passes ([`Schedule`]) and where a run stands among them
//! ([`Progress`]): what a partial field records so that a resumed run finishes exactly the passes
//! and cells an uninterrupted one would.

use super::RenderOptions;

/// Samples per cell and pass when neither a sample cap nor `pass_spp` says.
pub const DEFAULT_PASS_SPP: u32 = 8;

/// Samples per cell in pass `pass` of `batches` (spreads the remainder over the first passes).
pub fn samples_in_pass(spp: u32, batches: u32, pass: u32) -> u32 {
    spp / batches + u32::from(pass < spp % batches)
}

/// How many samples each cell gets in each pass (before adaptive allocation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Schedule {
    /// `spp` split into `batches` passes, the remainder over the first ones: the behaviour of a run
    /// given only a sample cap (and a number of batches).
    Split { spp: u32, batches: u32 },
    /// `per_pass` samples per cell and pass; with a cap, the last pass is cut to reach it exactly.
    Every { per_pass: u32, cap: Option<u32> },
}

impl Schedule {
    /// The schedule `opts` asks for.
    pub fn of(opts: &RenderOptions) -> Schedule {
        let spp = opts.spp.max(1);
        let batches = opts.batches.clamp(1, spp);
        let cap = opts.budget.cap_spp.then_some(spp);
        match (opts.pass_spp, cap) {
            (Some(p), cap) => Schedule::Every {
                per_pass: p.max(1),
                cap,
            },
            (None, Some(spp)) if opts.adaptive.is_none() => Schedule::Split { spp, batches },
            (None, Some(spp)) => Schedule::Every {
                per_pass: (spp / batches).max(1),
                cap: Some(spp),
            },
            (None, None) => Schedule::Every {
                per_pass: DEFAULT_PASS_SPP,
                cap: None,
            },
        }
    }

    /// Samples per cell in (uniform) pass `pass`; 0 once the cap is reached.
    pub fn uniform(&self, pass: u32) -> u32 {
        match *self {
            Schedule::Split { spp, batches } if pass < batches => {
                samples_in_pass(spp, batches, pass)
            }
            Schedule::Split { .. } => 0,
            Schedule::Every {
                per_pass,
                cap: None,
            } => per_pass,
            Schedule::Every {
                per_pass,
                cap: Some(c),
            } => c
                .saturating_sub(per_pass.saturating_mul(pass))
                .min(per_pass),
        }
    }

    /// The samples per cell of a full pass (the unit of adaptive allocation).
    pub fn unit(&self) -> u32 {
        match *self {
            Schedule::Split { .. } => self.uniform(0),
            Schedule::Every { per_pass, .. } => per_pass,
        }
    }

    /// What fixes the pass sizes, as recorded in a field's metadata (`schedule`): a run resumes
    /// only with the same schedule. The cap of `Every` is a budget, not part of it.
    pub fn key(&self) -> String {
        match *self {
            Schedule::Split { spp, batches } => format!("{spp} spp in {batches} passes"),
            Schedule::Every { per_pass, .. } => format!("{per_pass} spp per pass"),
        }
    }
}

/// Where a run stands: what a partial field must record for a run to resume from it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Progress {
    /// Passes every cell has completed.
    pub passes: u32,
    /// The pass `passes`, if it was interrupted part-way.
    pub inflight: Option<InFlight>,
    /// Compute seconds spent by earlier invocations and this one so far.
    pub elapsed: f64,
}

/// A pass interrupted part-way.
#[derive(Clone, Debug, PartialEq)]
pub struct InFlight {
    /// Per cell: whether it completed the pass.
    pub done: Vec<bool>,
    /// Adaptive passes: the allocation (units of [`Schedule::unit`] samples) of every cell, which
    /// depends on the sums before the pass and cannot be recomputed afterwards.
    pub units: Option<Vec<u32>>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::Adaptive;

    #[test]
    fn pass_sizes_sum_to_spp() {
        for spp in [1, 7, 64, 1000] {
            for b in [1, 3, 8] {
                let b = b.min(spp);
                assert_eq!((0..b).map(|p| samples_in_pass(spp, b, p)).sum::<u32>(), spp);
            }
        }
    }

    #[test]
    fn schedules() {
        let o = RenderOptions::default();
        assert_eq!(
            Schedule::of(&o),
            Schedule::Split {
                spp: 64,
                batches: 8
            }
        );
        let mut t = o.clone();
        t.budget.cap_spp = false;
        assert_eq!(
            Schedule::of(&t),
            Schedule::Every {
                per_pass: DEFAULT_PASS_SPP,
                cap: None
            }
        );
        let mut p = o.clone();
        p.pass_spp = Some(10);
        let s = Schedule::of(&p);
        let sizes: Vec<u32> = (0..8).map(|i| s.uniform(i)).collect();
        assert_eq!(sizes, [10, 10, 10, 10, 10, 10, 4, 0]);
        let mut a = o.clone();
        a.adaptive = Some(Adaptive::default());
        assert_eq!(
            Schedule::of(&a),
            Schedule::Every {
                per_pass: 8,
                cap: Some(64)
            }
        );
    }
}
