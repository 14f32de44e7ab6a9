//! strahl's Whitted materials as BSDF lobes, so that the path tracer renders the lecture
//! scenes with the optics the Whitted integrator uses ([`crate::optics`]):
//!
//! ```text
//! f = ρ/π                                  Lambert (ρ = SurfacePoint::albedo)
//!   + k_s K(n) (n·h)ⁿ                      normalised Blinn–Phong, sampled by (n·h)ⁿ
//!   + k_r δ(mirror)                        ideal mirror
//!   + k_t [R δ(mirror) + (1 − R) δ(Snell)] dielectric, exact Fresnel R
//! ```
//!
//! The dielectric's refraction carries radiance's `1/η²` ([`super::specular`]). The energy is
//! the material's: `ρ + k_s + k_r + k_t ≤ 1` per channel reflects at most what arrives
//! ([`crate::material::Material`]).

use super::{Bsdf, Lobe, blinn_phong, lambert, specular};
use crate::math::Vec3;

/// A Whitted material's numbers at one hit (the diffuse texture already applied).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LectureParams {
    /// Diffuse albedo ρ.
    pub albedo: Vec3,
    /// Blinn–Phong weight `k_s`.
    pub specular: Vec3,
    /// Blinn–Phong exponent `n` (≥ 0).
    pub shininess: f32,
    /// Mirror reflectance `k_r`.
    pub mirror: Vec3,
    /// Dielectric weight `k_t` (zero for an opaque material).
    pub transmission: Vec3,
    /// Index of refraction of the inside; the outside is vacuum.
    pub ior: f32,
}

/// Adds the lecture material's lobes to `b`, an empty BSDF ([`Bsdf::new`]: its frame around the
/// shading normal and its geometric normal facing `wo`, and whether the surface was hit from
/// outside), filled in place ([`crate::shading::shade_at`] says why).
pub fn lecture(b: &mut Bsdf, p: &LectureParams) {
    let front_face = b.front_face();
    if p.albedo != Vec3::ZERO {
        b.push(Lobe::Lambert(lambert::Lambert { color: p.albedo }));
    }
    if p.specular != Vec3::ZERO {
        b.push(Lobe::BlinnPhong(blinn_phong::BlinnPhong { ks: p.specular, exponent: p.shininess.max(0.0) }));
    }
    if p.mirror != Vec3::ZERO {
        b.push(Lobe::Mirror(specular::Mirror { kr: p.mirror }));
    }
    if p.transmission != Vec3::ZERO {
        let (eta_i, eta_t) = if front_face { (1.0, p.ior) } else { (p.ior, 1.0) };
        b.push(Lobe::SmoothDielectric(specular::SmoothDielectric { kt: p.transmission, eta_i, eta_t }));
    }
}
