//! The albedo and lobe maths that the material model and the readers share: energy conservation of
//! the additive Lambertian + specular model, and the metallic-roughness mapping onto it (glTF's
//! parameters to `kd`, `ks` and a Phong exponent; the table is in [`crate::scene::gltf`]). The
//! mapping runs at load for constant materials and at each hit for metallic-roughness textures
//! ([`crate::scene::material::MetallicRoughness`]), so both read it from here. A leaf: it imports
//! nothing of `crate::scene`.

use crate::math::Rgb;

/// Largest Phong exponent the mapping produces; reaching it means a mirror.
pub const MAX_PHONG_EXPONENT: f64 = 1e6;

/// Scales `kd` and `ks` so that `kd + ks` ≤ 1 in every channel; returns whether it had to.
pub fn conserve_energy(kd: &mut Rgb, ks: &mut Rgb) -> bool {
    let m = (*kd + *ks).max_element();
    if m > 1.0 {
        *kd /= m;
        *ks /= m;
        true
    } else {
        false
    }
}

/// Phong exponent equivalent to a GGX roughness: α = r², n = 2/α² − 2, clamped to [1, 10⁶].
pub fn phong_exponent(roughness: f64) -> f64 {
    let alpha = roughness.clamp(0.0, 1.0).powi(2);
    if alpha <= 0.0 {
        return MAX_PHONG_EXPONENT;
    }
    (2.0 / (alpha * alpha) - 2.0).clamp(1.0, MAX_PHONG_EXPONENT)
}

/// The Lambertian corner of the mapping: a rough dielectric (m ≤ 0.05, r ≥ 0.9).
#[inline]
pub fn is_lambertian(metallic: f64, roughness: f64) -> bool {
    metallic <= 0.05 && roughness >= 0.9
}

/// The glossy model's albedos and Phong exponent for base colour `base`, metallic `metallic` and
/// roughness `roughness` (the glTF table's rows below transmission): in the Lambertian corner
/// `kd` = base and `ks` = 0; elsewhere `kd` = base·(1 − m), `ks` = mix(0.04, base, m), scaled down
/// where `kd + ks` exceeds 1, and n = [`phong_exponent`]`(r)`. Metallic and roughness are clamped
/// to [0, 1], the base colour to ≥ 0. Used at load for constant materials
/// ([`crate::scene::gltf::map_pbr`]) and at each hit for materials with a metallic-roughness
/// texture ([`MetallicRoughness::bsdf`](crate::scene::material::MetallicRoughness::bsdf)).
#[inline]
pub fn pbr_lobes(base: Rgb, metallic: f64, roughness: f64) -> (Rgb, Rgb, f64) {
    let (m, r) = (metallic.clamp(0.0, 1.0), roughness.clamp(0.0, 1.0));
    // Float base-colour texels may be negative.
    let base = base.max(Rgb::ZERO);
    let (mut kd, mut ks) = if is_lambertian(m, r) {
        (base, Rgb::ZERO)
    } else {
        (base * (1.0 - m), Rgb::splat(0.04).lerp(base, m))
    };
    conserve_energy(&mut kd, &mut ks);
    (kd, ks, phong_exponent(r))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn phong_exponent_follows_roughness() {
        assert_eq!(phong_exponent(1.0), 1.0);
        assert_eq!(phong_exponent(0.0), MAX_PHONG_EXPONENT);
        // r = 0.5: α = 0.25, n = 2/0.0625 − 2 = 30.
        assert!((phong_exponent(0.5) - 30.0).abs() < 1e-12);
        let mut last = 0.0;
        for k in (0..=100).rev() {
            let n = phong_exponent(k as f64 / 100.0);
            assert!(n >= last);
            last = n;
        }
    }
}
