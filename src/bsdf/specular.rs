//! The lecture's perfectly specular lobes: Whitted's ideal mirror and his dielectric with the
//! exact Fresnel equations ([`crate::optics`]).
//!
//! ```text
//! mirror        i = (−o_x, −o_y, o_z),  weight k_r
//! dielectric    R = Fresnel(cos θo, η_i, η_t) (1 under total internal reflection)
//!               reflection: the mirror direction, weight k_t R, chosen with probability R
//!               refraction: Snell's direction,     weight k_t (1 − R)/η², probability 1 − R
//! ```
//!
//! `η = η_t/η_i`; the `1/η²` is radiance's (see [`super::glass`]): Whitted's tracer weights
//! the refracted ray by `k_t (1 − R)` and the two differ only for paths that start or end
//! inside a medium. A delta lobe has no value at any given pair of directions: `f` and `pdf`
//! of its samples are the weight's `f |cos θi| / pdf` and the discrete probability.

use super::{LobeFlags, LobeSample};
use crate::math::Vec3;
use crate::optics;

/// Whitted's ideal mirror of reflectance `k_r`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mirror {
    pub kr: Vec3,
}

impl Mirror {
    pub fn sample(&self, wo: Vec3) -> Option<LobeSample> {
        (wo.z > 0.0).then(|| LobeSample {
            wi: Vec3::new(-wo.x, -wo.y, wo.z),
            f: self.kr / wo.z,
            pdf: 1.0,
            specular: true,
            eta: 1.0,
        })
    }
}

/// Whitted's dielectric of weight `k_t` between media of indices `eta_i` (the side of `wo`)
/// and `eta_t`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SmoothDielectric {
    pub kt: Vec3,
    pub eta_i: f32,
    pub eta_t: f32,
}

impl SmoothDielectric {
    /// The Fresnel reflectance at `cos θo`, as the Whitted integrator computes it.
    #[inline]
    pub fn reflectance(&self, cos_o: f32) -> f32 {
        optics::fresnel_dielectric(cos_o, self.eta_i, self.eta_t)
    }

    pub fn sample(&self, wo: Vec3, uc: f32) -> Option<LobeSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let r = self.reflectance(wo.z);
        if uc < r {
            let wi = Vec3::new(-wo.x, -wo.y, wo.z);
            return Some(LobeSample { wi, f: self.kt * (r / wo.z), pdf: r, specular: true, eta: 1.0 });
        }
        let eta = self.eta_t / self.eta_i;
        let wi = optics::refract(-wo, Vec3::Z, self.eta_i / self.eta_t)?.normalize();
        let f = self.kt * ((1.0 - r) / (eta * eta * wi.z.abs()));
        Some(LobeSample { wi, f, pdf: 1.0 - r, specular: true, eta })
    }
}

pub(super) const MIRROR_FLAGS: LobeFlags = LobeFlags::SPECULAR.union(LobeFlags::REFLECTION);
pub(super) const DIELECTRIC_FLAGS: LobeFlags =
    LobeFlags::SPECULAR.union(LobeFlags::REFLECTION).union(LobeFlags::TRANSMISSION);
