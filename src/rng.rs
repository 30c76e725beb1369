//! Deterministic random streams. Every sample stream is keyed by (seed, pass, cell) so that a result
//! does not depend on the thread count or the tile order, and merged runs never reuse numbers.
//!
//! The first [`QMC_DIMS`] numbers of a sample may come from an Owen-scrambled Sobol' sequence
//! ("Practical Hash-based Owen Scrambling", JCGT 9(4), 2020, through `sobol_burley`)
//! instead of the random stream ([`Sampler::begin_sample`]); the numbers after them are the random
//! stream's (padding). A cell's pass takes its samples in groups of [`QMC_GROUP`]; each group is
//! its own scrambled sequence, scrambled by a hash of (seed, pass, cell, group): groups are
//! independent randomised QMC estimates, so the standard error over group sums is honest
//! ([`crate::ftpd::moments::Moments::stderr`]), every point is uniform on its own (unbiased), and
//! two runs of other seeds, passes or cells share no sequence. The group's length does not depend
//! on the pass's, so a run's statistics do not depend on how its samples are split into passes.

use rand_core::Rng;
use rand_pcg::Pcg64Mcg;
#[cfg(test)]
use sobol_burley::parts::owen_scramble_int4_rev;
use sobol_burley::parts::{Int4, hash, hash_int4, owen_scramble_rev, sobol_int4_rev};
use std::sync::LazyLock;

/// SplitMix64 finaliser: a bijective 64-bit mixer used to turn stream keys into PCG states.
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A number in [0, 1) that is a fixed function of `words` (SplitMix64 over them): for decisions
/// that must be random across rays but the same wherever the same ray is traced, on any thread
/// (stochastic cut-outs, keyed by the ray's bits and the triangle).
#[inline]
pub fn hash_unit(words: &[u32]) -> f64 {
    let h = words
        .iter()
        .fold(0x2545_F491_4F6C_DD1D_u64, |h, &w| mix64(h ^ w as u64));
    unit_f64(h)
}

/// The top 53 bits of `bits` as a number in [0, 1): every uniform number the project draws.
#[inline(always)]
pub fn unit_f64(bits: u64) -> f64 {
    (bits >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// Numbers per sample drawn from the scrambled Sobol' sequence: the start point's in its cell,
/// the start direction's (its strategy, light and two numbers with radiance weighting), then the
/// run lengths' and the cone directions' offsets as far as they fit; the rest of the sample, its
/// radiance path and its walks (each walk from a [`Sampler::child`] stream) draw from random
/// streams (see [`crate::ftpd::visit_at`] for the order).
pub const QMC_DIMS: u32 = 8;

/// Samples per scrambled Sobol' sequence: one independent unit of the standard error. Longer
/// sequences stratify more, but leave each cell fewer units to estimate its error from, and the
/// correction for few units ([`crate::ftpd::moments::Moments::stderr`]) then widens the error
/// bars by far more than the stratification narrows the error: short groups keep the bars tight
/// and honest at the sample counts runs take.
pub const QMC_GROUP: u32 = 8;

/// Points of one scrambled sequence `sobol_burley` can give; a batch with more samples takes
/// the rest from the random stream.
const QMC_MAX_POINTS: u32 = 1 << 16;

/// Sets of four dimensions of a point ([`QMC_DIMS`] rounded up to whole sets).
const QMC_SETS: usize = QMC_DIMS.div_ceil(4) as usize;

/// The XORed direction vectors of one set of four dimensions for each value of an index byte.
type ByteVectors = [[[u32; 4]; 256]; 2];

/// For each set of four dimensions, the XOR of the (bit-reversed) Sobol' direction vectors of each
/// value of the shuffled index's top byte (`[0]`) and second byte (`[1]`): `sobol_int4_rev`
/// XORs one vector per set bit of those 16 bits, so two lookups give the same result without
/// its loop over the bits. Built from `sobol_int4_rev` itself.
static SOBOL_BYTES: LazyLock<Box<[ByteVectors; QMC_SETS]>> = LazyLock::new(|| {
    let mut t = Box::new([[[[0u32; 4]; 256]; 2]; QMC_SETS]);
    for (set, bytes) in t.iter_mut().enumerate() {
        for b in 0..256u32 {
            bytes[0][b as usize] = sobol_int4_rev(b << 24, set as u32).into();
            bytes[1][b as usize] = sobol_int4_rev(b << 16, set as u32).into();
        }
    }
    t
});

/// The scrambles of one Sobol' sequence (`sobol_burley::sample_4d` with seed `seed`), hashed once
/// for its points: [`SobolKeys::point`] gives exactly `sample_4d`'s numbers.
#[derive(Clone, Copy, Debug)]
struct SobolKeys {
    /// Scramble of the point index (the sequence's shuffle).
    index: u32,
    /// Owen scramble of each set of four dimensions.
    lanes: [[u32; 4]; QMC_SETS],
}

impl SobolKeys {
    fn new(seed: u32) -> Self {
        let salt = Int4::from([0x912f_69ba, 0x174f_18ab, 0x691e_72ca, 0xb40c_c1b8]);
        let seed4 = Int4::from([seed.wrapping_mul(0x9c8f_2d3b); 4]);
        SobolKeys {
            index: hash(seed ^ 0x79c6_8e4a),
            lanes: std::array::from_fn(|set| {
                hash_int4(seed4 ^ Int4::from([set as u32; 4]) ^ salt).into()
            }),
        }
    }

    /// The shuffled (bit-reversed) index of point `index`, shared by the point's sets.
    #[inline]
    fn shuffle(&self, index: u32) -> u32 {
        owen_scramble_rev(index.reverse_bits(), self.index)
    }

    /// Dimensions `4 set .. 4 set + 4` of the point whose shuffled index is `shuffled`, with the
    /// crate's four-lane integers (the reference [`SobolKeys::points`] is tested against).
    #[cfg(test)]
    fn point(&self, shuffled: u32, set: usize) -> [f32; 4] {
        let t = &SOBOL_BYTES[set];
        let sobol = Int4::from(t[0][(shuffled >> 24) as usize])
            ^ Int4::from(t[1][((shuffled >> 16) & 0xff) as usize]);
        owen_scramble_int4_rev(sobol, Int4::from(self.lanes[set]))
            .reverse_bits()
            .to_f32_norm()
    }

    /// Every dimension of the point whose shuffled index is `shuffled`: [`SobolKeys::point`]'s
    /// numbers bit for bit, as f64. The Owen scramble runs lane by lane on scalar integers, where
    /// a 32-bit multiplication is one instruction (`Int4`'s is emulated by a sequence of them on
    /// SSE2, which has no such multiplication); the bit reversal stays four lanes at a time.
    #[inline]
    fn points(&self, shuffled: u32, out: &mut [f64; QMC_DIMS as usize]) {
        let (hi, lo) = (
            (shuffled >> 24) as usize,
            ((shuffled >> 16) & 0xff) as usize,
        );
        for set in 0..QMC_SETS {
            let t = &SOBOL_BYTES[set];
            let n: [u32; 4] = std::array::from_fn(|k| {
                owen_scramble_rev(t[0][hi][k] ^ t[1][lo][k], self.lanes[set][k])
            });
            let four = Int4::from(n).reverse_bits().to_f32_norm();
            for (q, x) in out[4 * set..].iter_mut().zip(four) {
                *q = f64::from(x);
            }
        }
    }
}

/// A source of uniform numbers in [0, 1): a sample's stream ([`Sampler`]), or a walk's
/// random-only one (`crate::transport::deflection::WalkStream`), for the code both draw through.
pub trait Uniform {
    fn next_f64(&mut self) -> f64;

    #[inline(always)]
    fn next_2d(&mut self) -> (f64, f64) {
        (self.next_f64(), self.next_f64())
    }
}

impl Uniform for Sampler {
    #[inline(always)]
    fn next_f64(&mut self) -> f64 {
        Sampler::next_f64(self)
    }
}

/// A uniform random number source for one sample stream.
#[derive(Clone)]
pub struct Sampler {
    rng: Pcg64Mcg,
    /// The low word of the stream's key, hashed into the scramble seeds of its groups only when a
    /// group's first point is drawn ([`Sampler::next_point`]): random-only streams (the walks')
    /// never pay for that hash.
    lo: u64,
    /// The current sample's group, its point's index in the group's sequence and the next
    /// dimension; `dim == QMC_DIMS` when every number comes from `rng`.
    group: u32,
    index: u32,
    dim: u32,
    /// The scrambles of group `keyed` (hashed when a group's first number is drawn, so samples
    /// that draw from the random stream only never pay for them).
    keyed: Option<u32>,
    keys: SobolKeys,
    /// The current point's [`QMC_DIMS`] numbers, computed when its first one is drawn.
    point: [f64; QMC_DIMS as usize],
}

impl Sampler {
    /// The stream of `cell` in pass `pass` of a run seeded with `seed`.
    pub fn new(seed: u64, pass: u64, cell: u64) -> Self {
        let hi = mix64(seed ^ mix64(pass.wrapping_mul(0xD6E8_FEB8_6659_FD93)));
        let lo = mix64(cell ^ mix64(hi));
        Sampler::new_raw(hi, lo)
    }

    /// The stream of the 128-bit state `hi`:`lo`.
    #[inline]
    fn new_raw(hi: u64, lo: u64) -> Self {
        // MCG state must be odd; the generator forces that itself.
        Sampler {
            rng: Pcg64Mcg::new(((hi as u128) << 64) | lo as u128),
            lo,
            group: 0,
            index: 0,
            dim: QMC_DIMS,
            keyed: None,
            // Unused until a group's first point hashes its own (`keyed`).
            keys: SobolKeys {
                index: 0,
                lanes: [[0; 4]; QMC_SETS],
            },
            point: [0.0; QMC_DIMS as usize],
        }
    }

    /// A random-only stream of its own for each `k` under `key` (a [`Sampler::fork_key`]): the
    /// walks of one sample each draw from one, so that no number is shared between walks.
    /// [`Children`] gives the same streams with the key's hash taken once for all of them.
    #[inline]
    pub fn child(key: u64, k: u64) -> Self {
        Children::new(key).stream(k)
    }

    /// 64 bits of the random stream, for the keys of [`Sampler::child`] streams; takes no
    /// dimension of the current QMC point.
    #[inline]
    pub fn fork_key(&mut self) -> u64 {
        self.rng.next_u64()
    }

    /// Starts sample `index` of group `batch` of this stream: its first [`QMC_DIMS`] numbers are
    /// point `index` of the group's scrambled Sobol' sequence. Without this call (tests, single
    /// points, the reference estimator) every number is the random stream's.
    #[inline]
    pub fn begin_sample(&mut self, batch: u32, index: u32) {
        if index >= QMC_MAX_POINTS {
            self.dim = QMC_DIMS;
            return;
        }
        self.group = batch;
        self.index = index;
        self.dim = 0;
    }

    /// Uniform in [0, 1): the next dimension of the current QMC point, or 53 random bits.
    #[inline]
    pub fn next_f64(&mut self) -> f64 {
        let r = unit_f64(self.rng.next_u64());
        if self.dim < QMC_DIMS {
            let d = self.dim;
            self.dim += 1;
            if d == 0 {
                self.next_point();
            }
            // 24 bits from the sequence, the bits below them from the random stream: the point
            // keeps its strata, and every number keeps 53 bits.
            return Self::blend(self.point[d as usize], r);
        }
        r
    }

    /// Every dimension of the current QMC point into `point`, when its first number is drawn (the
    /// samples that draw a point use all of its sets). Not inlined: the point's code is large and
    /// runs once per sample, while [`Sampler::next_f64`] is called at every bounce; inlined into
    /// each call site it slows every draw, those of samples that never draw a point included
    /// (radiance weighting).
    #[inline(never)]
    fn next_point(&mut self) {
        if self.keyed != Some(self.group) {
            let key = mix64(self.lo ^ 0x5851_F42D_4C95_7F2D);
            self.keys = SobolKeys::new(mix64(key ^ u64::from(self.group)) as u32);
            self.keyed = Some(self.group);
        }
        self.keys
            .points(self.keys.shuffle(self.index), &mut self.point);
    }

    #[inline]
    pub fn next_2d(&mut self) -> (f64, f64) {
        (self.next_f64(), self.next_f64())
    }

    /// `N` numbers in a row, the same as `N` calls of [`Sampler::next_f64`]: where all of them are
    /// dimensions of the current QMC point, with one test of the dimension for all of them (a
    /// sample's first numbers: its start point's, direction's and offsets'). Random-only streams
    /// (the walks') should keep to [`Sampler::next_f64`], which tests less for them.
    #[inline]
    pub fn next_n<const N: usize>(&mut self) -> [f64; N] {
        let d = self.dim as usize;
        if d + N <= QMC_DIMS as usize {
            if d == 0 {
                self.next_point();
            }
            self.dim += N as u32;
            return std::array::from_fn(|k| {
                let r = unit_f64(self.rng.next_u64());
                Self::blend(self.point[d + k], r)
            });
        }
        std::array::from_fn(|_| self.next_f64())
    }

    /// A QMC number `q` (24 bits) with the random number `r`'s bits below them.
    #[inline(always)]
    fn blend(q: f64, r: f64) -> f64 {
        (q + r * (1.0 / (1u64 << 24) as f64)).min(1.0 - f64::EPSILON / 2.0)
    }
}

/// The [`Sampler::child`] streams of one key, its hash taken once: a sample's walks each draw
/// from one of them.
#[derive(Clone, Copy, Debug)]
pub struct Children {
    hi: u64,
}

impl Children {
    #[inline]
    pub fn new(key: u64) -> Self {
        Children {
            hi: mix64(key ^ 0xA076_1D64_78BD_642F),
        }
    }

    /// The 128-bit state `(hi, lo)` of stream `k`.
    #[inline]
    pub fn state(&self, k: u64) -> (u64, u64) {
        (
            self.hi,
            mix64(self.hi ^ k.wrapping_mul(0xE703_7ED1_A0B4_28DB)),
        )
    }

    /// Stream `k`: [`Sampler::child`]`(key, k)`.
    #[inline]
    pub fn stream(&self, k: u64) -> Sampler {
        let (hi, lo) = self.state(k);
        Sampler::new_raw(hi, lo)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let a: Vec<f64> = (0..4)
            .map(|_| 0.0)
            .scan(Sampler::new(1, 0, 7), |s, _| Some(s.next_f64()))
            .collect();
        let b: Vec<f64> = (0..4)
            .map(|_| 0.0)
            .scan(Sampler::new(1, 0, 7), |s, _| Some(s.next_f64()))
            .collect();
        let c: Vec<f64> = (0..4)
            .map(|_| 0.0)
            .scan(Sampler::new(1, 1, 7), |s, _| Some(s.next_f64()))
            .collect();
        let d: Vec<f64> = (0..4)
            .map(|_| 0.0)
            .scan(Sampler::new(2, 0, 7), |s, _| Some(s.next_f64()))
            .collect();
        assert_eq!(a, b);
        assert_ne!(a, c);
        assert_ne!(a, d);
        assert!(a.iter().all(|x| (0.0..1.0).contains(x)));
    }

    #[test]
    fn uniform_mean_and_variance() {
        let mut s = Sampler::new(42, 0, 0);
        let n = 200_000;
        let (mut m, mut m2) = (0.0, 0.0);
        for _ in 0..n {
            let x = s.next_f64();
            m += x;
            m2 += x * x;
        }
        m /= n as f64;
        m2 /= n as f64;
        // mean 1/2 with standard error sqrt(1/12/n); allow 4 standard errors.
        let se = (1.0f64 / 12.0 / n as f64).sqrt();
        assert!((m - 0.5).abs() < 4.0 * se, "mean {m}");
        assert!((m2 - m * m - 1.0 / 12.0).abs() < 0.002);
    }

    #[test]
    fn qmc_points_are_distinct_across_seeds_passes_cells_and_groups() {
        // The first two dimensions of the points of 8 groups of each stream (a pass of 64 samples,
        // as the driver numbers its groups): no point of one stream or group equals a point of
        // another (they would if two keys shared a scramble).
        let mut seen = std::collections::HashSet::new();
        for seed in 0..3u64 {
            for pass in 0..3u64 {
                for cell in 0..4u64 {
                    let mut s = Sampler::new(seed, pass, cell);
                    for batch in 0..8 {
                        for i in 0..QMC_GROUP {
                            s.begin_sample(batch, i);
                            let p = (s.next_f64().to_bits(), s.next_f64().to_bits());
                            assert!(
                                seen.insert(p),
                                "point shared: {seed} {pass} {cell} {batch} {i}"
                            );
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn sobol_points_are_sample_4d_bit_for_bit() {
        // The table lookups and the hashed-once scrambles against the crate's own sampler, over
        // seeds, every set a sample uses, and indices over the whole 16-bit range.
        let mut h = 0x1234_5678_u64;
        for _ in 0..20_000 {
            h = mix64(h);
            let (seed, index) = (h as u32, (h >> 32) as u32 % QMC_MAX_POINTS);
            let keys = SobolKeys::new(seed);
            let mut all = [0.0; QMC_DIMS as usize];
            keys.points(keys.shuffle(index), &mut all);
            for set in 0..QMC_SETS {
                let a = keys.point(keys.shuffle(index), set);
                let whole: Vec<f64> = a.iter().map(|&x| f64::from(x)).collect();
                assert_eq!(all[4 * set..4 * set + 4], whole[..], "{seed} {index} {set}");
                let b = sobol_burley::sample_4d(index, set as u32, seed);
                assert_eq!(
                    a.map(f32::to_bits),
                    b.map(f32::to_bits),
                    "{seed} {index} {set}"
                );
            }
        }
    }

    #[test]
    fn next_n_draws_what_next_f64_draws() {
        // Every split of a sample's numbers into runs of 1-4, from every dimension a run can start
        // at, bit for bit against one number at a time (QMC, mixed and random-only runs).
        for start in 0..QMC_DIMS + 2 {
            for run in 1..=4usize {
                let mut a = Sampler::new(3, 1, 9);
                let mut b = Sampler::new(3, 1, 9);
                a.begin_sample(2, 5);
                b.begin_sample(2, 5);
                for _ in 0..start {
                    a.next_f64();
                    b.next_f64();
                }
                let want: Vec<u64> = (0..3 * run).map(|_| a.next_f64().to_bits()).collect();
                let mut got = Vec::new();
                for _ in 0..3 {
                    let xs: Vec<f64> = match run {
                        1 => b.next_n::<1>().to_vec(),
                        2 => b.next_n::<2>().to_vec(),
                        3 => b.next_n::<3>().to_vec(),
                        _ => b.next_n::<4>().to_vec(),
                    };
                    got.extend(xs.iter().map(|x| x.to_bits()));
                }
                assert_eq!(want, got, "start {start}, runs of {run}");
                assert_eq!(a.next_f64().to_bits(), b.next_f64().to_bits());
            }
        }
    }

    #[test]
    fn qmc_batch_is_stratified() {
        // 16 points of one batch: each of the first dimensions has exactly one point in each
        // sixteenth of [0, 1) (a (0, m, s)-net property of Sobol' points kept by Owen scrambling).
        let mut s = Sampler::new(7, 1, 3);
        let mut strata = vec![[0u32; 16]; QMC_DIMS as usize];
        for i in 0..16 {
            s.begin_sample(0, i);
            for st in strata.iter_mut() {
                let u = s.next_f64();
                assert!((0.0..1.0).contains(&u));
                st[(u * 16.0) as usize] += 1;
            }
        }
        for st in &strata {
            assert!(st.iter().all(|&c| c == 1), "{st:?}");
        }
    }
}
