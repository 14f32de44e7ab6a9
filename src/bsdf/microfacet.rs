//! GGX microfacet reflection with Schlick's Fresnel, as glTF's Appendix B defines its metal and
//! its dielectric's specular layer, with Kulla and Conty's multiple-scattering compensation
//! ("Revisiting Physically Based Shading at Imageworks", SIGGRAPH 2017 course).
//!
//! ```text
//! f_ss  = F(o·h) D(h) V(o, i)                              (Appendix B, ggx.rs)
//! f_ms  = F_ms (1 − E(μo)) (1 − E(μi)) / (π (1 − Ē))       (Kulla–Conty)
//! F_ms  = F̄² Ē / (1 − F̄ (1 − Ē))                           (F̄ = F₀ + (F₉₀ − F₀)/21)
//! f     = w (f_ss + f_ms)
//! ```
//!
//! `E(μ)` is the single-scattering albedo with `F = 1` and `Ē` its average ([`super::albedo`]).
//! `f_ms` returns the energy that single scattering loses (the light that bounces more than
//! once between microfacets), reciprocally: with `F = 1` the lobe reflects exactly
//! `E(μo) + (1 − E(μo)) = 1`; with a coloured `F` each further bounce is tinted by `F̄`, which
//! `F_ms` sums (a geometric series). The lobe's albedo is
//! `E_s(μ) = F₀ A(μ) + F₉₀ B(μ) + F_ms (1 − E(μ))`.
//!
//! Sampling: visible normals ([`Ggx::sample_visible`]) for `f_ss`, the cosine for `f_ms`, chosen
//! in proportion to their albedos at `μo`. Below [`super::ggx::SMOOTH_ALPHA`] the lobe is a
//! mirror: one direction, weight `w F(μo)`.

use std::f32::consts::FRAC_1_PI;

use super::albedo;
use super::fresnel::{schlick, schlick_average};
use super::ggx::Ggx;
use super::{Frame, LobeFlags, LobeSample, PassClass};
use crate::math::{Vec2, Vec3};
use crate::sampling::{cosine_hemisphere_pdf, square_to_cosine_hemisphere};

/// A GGX reflection layer without its colour weight: the Fresnel parameters, the roughness and
/// the multiple-scattering term.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GgxReflection {
    ggx: Ggx,
    roughness: f32,
    f0: Vec3,
    f90: Vec3,
    /// `F_ms / (π (1 − Ē))` per channel; zero when smooth or uncompensated.
    ms: Vec3,
}

impl GgxReflection {
    /// A layer of glTF roughness `roughness` (`α = roughness²`) and Schlick parameters `f0`,
    /// `f90`; `compensate` adds the multiple-scattering term.
    pub fn new(roughness: f32, f0: Vec3, f90: Vec3, compensate: bool) -> Self {
        let roughness = roughness.clamp(0.0, 1.0);
        let ggx = Ggx::from_roughness(roughness);
        let mut ms = Vec3::ZERO;
        if compensate && !ggx.is_smooth() {
            let t = albedo::ggx();
            let e_avg = t.a.average(roughness) + t.b.average(roughness);
            if 1.0 - e_avg > 1e-6 {
                let f_avg = schlick_average(f0, f90);
                let f_ms = f_avg * f_avg * e_avg / (Vec3::ONE - f_avg * (1.0 - e_avg));
                ms = f_ms * FRAC_1_PI / (1.0 - e_avg);
            }
        }
        GgxReflection { ggx, roughness, f0, f90, ms }
    }

    /// `wa·a + wb·b`: the layer whose every term is the weighted sum of the two layers' (which
    /// must have the same roughness). `f_ss` and `f_ms` are linear in `F₀`, `F₉₀` and `F_ms`.
    pub fn mix(a: &GgxReflection, wa: f32, b: &GgxReflection, wb: f32) -> Self {
        GgxReflection {
            ggx: a.ggx,
            roughness: a.roughness,
            f0: wa * a.f0 + wb * b.f0,
            f90: wa * a.f90 + wb * b.f90,
            ms: wa * a.ms + wb * b.ms,
        }
    }

    pub fn is_smooth(&self) -> bool {
        self.ggx.is_smooth()
    }

    /// Whether the layer reflects nothing.
    pub fn is_black(&self) -> bool {
        self.f0 == Vec3::ZERO && self.f90 == Vec3::ZERO && self.ms == Vec3::ZERO
    }

    /// `E(μ)` with `F = 1` (single scattering).
    #[inline]
    fn e1(&self, mu: f32) -> f32 {
        let t = albedo::ggx();
        t.a.lookup(mu, self.roughness) + t.b.lookup(mu, self.roughness)
    }

    /// Single- and multiple-scattering albedo at `μ`.
    #[inline]
    fn albedos(&self, mu: f32) -> (Vec3, Vec3) {
        if self.is_smooth() {
            return (schlick(self.f0, self.f90, mu), Vec3::ZERO);
        }
        let t = albedo::ggx();
        let (a, b) = (t.a.lookup(mu, self.roughness), t.b.lookup(mu, self.roughness));
        let ms_albedo = self.ms * std::f32::consts::PI * (1.0 - self.e1_avg()) * (1.0 - (a + b));
        (self.f0 * a + self.f90 * b, ms_albedo)
    }

    #[inline]
    fn e1_avg(&self) -> f32 {
        let t = albedo::ggx();
        t.a.average(self.roughness) + t.b.average(self.roughness)
    }

    /// The directional albedo `E_s(μ)` (module docs).
    #[inline]
    pub fn albedo(&self, mu: f32) -> Vec3 {
        let (ss, ms) = self.albedos(mu);
        ss + ms
    }

    /// The hemispherical average `Ē_s`, exactly that of [`GgxReflection::albedo`]'s interpolant.
    pub fn average_albedo(&self) -> Vec3 {
        if self.is_smooth() {
            return schlick_average(self.f0, self.f90);
        }
        let t = albedo::ggx();
        let e_avg = self.e1_avg();
        let ms_avg = self.ms * std::f32::consts::PI * (1.0 - e_avg) * (1.0 - e_avg);
        self.f0 * t.a.average(self.roughness) + self.f90 * t.b.average(self.roughness) + ms_avg
    }

    /// `f_ss + f_ms` (local, both directions above).
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wo.z <= 0.0 || wi.z <= 0.0 || self.is_smooth() {
            return Vec3::ZERO;
        }
        let h = (wo + wi).normalize();
        let ss = schlick(self.f0, self.f90, wo.dot(h)) * (self.ggx.d(h) * self.ggx.visibility(wo.z, wi.z));
        if self.ms == Vec3::ZERO {
            return ss;
        }
        ss + self.ms * ((1.0 - self.e1(wo.z)) * (1.0 - self.e1(wi.z)))
    }

    /// The probability of sampling the multiple-scattering part.
    #[inline]
    fn ms_probability(&self, mu_o: f32) -> f32 {
        if self.ms == Vec3::ZERO {
            return 0.0;
        }
        let (ss, ms) = self.albedos(mu_o);
        let (s, m) = (ss.element_sum(), ms.element_sum());
        if s + m > 0.0 { m / (s + m) } else { 0.0 }
    }

    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 || self.is_smooth() {
            return 0.0;
        }
        let p_ms = self.ms_probability(wo.z);
        let h = (wo + wi).normalize();
        let p_ss = self.ggx.visible_pdf(wo, h) / (4.0 * wo.dot(h));
        (1.0 - p_ms) * p_ss + p_ms * cosine_hemisphere_pdf(wi.z)
    }

    /// A direction for `wo`; `uc` chooses between the parts. `f` is this layer's value only.
    pub fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<LobeSample> {
        if wo.z <= 0.0 {
            return None;
        }
        if self.is_smooth() {
            let wi = Vec3::new(-wo.x, -wo.y, wo.z);
            let f = schlick(self.f0, self.f90, wo.z) / wo.z;
            return Some(LobeSample { wi, f, pdf: 1.0, specular: true, eta: 1.0 });
        }
        let wi = if uc < self.ms_probability(wo.z) {
            square_to_cosine_hemisphere(u)
        } else {
            let h = self.ggx.sample_visible(wo, u);
            2.0 * wo.dot(h) * h - wo
        };
        if wi.z <= 0.0 {
            return None;
        }
        let pdf = self.pdf(wo, wi);
        (pdf > 0.0).then(|| LobeSample { wi, f: self.eval(wo, wi), pdf, specular: false, eta: 1.0 })
    }
}

/// A weighted GGX reflection lobe: glTF's metal and dielectric specular (one lobe, their
/// Fresnel parameters mixed), or its clearcoat.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Microfacet {
    pub weight: Vec3,
    pub layer: GgxReflection,
}

impl Microfacet {
    pub fn flags(&self) -> LobeFlags {
        let kind = if self.layer.is_smooth() { LobeFlags::SPECULAR } else { LobeFlags::GLOSSY };
        kind.union(LobeFlags::REFLECTION)
    }
}

/// A [`Microfacet`] lobe about a normal of its own: glTF's clearcoat under its
/// `clearcoatNormalTexture`, or over a normal-mapped base, which the coat does not follow.
/// `frame` is the lobe's frame in the BSDF's local coordinates; the layer sees `wo` and `wi`
/// in it (`θ'` its angles). The integrator weights every lobe by `|cos θi|` about the BSDF's
/// shading normal, so this lobe's `f` is the layer's times `cos θi' / |cos θi|`: `f |cos θi|`
/// is then the layer's own `f cos θi'`, and the lobe reflects what the layer would about its
/// normal. Directions below that normal get nothing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tilted {
    pub lobe: Microfacet,
    pub frame: Frame,
}

impl Tilted {
    /// The lobe with the unit normal `n` given in the BSDF's local coordinates.
    pub fn new(lobe: Microfacet, n: Vec3) -> Self {
        Tilted { lobe, frame: Frame::from_normal(n) }
    }

    /// `cos θ'` of the local direction `w`.
    #[inline]
    pub fn mu(&self, w: Vec3) -> f32 {
        self.frame.n.dot(w)
    }

    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let (o, i) = (self.frame.to_local(wo), self.frame.to_local(wi));
        if wi.z == 0.0 {
            return Vec3::ZERO;
        }
        self.lobe.weight * self.lobe.layer.eval(o, i) * (i.z / wi.z.abs())
    }

    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.lobe.layer.pdf(self.frame.to_local(wo), self.frame.to_local(wi))
    }

    /// Out of line, as [`Tilted::albedo`].
    #[inline(never)]
    pub fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<LobeSample> {
        let s = self.lobe.layer.sample(self.frame.to_local(wo), uc, u)?;
        let wi = self.frame.to_world(s.wi);
        if wi.z == 0.0 {
            return None;
        }
        Some(LobeSample { wi, f: self.lobe.weight * s.f * (s.wi.z / wi.z.abs()), ..s })
    }

    /// The directional albedo from the local direction `w` (at `cos θ'`). Out of line: inlined
    /// into the loops over the lobes, it made every BSDF's lobe selection dearer.
    #[inline(never)]
    pub fn albedo(&self, w: Vec3) -> Vec3 {
        self.lobe.weight * self.lobe.layer.albedo(self.mu(w).max(0.0))
    }
}

pub(super) const CLASS: PassClass = PassClass::Glossy;
