//! The Trowbridge–Reitz (GGX) microfacet distribution of glTF's Appendix B, isotropic, with
//! `α = roughness²`, its height-correlated Smith masking-shadowing and the sampling of its
//! visible normals.
//!
//! ```text
//! D(h)      = α² χ⁺(h_z) / (π (h_z² (α² − 1) + 1)²)
//! Λ(ω)      = (√(α² + (1 − α²) cos²θ) / |cos θ| − 1) / 2,     G₁(ω) = 1 / (1 + Λ(ω))
//! G₂(o, i)  = 1 / (1 + Λ(o) + Λ(i))                                (height-correlated)
//! V(o, i)   = G₂ / (4 |cos θo| |cos θi|)
//!           = 1 / (2 (|cos θo| √(α² + (1 − α²) cos²θi) + |cos θi| √(α² + (1 − α²) cos²θo)))
//! D_o(h)    = G₁(o) max(0, o·h) D(h) / cos θo                      (visible normals)
//! ```
//!
//! `V` is Appendix B's visibility written as the specification writes it; `G₂` is the same
//! function (the two agree to rounding, tested). Visible normals are sampled by Dupuy and
//! Benyoub's spherical caps ("Sampling Visible GGX Normals with Spherical Caps", HPG 2023),
//! which draws exactly Heitz's `D_o` ("Sampling the GGX Distribution of Visible Normals",
//! JCGT 2018) in fewer operations.

use std::f32::consts::PI;

use crate::math::{Vec2, Vec3};

/// Below this `α` a microfacet lobe is treated as a perfect (delta) interface: `D` would exceed
/// `1/(π α²) ≈ 3·10⁵` and its visible normals would all round to `n`, so sampling it as a
/// distribution gains nothing and loses precision (pbrt-v4's `EffectivelySmooth` uses the same
/// bound). Roughness below `√0.001 ≈ 0.0316` is thus a mirror or clear glass.
pub const SMOOTH_ALPHA: f32 = 1e-3;

/// An isotropic GGX distribution.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ggx {
    pub alpha: f32,
}

impl Ggx {
    /// The distribution of glTF roughness `roughness` (`α = roughness²`).
    #[inline]
    pub fn from_roughness(roughness: f32) -> Ggx {
        Ggx { alpha: roughness * roughness }
    }

    /// Whether the lobe is a delta interface (see [`SMOOTH_ALPHA`]).
    #[inline]
    pub fn is_smooth(&self) -> bool {
        self.alpha < SMOOTH_ALPHA
    }

    /// `D(h)` for the unit microfacet normal `h` (local).
    #[inline]
    pub fn d(&self, h: Vec3) -> f32 {
        if h.z <= 0.0 {
            return 0.0;
        }
        // h_z² (α² − 1) + 1 = α² h_z² + h_x² + h_y² for a unit h: no cancellation near the peak
        // (the other form loses 1e-3 relative at α = 0.01 in f32).
        let a2 = self.alpha * self.alpha;
        let t = a2 * h.z * h.z + h.x * h.x + h.y * h.y;
        a2 / (PI * t * t)
    }

    /// Smith's `Λ` for the direction `w` (local).
    #[inline]
    pub fn lambda(&self, w: Vec3) -> f32 {
        let c = w.z.abs();
        if c == 0.0 {
            return f32::INFINITY;
        }
        let a2 = self.alpha * self.alpha;
        0.5 * ((a2 + (1.0 - a2) * c * c).sqrt() / c - 1.0)
    }

    /// `G₁(w) = 1/(1 + Λ(w))`.
    #[inline]
    pub fn g1(&self, w: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(w))
    }

    /// Height-correlated `G₂(wo, wi) = 1/(1 + Λ(wo) + Λ(wi))`.
    #[inline]
    pub fn g2(&self, wo: Vec3, wi: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(wo) + self.lambda(wi))
    }

    /// Appendix B's visibility `V = G₂ / (4 |cos θo| |cos θi|)` for the two cosines.
    #[inline]
    pub fn visibility(&self, cos_o: f32, cos_i: f32) -> f32 {
        let (co, ci) = (cos_o.abs(), cos_i.abs());
        let a2 = self.alpha * self.alpha;
        let denom = co * (a2 + (1.0 - a2) * ci * ci).sqrt() + ci * (a2 + (1.0 - a2) * co * co).sqrt();
        if denom > 0.0 { 0.5 / denom } else { 0.0 }
    }

    /// A microfacet normal drawn from the visible normals `D_o` of `wo` (local, `wo.z > 0`).
    #[inline]
    pub fn sample_visible(&self, wo: Vec3, u: Vec2) -> Vec3 {
        let a = self.alpha;
        // Stretch to the hemisphere configuration, where visible normals are the points of a
        // spherical cap around wo shifted by wo.
        let w = Vec3::new(a * wo.x, a * wo.y, wo.z).normalize();
        let phi = 2.0 * PI * u.x;
        let z = (1.0 - u.y) * (1.0 + w.z) - w.z;
        let sin_theta = (1.0 - z * z).clamp(0.0, 1.0).sqrt();
        let (s, c) = phi.sin_cos();
        let hs = Vec3::new(sin_theta * c, sin_theta * s, z) + w;
        // Unstretch.
        let h = Vec3::new(a * hs.x, a * hs.y, hs.z.max(0.0)).normalize_or_zero();
        if h == Vec3::ZERO { Vec3::Z } else { h }
    }

    /// The density of [`Ggx::sample_visible`]: `D_o(h) = G₁(o) max(0, o·h) D(h) / cos θo`,
    /// per steradian of `h`.
    #[inline]
    pub fn visible_pdf(&self, wo: Vec3, h: Vec3) -> f32 {
        if wo.z <= 0.0 {
            return 0.0;
        }
        self.g1(wo) * wo.dot(h).max(0.0) * self.d(h) / wo.z
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::chi2::{Chi2Test, sidak};

    #[test]
    fn distribution_is_normalised_and_visibility_is_g2() {
        for r in [0.1f32, 0.5, 1.0] {
            let g = Ggx::from_roughness(r);
            // ∫ D(h) cos θh dω = 1; with x = cos²θ, cos θ dω = π dx (D is radially symmetric).
            let mut d = |x: f64| {
                let h = Vec3::new((1.0 - x as f32).max(0.0).sqrt(), 0.0, (x as f32).sqrt());
                g.d(h) as f64 * std::f64::consts::PI
            };
            let sum = crate::sampling::quadrature::adaptive_simpson(&mut d, 0.0, 1.0, 1e-9, 40);
            assert!((sum - 1.0).abs() < 2e-3, "r = {r}: ∫ D cos = {sum}");
            for (co, ci) in [(0.9f32, 0.2f32), (0.1, 0.7), (1.0, 1.0)] {
                let wo = Vec3::new((1.0 - co * co).sqrt(), 0.0, co);
                let wi = Vec3::new(0.0, (1.0 - ci * ci).sqrt(), ci);
                let v = g.visibility(co, ci);
                let from_g2 = g.g2(wo, wi) / (4.0 * co * ci);
                assert!((v - from_g2).abs() <= 1e-5 * v, "r = {r}: {v} vs {from_g2}");
            }
        }
    }

    #[test]
    fn visible_normals_pass_chi2() {
        let cases = [(0.1f32, 0.9f32), (0.3, 0.5), (0.7, 0.1), (1.0, 0.95)];
        for (r, cos_o) in cases {
            let g = Ggx::from_roughness(r);
            let wo = Vec3::new((1.0 - cos_o * cos_o).sqrt(), 0.0, cos_o);
            let res = Chi2Test::default().run(|_, u| Some(g.sample_visible(wo, u)), |h| g.visible_pdf(wo, h) as f64);
            assert!(res.passes(sidak(0.01, cases.len())), "r = {r}, cos θo = {cos_o}: {res}");
        }
    }
}
