//! A rough (or smooth) dielectric interface: GGX reflection and refraction after Walter et al.
//! ("Microfacet Models for Refraction through Rough Surfaces", EGSR 2007), in pbrt-v4's form,
//! with a reciprocal multiple-scattering compensation. glTF's `KHR_materials_transmission` with
//! `KHR_materials_ior`.
//!
//! With `wo` above the surface, `η = η_below/η_above` and `F = F(o·h)` Schlick's Fresnel on the
//! less dense side ([`super::fresnel::schlick_dielectric`], 1 under total internal reflection):
//!
//! ```text
//! reflection    h = (o + i)/|o + i|       f_R = w_R F D(h) G₂ / (4 |cos θo| |cos θi|)
//! refraction    h = ±(o + η i)/|o + η i|  f_T = w_T (1 − F) D(h) G₂ |i·h| |o·h|
//!                                               / (|cos θo| |cos θi| (η i·h + o·h)²)
//! ```
//!
//! `f_T` carries radiance, so it includes the `1/η²` of pbrt-v4's `TransportMode::Radiance`:
//! radiance entering a denser medium is compressed into a smaller solid angle. A path that
//! enters and leaves an object picks up `1/η²` and `η²`, which cancel. Generalised reciprocity
//! then reads `f(o, i)/η_o² = f(i, o)/η_i²`, and a white furnace is in equilibrium when the
//! radiance inside the medium is `η²` times that outside (`L/η²` is invariant): in those units
//! ("energy") the lobe's albedo is `∫ f_R |cos θi| + ∫ f_T (η_i/η_o)² |cos θi|`.
//!
//! **Multiple scattering.** Single scattering keeps the fraction `E_a(μo)` of the energy
//! arriving from above and `E_b(μo)` from below ([`super::albedo::glass`]). The rest returns as
//! two diffuse-shaped lobes, written with the symmetric kernel `s = f/η_o²`:
//!
//! ```text
//! s_aa = c_aa (1 − E_a(μo)) (1 − E_a(μi))      reflection above
//! s_ab = c_ab (1 − E_a(μo)) (1 − E_b(μi))      transmission (the same c_ab both ways: reciprocal)
//! P_a = π (1 − Ē_a) η_a²,   P_b = π (1 − Ē_b) η_b²
//! c_ab = 1 / max(P_a, P_b),   c_aa = (1 − c_ab P_b) / P_a
//! ```
//!
//! so that from above `c_aa P_a + c_ab P_b = 1` (the lost `1 − E_a(μo)` is returned in full),
//! and likewise from below; the side with the larger `P` transmits all its lost energy. These
//! lobes are reciprocal and keep the furnace within the tables' accuracy at every roughness.
//!
//! Sampling: visible normals of `wo`, then reflection with probability
//! `F w̄_R / (F w̄_R + (1 − F) w̄_T)`; or, with probability `1 − E_a(μo)`, a cosine direction on
//! either side, in proportion to `c_aa P_a : c_ab P_b` (that probability at least 5 %, which keeps
//! the weights of these lobes bounded). Below [`super::ggx::SMOOTH_ALPHA`], or
//! when `η` is 1 (nothing refracts), the interface is smooth: two delta directions.

use std::f32::consts::FRAC_1_PI;

use super::albedo::{self, GlassAlbedo};
use super::fresnel::schlick_dielectric;
use super::ggx::Ggx;
use super::{LobeFlags, LobeSample};
use crate::math::{Vec2, Vec3};
use crate::optics;
use crate::sampling::square_to_cosine_hemisphere;

/// The least probability of sampling the multiple-scattering lobes (see `Glass::ms_probability`).
const MS_MIN_PROBABILITY: f32 = 0.05;

/// Refraction of `wo` (pointing away) through a microfacet `h` on its side, for
/// `eta = η_other/η_this`; `None` under total internal reflection.
#[inline]
pub fn refract(wo: Vec3, h: Vec3, eta: f32) -> Option<Vec3> {
    optics::refract(-wo, h, 1.0 / eta).map(|t| t.normalize())
}

/// `F G₂ + (1 − F) G₂` of the reflected and refracted directions at microfacet `h` (the weights
/// `f |cos θi| / D_o(h)·G₁(o)` of visible-normal samples, in energy units), with `F₀` from `η`:
/// what the quadrature of [`albedo::glass`]'s tables integrates (compiled for the tests,
/// which compute those tables).
#[cfg(test)]
pub fn single_scattering_weight(ggx: Ggx, eta: f32, wo: Vec3, h: Vec3) -> f32 {
    let c = wo.dot(h);
    if c <= 0.0 {
        return 0.0;
    }
    let f = schlick_dielectric(super::fresnel::f0_from_ior(eta), 1.0, c, eta);
    let mut w = 0.0;
    let wr = 2.0 * c * h - wo;
    if wr.z > 0.0 {
        w += f * ggx.g2(wo, wr);
    }
    if let Some(wt) = refract(wo, h, eta).filter(|t| t.z < 0.0) {
        w += (1.0 - f) * ggx.g2(wo, wt);
    }
    w
}

/// The compensation's tables and coefficients (module docs).
#[derive(Clone, Copy, Debug)]
struct MultipleScattering {
    above: GlassAlbedo,
    below: GlassAlbedo,
    c_r: f32,
    c_t: f32,
    /// `c_aa P_a`: the share of the lost energy returned by reflection.
    share_r: f32,
}

/// The interface (module docs).
#[derive(Clone, Copy, Debug)]
pub struct Glass {
    reflect_weight: Vec3,
    tint: Vec3,
    ggx: Ggx,
    roughness: f32,
    eta: f32,
    f0: f32,
    f90: f32,
    smooth: bool,
    ms: Option<MultipleScattering>,
}

impl Glass {
    /// An interface of glTF roughness `roughness` into a medium of relative index `eta`
    /// (below/above), Schlick parameters `f0`, `f90`, reflection weighted by `reflect_weight`
    /// and transmission by `tint`.
    pub fn new(
        reflect_weight: Vec3,
        tint: Vec3,
        roughness: f32,
        eta: f32,
        f0: f32,
        f90: f32,
        compensate: bool,
    ) -> Self {
        let roughness = roughness.clamp(0.0, 1.0);
        let ggx = Ggx::from_roughness(roughness);
        let smooth = ggx.is_smooth() || (eta - 1.0).abs() < 1e-3;
        let mut ms = None;
        if compensate && !smooth {
            let (above, below) = (albedo::glass(eta), albedo::glass(1.0 / eta));
            let p_a = std::f32::consts::PI * (1.0 - above.average(roughness));
            let p_b = std::f32::consts::PI * (1.0 - below.average(roughness)) * eta * eta;
            if p_a.max(p_b) > 1e-6 {
                let c_t = 1.0 / p_a.max(p_b);
                let c_r = if p_a > 1e-7 { ((1.0 - c_t * p_b) / p_a).max(0.0) } else { 0.0 };
                ms = Some(MultipleScattering { above, below, c_r, c_t, share_r: c_r * p_a });
            }
        }
        Glass { reflect_weight, tint, ggx, roughness, eta, f0, f90, smooth, ms }
    }

    pub fn flags(&self) -> LobeFlags {
        let kind = if self.smooth { LobeFlags::SPECULAR } else { LobeFlags::GLOSSY };
        kind.union(LobeFlags::REFLECTION).union(LobeFlags::TRANSMISSION)
    }

    pub fn reflect_weight(&self) -> Vec3 {
        self.reflect_weight
    }

    pub fn tint(&self) -> Vec3 {
        self.tint
    }

    #[inline]
    fn fresnel(&self, cos: f32) -> f32 {
        schlick_dielectric(self.f0, self.f90, cos, self.eta)
    }

    /// The probability of reflection at Fresnel `f`.
    #[inline]
    fn reflect_probability(&self, f: f32) -> f32 {
        let (r, t) = (f * self.reflect_weight.element_sum(), (1.0 - f) * self.tint.element_sum());
        if r + t > 0.0 { r / (r + t) } else { 0.0 }
    }

    /// The generalised half vector of a refraction `wo → wi` (pointing above), if the pair is a
    /// refraction through a front-facing microfacet.
    #[inline]
    fn refraction_half_vector(&self, wo: Vec3, wi: Vec3) -> Option<Vec3> {
        let h = (wo + self.eta * wi).normalize_or_zero();
        let h = if h.z < 0.0 { -h } else { h };
        (h != Vec3::ZERO && wo.dot(h) > 0.0 && wi.dot(h) < 0.0).then_some(h)
    }

    /// The probability of sampling the multiple-scattering lobes at `μo`: their share of the
    /// energy, but at least [`MS_MIN_PROBABILITY`]. Their shape `1 − E(μi)` is far from the
    /// cosine they are sampled by when `Ē` is close to 1 (smooth glass loses energy only at
    /// grazing angles): sampled in proportion to their tiny share, their weights reach
    /// `(1 − E(μi))/(1 − Ē)` (hundreds), rare fireflies; the floor bounds them by a few units.
    #[inline]
    fn ms_probability(&self, mu_o: f32) -> f32 {
        self.ms.map_or(0.0, |m| (1.0 - m.above.lookup(mu_o, self.roughness)).clamp(MS_MIN_PROBABILITY, 1.0))
    }

    /// `f` (local, `wo` above; reflection when `wi` is above too).
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wo.z <= 0.0 || wi.z == 0.0 || self.smooth {
            return Vec3::ZERO;
        }
        let mut f = Vec3::ZERO;
        if wi.z > 0.0 {
            let h = (wo + wi).normalize();
            let fr = self.fresnel(wo.dot(h));
            let d_g = self.ggx.d(h) * self.ggx.g2(wo, wi) / (4.0 * wo.z * wi.z);
            f += self.reflect_weight * (fr * d_g);
            if let Some(m) = self.ms {
                let e = (1.0 - m.above.lookup(wo.z, self.roughness)) * (1.0 - m.above.lookup(wi.z, self.roughness));
                f += self.reflect_weight * (m.c_r * e);
            }
        } else {
            if let Some(h) = self.refraction_half_vector(wo, wi) {
                let (ci, co) = (wi.dot(h), wo.dot(h));
                let ft = 1.0 - self.fresnel(co);
                let denom = self.eta * ci + co;
                let v = self.ggx.d(h) * self.ggx.g2(wo, wi) * (ci * co).abs() / (wo.z * wi.z.abs() * denom * denom);
                f += self.tint * (ft * v);
            }
            if let Some(m) = self.ms {
                let e = (1.0 - m.above.lookup(wo.z, self.roughness)) * (1.0 - m.below.lookup(-wi.z, self.roughness));
                f += self.tint * (m.c_t * e);
            }
        }
        f
    }

    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z == 0.0 || self.smooth {
            return 0.0;
        }
        let p_ms = self.ms_probability(wo.z);
        let share_r = self.ms.map_or(0.0, |m| m.share_r);
        if wi.z > 0.0 {
            let h = (wo + wi).normalize();
            let pr = self.reflect_probability(self.fresnel(wo.dot(h)));
            let p_ss = self.ggx.visible_pdf(wo, h) / (4.0 * wo.dot(h)) * pr;
            (1.0 - p_ms) * p_ss + p_ms * share_r * wi.z * FRAC_1_PI
        } else {
            let p_ss = self.refraction_half_vector(wo, wi).map_or(0.0, |h| {
                let (ci, co) = (wi.dot(h), wo.dot(h));
                let pt = 1.0 - self.reflect_probability(self.fresnel(co));
                let denom = ci + co / self.eta;
                self.ggx.visible_pdf(wo, h) * ci.abs() / (denom * denom) * pt
            });
            (1.0 - p_ms) * p_ss + p_ms * (1.0 - share_r) * (-wi.z) * FRAC_1_PI
        }
    }

    pub fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<LobeSample> {
        if wo.z <= 0.0 {
            return None;
        }
        if self.smooth {
            return self.sample_smooth(wo, uc);
        }
        let p_ms = self.ms_probability(wo.z);
        let wi = if uc < p_ms {
            let share_r = self.ms.map_or(0.0, |m| m.share_r);
            let w = square_to_cosine_hemisphere(u);
            if uc < p_ms * share_r { w } else { Vec3::new(w.x, w.y, -w.z) }
        } else {
            let uc = (uc - p_ms) / (1.0 - p_ms);
            let h = self.ggx.sample_visible(wo, u);
            let c = wo.dot(h);
            if c <= 0.0 {
                return None;
            }
            // A reflection below the surface, or a refraction above it, is no sample: its
            // direction belongs to the other half of the lobe, whose density it does not have.
            if uc < self.reflect_probability(self.fresnel(c)) {
                Some(2.0 * c * h - wo).filter(|w| w.z > 0.0)?
            } else {
                refract(wo, h, self.eta).filter(|w| w.z < 0.0)?
            }
        };
        if wi.z == 0.0 {
            return None;
        }
        let pdf = self.pdf(wo, wi);
        let eta = if wi.z < 0.0 { self.eta } else { 1.0 };
        (pdf > 0.0).then(|| LobeSample { wi, f: self.eval(wo, wi), pdf, specular: false, eta })
    }

    /// The smooth interface: mirror with probability `F w̄_R / (F w̄_R + (1 − F) w̄_T)`,
    /// otherwise Snell's direction.
    fn sample_smooth(&self, wo: Vec3, uc: f32) -> Option<LobeSample> {
        let f = self.fresnel(wo.z);
        let pr = self.reflect_probability(f);
        if uc < pr {
            let wi = Vec3::new(-wo.x, -wo.y, wo.z);
            return Some(LobeSample { wi, f: self.reflect_weight * (f / wo.z), pdf: pr, specular: true, eta: 1.0 });
        }
        let wi = refract(wo, Vec3::Z, self.eta)?;
        let f = self.tint * ((1.0 - f) / (self.eta * self.eta * wi.z.abs()));
        Some(LobeSample { wi, f, pdf: 1.0 - pr, specular: true, eta: self.eta })
    }

    /// The albedo from `μ` in energy units (module docs): `w_R R + w_T T`, `R`, `T` estimated
    /// by Schlick's `F(μ)` (compensated lobes return what single scattering loses).
    pub fn albedo(&self, mu: f32) -> Vec3 {
        let f = self.fresnel(mu);
        self.reflect_weight * f + self.tint * (1.0 - f)
    }
}
