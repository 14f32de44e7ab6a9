//! Area lights: emitters with a shape, of radiance `L` (W/(m²·sr) per channel), lighting a
//! point through samples on the light (Cook, Porter and Carpenter's distribution ray tracing).
//!
//! The irradiance a surface point `p` with normal `n` receives from a light is
//!
//! ```text
//! E = ∫_A L · cosθ_s · cosθ_l / d² · V dA
//! ```
//!
//! over the light's area `A`, with `θ_s` the angle at `p` between `n` and the direction to the
//! light point `y`, `θ_l` the angle at `y` between the light's normal and the direction back to
//! `p`, `d = |y − p|` and `V` the visibility. A sample `y` drawn with density `pdf_A(y)` per unit
//! area gives the unbiased estimate
//!
//! ```text
//! Ê = L · cosθ_s · cosθ_l / d² / pdf_A(y)
//! ```
//!
//! ([`AreaLight::sample`] returns everything but `cosθ_s`, which the integrator applies with
//! the BRDF, exactly as for a point light). Quads and disks are sampled uniformly by area
//! (`pdf_A = 1/A`; disks through Shirley and Chiu's concentric map, which keeps the strata of
//! the unit square compact). A sphere seen from outside is sampled uniformly in the cone of
//! directions it subtends (`pdf_ω = 1/(2π(1 − cosθ_max))`, `sin θ_max = r/|c − p|`), which
//! never wastes a sample on its far side: `Ê = L · cosθ_s / pdf_ω`. From inside a two-sided
//! sphere it is sampled uniformly by area.
//!
//! A light emits on the side its normal points to (a quad's `edge1 × edge2`, a disk's
//! `normal`, a sphere's outside), or on both when `two_sided`; a point on the other side
//! receives nothing. `light_samples` samples per shading point are averaged: each carries
//! `1/light_samples` of the estimate. The sampling arithmetic is in f64 (the sphere's cone
//! needs it for small, distant lights), rounded to f32 once.

use glam::DVec3;

use crate::light::Incidence;
use crate::math::{Vec2, Vec3};
use crate::sampler::concentric_disk;

/// The largest `light_samples` a light may ask for (shadow rays per shading point).
pub const MAX_LIGHT_SAMPLES: u32 = 4096;

/// The shape of an area light, in world space (metres).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// The parallelogram `corner + a·edge1 + b·edge2`, `a, b ∈ [0, 1]`; its normal is
    /// `edge1 × edge2` normalised.
    Quad { corner: Vec3, edge1: Vec3, edge2: Vec3 },
    /// The disk of `radius` around `center` perpendicular to the unit `normal`.
    Disk { center: Vec3, normal: Vec3, radius: f32 },
    /// The sphere of `radius` around `center`; its normal points outwards.
    Sphere { center: Vec3, radius: f32 },
}

/// An emitter with a shape (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AreaLight {
    pub shape: Shape,
    /// Emitted radiance `L`, W/(m²·sr) per channel, the same in every direction.
    pub radiance: Vec3,
    /// Whether the back side emits too.
    pub two_sided: bool,
    /// Samples (shadow rays) per shading point, in `1..=MAX_LIGHT_SAMPLES`.
    pub samples: u32,
}

/// Two unit vectors that make a right-handed basis `(t, b, n)` with the unit `n`:
/// `t × b = n` (Duff et al., "Building an orthonormal basis, revisited").
pub fn basis(n: DVec3) -> (DVec3, DVec3) {
    let sign = 1f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x), DVec3::new(b, sign + n.y * n.y * a, -n.y))
}

impl AreaLight {
    /// The light's area, m².
    pub fn area(&self) -> f64 {
        match self.shape {
            Shape::Quad { edge1, edge2, .. } => edge1.as_dvec3().cross(edge2.as_dvec3()).length(),
            Shape::Disk { radius, .. } => std::f64::consts::PI * (radius as f64).powi(2),
            Shape::Sphere { radius, .. } => 4.0 * std::f64::consts::PI * (radius as f64).powi(2),
        }
    }

    /// One sample of the light as seen from `p`, for the point `u ∈ [0, 1)²`: the direction
    /// and distance to the light point, and `L·cosθ_l/(d²·pdf_A)/light_samples` as the
    /// incidence's irradiance (the integrator multiplies by the BRDF and `cosθ_s`). `None` when
    /// the sample cannot light `p`: `p` is behind a one-sided light, on it, or inside a
    /// one-sided sphere.
    pub fn sample(&self, p: Vec3, u: Vec2) -> Option<Incidence> {
        let pd = p.as_dvec3();
        let scale = self.radiance.as_dvec3() / self.samples.max(1) as f64;
        let by_area = |y: DVec3, normal: DVec3, area: f64| -> Option<Incidence> {
            let to = y - pd;
            let d2 = to.length_squared();
            let w = to / d2.sqrt();
            let mut cos_l = -normal.dot(w);
            if self.two_sided {
                cos_l = cos_l.abs();
            }
            (d2 > 0.0 && cos_l > 0.0).then(|| incidence(w, d2.sqrt(), scale * (cos_l * area / d2)))
        };
        match self.shape {
            Shape::Quad { corner, edge1, edge2 } => {
                let (e1, e2) = (edge1.as_dvec3(), edge2.as_dvec3());
                let y = corner.as_dvec3() + u.x as f64 * e1 + u.y as f64 * e2;
                let cross = e1.cross(e2);
                by_area(y, cross.normalize(), cross.length())
            }
            Shape::Disk { center, normal, radius } => {
                let n = normal.as_dvec3().normalize();
                let (t, b) = basis(n);
                let (x, z) = concentric_disk(u);
                let r = radius as f64;
                by_area(center.as_dvec3() + r * (x * t + z * b), n, self.area())
            }
            Shape::Sphere { center, radius } => {
                let (c, r) = (center.as_dvec3(), radius as f64);
                let to_c = c - pd;
                let dc2 = to_c.length_squared();
                if dc2 <= r * r {
                    if !self.two_sided {
                        return None;
                    }
                    // Inside: uniform by area; the inner side faces p.
                    let z = 1.0 - 2.0 * u.x as f64;
                    let s = (1.0 - z * z).max(0.0).sqrt();
                    let phi = 2.0 * std::f64::consts::PI * u.y as f64;
                    let n = DVec3::new(s * phi.cos(), s * phi.sin(), z);
                    return by_area(c + r * n, n, self.area());
                }
                let dc = dc2.sqrt();
                let wc = to_c / dc;
                let sin2_max = r * r / dc2;
                let cos_max = (1.0 - sin2_max).max(0.0).sqrt();
                // 1 − cosθ_max without cancellation for small cones.
                let one_minus_cos_max = sin2_max / (1.0 + cos_max);
                let one_minus_cos = u.x as f64 * one_minus_cos_max;
                let cos = 1.0 - one_minus_cos;
                let sin = (one_minus_cos * (2.0 - one_minus_cos)).max(0.0).sqrt();
                let phi = 2.0 * std::f64::consts::PI * u.y as f64;
                let (t, b) = basis(wc);
                let w = (cos * wc + sin * (phi.cos() * t + phi.sin() * b)).normalize();
                // The near intersection of p + s·w with the sphere.
                let proj = dc * cos;
                let s = proj - (r * r - dc2 * sin * sin).max(0.0).sqrt();
                let weight = 2.0 * std::f64::consts::PI * one_minus_cos_max;
                Some(incidence(w, s.max(0.0), scale * weight))
            }
        }
    }

    /// Why this light cannot be rendered, if it cannot.
    pub fn problem(&self) -> Option<String> {
        let finite = |what: &str, v: Vec3| (!v.is_finite()).then(|| format!("{what} {v} is not finite"));
        let shape = match self.shape {
            Shape::Quad { corner, edge1, edge2 } => finite("corner", corner)
                .or_else(|| finite("edge1", edge1))
                .or_else(|| finite("edge2", edge2))
                .or_else(|| {
                    let a = self.area();
                    (!(a > 0.0 && a.is_finite()))
                        .then(|| format!("edge1 {edge1} and edge2 {edge2} span no area (zero or parallel edges)"))
                }),
            Shape::Disk { center, normal, radius } => finite("center", center)
                .or_else(|| finite("normal", normal))
                .or_else(|| (normal.length_squared() == 0.0).then(|| "normal is zero".to_string()))
                .or_else(|| positive_radius(radius)),
            Shape::Sphere { center, radius } => finite("center", center).or_else(|| positive_radius(radius)),
        };
        shape
            .or_else(|| {
                (!(self.radiance.is_finite() && self.radiance.min_element() >= 0.0))
                    .then(|| format!("radiance {} must be finite and ≥ 0", self.radiance))
            })
            .or_else(|| {
                (!(1..=MAX_LIGHT_SAMPLES).contains(&self.samples))
                    .then(|| format!("light_samples {} must lie in 1..={MAX_LIGHT_SAMPLES}", self.samples))
            })
    }
}

fn positive_radius(radius: f32) -> Option<String> {
    (!(radius > 0.0 && radius.is_finite())).then(|| format!("radius {radius} must be finite and > 0"))
}

fn incidence(w: DVec3, distance: f64, irradiance: DVec3) -> Incidence {
    Incidence { to_light: w.as_vec3(), distance: distance as f32, normal_irradiance: irradiance.as_vec3() }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// The mean and standard error of `E` at `p` (normal `n`, no occluders) over an `k × k`
    /// grid of jittered strata of the light's unit square.
    fn estimate(light: &AreaLight, p: Vec3, n: Vec3, k: u32, seed: u64) -> (f64, f64) {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(seed);
        let mut values = Vec::new();
        for i in 0..k {
            for j in 0..k {
                let u =
                    Vec2::new((i as f32 + rng.random::<f32>()) / k as f32, (j as f32 + rng.random::<f32>()) / k as f32);
                let e = light.sample(p, u).map_or(0.0, |inc| {
                    let cos = n.dot(inc.to_light).max(0.0) as f64;
                    inc.normal_irradiance.x as f64 * cos
                });
                values.push(e);
            }
        }
        let m = values.iter().sum::<f64>() / values.len() as f64;
        let var = values.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (values.len() - 1) as f64;
        (m, (var / values.len() as f64).sqrt())
    }

    #[test]
    fn disk_on_axis_converges_to_the_closed_form() {
        let (l, r, h) = (3.0, 0.5, 2.0);
        let light = AreaLight {
            shape: Shape::Disk { center: Vec3::new(0.0, h, 0.0), normal: Vec3::NEG_Y, radius: r },
            radiance: Vec3::splat(l),
            two_sided: false,
            samples: 1,
        };
        let exact = PI * l as f64 * (r * r) as f64 / (h * h + r * r) as f64;
        for k in [4, 16, 64] {
            let (m, se) = estimate(&light, Vec3::ZERO, Vec3::Y, k, 7);
            assert!((m - exact).abs() <= 3.0 * se.max(1e-9 * exact), "k {k}: {m} vs {exact} ± {se}");
        }
        // Below the disk, nothing: the light is one-sided and faces down.
        assert!(light.sample(Vec3::new(0.0, 3.0, 0.0), Vec2::splat(0.3)).is_none());
    }

    #[test]
    fn sphere_fully_visible_gives_pi_l_r2_over_d2_cos() {
        let (l, r, d) = (2.0f32, 0.25f32, 3.0f32);
        let light = AreaLight {
            shape: Shape::Sphere { center: Vec3::new(0.0, d, 0.0), radius: r },
            radiance: Vec3::splat(l),
            two_sided: false,
            samples: 1,
        };
        for theta in [0.0f32, 0.5, 1.0] {
            let n = Vec3::new(theta.sin(), theta.cos(), 0.0);
            let exact = PI * l as f64 * (r as f64 / d as f64).powi(2) * (theta as f64).cos();
            let (m, se) = estimate(&light, Vec3::ZERO, n, 64, 11);
            assert!((m - exact).abs() <= 3.0 * se + 1e-6 * exact, "θ {theta}: {m} vs {exact} ± {se}");
        }
        // The sampled points lie on the near side of the sphere.
        let inc = light.sample(Vec3::ZERO, Vec2::new(0.0, 0.0)).unwrap();
        assert!((inc.distance - (d - r)).abs() < 1e-5, "{}", inc.distance);
        assert!(light.sample(Vec3::new(0.0, d, 0.1), Vec2::splat(0.5)).is_none(), "inside a one-sided sphere");
    }

    #[test]
    fn quad_seen_whole_is_the_form_factor() {
        // A unit square at height 1 centred above p: E = L · 4·(x/√(1+x²))·atan(x/√(1+x²))
        // summed over its four quadrants (x = 1/2), the classic parallel-rectangle form factor.
        let light = AreaLight {
            shape: Shape::Quad {
                corner: Vec3::new(-0.5, 1.0, -0.5),
                edge1: Vec3::X,
                edge2: Vec3::Z, // x × z = −y: facing down, at p
            },
            radiance: Vec3::ONE,
            two_sided: false,
            samples: 1,
        };
        // One quadrant (a × b rectangle with a corner above p, height c = 1):
        // F = (1/2π)(a/√(a²+c²)·atan(b/√(a²+c²)) + b/√(b²+c²)·atan(a/√(b²+c²))), E = π·L·F.
        let (a, b): (f64, f64) = (0.5, 0.5);
        let f = (a / (a * a + 1.0).sqrt() * (b / (a * a + 1.0).sqrt()).atan()
            + b / (b * b + 1.0).sqrt() * (a / (b * b + 1.0).sqrt()).atan())
            / (2.0 * PI);
        let exact = 4.0 * PI * f;
        let (m, se) = estimate(&light, Vec3::ZERO, Vec3::Y, 64, 3);
        assert!((m - exact).abs() <= 3.0 * se, "{m} vs {exact} ± {se}");
        // Turned upside down (edges swapped) it faces away: nothing, unless two-sided.
        let up = AreaLight {
            shape: Shape::Quad { corner: Vec3::new(-0.5, 1.0, -0.5), edge1: Vec3::Z, edge2: Vec3::X },
            ..light
        };
        assert!(up.sample(Vec3::ZERO, Vec2::splat(0.5)).is_none());
        let (m2, _) = estimate(&AreaLight { two_sided: true, ..up }, Vec3::ZERO, Vec3::Y, 64, 3);
        assert!((m2 - exact).abs() <= 3.0 * se + 1e-3 * exact, "{m2} vs {exact}");
    }

    #[test]
    fn problems_are_named() {
        let ok = AreaLight {
            shape: Shape::Sphere { center: Vec3::ZERO, radius: 1.0 },
            radiance: Vec3::ONE,
            two_sided: false,
            samples: 1,
        };
        assert_eq!(ok.problem(), None);
        let quad = Shape::Quad { corner: Vec3::ZERO, edge1: Vec3::X, edge2: Vec3::X * 2.0 };
        assert!(AreaLight { shape: quad, ..ok }.problem().unwrap().contains("span no area"));
        assert!(AreaLight { samples: 0, ..ok }.problem().unwrap().contains("light_samples 0"));
        assert!(AreaLight { radiance: Vec3::NEG_ONE, ..ok }.problem().unwrap().contains("radiance"));
        let disk = Shape::Disk { center: Vec3::ZERO, normal: Vec3::ZERO, radius: 1.0 };
        assert!(AreaLight { shape: disk, ..ok }.problem().unwrap().contains("normal is zero"));
    }
}
