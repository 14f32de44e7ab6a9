//! The lecture's normalised Blinn–Phong highlight as a BRDF lobe, sampled by its own
//! half-vector distribution.
//!
//! ```text
//! f      = k_s K(n) (n·h)ⁿ,  h = (o + i)/|o + i|     (crate::optics: K(n) makes the albedo ≤ 1)
//! p(h)   = (n + 1)/(2π) cosⁿθh                      (cos θh = u₁^(1/(n+1)), φ = 2π u₂)
//! p(i)   = p(h) / (4 o·h)                            (i = 2(o·h)h − o)
//! ```
//!
//! Half vectors facing away from `o`, or reflecting below the horizon, give no sample; the
//! density lost there is missing from `pdf` too.

use std::f32::consts::PI;

use super::{LobeFlags, LobeSample, PassClass};
use crate::math::{Vec2, Vec3};
use crate::optics;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlinnPhong {
    pub ks: Vec3,
    pub exponent: f32,
}

impl BlinnPhong {
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        let h = (wo + wi).normalize();
        self.ks * optics::blinn_phong(h.z, self.exponent)
    }

    #[inline]
    fn half_vector_pdf(&self, h: Vec3) -> f32 {
        if h.z <= 0.0 { 0.0 } else { (self.exponent + 1.0) / (2.0 * PI) * h.z.powf(self.exponent) }
    }

    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let h = (wo + wi).normalize();
        self.half_vector_pdf(h) / (4.0 * wo.dot(h))
    }

    pub fn sample(&self, wo: Vec3, u: Vec2) -> Option<LobeSample> {
        let cos_h = u.x.powf(1.0 / (self.exponent + 1.0));
        let sin_h = (1.0 - cos_h * cos_h).max(0.0).sqrt();
        let (s, c) = (2.0 * PI * u.y).sin_cos();
        let h = Vec3::new(sin_h * c, sin_h * s, cos_h);
        let c = wo.dot(h);
        if wo.z <= 0.0 || c <= 0.0 {
            return None;
        }
        let wi = 2.0 * c * h - wo;
        if wi.z <= 0.0 {
            return None;
        }
        let pdf = self.pdf(wo, wi);
        (pdf > 0.0).then(|| LobeSample { wi, f: self.eval(wo, wi), pdf, specular: false, eta: 1.0 })
    }
}

pub(super) const FLAGS: LobeFlags = LobeFlags::GLOSSY.union(LobeFlags::REFLECTION);
pub(super) const CLASS: PassClass = PassClass::Glossy;
