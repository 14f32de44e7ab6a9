//! Lambertian reflection, alone (the lecture's `ρ/π`) or under a specular layer (glTF's
//! base), cosine-sampled.
//!
//! ```text
//! Lambert:          f = ρ/π
//! under a layer:    f = ρ/π · (1 − E_s(μo)) (1 − E_s(μi)) / (1 − Ē_s)
//! ```
//!
//! `E_s` is the directional albedo of the specular layer above ([`GgxReflection::albedo`]),
//! `Ē_s` its hemispherical average. This albedo scaling (Kelemen and Szirmay-Kalos 2001, the
//! form Kulla and Conty 2017 use for their multiple-scattering lobe) is reciprocal (symmetric in
//! `μo`, `μi`) and energy-preserving: since `∫ (1 − E_s(μi)) cos θi dωi / π = 1 − Ē_s`, the base
//! reflects exactly `ρ (1 − E_s(μo))`, what the layer lets through, so a white base under a
//! white-furnace-exact layer reflects exactly 1. It replaces Appendix B's `(1 − F(V·H))`
//! weight, which the specification's own sample implementation notes is neither
//! energy-conserving nor reciprocal.

use std::f32::consts::FRAC_1_PI;

use super::microfacet::GgxReflection;
use super::{LobeFlags, LobeSample, PassClass};
use crate::math::{Vec2, Vec3};
use crate::sampling::{cosine_hemisphere_pdf, square_to_cosine_hemisphere};

/// `f = ρ/π` above the surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lambert {
    pub color: Vec3,
}

/// The Lambertian base under a GGX layer, albedo-scaled (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LayeredDiffuse {
    color: Vec3,
    under: GgxReflection,
    /// `1/(1 − Ē_s)` per channel (0 where the layer reflects everything).
    inv_rest: Vec3,
}

impl LayeredDiffuse {
    pub fn new(color: Vec3, under: GgxReflection) -> Self {
        let rest = Vec3::ONE - under.average_albedo();
        let inv_rest = Vec3::select(rest.cmpgt(Vec3::splat(1e-6)), rest.recip(), Vec3::ZERO);
        LayeredDiffuse { color, under, inv_rest }
    }
}

/// Both lobes: a diffuse reflection with the colour `color · scale(μo, μi)`.
pub(super) trait Diffuse {
    fn factor(&self, mu_o: f32, mu_i: f32) -> Vec3;
    fn albedo_at(&self, mu: f32) -> Vec3;
    fn colour(&self) -> Vec3;
}

impl Diffuse for Lambert {
    #[inline]
    fn factor(&self, _: f32, _: f32) -> Vec3 {
        self.color * FRAC_1_PI
    }
    #[inline]
    fn albedo_at(&self, _: f32) -> Vec3 {
        self.color
    }
    fn colour(&self) -> Vec3 {
        self.color
    }
}

impl Diffuse for LayeredDiffuse {
    #[inline]
    fn factor(&self, mu_o: f32, mu_i: f32) -> Vec3 {
        let (eo, ei) = (self.under.albedo(mu_o), self.under.albedo(mu_i));
        self.color * FRAC_1_PI * (Vec3::ONE - eo) * (Vec3::ONE - ei) * self.inv_rest
    }
    #[inline]
    fn albedo_at(&self, mu: f32) -> Vec3 {
        // Exactly what the lobe integrates to (module docs), clamped against rounding.
        (self.color * (Vec3::ONE - self.under.albedo(mu))).max(Vec3::ZERO)
    }
    fn colour(&self) -> Vec3 {
        self.color
    }
}

/// The shared evaluation and cosine sampling of the two diffuse lobes.
pub(super) fn eval(l: &impl Diffuse, wo: Vec3, wi: Vec3) -> Vec3 {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return Vec3::ZERO;
    }
    l.factor(wo.z, wi.z)
}

pub(super) fn pdf(wo: Vec3, wi: Vec3) -> f32 {
    if wo.z <= 0.0 { 0.0 } else { cosine_hemisphere_pdf(wi.z) }
}

pub(super) fn sample(l: &impl Diffuse, wo: Vec3, u: Vec2) -> Option<LobeSample> {
    let wi = square_to_cosine_hemisphere(u);
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return None;
    }
    Some(LobeSample { wi, f: l.factor(wo.z, wi.z), pdf: cosine_hemisphere_pdf(wi.z), specular: false, eta: 1.0 })
}

pub(super) const FLAGS: LobeFlags = LobeFlags::DIFFUSE.union(LobeFlags::REFLECTION);
pub(super) const CLASS: PassClass = PassClass::Diffuse;
