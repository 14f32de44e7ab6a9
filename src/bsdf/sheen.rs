//! The sheen of `KHR_materials_sheen`: Estevez and Kulla's "Charlie" distribution and
//! visibility ("Production Friendly Microfacet Sheen BRDF", Imageworks 2017), as the
//! extension's implementation notes give them, cosine-sampled.
//!
//! ```text
//! α = r²  (r the sheen roughness, at least SHEEN_MIN_ROUGHNESS)
//! D(h)    = (2 + 1/α) sin(θh)^(1/α) / (2π)
//! l(x)    = a/(1 + b x^c) + d x + e,   a … e interpolated in (1 − α)² between the fits
//! Λ(μ)    = exp(l(μ))  for μ < 1/2,    exp(2 l(1/2) − l(1 − μ))  otherwise
//! f       = C D(h) / ((1 + Λ(μo) + Λ(μi)) 4 μo μi)
//! ```
//!
//! The lobe is layered over the rest of the material by the extension's albedo scaling
//! `min(1 − max(C) E(μo), 1 − max(C) E(μi))` with its albedo `E` from [`super::albedo::sheen`]
//! (reciprocal, energy-conserving; see [`super::Bsdf`]).

use std::f32::consts::PI;

use super::albedo;
use super::{LobeFlags, PassClass};
use crate::math::Vec3;

/// The smallest sheen roughness used: below it `sin(θh)^(1/α)` (exponent > 200) puts every
/// microfacet at grazing and the fits of `Λ` leave the range they were made for.
pub const SHEEN_MIN_ROUGHNESS: f32 = 0.07;

/// A sheen lobe of colour `C` and roughness `r`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sheen {
    pub color: Vec3,
    roughness: f32,
    alpha: f32,
}

#[inline]
fn mix(a: f32, b: f32, t: f32) -> f32 {
    a + (b - a) * t
}

impl Sheen {
    pub fn new(color: Vec3, roughness: f32) -> Self {
        let roughness = roughness.clamp(SHEEN_MIN_ROUGHNESS, 1.0);
        Sheen { color, roughness, alpha: roughness * roughness }
    }

    #[inline]
    fn l(&self, x: f32) -> f32 {
        let t = (1.0 - self.alpha) * (1.0 - self.alpha);
        let a = mix(21.5473, 25.3245, t);
        let b = mix(3.82987, 3.32435, t);
        let c = mix(0.19823, 0.16801, t);
        let d = mix(-1.97760, -1.27393, t);
        let e = mix(-4.32054, -4.85967, t);
        a / (1.0 + b * x.powf(c)) + d * x + e
    }

    #[inline]
    fn lambda(&self, mu: f32) -> f32 {
        let mu = mu.abs();
        if mu < 0.5 { self.l(mu).exp() } else { (2.0 * self.l(0.5) - self.l(1.0 - mu)).exp() }
    }

    /// `D V` without the colour (local, both directions above).
    #[inline]
    pub fn value(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let h = (wo + wi).normalize();
        let inv = 1.0 / self.alpha;
        let sin2 = h.x * h.x + h.y * h.y;
        let d = (2.0 + inv) * sin2.powf(0.5 * inv) / (2.0 * PI);
        let v = 1.0 / ((1.0 + self.lambda(wo.z) + self.lambda(wi.z)) * 4.0 * wo.z * wi.z);
        d * v
    }

    /// `E(μ)` of the uncoloured lobe.
    #[inline]
    pub fn white_albedo(&self, mu: f32) -> f32 {
        albedo::sheen().lookup(mu, self.roughness)
    }

    /// `C E(μ)`.
    #[inline]
    pub fn albedo(&self, mu: f32) -> Vec3 {
        self.color * self.white_albedo(mu)
    }
}

pub(super) const FLAGS: LobeFlags = LobeFlags::DIFFUSE.union(LobeFlags::REFLECTION);
/// Cycles counts its sheen closure among the diffuse ones (its passes follow).
pub(super) const CLASS: PassClass = PassClass::Diffuse;
