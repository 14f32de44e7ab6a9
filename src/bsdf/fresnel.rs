//! Schlick's Fresnel approximation, as glTF's Appendix B and its extensions use it.
//!
//! ```text
//! F(c)  = F₀ + (F₉₀ − F₀)(1 − |c|)⁵                        (Appendix B; F₉₀ = 1 unless
//!                                                            KHR_materials_specular sets it)
//! F₀    = ((η − 1)/(η + 1))²                                (KHR_materials_ior)
//! F̄     = 2 ∫₀¹ F(μ) μ dμ = F₀ + (F₉₀ − F₀)/21              (hemispherical average)
//! ```
//!
//! Across a refracting interface Schlick's formula is evaluated with the cosine on the less
//! dense side (the angle of the refracted ray when light arrives from the denser side), and
//! total internal reflection gives `F = 1`: so `F` is the same for a light path and its
//! reverse, which the reciprocity of the transmission lobe needs. The exact equations are in
//! [`crate::optics::fresnel_dielectric`] (used by the lecture's glass).

use crate::math::Vec3;

/// `(1 − |c|)⁵`, the weight of `F₉₀` in Schlick's formula.
#[inline]
pub fn schlick_weight(cos: f32) -> f32 {
    let m = (1.0 - cos.abs()).clamp(0.0, 1.0);
    let m2 = m * m;
    m2 * m2 * m
}

/// Schlick's `F = F₀ + (F₉₀ − F₀)(1 − |c|)⁵`, per channel.
#[inline]
pub fn schlick(f0: Vec3, f90: Vec3, cos: f32) -> Vec3 {
    f0 + (f90 - f0) * schlick_weight(cos)
}

/// The hemispherical average `F̄ = F₀ + (F₉₀ − F₀)/21` of Schlick's `F`.
#[inline]
pub fn schlick_average(f0: Vec3, f90: Vec3) -> Vec3 {
    f0 + (f90 - f0) / 21.0
}

/// `F₀ = ((η − 1)/(η + 1))²` of an interface of relative index `η` (the same for `1/η`).
#[inline]
pub fn f0_from_ior(eta: f32) -> f32 {
    let r = (eta - 1.0) / (eta + 1.0);
    r * r
}

/// Schlick's `F` for light meeting a microfacet at cosine `cos_i` (> 0) from the side where
/// the relative index is `eta = η_other/η_this`: the cosine on the less dense side is used,
/// and total internal reflection gives 1.
#[inline]
pub fn schlick_dielectric(f0: f32, f90: f32, cos_i: f32, eta: f32) -> f32 {
    let c = cos_i.clamp(0.0, 1.0);
    let c = if eta >= 1.0 {
        c
    } else {
        let sin2_t = (1.0 - c * c) / (eta * eta);
        if sin2_t >= 1.0 {
            return 1.0;
        }
        (1.0 - sin2_t).sqrt()
    };
    f0 + (f90 - f0) * schlick_weight(c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn average_matches_quadrature_and_reverse_paths_agree() {
        let (f0, f90) = (Vec3::new(0.04, 0.5, 0.9), Vec3::new(1.0, 0.8, 1.0));
        let n = 100_000;
        let q: Vec3 = (0..n)
            .map(|i| {
                let mu = (i as f32 + 0.5) / n as f32;
                2.0 * schlick(f0, f90, mu) * mu / n as f32
            })
            .sum();
        assert!((q - schlick_average(f0, f90)).abs().max_element() < 1e-4, "{q}");
        assert!((f0_from_ior(1.5) - 0.04).abs() < 1e-7);
        // Light entering glass at 60° and leaving it along the refracted path see the same F.
        let eta = 1.5f32;
        let ci = 0.5f32;
        let ct = (1.0 - (1.0 - ci * ci) / (eta * eta)).sqrt();
        let f0 = f0_from_ior(eta);
        assert!((schlick_dielectric(f0, 1.0, ci, eta) - schlick_dielectric(f0, 1.0, ct, 1.0 / eta)).abs() < 1e-6);
        assert_eq!(schlick_dielectric(f0, 1.0, 0.3, 1.0 / eta), 1.0); // beyond the critical angle
    }
}
