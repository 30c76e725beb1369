//! The pairs of one sample ([`Design`]): for a start point x, a direction ω and its weight w,
//! `cones` directions ω'_j in the cone around ω, `along` walks along ω and `across` walks along
//! each ω'_j, every
//! walk read at `lengths` run lengths T_m; Δ (eq. 9 with its regulariser) of every combination
//! (a walk along ω, a cone direction, a walk along it, a run length) weighted by
//! c = luminance(w · βA · βB) and averaged.
//!
//! The combinations are pairs of the product distribution of section 5.1: each walk draws from a
//! random stream of its own ([`Sampler::child`]), no number is shared between the two sides or
//! between walks, and each walk read at T_m is a walk of length T_m
//! ([`crate::transport::deflection`]). So every combination is distributed as the single pair of
//! eqs. 9-14 and the average has its expectation; the average is one unit of the moments (one
//! sample), never as many independent samples as it has combinations.
//!
//! Run lengths: T_m = t0 + (t1 − t0)(m + u)/M with one number u for all m (each T_m uniform in
//! its stratum, the M strata cover [t0, t1] once). Cone directions: ω'_j from the numbers
//! ((u0 + j/J) mod 1, (u1 + j·g) mod 1), g the golden ratio's fraction, a randomly shifted
//! lattice (each ω'_j uniform in the cone, together spread over it). Both take the numbers of one
//! run length and one cone direction, whatever the design, so the sample layout
//! ([`crate::rng::QMC_DIMS`]) does not depend on it.

use super::design::Design;
use super::{Params, Sample, cone_constants, regulariser};
use crate::kernel::{Kernel, Space};
use crate::math::{Rgb, luminance};
use crate::rng::{Children, Sampler};
use crate::scene::Scene;
use crate::transport::deflection::{End, FirstSegment, WalkStream, walk_ends};
use glam::DVec3;
use std::cell::RefCell;

/// One combination of a sample, as [`super::visit`] shows it to a caller.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pair {
    /// c = luminance(w · βA · βB) (0 when a walk was absorbed before T).
    pub c: f64,
    pub delta: f64,
    /// The run length T.
    pub t: f64,
    /// Scattering events of the walk along ω and of the walk along ω' up to T.
    pub bounces: (u32, u32),
}

/// The numbers that place a sample's run lengths and cone directions, drawn after those of its
/// start point and direction.
#[derive(Clone, Copy, Debug)]
pub struct Offsets {
    pub u_t: f64,
    pub u_cone: (f64, f64),
}

impl Offsets {
    #[inline]
    pub fn draw(s: &mut Sampler) -> Self {
        let [u_t, u0] = s.next_n();
        Offsets {
            u_t,
            u_cone: (u0, s.next_f64()),
        }
    }
}

/// The golden ratio's fraction: successive multiples spread evenly over [0, 1).
const GOLDEN: f64 = 0.618_033_988_749_894_8;

/// `x` mod 1 for x ≥ 0, kept below 1.
#[inline]
fn frac(x: f64) -> f64 {
    let f = x - x.floor();
    if f < 1.0 { f } else { 0.0 }
}

/// The numbers of cone direction `j` of `n` from the sample's pair `u`.
#[inline]
fn cone_numbers(u: (f64, f64), j: u32, n: u32) -> (f64, f64) {
    if j == 0 {
        return u;
    }
    (
        frac(u.0 + f64::from(j) / f64::from(n)),
        frac(u.1 + f64::from(j) * GOLDEN),
    )
}

/// The run lengths T_m = t0 + (t1 − t0)(m + u)/M, ascending, into `out`.
#[inline]
fn run_lengths(p: &Params, m: u32, u: f64, out: &mut Vec<f64>) {
    out.clear();
    let span = p.t1 - p.t0;
    for k in 0..m {
        out.push(p.t0 + span * (f64::from(k) + u) / f64::from(m));
    }
}

/// [`super::pairwise_deviation`] for one run length `t` and cone direction (`chord`, `r`), its
/// regulariser and guards evaluated once for all the pairs that share them; [`Deviation::of`]
/// gives the same bits as `pairwise_deviation(dist, t, chord, r)`.
#[derive(Clone, Copy, Debug)]
struct Deviation {
    s: f64,
    denom: f64,
    /// Δ is 0 for every distance (no regularised weight, or no usable denominator).
    zero: bool,
}

impl Deviation {
    #[inline(always)]
    #[allow(clippy::eq_op)]
    fn new(t: f64, chord: f64, r: f64) -> Self {
        let s = regulariser(r);
        let denom = t * chord;
        // `pairwise_deviation`'s guards (s = 0, or denom not positive and finite) as float
        // comparisons: `denom - denom` is 0 exactly when denom is finite (NaN otherwise), and
        // only evaluated when the others pass. Written as `is_finite` (or `denom < ∞`), the test
        // compiles to a long integer test of the bits.
        Deviation {
            s,
            denom,
            zero: !(s != 0.0 && denom > 0.0 && denom - denom == 0.0),
        }
    }

    #[inline(always)]
    fn of(&self, dist_ab: f64) -> f64 {
        if self.zero {
            return 0.0;
        }
        let d = self.s * (dist_ab / self.denom - 1.0);
        if d.is_finite() { d } else { 0.0 }
    }
}

/// What the walks of one sample share.
struct Walks<'a> {
    scene: &'a Scene,
    lengths: &'a [f64],
    max_bounces: u32,
    /// The sample's walk streams ([`Sampler::child`] of its key).
    streams: Children,
}

impl Walks<'_> {
    /// The walks from `first` into `ends` (walk-major, as many run lengths each as `lengths`), walk
    /// i drawing from stream `index + i`. Always inlined (it was a closure called twice per
    /// sample, whose call was a measurable part of the sample's own work).
    #[inline(always)]
    fn trace<K: Kernel>(
        &self,
        first: &FirstSegment,
        index: u64,
        ends: &mut [End],
        out: &mut Sample,
    ) {
        out.rays += 1;
        for (i, e) in ends.chunks_exact_mut(self.lengths.len()).enumerate() {
            let mut ws = WalkStream::of(&self.streams, index + i as u64);
            let st = walk_ends::<K>(
                self.scene,
                first,
                self.lengths,
                self.max_bounces,
                &mut ws,
                e,
            );
            out.rays += st.rays;
            out.capped += u32::from(st.capped);
        }
    }
}

/// Buffers of a sample's walk ends, kept per thread so that samples allocate nothing.
#[derive(Default)]
struct Scratch {
    lengths: Vec<f64>,
    /// The ends of the walks along ω (walk-major: walk i at T_m is `i · M + m`).
    a: Vec<End>,
    /// The ends of the walks along the current ω'_j.
    b: Vec<End>,
}

thread_local! {
    static SCRATCH: RefCell<Scratch> = RefCell::new(Scratch::default());
}

/// The pairs of one sample from `x` along `omega` with weight `weight` (RGB), the run lengths
/// and cone directions placed by `off`, the walks' streams keyed by `key`; `visit` sees every
/// combination. Returns the averages over the combinations with the rays traced.
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn pairs<K: Kernel, V: FnMut(&Pair) + ?Sized>(
    scene: &Scene,
    x: DVec3,
    omega: DVec3,
    weight: Rgb,
    off: Offsets,
    key: u64,
    p: &Params,
    visit: &mut V,
) -> Sample {
    let mut out = Sample {
        weight,
        ..Default::default()
    };
    if luminance(weight) <= 0.0 {
        // No light passes here in this direction: the pairs carry no weight; trace none.
        return out;
    }
    SCRATCH.with(|cell| {
        let sc = &mut *cell.borrow_mut();
        combine::<K, V>(scene, x, omega, weight, off, key, p, sc, visit, &mut out);
    });
    out
}

/// [`pairs`] with the thread's buffers.
#[allow(clippy::too_many_arguments)]
#[inline]
fn combine<K: Kernel, V: FnMut(&Pair) + ?Sized>(
    scene: &Scene,
    x: DVec3,
    omega: DVec3,
    weight: Rgb,
    off: Offsets,
    key: u64,
    p: &Params,
    sc: &mut Scratch,
    visit: &mut V,
    out: &mut Sample,
) {
    let Design {
        along,
        across,
        cones,
        lengths,
    } = p.design;
    let m = lengths as usize;
    run_lengths(p, lengths, off.u_t, &mut sc.lengths);
    let t_max = sc.lengths[m - 1];
    sc.a.resize(along as usize * m, End::default());
    sc.b.resize(across as usize * m, End::default());
    // Walk i of the sample draws from stream i: the walks along ω first, then those of each ω'_j.
    let walks = Walks {
        scene,
        lengths: &sc.lengths,
        max_bounces: p.max_bounces,
        streams: Children::new(key),
    };
    let first = FirstSegment::trace::<K>(scene, x, omega, t_max);
    walks.trace::<K>(&first, 0, &mut sc.a, out);
    let (one_minus_cos_max, tan_half_max) = cone_constants(p);
    let sp = K::Space::of(scene);
    let mut sums = [0.0f64; 3];
    for j in 0..cones {
        let u = cone_numbers(off.u_cone, j, cones);
        let (omega2, chord, r) = sp.perturb(omega, p.theta_max, one_minus_cos_max, tan_half_max, u);
        let first = FirstSegment::trace::<K>(scene, x, omega2, t_max);
        walks.trace::<K>(&first, u64::from(along + j * across), &mut sc.b, out);
        for (mi, &t) in sc.lengths.iter().enumerate() {
            // Δ's factors that depend on the cone direction and the run length only, computed
            // once for the pairs they share (the same operations as `pairwise_deviation`).
            let scale = Deviation::new(t, chord, r);
            for ia in 0..along as usize {
                let a = &sc.a[ia * m + mi];
                let wa = weight * a.beta;
                for ib in 0..across as usize {
                    let b = &sc.b[ib * m + mi];
                    let c = luminance(wa * b.beta);
                    let c = if c.is_finite() {
                        c.max(0.0)
                    } else {
                        out.clamped = true;
                        0.0
                    };
                    // Two straight walks: Δ is exactly 0 (empty space).
                    let delta = if a.bounces == 0 && b.bounces == 0 {
                        0.0
                    } else {
                        scale.of((a.p - b.p).length())
                    };
                    let cd = c * delta;
                    sums[0] += c;
                    sums[1] += cd;
                    sums[2] += cd * delta;
                    visit(&Pair {
                        c,
                        delta,
                        t,
                        bounces: (a.bounces, b.bounces),
                    });
                }
            }
        }
    }
    let n = f64::from(p.design.pairs());
    out.c = sums[0] / n;
    out.cd = sums[1] / n;
    out.cd2 = sums[2] / n;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ftpd::pairwise_deviation;

    /// The factored Δ is `pairwise_deviation` to the bit, guards included.
    #[test]
    fn deviation_matches_pairwise_deviation_bit_for_bit() {
        let mut s = Sampler::new(17, 0, 0);
        let specials = [0.0, -0.0, 1e-300, f64::INFINITY, f64::NAN, -1.0];
        for k in 0..20_000 {
            let mut v = [0.0; 4];
            for x in v.iter_mut() {
                *x = (s.next_f64() * 4.0 - 0.5) * 10f64.powi((s.next_f64() * 8.0) as i32 - 4);
            }
            if k % 7 == 0 {
                v[(k / 7) % 4] = specials[(k / 28) % specials.len()];
            }
            let [dist, t, chord, r] = v;
            let want = pairwise_deviation(dist, t, chord, r);
            let got = Deviation::new(t, chord, r).of(dist);
            assert_eq!(want.to_bits(), got.to_bits(), "{v:?}");
        }
    }
}
