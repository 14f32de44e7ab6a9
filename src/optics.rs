//! The optics of Whitted shading: Lambert's diffuse BRDF, the normalised Blinn–Phong lobe,
//! the mirror direction, Snell's law and the exact Fresnel equations for a dielectric.
//!
//! Conventions: directions are unit vectors; `n` is a unit normal on the side the light
//! arrives from (so `cos θi = −d·n > 0` for an incoming direction `d`); `eta_i`, `eta_t` are
//! the refractive indices of the incident and the transmitting medium.

use std::f32::consts::{FRAC_1_PI, PI};

use crate::math::Vec3;

/// Lambert's BRDF `ρ/π`: a surface of albedo `ρ` under irradiance `E` reflects radiance
/// `ρ/π · E`, and under uniform incident radiance `L` reflects `ρ·L`.
#[inline]
pub fn lambert(albedo: Vec3) -> Vec3 {
    albedo * FRAC_1_PI
}

/// The normalisation `K(n)` of the Blinn–Phong lobe `K(n)·(n·h)^n` that makes its
/// directional albedo `∫ K(n)·(n·h)^n cos θi dωi` exactly 1 for a viewer along the normal,
/// where it is largest, and less than 1 for every other view:
///
/// ```text
/// K(n) = (n + 2)(n + 4) / (8π (2^(−n/2) + n))
/// ```
///
/// (with `h = (wi + n)/|wi + n|`, `n·h = cos(θi/2)`, the integral is
/// `8π (n + 2^(−n/2)) / ((n+2)(n+4))`). `K(0) = 1/π`: a zero exponent is Lambert.
///
/// The popular `(n + 8)/(8π)` (Real-Time Rendering) approximates this but is not
/// energy-bounded: its albedo at normal view is `(n+8)(n + 2^(−n/2))/((n+2)(n+4))`, up to
/// 1.074 at `n ≈ 11` (see `tests/optics.rs`). strahl uses the exact form; for large `n` the
/// approximation over-reflects by about `2/n` (1.8 % at `n = 100`).
#[inline]
pub fn blinn_phong_normalization(exponent: f32) -> f32 {
    let n = exponent;
    (n + 2.0) * (n + 4.0) / (8.0 * PI * ((-0.5 * n).exp2() + n))
}

/// The normalised Blinn–Phong lobe `K(n)·(n·h)^n` for the cosine `n_dot_h` between the
/// normal and the half vector `h = (wi + wo)/|wi + wo|` (0 where `n·h ≤ 0`); a BRDF value,
/// per steradian.
#[inline]
pub fn blinn_phong(n_dot_h: f32, exponent: f32) -> f32 {
    if n_dot_h <= 0.0 {
        return 0.0;
    }
    blinn_phong_normalization(exponent) * n_dot_h.powf(exponent)
}

/// The mirror direction of incoming `d` about `n`: `r = d − 2(d·n)n`.
#[inline]
pub fn reflect(d: Vec3, n: Vec3) -> Vec3 {
    d - 2.0 * d.dot(n) * n
}

/// Snell's law `η_i sin θi = η_t sin θt`: `cos θt` for `cos θi` (in `[0, 1]`) and the ratio
/// `eta = η_i/η_t`, or `None` for total internal reflection (`sin θt > 1`).
#[inline]
pub fn snell_cos_t(cos_i: f32, eta: f32) -> Option<f32> {
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i).max(0.0);
    (sin2_t < 1.0).then(|| (1.0 - sin2_t).sqrt())
}

/// The refracted direction of incoming `d` through a surface with normal `n` on the incident
/// side, for `eta = η_i/η_t`: `t = η d + (η cos θi − cos θt) n`; `None` on total internal
/// reflection.
#[inline]
pub fn refract(d: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let cos_i = (-d.dot(n)).clamp(0.0, 1.0);
    let cos_t = snell_cos_t(cos_i, eta)?;
    Some(eta * d + (eta * cos_i - cos_t) * n)
}

/// The Fresnel reflectance of unpolarised light at a smooth dielectric interface: the mean of
/// the s- and p-polarised reflectances
///
/// ```text
/// r_s = (η_i cos θi − η_t cos θt) / (η_i cos θi + η_t cos θt)
/// r_p = (η_t cos θi − η_i cos θt) / (η_t cos θi + η_i cos θt)
/// R   = (r_s² + r_p²) / 2,        T = 1 − R
/// ```
///
/// with `cos θt` from Snell's law; 1 on total internal reflection. `cos_i` is clamped to
/// `[0, 1]`.
#[inline]
pub fn fresnel_dielectric(cos_i: f32, eta_i: f32, eta_t: f32) -> f32 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let Some(cos_t) = snell_cos_t(cos_i, eta_i / eta_t) else {
        return 1.0;
    };
    let r_s = (eta_i * cos_i - eta_t * cos_t) / (eta_i * cos_i + eta_t * cos_t);
    let r_p = (eta_t * cos_i - eta_i * cos_t) / (eta_t * cos_i + eta_i * cos_t);
    (0.5 * (r_s * r_s + r_p * r_p)).min(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mirror_direction_keeps_the_tangent_and_flips_the_normal_part() {
        let d = Vec3::new(1.0, -1.0, 0.0).normalize();
        let r = reflect(d, Vec3::Y);
        assert!((r - Vec3::new(1.0, 1.0, 0.0).normalize()).length() < 1e-7);
    }

    #[test]
    fn refraction_obeys_snell() {
        // 45° into glass of index 1.5: sin θt = sin 45° / 1.5.
        let d = Vec3::new(1.0, -1.0, 0.0).normalize();
        let t = refract(d, Vec3::Y, 1.0 / 1.5).unwrap();
        assert!((t.length() - 1.0).abs() < 1e-6);
        let sin_t = t.x; // the tangent component of a unit vector
        let expected = (std::f64::consts::FRAC_1_SQRT_2 / 1.5) as f32;
        assert!((sin_t - expected).abs() < 1e-6, "{sin_t} vs {expected}");
        assert!(t.y < 0.0);
        // Normal incidence goes straight through.
        assert_eq!(refract(-Vec3::Y, Vec3::Y, 1.0 / 1.5), Some(-Vec3::Y));
    }

    #[test]
    fn lambert_and_a_zero_exponent_agree() {
        assert_eq!(lambert(Vec3::ONE).x, FRAC_1_PI);
        assert!((blinn_phong(0.3, 0.0) - FRAC_1_PI).abs() < 1e-7);
        assert_eq!(blinn_phong(-0.1, 10.0), 0.0);
    }
}
