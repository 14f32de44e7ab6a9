//! Warps from the unit square to the disk, the hemisphere and the sphere, each with its density,
//! and the tools that check sampling routines ([`chi2`]) and integrate tables ([`quadrature`]); the path tracer's
//! Owen-scrambled Sobol sampler ([`sobol`]).
//!
//! ```text
//! disk (Shirley–Chiu concentric)   p = 1/π                      (area)
//! cosine hemisphere (Malley)       p(ω) = cos θ / π             (solid angle)
//! uniform hemisphere               p(ω) = 1 / (2π),  cos θ = u₁
//! uniform sphere                   p(ω) = 1 / (4π),  cos θ = 1 − 2u₁
//! ```
//!
//! Directions are in a local frame whose `z` is the normal; `u` lies in `[0, 1)²`.
//!
//! Every pixel's samplers are keyed by [`seeded_pixel`]: the pixel's index `y·W + x`, with the
//! render's seed (`[render] seed`, `--seed`) folded in as `index ⊕ splitmix64(seed)`; seed 0
//! keys a pixel by its index alone. The samplers hash their key, so another seed gives every
//! pixel an independent sequence (Cycles' `seed`; an animation renders each frame with its own
//! seed, as Cycles' animated seed does, so that its noise does not stand still).

pub mod chi2;
pub mod distribution;
pub mod quadrature;
pub mod sobol;
pub mod spherical_triangle;

use std::f32::consts::{FRAC_1_PI, FRAC_PI_2, FRAC_PI_4, PI};

use crate::math::{Vec2, Vec3};

/// The key of pixel `index` (`y·W + x`) under the render's `seed` (module docs): `index`
/// itself for seed 0, `index ⊕ splitmix64(seed)` otherwise.
#[inline]
pub fn seeded_pixel(index: u64, seed: u32) -> u64 {
    if seed == 0 { index } else { index ^ sobol::splitmix64(seed as u64) }
}

/// Shirley and Chiu's concentric map of the square onto the unit disk: area-preserving, and
/// neighbouring points stay neighbours (good for stratified samples).
#[inline]
pub fn square_to_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) =
        if o.x.abs() > o.y.abs() { (o.x, FRAC_PI_4 * (o.y / o.x)) } else { (o.y, FRAC_PI_2 - FRAC_PI_4 * (o.x / o.y)) };
    let (s, c) = theta.sin_cos();
    r * Vec2::new(c, s)
}

/// Cosine-weighted hemisphere (Malley's method: a disk point lifted onto the hemisphere).
#[inline]
pub fn square_to_cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = square_to_disk(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// The density of [`square_to_cosine_hemisphere`]: `cos θ / π` above the horizon, 0 below.
#[inline]
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    if cos_theta > 0.0 { cos_theta * FRAC_1_PI } else { 0.0 }
}

/// Uniform directions on the upper hemisphere.
#[inline]
pub fn square_to_uniform_hemisphere(u: Vec2) -> Vec3 {
    let z = u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (s, c) = (2.0 * PI * u.y).sin_cos();
    Vec3::new(r * c, r * s, z)
}

/// The density of [`square_to_uniform_hemisphere`]: `1/(2π)`.
pub const UNIFORM_HEMISPHERE_PDF: f32 = 0.5 * FRAC_1_PI;

/// Uniform directions on the whole sphere.
#[inline]
pub fn square_to_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (s, c) = (2.0 * PI * u.y).sin_cos();
    Vec3::new(r * c, r * s, z)
}

/// The density of [`square_to_uniform_sphere`]: `1/(4π)`.
pub const UNIFORM_SPHERE_PDF: f32 = 0.25 * FRAC_1_PI;

#[cfg(test)]
mod tests {
    use super::chi2::{Chi2Test, sidak};
    use super::*;

    const TESTS: usize = 4;

    #[test]
    fn concentric_disk_stays_inside_and_keeps_area() {
        // The map is area-preserving: the quadrant u < 1/2, v < 1/2 covers a quarter of the disk.
        let mut inside_quarter = 0;
        let n = 200;
        for i in 0..n {
            for j in 0..n {
                let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                let d = square_to_disk(u);
                assert!(d.length() <= 1.0 + 1e-6);
                inside_quarter += (d.x < 0.0 && d.y < 0.0) as u32;
            }
        }
        let share = inside_quarter as f32 / (n * n) as f32;
        assert!((share - 0.25).abs() < 0.01, "{share}");
    }

    #[test]
    fn cosine_hemisphere_passes_chi2() {
        let r =
            Chi2Test::default().run(|_, u| Some(square_to_cosine_hemisphere(u)), |w| cosine_hemisphere_pdf(w.z) as f64);
        assert!(r.passes(sidak(0.01, TESTS)), "{r}");
    }

    #[test]
    fn uniform_hemisphere_and_sphere_pass_chi2() {
        let r = Chi2Test::default().run(
            |_, u| Some(square_to_uniform_hemisphere(u)),
            |w| if w.z > 0.0 { UNIFORM_HEMISPHERE_PDF as f64 } else { 0.0 },
        );
        assert!(r.passes(sidak(0.01, TESTS)), "{r}");
        let r = Chi2Test::default().run(|_, u| Some(square_to_uniform_sphere(u)), |_| UNIFORM_SPHERE_PDF as f64);
        assert!(r.passes(sidak(0.01, TESTS)), "{r}");
    }

    #[test]
    fn a_wrong_density_is_rejected() {
        // Cosine samples tested against the uniform density, and against cos^1.1: both rejected.
        let r = Chi2Test::default().run(
            |_, u| Some(square_to_cosine_hemisphere(u)),
            |w| if w.z > 0.0 { UNIFORM_HEMISPHERE_PDF as f64 } else { 0.0 },
        );
        assert!(!r.passes(sidak(0.01, TESTS)), "{r}");
        let r = Chi2Test::default().run(
            |_, u| Some(square_to_cosine_hemisphere(u)),
            |w| if w.z > 0.0 { 2.1 / (2.0 * std::f64::consts::PI) * (w.z as f64).powf(1.1) } else { 0.0 },
        );
        assert!(!r.passes(sidak(0.01, TESTS)), "{r}");
    }
}
