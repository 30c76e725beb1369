//! What a hit sees of its material: the material, emitted radiance (with emission textures) and
//! the scattering model with its texels applied.

use crate::math::Rgb;
use crate::scene::geometry::barycentric;
use crate::scene::hit::Hit;
use crate::scene::material::{Bsdf, Material, TextureRef};
use crate::scene::model::Scene;
use glam::DVec3;

impl Scene {
    pub fn material(&self, hit: &Hit) -> &Material {
        &self.materials[hit.material as usize]
    }

    /// Emitted radiance leaving a hit towards `wo` (front side only): the material's emission, or
    /// its emission texture's texel times it.
    #[inline]
    pub fn emitted(&self, hit: &Hit, wo: DVec3) -> Rgb {
        let m = self.material(hit);
        if m.emission != Rgb::ZERO && wo.dot(hit.ng) > 0.0 {
            if self.features.emission_textures {
                return self
                    .emission_texel(hit.prim, hit.bary)
                    .unwrap_or(m.emission);
            }
            m.emission
        } else {
            Rgb::ZERO
        }
    }

    /// The emission texture's radiance at point `y` of triangle `prim` (the texel at its
    /// barycentric coordinates, times the material's emission); `None` when the scene has no
    /// emission textures or the material none. For light samples, which know a point, not a hit.
    #[inline(always)]
    pub fn emission_at(&self, prim: u32, y: DVec3) -> Option<Rgb> {
        if !self.features.emission_textures {
            return None;
        }
        let [a, b, c] =
            self.triangles[prim as usize].map(|v| self.positions[v as usize].as_dvec3());
        self.emission_texel(prim, barycentric(y, a, b, c).map(|u| u as f32))
    }

    /// The emission texture's radiance (texel × the material's emission) at barycentric `bary` of
    /// triangle `prim`; `None` when its material has no emission texture.
    #[inline(never)]
    fn emission_texel(&self, prim: u32, bary: [f32; 2]) -> Option<Rgb> {
        let m = &self.materials[self.tri_material[prim as usize] as usize];
        let t = m.maps.emission.as_ref()?;
        let texture = self.textures.textures.get(t.texture as usize)?;
        let [r, g, b, _] = t.texel(texture, self.hit_uv(prim, bary));
        Some(m.emission * Rgb::new(r, g, b))
    }

    /// texels (base colour × its factor for `kd`, specular × its factor for `ks`, bilinear at the
    /// interpolated texture coordinate), or with a metallic-roughness map the whole glossy model
    /// rebuilt from the texels ([`MetallicRoughness::bsdf`]); `None` for materials without,
    /// which keep their own. Scenes without textures return at the first test.
    ///
    /// The model returned is of the material's own kind, so the kernel's choice of effects holds
    /// for it; its Phong exponent may differ from the material's (flatland then computes the
    /// lobe's normalisation for it: `Space::textured_lobe`).
    ///
    /// [`MetallicRoughness::bsdf`]: crate::scene::material::MetallicRoughness::bsdf
    #[inline(always)]
    pub fn textured_bsdf(&self, hit: &Hit) -> Option<Bsdf> {
        if !self.features.textures {
            return None;
        }
        self.texel_bsdf(hit)
    }

    /// The BSDF at `hit`: the one its texels give ([`textured_bsdf`](Self::textured_bsdf)) where
    /// they change it, else `own` (the material's model, or the flatland one made of it).
    #[inline(always)]
    pub fn bsdf_at<'a>(&self, hit: &Hit, own: &'a Bsdf) -> std::borrow::Cow<'a, Bsdf> {
        match self.textured_bsdf(hit) {
            Some(b) => std::borrow::Cow::Owned(b),
            None => std::borrow::Cow::Borrowed(own),
        }
    }

    /// [`textured_bsdf`](Self::textured_bsdf) in a scene with textures: kept out of line, so
    /// that the hit code of scenes without textures stays small.
    #[inline(never)]
    fn texel_bsdf(&self, hit: &Hit) -> Option<Bsdf> {
        let m = &self.materials[hit.material as usize];
        let (base, spec) = (m.maps.base_color.as_ref(), m.maps.specular.as_ref());
        let mr = m.maps.metallic_roughness.as_ref();
        if base.is_none() && spec.is_none() && mr.is_none() {
            return None;
        }
        let uv = self.hit_uv(hit.prim, hit.bary);
        let colour = |t: &TextureRef| {
            let [r, g, b, _] = t.texel(&self.textures.textures[t.texture as usize], uv);
            t.factor * Rgb::new(r, g, b)
        };
        if let Some(mr) = mr {
            let texel = mr
                .map
                .texel(&self.textures.textures[mr.map.texture as usize], uv);
            return Some(mr.bsdf(base.map_or(mr.base, colour), texel));
        }
        Some(m.bsdf.with_albedos(base.map(colour), spec.map(colour)))
    }
}
