//! The walks of a deflection sample read at several run lengths (paper section 5.1): one walk
//! traced to the longest run length gives its end point at every shorter one on the way.
//!
//! A walk of length T is a prefix of a walk of length T' > T: both draw the same numbers at the
//! same hits until T is used up (a hit at or beyond the remaining length ends the shorter walk
//! before it scatters, absorption and the bounce cap take effect at hits only), so the point the
//! longer walk reaches at arc length T is the end point of the shorter walk, with its throughput
//! and scattering events. [`walk_ends`] reads every run length of a sorted list off one walk.
//!
//! Walks that start at the same point along the same direction share their first segment: its
//! hit is a fixed function of the ray, so it is traced once ([`FirstSegment`]) and each walk goes
//! on from it with its own random numbers.

use crate::kernel::{Kernel, Space};
use crate::math::Rgb;
use crate::rng::Uniform;
use crate::scene::{Hit, Scene};
use crate::transport::bsdf::Mode;
use crate::transport::trace;
use glam::DVec3;

/// Where a walk is at one run length: its point, its throughput (the product of `f |cos| / pdf`;
/// zero once the walk was absorbed) and its scattering events so far.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct End {
    pub p: DVec3,
    pub beta: Rgb,
    pub bounces: u32,
}

impl Default for End {
    fn default() -> Self {
        End {
            p: DVec3::ZERO,
            beta: Rgb::ZERO,
            bounces: 0,
        }
    }
}

/// The first segment of the walks from `x` along `dir`: the closest hit within the longest run
/// length, traced once for all of them.
#[derive(Clone, Copy, Debug)]
pub struct FirstSegment {
    pub x: DVec3,
    pub dir: DVec3,
    pub hit: Option<Hit>,
}

impl FirstSegment {
    /// Traces the ray from `x` (off every surface) along the unit `dir` up to `t_max`.
    #[inline]
    pub fn trace<K: Kernel>(scene: &Scene, x: DVec3, dir: DVec3, t_max: f64) -> Self {
        FirstSegment {
            x,
            dir,
            hit: trace::intersect::<K>(scene, x, dir, t_max),
        }
    }

    /// Whether every walk from it is straight up to `t_max` (no hit within it): then all of them
    /// are the same deterministic line and one stands for all.
    #[inline]
    pub fn is_straight(&self) -> bool {
        self.hit.is_none()
    }
}

/// The random stream of one walk: the numbers of [`crate::rng::Sampler::child`] for the same key and index,
/// without what a sample's stream carries besides (the Sobol' point, its scrambles and the test
/// of every number for a QMC dimension; walks draw none). Made once per walk, drawn from at
/// every scattering event.
pub struct WalkStream {
    rng: rand_pcg::Pcg64Mcg,
}

impl WalkStream {
    /// The stream [`crate::rng::Sampler::child`] gives for `key` and `k`.
    #[inline(always)]
    pub fn child(key: u64, k: u64) -> Self {
        WalkStream::of(&crate::rng::Children::new(key), k)
    }

    /// Stream `k` of `children` (their key hashed once for all the sample's walks): the numbers
    /// of [`crate::rng::Children::stream`].
    #[inline(always)]
    pub fn of(children: &crate::rng::Children, k: u64) -> Self {
        let (hi, lo) = children.state(k);
        WalkStream {
            rng: rand_pcg::Pcg64Mcg::new(((hi as u128) << 64) | lo as u128),
        }
    }
}

impl Uniform for WalkStream {
    /// 53 random bits, as [`crate::rng::Sampler::next_f64`] past its QMC dimensions.
    #[inline(always)]
    fn next_f64(&mut self) -> f64 {
        use rand_core::Rng;
        crate::rng::unit_f64(self.rng.next_u64())
    }
}

/// What [`walk_ends`] traced: rays beyond the shared first segment, and whether the walk reached
/// the bounce cap before its longest run length.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WalkStats {
    pub rays: u32,
    pub capped: bool,
}

/// One walk from `first` read at each run length of `lengths` (ascending, positive), into
/// `ends` (as long as `lengths`): the end point of a walk of exactly that Euclidean length (paper
/// section 5.1: scattering at every hit by sampling the BSDF, straight on after leaving the
/// scene). A walk that reaches `max_bounces` scattering events ends at the hit where it would
/// scatter once more, for every longer run length; a walk absorbed at a hit has zero throughput
/// from there on. Draws three numbers from `s` per scattering event.
///
/// Always inlined: a sample calls it from one place per kernel, and the call's set-up was a
/// measurable part of a walk's own work.
#[inline(always)]
pub fn walk_ends<K: Kernel>(
    scene: &Scene,
    first: &FirstSegment,
    lengths: &[f64],
    max_bounces: u32,
    s: &mut impl Uniform,
    ends: &mut [End],
) -> WalkStats {
    debug_assert_eq!(lengths.len(), ends.len());
    debug_assert!(lengths.windows(2).all(|w| w[0] <= w[1]));
    let sp = K::Space::of(scene);
    let t_max = lengths.last().copied().unwrap_or(0.0);
    let mut stats = WalkStats::default();
    // `base` is the true start of the current segment (x, then surface points), `origin` the
    // same point pushed off the surface for the ray query, `travelled` the arc length up to
    // `base`. Lengths are measured from `base`, so the offsets never change the geometry.
    let (mut base, mut origin, mut d) = (first.x, first.x, first.dir);
    let mut travelled = 0.0;
    let mut beta = Rgb::ONE;
    let mut bounces = 0;
    // The current segment's hit, borrowed (from `first`, then from `traced`) rather than copied:
    // a hit is about 120 bytes and every walk starts from the shared first segment. A segment
    // without a hit goes straight on through every run length left (handled where the ray
    // query returns, so that no empty hit is stored).
    let mut traced: Hit;
    let mut next = 0;
    let Some(mut h) = first.hit.as_ref() else {
        straight(lengths, ends, base, d, travelled, beta, bounces);
        return stats;
    };
    loop {
        // The segment ends at the hit; every run length it covers ends on it.
        let seg_end = travelled + (h.p - base).dot(d);
        while next < lengths.len() && lengths[next] <= seg_end {
            ends[next] = End {
                p: base + d * (lengths[next] - travelled),
                beta,
                bounces,
            };
            next += 1;
        }
        if next == lengths.len() {
            return stats;
        }
        if bounces >= max_bounces {
            // Capped: the longer run lengths end at this hit.
            stats.capped = true;
            fill(
                &mut ends[next..],
                End {
                    p: h.p,
                    beta,
                    bounces,
                },
            );
            return stats;
        }
        let u_lobe = s.next_f64();
        let u = s.next_2d();
        let (bsdf, lobe) = K::Space::scatter(scene, h.material);
        let textured;
        let (bsdf, lobe) = match scene.textured_bsdf(h) {
            Some(b) => {
                textured = (K::Space::textured_lobe(&b, lobe), b);
                (&textured.1, &textured.0)
            }
            None => (bsdf, lobe),
        };
        let sampled = bsdf.sample_in(sp, lobe, -d, h.ng, h.ns, u_lobe, u, s, Mode::Importance);
        let absorbed = End {
            p: h.p,
            beta: Rgb::ZERO,
            bounces,
        };
        let Some(bs) = sampled else {
            fill(&mut ends[next..], absorbed);
            return stats;
        };
        beta *= bs.weight;
        if beta == Rgb::ZERO {
            fill(&mut ends[next..], absorbed);
            return stats;
        }
        bounces += 1;
        origin = scene.spawn_origin_from(h, bs.wi, origin);
        d = bs.wi;
        base = h.p;
        travelled = seg_end;
        stats.rays += 1;
        let reach = (t_max - travelled) + (origin - base).length();
        match trace::intersect::<K>(scene, origin, d, reach) {
            Some(hit) => {
                traced = hit;
                h = &traced;
            }
            None => {
                straight(
                    &lengths[next..],
                    &mut ends[next..],
                    base,
                    d,
                    travelled,
                    beta,
                    bounces,
                );
                return stats;
            }
        }
    }
}

/// The ends at `lengths` of a walk that goes straight on from `base` along `d`, `travelled` of
/// its length used up at `base`.
#[inline(always)]
fn straight(
    lengths: &[f64],
    ends: &mut [End],
    base: DVec3,
    d: DVec3,
    travelled: f64,
    beta: Rgb,
    bounces: u32,
) {
    for (e, &len) in ends.iter_mut().zip(lengths) {
        *e = End {
            p: base + d * (len - travelled),
            beta,
            bounces,
        };
    }
}

fn fill(ends: &mut [End], e: End) {
    for x in ends {
        *x = e;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Sampler;

    #[test]
    fn walk_streams_are_the_sample_streams_children() {
        for (key, k) in [
            (0, 0),
            (1, 7),
            (u64::MAX, 3),
            (0x1234_5678_9abc_def0, 1 << 40),
        ] {
            let (mut a, mut b) = (WalkStream::child(key, k), Sampler::child(key, k));
            for _ in 0..64 {
                assert_eq!(a.next_f64().to_bits(), b.next_f64().to_bits(), "{key} {k}");
            }
            assert_eq!(a.next_2d(), b.next_2d());
        }
    }
}
