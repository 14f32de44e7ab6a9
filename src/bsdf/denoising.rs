//! What a BSDF gives the denoising features ([`crate::integrator::features`]), by Cycles' rule
//! for its `Denoising Albedo` and `Denoising Normal` passes: a lobe is *specular-like* when
//! its squared roughness is at most 0.075², diffuse-like otherwise; a surface whose
//! diffuse-like lobes hold more than a quarter of the weight records its features there
//!
//! ```text
//! albedo = Σ_diffuse-like A_k(μo)           normal = the shading normal
//! ```
//!
//! and any other surface passes them on along its specular directions, weighted by what each
//! direction carries: the mirror direction `Σ_specular-like reflection A_k(μo)`, the refracted
//! one `k_t (1 − F)` (energy, not radiance: no `1/η²`). The weight of a lobe is its mean
//! albedo at `μo` (the layering factors of [`Bsdf::albedo`] included).
//!
//! Roughness: Lambert and sheen are diffuse-like; mirrors and smooth dielectrics specular; a
//! Blinn–Phong lobe of exponent `n` has Beckmann `α² = 2/(n + 2)`, so it is specular-like
//! from `n ≥ 354`; glTF's GGX lobes are specular-like only when they are delta lobes
//! (`α < 10⁻³`, [`super::ggx::SMOOTH_ALPHA`]) — a simplification: Cycles' threshold would also
//! count `10⁻³ ≤ α ≤ 0.075` as specular-like.

use super::{Bsdf, Lobe, LobeFlags};
use crate::math::{Vec2, Vec3};

/// Cycles' roughness threshold: specular-like at `α² ≤ 0.075²`.
const SPECULAR_ROUGHNESS2: f32 = 0.075 * 0.075;

/// A BSDF's part in the denoising features at one hit (module docs). Directions are world
/// space.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DenoisingSplit {
    /// Whether the features are recorded here (diffuse-like lobes hold > 1/4 of the weight,
    /// or the BSDF is black).
    pub here: bool,
    /// The albedo of the diffuse-like lobes.
    pub diffuse: Vec3,
    /// Whether the BSDF has any lobe at all (a black surface, an emitter without a BSDF: 0).
    pub has_lobes: bool,
    /// The specular-like reflection: its direction and what it carries.
    pub reflect: Option<(Vec3, Vec3)>,
    /// The refraction: its direction and what it carries.
    pub transmit: Option<(Vec3, Vec3)>,
}

impl Lobe {
    /// Whether the lobe is specular-like (module docs).
    fn specular_like(&self) -> bool {
        match self {
            Lobe::BlinnPhong(b) => 2.0 / (b.exponent + 2.0) <= SPECULAR_ROUGHNESS2,
            _ => self.flags().contains(LobeFlags::SPECULAR),
        }
    }
}

impl Bsdf {
    /// The split of the denoising features at this surface seen from `wo` (module docs).
    pub fn denoising_split(&self, wo: Vec3) -> DenoisingSplit {
        let mut out = DenoisingSplit::default();
        let lo = self.frame.to_local(wo);
        if lo.z <= 0.0 {
            out.here = true;
            return out;
        }
        let scales = self.scales_at(lo, lo);
        let (mut total, mut diffuse_weight) = (0.0, 0.0);
        let (mut reflect, mut transmit) = (Vec3::ZERO, Vec3::ZERO);
        let mut refracted = None;
        for (k, lobe) in self.lobes().iter().enumerate() {
            out.has_lobes = true;
            let scale = scales[self.under[k] as usize];
            let albedo = lobe.albedo_from(lo) * scale;
            let weight = albedo.element_sum() / 3.0;
            total += weight;
            if !lobe.specular_like() {
                out.diffuse += albedo;
                diffuse_weight += weight;
                continue;
            }
            if !lobe.flags().contains(LobeFlags::TRANSMISSION) {
                reflect += albedo;
                continue;
            }
            // A dielectric: its two delta choices, each with what it carries (f·|cos θi|, in
            // energy units: η² undoes the radiance scaling of refraction).
            for uc in [0.0, 1.0 - f32::EPSILON] {
                let Some(s) = lobe.sample(lo, uc, Vec2::splat(0.5)) else { continue };
                let carried = s.f * s.wi.z.abs() * (s.eta * s.eta) * scale;
                if s.wi.z > 0.0 {
                    reflect += carried;
                } else {
                    transmit += carried;
                    refracted = Some(self.frame.to_world(s.wi).normalize_or_zero());
                }
                if s.pdf >= 1.0 {
                    break; // total internal reflection (or no reflection): one choice only
                }
            }
        }
        out.here = total == 0.0 || diffuse_weight * 4.0 > total;
        if out.here {
            return out;
        }
        if reflect != Vec3::ZERO {
            let mirror = self.frame.to_world(Vec3::new(-lo.x, -lo.y, lo.z)).normalize_or_zero();
            out.reflect = Some((mirror, reflect));
        }
        if let Some(dir) = refracted.filter(|_| transmit != Vec3::ZERO) {
            out.transmit = Some((dir, transmit));
        }
        out
    }
}
