//! The flatland preparation of a scene: the slice plane ([`Flatland`]), the check that the geometry
//! is extruded along its normal, the emitters' cross-sections with it and every material in 2D form
//! ([`FlatScene`]). Sampling and evaluating these in 2D is light transport (`crate::transport::space`,
//! where the table of 2D measures is).

use crate::scene::light::{Light, Lights, Segment};
use crate::scene::material::Bsdf;
use glam::DVec3;
use std::f64::consts::{PI, TAU};

/// The slice plane of a flatland run: `normal · x = offset`, spanned by the orthonormal `e1`, `e2`
/// (`e1 × e2 = normal`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Flatland {
    pub normal: DVec3,
    pub offset: f64,
    pub e1: DVec3,
    pub e2: DVec3,
}

/// Largest |n_g · n_plane| of a triangle crossing the slice plane: its normal may lie at most this
/// far (as a sine, 1e-4 ≈ 0.006°) out of the plane.
pub const MAX_NORMAL_OUT_OF_PLANE: f64 = 1e-4;

impl Flatland {
    /// The plane through `origin` spanned by the orthonormal `u`, `v`.
    pub fn new(origin: DVec3, u: DVec3, v: DVec3) -> Flatland {
        let normal = u.cross(v).normalize();
        Flatland {
            normal,
            offset: normal.dot(origin),
            e1: u,
            e2: v,
        }
    }

    /// Signed distance of `p` from the plane.
    #[inline]
    pub fn distance(&self, p: DVec3) -> f64 {
        self.normal.dot(p) - self.offset
    }

    /// `v` without its component along the plane normal, normalised; `None` when nothing is left
    /// (v along the normal).
    #[inline]
    pub fn in_plane(&self, v: DVec3) -> Option<DVec3> {
        let p = v - self.normal * v.dot(self.normal);
        let l = p.length();
        (l > 1e-9 * v.length() && l.is_finite()).then(|| p / l)
    }

    /// The in-plane unit vector `a` turned by the angle whose cosine and sine are `c`, `s`
    /// (counter-clockwise about the plane normal).
    #[inline]
    pub fn rotate(&self, a: DVec3, c: f64, s: f64) -> DVec3 {
        a * c + self.normal.cross(a) * s
    }
}

/// `I(m) = ∫_{−π/2}^{π/2} cos^m α dα = √π Γ((m+1)/2) / Γ(m/2 + 1)` for real m ≥ 0.
///
/// Computed without cancellation: from m₀ = m mod 2 (I(0) = π, I(1) = 2 exactly, other m₀ by the
/// Lanczos Γ) by the recurrence I(m) = (m−1)/m · I(m−2) up to m = 4096, and above that by the
/// asymptotic series of Γ(a + ½)/Γ(a) with a = (m+1)/2 (relative error < 1e-16 there).
pub fn cos_power_integral(m: f64) -> f64 {
    assert!(m >= 0.0 && m.is_finite(), "cos_power_integral({m})");
    if m > 4096.0 {
        let a = 0.5 * (m + 1.0);
        let ia = 1.0 / a;
        let series = 1.0 - ia / 8.0 + ia * ia / 128.0 + 5.0 * ia.powi(3) / 1024.0
            - 21.0 * ia.powi(4) / 32768.0;
        return PI.sqrt() / (a.sqrt() * series);
    }
    let k = (0.5 * m).floor();
    let m0 = m - 2.0 * k;
    let mut i = if m0 == 0.0 {
        PI
    } else if m0 == 1.0 {
        2.0
    } else {
        PI.sqrt() * gamma(0.5 * (m0 + 1.0)) / gamma(0.5 * m0 + 1.0)
    };
    let mut mm = m0;
    for _ in 0..k as u32 {
        mm += 2.0;
        i *= (mm - 1.0) / mm;
    }
    i
}

/// [`cos_power_integral`] in closed form with a fixed, small cost, for Phong lobes whose exponent
/// changes from hit to hit (a metallic-roughness texture's roughness).
///
/// I(m) = √π / R(a) with a = (m+1)/2 and R(a) = Γ(a + ½)/Γ(a). R(a + 1) = R(a)·(a + ½)/a, so
/// R(a) = R(x)·∏ (a+j)/(a+j+½) over the j < k that lift a to x = a + k ≥ 32 (at most 32 factors),
/// and R(x) = √x (1 − 1/8x + 1/128x² + 5/1024x³ − 21/32768x⁴ − 399/262144x⁵ + 869/4194304x⁶ +
/// 39325/33554432x⁷ + …), the asymptotic series of the ratio, whose truncation there is below
/// 2·10⁻¹⁶ relative. Relative error ~10⁻¹⁵ for every m ≥ 0 (the tests hold it to quadrature).
#[inline]
pub fn cos_power_integral_closed(m: f64) -> f64 {
    let a = 0.5 * (m.max(0.0) + 1.0);
    let (mut num, mut den, mut x) = (1.0, 1.0, a);
    while x < 32.0 {
        num *= x;
        den *= x + 0.5;
        x += 1.0;
    }
    let t = 1.0 / x;
    let series = 1.0
        + t * (-1.0 / 8.0
            + t * (1.0 / 128.0
                + t * (5.0 / 1024.0
                    + t * (-21.0 / 32768.0
                        + t * (-399.0 / 262_144.0
                            + t * (869.0 / 4_194_304.0 + t * (39_325.0 / 33_554_432.0)))))));
    let ratio = x.sqrt() * series * (num / den);
    PI.sqrt() / ratio
}

/// Γ(x) for x in [0.5, 2] (Lanczos, g = 7, 9 terms; relative error ~1e-15).
fn gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    let x = x - 1.0;
    let mut a = C[0];
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    let t = x + G + 0.5;
    (TAU).sqrt() * t.powf(x + 0.5) * (-t).exp() * a
}

/// The 2D normalised Phong lobe of exponent n around the mirror direction r, α the angle to r:
///
/// `f = ks · cosⁿα / I(n+1)` with `I(m) = ∫_{−π/2}^{π/2} cos^m α dα` ([`cos_power_integral`]).
///
/// The 3D code normalises by (n+2)/2π, which makes the directional albedo exactly ks at normal
/// incidence (where α is the angle to the normal, so ∫ cosⁿα cos θ dω = 2π/(n+2)). The same
/// condition in 2D is `∫ f cos θ dθ = ks/I(n+1) · ∫ cos^(n+1) θ dθ = ks`, hence I(n+1). At other
/// incidences the albedo is smaller (cosⁿ(θ − θr) and cos θ are symmetric and decreasing about
/// their centres, so their overlap is largest when the centres coincide, and the horizon clips the
/// lobe), so the lobe never creates energy.
///
/// Sampling is ∝ cosⁿα on (−π/2, π/2) (density `cosⁿα / I(n)`), exactly, by rejection: for n ≥ 1
/// from the Gaussian N(0, 1/n), which bounds it (ln cos α ≤ −α²/2, so cosⁿα ≤ e^(−nα²/2)), accepting
/// with probability cosⁿα · e^(nα²/2) (acceptance ≥ 0.90 at n = 1, → 1 as n grows); for n < 1 from
/// the uniform density on (−π/2, π/2), accepting with probability cosⁿα (≥ 2/π).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhongLobe {
    pub exponent: f64,
    /// 1/I(n): the sampling density's normalisation.
    pub inv_pdf_norm: f64,
    /// 1/I(n+1): the BRDF's normalisation.
    pub inv_brdf_norm: f64,
}

impl PhongLobe {
    pub fn new(exponent: f64) -> PhongLobe {
        let n = exponent.max(0.0);
        PhongLobe {
            exponent: n,
            inv_pdf_norm: 1.0 / cos_power_integral(n),
            inv_brdf_norm: 1.0 / cos_power_integral(n + 1.0),
        }
    }
}

impl PhongLobe {
    /// [`PhongLobe::new`] for an exponent read at a hit (a metallic-roughness texel): both
    /// normalisations from one closed-form integral ([`cos_power_integral_closed`]), the BRDF's by
    /// I(n)·I(n+1) = 2π/(n+1) (Γ((n+1)/2)/Γ((n+3)/2) = 2/(n+1)).
    #[inline]
    pub fn at(exponent: f64) -> PhongLobe {
        let n = exponent.max(0.0);
        let i = cos_power_integral_closed(n);
        PhongLobe {
            exponent: n,
            inv_pdf_norm: 1.0 / i,
            inv_brdf_norm: i * (n + 1.0) / TAU,
        }
    }
}

/// A material's scattering model in flatland: the same [`Bsdf`] with 2D lobes (see the table in
/// `crate::transport::space`), and for Phong its precomputed normalisation.
#[derive(Clone, Debug, PartialEq)]
pub struct FlatBsdf {
    pub bsdf: Bsdf,
    pub(crate) lobe: PhongLobe,
}

impl FlatBsdf {
    pub fn new(bsdf: &Bsdf) -> FlatBsdf {
        let exponent = match bsdf {
            Bsdf::Glossy { exponent, .. } => *exponent,
            _ => 0.0,
        };
        FlatBsdf {
            bsdf: bsdf.clone(),
            lobe: PhongLobe::new(exponent),
        }
    }
}

/// A light source as flatland sees it: the cross-section of an emissive triangle with the plane,
/// or a point light in the plane (radiant intensity per radian).
pub type FlatLight = Light<Segment>;

/// The lights of a flatland run: one is chosen in proportion to its 2D power, then a point on a
/// segment uniformly by length; densities are per radian at the receiving point.
pub type FlatLights = Lights<Segment>;

/// Why a scene cannot run in flatland on a plane (a command line names its own flag for flatland:
/// `crate::cli::errors`).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum FlatlandError {
    /// Geometry crosses the plane with its normal out of it.
    #[error("{file}: flatland needs geometry extruded along the slice normal; {detail}")]
    NotExtruded { file: String, detail: String },
    /// A light (or its direction) does not lie in the plane.
    #[error("{file}: flatland: {detail}")]
    LightOffPlane { file: String, detail: String },
}

/// How a triangle meets the slice plane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Section {
    /// Not at all, or in a single point.
    None,
    /// Along a segment; `edge` when that segment is an edge of the triangle (two vertices on the
    /// plane, the third off it).
    Segment { a: DVec3, b: DVec3, edge: bool },
    /// The triangle lies in the plane.
    Coplanar,
}

/// The intersection of the triangle `v` with the plane. Vertices within `tol` of the plane count as
/// on it; segment end points are projected onto the plane.
pub fn cross_section(pl: &Flatland, v: [DVec3; 3], tol: f64) -> Section {
    let d = v.map(|p| pl.distance(p));
    let sign = d.map(|x| {
        if x > tol {
            1i8
        } else if x < -tol {
            -1
        } else {
            0
        }
    });
    let zeros = sign.iter().filter(|s| **s == 0).count();
    if zeros == 3 {
        return Section::Coplanar;
    }
    let on = |p: DVec3| p - pl.normal * pl.distance(p);
    let mut pts: Vec<DVec3> = Vec::with_capacity(3);
    for k in 0..3 {
        if sign[k] == 0 {
            pts.push(on(v[k]));
        }
    }
    for (i, j) in [(0, 1), (1, 2), (2, 0)] {
        if sign[i] * sign[j] < 0 {
            let t = d[i] / (d[i] - d[j]);
            pts.push(on(v[i] + (v[j] - v[i]) * t));
        }
    }
    if pts.len() < 2 {
        return Section::None;
    }
    // With two or more points, take the two farthest apart (rounding may add a near-duplicate).
    let (mut a, mut b, mut best) = (pts[0], pts[1], -1.0);
    for i in 0..pts.len() {
        for j in i + 1..pts.len() {
            let l = (pts[i] - pts[j]).length_squared();
            if l > best {
                (a, b, best) = (pts[i], pts[j], l);
            }
        }
    }
    if !(best > 0.0) {
        return Section::None;
    }
    Section::Segment {
        a,
        b,
        edge: zeros == 2,
    }
}

/// What a flatland run needs about its plane: the plane, its label (e.g. `z=0`), the emitters'
/// cross-sections, and every material in 2D form (indexed like `Scene::materials`).
#[derive(Clone, Debug)]
pub struct FlatScene {
    pub plane: Flatland,
    pub label: String,
    pub lights: FlatLights,
    pub bsdfs: Vec<FlatBsdf>,
    /// The planar mirrors that cross the plane, as lines in it.
    pub mirrors: crate::scene::mirror::Mirrors,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ∫_{−π/2}^{π/2} cosᵐα dα by tanh-sinh quadrature over [−L, L], L = min(π/2, 40/√m) (beyond
    /// it cosᵐα ≤ e^(−mα²/2) < e^(−800)): double-exponential nodes, so the endpoint singularity of
    /// m < 1 and the narrow peak of m = 10⁶ converge alike.
    fn quadrature(m: f64) -> f64 {
        let l = if m > 0.0 {
            (40.0 / m.sqrt()).min(PI / 2.0)
        } else {
            PI / 2.0
        };
        let h = 1.0 / 256.0;
        let mut sum = 0.0;
        for k in -1400..=1400 {
            let t = k as f64 * h;
            let u = PI / 2.0 * t.sinh();
            // α = L tanh u; L − |α| = 2L / (1 + e^(2|u|)).
            let gap = 2.0 * l / (1.0 + (2.0 * u.abs()).exp());
            let alpha_abs = l - gap;
            // ln cos α: by ln(1 − 2 sin²(α/2)) near the peak, so that cosᵐ keeps its precision
            // for m = 10⁶; by the sine of the gap near the ends.
            let ln_cos = if l < PI / 2.0 {
                (-2.0 * (0.5 * alpha_abs).sin().powi(2)).ln_1p()
            } else {
                gap.sin().ln()
            };
            let w = l * PI / 2.0 * t.cosh() / u.cosh().powi(2);
            if w > 0.0 && ln_cos.is_finite() {
                sum += w * (m * ln_cos).exp();
            }
        }
        sum * h
    }

    #[test]
    fn quadrature_reproduces_closed_forms() {
        // I(0) = π, I(1) = 2, I(2) = π/2, I(3) = 4/3.
        for (m, v) in [(0.0, PI), (1.0, 2.0), (2.0, PI / 2.0), (3.0, 4.0 / 3.0)] {
            assert!((quadrature(m) / v - 1.0).abs() < 1e-13, "m = {m}");
        }
    }

    /// The per-hit closed form against independent quadrature and the recurrence, over the
    /// exponents a roughness texel can give (n(r) ∈ [1, 10⁶]) and below; both normalisations of
    /// [`PhongLobe::at`] make the sampling density integrate to 1 and the BRDF's normal-incidence
    /// albedo ks, and equal [`PhongLobe::new`]'s.
    #[test]
    fn closed_form_lobe_normalisation_matches_quadrature_per_exponent() {
        for m in [
            0.0, 0.25, 0.5, 1.0, 1.5, 2.0, 2.646, 7.3, 13.43, 30.0, 62.5, 63.0, 245.0, 1029.0,
            4095.5, 4097.0, 1.0e4, 1.2345e5, 1.0e6,
        ] {
            let q = quadrature(m);
            let c = cos_power_integral_closed(m);
            assert!(
                (c / q - 1.0).abs() < 1e-13,
                "m = {m}: closed {c} vs quadrature {q}"
            );
            let r = cos_power_integral(m);
            assert!(
                (c / r - 1.0).abs() < 1e-13,
                "m = {m}: closed {c} vs recurrence {r}"
            );
            let lobe = PhongLobe::at(m);
            assert_eq!(lobe.exponent, m);
            // ∫ pdf = I(n)/I(n) and ∫ brdf cos^(n+1)… = I(n+1)/I(n+1), by quadrature.
            assert!((lobe.inv_pdf_norm * q - 1.0).abs() < 1e-13, "m = {m}");
            let q1 = quadrature(m + 1.0);
            assert!((lobe.inv_brdf_norm * q1 - 1.0).abs() < 1e-13, "m = {m}");
            let own = PhongLobe::new(m);
            assert!((lobe.inv_pdf_norm / own.inv_pdf_norm - 1.0).abs() < 1e-13);
            assert!((lobe.inv_brdf_norm / own.inv_brdf_norm - 1.0).abs() < 1e-13);
        }
    }

    #[test]
    fn section_of_an_extruded_quad() {
        let pl = Flatland::new(DVec3::ZERO, DVec3::X, DVec3::Y);
        let v = [
            DVec3::new(0.0, 0.0, -1.0),
            DVec3::new(1.0, 0.0, -1.0),
            DVec3::new(1.0, 0.0, 1.0),
        ];
        let Section::Segment { a, b, edge } = cross_section(&pl, v, 1e-12) else {
            panic!()
        };
        assert!(!edge);
        assert_eq!(a.z, 0.0);
        assert_eq!(b.z, 0.0);
        assert!(((a - b).length() - 0.5).abs() < 1e-15);
        let flat = [DVec3::ZERO, DVec3::X, DVec3::Y];
        assert_eq!(cross_section(&pl, flat, 1e-12), Section::Coplanar);
        let touching = [
            DVec3::ZERO,
            DVec3::new(1.0, 0.0, 1.0),
            DVec3::new(0.0, 1.0, 1.0),
        ];
        assert_eq!(cross_section(&pl, touching, 1e-12), Section::None);
    }
}
