//! The shading formulas against their closed forms: Fresnel (normal incidence, total internal
//! reflection, grazing incidence, energy), Snell, and the normalisation of the Blinn–Phong
//! lobe by numerical integration.

use std::f64::consts::PI;

use strahl::math::Vec3;
use strahl::optics::{blinn_phong, blinn_phong_normalization, fresnel_dielectric, lambert, refract, snell_cos_t};

fn rel(a: f32, b: f64) -> f64 {
    ((a as f64) - b).abs() / b.abs()
}

const IORS: [f32; 4] = [1.1, 1.333, 1.5, 2.42];

#[test]
fn fresnel_at_normal_incidence_is_the_square_of_n_minus_1_over_n_plus_1() {
    for n in IORS {
        let nd = n as f64;
        let expected = ((nd - 1.0) / (nd + 1.0)).powi(2);
        // Entering and leaving reflect the same at normal incidence.
        assert!(rel(fresnel_dielectric(1.0, 1.0, n), expected) <= 1e-5, "n = {n}");
        assert!(rel(fresnel_dielectric(1.0, n, 1.0), expected) <= 1e-5, "n = {n}");
    }
}

/// The transmittance from the Fresnel transmission amplitudes, independently of `R`:
/// `T = (η_t cos θt)/(η_i cos θi) · (t_s² + t_p²)/2` with `t_s = 2η_i cos θi/(η_i cos θi + η_t cos θt)`,
/// `t_p = 2η_i cos θi/(η_t cos θi + η_i cos θt)`. In f64.
fn transmittance(cos_i: f64, eta_i: f64, eta_t: f64) -> f64 {
    let sin_t = eta_i / eta_t * (1.0 - cos_i * cos_i).sqrt();
    let cos_t = (1.0 - sin_t * sin_t).sqrt();
    let t_s = 2.0 * eta_i * cos_i / (eta_i * cos_i + eta_t * cos_t);
    let t_p = 2.0 * eta_i * cos_i / (eta_t * cos_i + eta_i * cos_t);
    eta_t * cos_t / (eta_i * cos_i) * 0.5 * (t_s * t_s + t_p * t_p)
}

#[test]
fn fresnel_reflectance_and_transmittance_add_up_to_one() {
    for n in IORS {
        for k in 0..=90 {
            let theta = (k as f64).to_radians() * 0.999; // up to just short of grazing
            let cos_i = theta.cos();
            // Entering the denser medium: never total internal reflection.
            let r = fresnel_dielectric(cos_i as f32, 1.0, n) as f64;
            let t = transmittance(cos_i, 1.0, n as f64);
            assert!((r + t - 1.0).abs() <= 1e-5, "n = {n}, θ = {theta}: R {r} + T {t}");
            // Leaving it, below the critical angle.
            if (theta.sin() * n as f64) < 0.999 {
                let r = fresnel_dielectric(cos_i as f32, n, 1.0) as f64;
                let t = transmittance(cos_i, n as f64, 1.0);
                assert!((r + t - 1.0).abs() <= 1e-5, "leaving n = {n}, θ = {theta}: R {r} + T {t}");
            }
        }
    }
}

#[test]
fn total_internal_reflection_beyond_the_critical_angle() {
    for n in IORS {
        let critical = (1.0 / n as f64).asin();
        for extra in [1e-3, 0.01, 0.1, 0.5] {
            let theta = (critical + extra).min(PI / 2.0);
            let cos_i = theta.cos() as f32;
            assert_eq!(fresnel_dielectric(cos_i, n, 1.0), 1.0, "n = {n}, θ = {theta}");
            assert_eq!(snell_cos_t(cos_i, n), None);
            let d = Vec3::new(theta.sin() as f32, -theta.cos() as f32, 0.0);
            assert_eq!(refract(d, Vec3::Y, n), None);
        }
        // Just inside the critical angle some light still leaves, and it leaves grazing.
        let theta = critical - 1e-3;
        let r = fresnel_dielectric(theta.cos() as f32, n, 1.0);
        assert!(r < 1.0 && r > 0.5, "n = {n}: R {r} just below the critical angle");
        assert!(snell_cos_t(theta.cos() as f32, n).unwrap() < 0.1);
    }
}

#[test]
fn reflectance_tends_to_one_at_grazing_incidence() {
    for n in IORS {
        assert_eq!(fresnel_dielectric(0.0, 1.0, n), 1.0);
        // Beyond Brewster's angle (at most 68° for these indices) R rises monotonically.
        let mut last = fresnel_dielectric(0.2, 1.0, n);
        for cos_i in [0.1f32, 1e-2, 1e-3, 1e-4] {
            let r = fresnel_dielectric(cos_i, 1.0, n);
            assert!(r > last, "n = {n}: R({cos_i}) = {r} after {last}");
            last = r;
        }
        assert!(last > 0.999, "n = {n}: R at cos θ = 1e-4 is {last}");
    }
}

#[test]
fn refraction_obeys_snell_and_normal_incidence_goes_straight() {
    for n in IORS {
        for k in 1..9 {
            let theta = (10.0 * k as f64).to_radians();
            let d = Vec3::new(theta.sin() as f32, -theta.cos() as f32, 0.0);
            let t = refract(d, Vec3::Y, 1.0 / n).unwrap();
            // η_i sin θi = η_t sin θt, sin θt being the tangential component of a unit t.
            assert!(rel(t.x * n, theta.sin()) <= 1e-5, "n = {n}, θ = {theta}");
            assert!((t.length() - 1.0).abs() < 1e-6 && t.y < 0.0);
        }
        assert_eq!(refract(-Vec3::Y, Vec3::Y, 1.0 / n), Some(-Vec3::Y));
    }
}

/// The directional albedo `∫ f(wi, wo) cos θi dωi` over the hemisphere of the lobe
/// `f = K(n)·(n·h)^n` (or `scale·(n·h)^n` when given), for a viewer at `theta_o` from the
/// normal: midpoint rule in θ and φ, in f64.
fn albedo(exponent: f32, theta_o: f64, scale: Option<f64>) -> f64 {
    let (nt, np) = (600, 600);
    let wo = glam::DVec3::new(theta_o.sin(), 0.0, theta_o.cos());
    let (dt, dp) = (0.5 * PI / nt as f64, 2.0 * PI / np as f64);
    let mut sum = 0.0;
    for i in 0..nt {
        let th = (i as f64 + 0.5) * dt;
        let (s, c) = th.sin_cos();
        for j in 0..np {
            let ph = (j as f64 + 0.5) * dp;
            let wi = glam::DVec3::new(s * ph.cos(), s * ph.sin(), c);
            let h = (wi + wo).normalize();
            let f = match scale {
                None => blinn_phong(h.z as f32, exponent) as f64,
                Some(k) => k * h.z.max(0.0).powf(exponent as f64),
            };
            sum += f * c * s * dt * dp;
        }
    }
    sum
}

#[test]
fn normalised_blinn_phong_never_reflects_more_than_it_receives() {
    for n in [0.0f32, 1.0, 4.0, 11.0, 50.0, 200.0] {
        // Largest for a viewer on the normal, where the normalisation makes it exactly 1.
        let head_on = albedo(n, 0.0, None);
        assert!((head_on - 1.0).abs() <= 1e-4, "n = {n}: albedo {head_on} at normal view");
        let mut last = head_on;
        for deg in [20.0f64, 45.0, 70.0, 85.0] {
            let a = albedo(n, deg.to_radians(), None);
            assert!(a <= 1.0 + 1e-4, "n = {n}, θo = {deg}°: albedo {a}");
            assert!(a <= last + 1e-4, "n = {n}: albedo grows towards grazing ({a} after {last})");
            last = a;
        }
    }
    // The closed form of K(n) agrees with the integral's.
    for n in [1.0f32, 11.0, 200.0] {
        let nd = n as f64;
        let k = (nd + 2.0) * (nd + 4.0) / (8.0 * PI * ((-0.5 * nd).exp2() + nd));
        assert!(rel(blinn_phong_normalization(n), k) <= 1e-6);
    }
    // Why not the popular (n+8)/(8π): for n = 11 it reflects 7 % more than it receives.
    let approx = albedo(11.0, 0.0, Some((11.0 + 8.0) / (8.0 * PI)));
    assert!(approx > 1.07, "(n+8)/(8π) at n = 11: albedo {approx}");
}

#[test]
fn lambert_reflects_albedo_over_pi() {
    let rho = Vec3::new(0.8, 0.5, 0.2);
    let f = lambert(rho);
    for (a, b) in f.to_array().into_iter().zip(rho.to_array()) {
        assert!(rel(a, b as f64 / PI) <= 1e-6);
    }
    // Its directional albedo is ρ: the zero-exponent lobe is Lambert's 1/π.
    assert!((albedo(0.0, 0.7, None) - 1.0).abs() <= 1e-4);
}
